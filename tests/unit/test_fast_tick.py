"""The simulated tick's optimised pieces give, bit for bit, what their reference formulas give on random
inputs: each reference is the straightforward per-joint (per-sample) form, kept here and not in pegbt, so
a tick that costs less is held to change no number."""

import math
import struct
from dataclasses import replace

import numpy as np
import pytest

from pegbt.physics import ArmPhysics, Effect
from pegbt.sim.arm import JointGroup
from pegbt.sim.playback import Playback
from pegbt.sim.tools import ToolState
from pegbt.workcell import workcell

MIXED = [
    Effect("offset", "q1", {"value": 0.01}),
    Effect("scale", "q2", {"value": 1.03}),
    Effect("coupling", "q6", {"source": "q5", "k": 0.2}),
    Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.05, "k": -0.6}),
    Effect("hysteresis", "q5", {"source": "q5", "half_width": 0.02, "k": 0.3}),
    Effect("hysteresis", "q6", {"source": "q6", "half_width": 0.04, "k": 0.6}),
    Effect("hysteresis", "q1", {"source": "q2", "half_width": 0.03, "k": 0.1}),
    Effect("backlash", "q3", {"half_width": 0.0005}),
    Effect("backlash", "q6", {"half_width": 0.01}),
    Effect("lag", "q4", {"tau": 0.05}),
    Effect("delay", "q2", {"seconds": 0.023}),
]


class ReferenceArm:
    """`ArmPhysics.reset`, `step` and `play_room` as first written: the static map, then each hysteresis in
    turn on scalars (its drive clipped by `np.clip`, its term added to its joint), then each transform."""

    def __init__(self, physics: ArmPhysics, q0: np.ndarray) -> None:
        self.p = physics
        static = physics.static_map(q0)
        self.play = np.array([static[j] if s == j else q0[s] for j, s, _, _ in physics.hysteresis])
        self.seen = self.play.copy()
        self.kernels: list[object] = [None] * len(physics.transforms)
        self._stages(static, 0.0, starting=True)

    def step(self, delayed: np.ndarray, dt: float) -> np.ndarray:
        target = self.p.static_map(delayed)
        if target.ndim == 2:
            target = np.diagonal(target).copy()
        static = target.copy()
        for n, (j, source, half_width, k) in enumerate(self.p.hysteresis):
            commands = delayed[j] if delayed.ndim == 2 else delayed
            seen = static[j] if source == j else commands[source]
            self.play[n] = np.clip(self.play[n], seen - half_width, seen + half_width)
            self.seen[n] = seen
            target[j] += k * (self.play[n] - seen)
        return self._stages(target, dt)

    def _stages(self, target: np.ndarray, dt: float, starting: bool = False) -> np.ndarray:
        signal = target.copy()
        play_input = play_output = None
        for n, (j, kind, effect) in enumerate(self.p.transforms):
            if play_input is None and kind.stage != "target":
                play_input = signal.copy()
            if play_output is None and kind.stage == "output":
                play_output = signal.copy()
            if starting:
                self.kernels[n] = kind.start(effect, float(signal[j]))
            signal[j], self.kernels[n] = kind.step(effect, self.kernels[n], float(signal[j]), dt)
        self.target = signal.copy() if play_input is None else play_input
        self.state = signal.copy() if play_output is None else play_output
        return signal

    def play_room(self, j: int) -> tuple[float, float]:
        down = float(self.state[j] - (self.target[j] - self.p.half_width[j]))
        up = float(self.target[j] + self.p.half_width[j] - self.state[j])
        for n, (target, source, half_width, k) in enumerate(self.p.hysteresis):
            if target == source == j:
                below = k * (self.play[n] - (self.seen[n] - half_width))
                above = k * (self.seen[n] + half_width - self.play[n])
                down, up = down + max(below, -above), up + max(above, -below)
        return down, up


def _walk(rng: np.random.Generator, n: int) -> np.ndarray:
    steps = rng.normal(size=(n, 6)) * [0.01, 0.01, 0.0005, 0.02, 0.02, 0.02]
    return np.cumsum(steps, axis=0) + [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]


@pytest.mark.parametrize("arm", ["PSM1", "PSM2", "mixed"])
def test_a_step_and_the_play_room_equal_the_per_joint_formula(arm):
    rng = np.random.default_rng(11)
    model = (lambda: ArmPhysics(MIXED)) if arm == "mixed" else (lambda: ArmPhysics.load("dvrk-real", arm))
    physics, twin = model(), model()  # the twin gives the command each joint sees (its delays)
    q = _walk(rng, 600)
    assert physics.reset(q[0]).tobytes() == twin.reset(q[0]).tobytes()
    reference = ReferenceArm(physics, q[0])
    for row in q[1:]:
        dt = float(rng.choice([0.01, 0.001, 0.0137]))
        twin._time += dt
        seen = twin._delayed_command(row)
        assert physics.step(row, dt).tobytes() == reference.step(seen, dt).tobytes()
        for j in range(6):
            assert physics.play_room(j) == reference.play_room(j)


def test_every_hysteresis_is_clipped_in_one_call_a_tick(monkeypatch):
    physics = ArmPhysics.load("dvrk-real", "PSM1")
    physics.reset(np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0]))
    calls = []
    clip = np.clip
    monkeypatch.setattr(np, "clip", lambda *args, **kwargs: calls.append(1) or clip(*args, **kwargs))
    physics.step(np.array([0.01, -0.02, 0.121, 0.1, 0.05, -0.05]), 0.01)
    assert len(physics.hysteresis) == 8 and len(calls) == 1


def test_a_playback_interpolates_as_a_search_of_its_times():
    rng = np.random.default_rng(5)
    for _ in range(50):
        times = np.cumsum(rng.uniform(0.001, 0.02, rng.integers(1, 40)))
        positions = rng.normal(size=(len(times), 6))
        playback = Playback("m", times, positions)
        assert playback.duration == float(times[-1])
        for elapsed in [*rng.uniform(-0.01, times[-1] + 0.01, 60), *times, 0.0]:
            if elapsed >= times[-1]:
                expected = positions[-1]
            else:
                i = int(np.searchsorted(times, elapsed, side="right"))
                if i == 0:
                    expected = positions[0]
                else:
                    t0, t1 = times[i - 1], times[i]
                    w = (elapsed - t0) / (t1 - t0)
                    expected = (1 - w) * positions[i - 1] + w * positions[i]
            assert playback.at(float(elapsed)).tobytes() == np.asarray(expected).tobytes()


class ReferenceGroup:
    """`JointGroup.advance` as first written: every tick plays the motion, moves the encoders by the
    servo's first-order response (its gain from the period), stops them at `lowest`, takes the velocity."""

    def __init__(self, q0: np.ndarray) -> None:
        self.setpoint = q0.copy()
        self.tick_setpoint, self.previous_tick_setpoint = q0.copy(), q0.copy()
        self.encoder, self.velocity = q0.copy(), np.zeros_like(q0)
        self.motion: Playback | None = None
        self.lowest: np.ndarray | None = None
        self.elapsed = 0.0

    def advance(self, dt: float) -> None:
        if self.motion is not None:
            self.elapsed += dt
            self.setpoint = self.motion.at(self.elapsed)
            if self.elapsed >= self.motion.duration - 1e-9:
                self.motion = None
        self.previous_tick_setpoint, self.tick_setpoint = self.tick_setpoint, self.setpoint.copy()
        alpha = 1.0 - math.exp(-dt / 0.004)
        previous = self.encoder
        self.encoder = previous + alpha * (self.setpoint - previous)
        if self.lowest is not None:
            self.encoder = np.maximum(self.encoder, self.lowest)
        self.velocity = (self.encoder - previous) / dt


def _state(group: JointGroup | ReferenceGroup) -> bytes:
    arrays = (
        group.setpoint,
        group.tick_setpoint,
        group.previous_tick_setpoint,
        group.encoder,
        group.velocity,
    )
    return b"".join(a.tobytes() for a in arrays)


@pytest.mark.parametrize("size", [6, 1])
def test_the_servo_follows_its_first_order_response_moving_held_or_settled(size):
    rng = np.random.default_rng(6 + size)
    q0 = np.zeros(size)
    group, reference = JointGroup(q0, 0.004, lambda q: [], lambda *a: []), ReferenceGroup(q0)
    settled = 0
    for _ in range(3000):
        event = rng.random()
        if event < 0.01:  # a new set-point (a servo command), sometimes -0.0 or exactly where it was
            target = rng.choice([rng.normal(size=size), -0.0 * np.ones(size), group.setpoint.copy()])
            group.setpoint, reference.setpoint = target.copy(), target.copy()
        elif event < 0.015:  # a motion played over the next ticks
            times = np.cumsum(rng.uniform(0.005, 0.02, int(rng.integers(2, 30))))
            motion = Playback("m", times, rng.normal(size=(len(times), size)))
            group.start(motion)
            reference.motion, reference.elapsed = motion, 0.0
        elif event < 0.02:  # a block stops the encoders from below, or no longer
            lowest = None if rng.random() < 0.5 else float(rng.normal())
            group.stop_at(lowest)
            reference.lowest = None if lowest is None else np.full_like(reference.encoder, lowest)
            if reference.lowest is not None:
                reference.encoder = np.maximum(reference.encoder, reference.lowest)
        dt = float(rng.choice([0.01, 0.01, 0.01, 0.005]))
        group.advance(dt)
        reference.advance(dt)
        settled += group._settled is not None
        assert _state(group) == _state(reference)
    assert settled > 500  # the settled ticks were exercised


def test_a_stop_asked_again_each_tick_changes_nothing():
    rng = np.random.default_rng(13)
    group, reference = (
        JointGroup(np.zeros(1), 0.004, lambda q: [], lambda *a: []),
        ReferenceGroup(np.zeros(1)),
    )
    lowest: float | None = None
    for _ in range(3000):
        event = rng.random()
        if event < 0.02:  # a new stop, at times on the encoders or at a zero of either sign
            lowest = rng.choice([None, float(rng.normal()), float(group.encoder[0]), 0.0, -0.0])
        elif event < 0.04:  # the jaw driven on, through or away from the stop
            target = rng.choice([rng.normal(size=1), -0.0 * np.ones(1), np.zeros(1)])
            group.setpoint, reference.setpoint = target.copy(), target.copy()
        group.stop_at(lowest)  # asked each tick, as the phase simulator asks the world's jaw stop
        reference.lowest = None if lowest is None else np.full_like(reference.encoder, lowest)
        if reference.lowest is not None:
            reference.encoder = np.maximum(reference.encoder, reference.lowest)
        assert _state(group) == _state(reference)
        assert (group.lowest is None and reference.lowest is None) or (
            group.lowest.tobytes() == reference.lowest.tobytes()
        )
        group.advance(0.01)
        reference.advance(0.01)
        assert _state(group) == _state(reference)


def test_a_tools_segments_are_its_shaft_wrist_and_jaw():
    rng = np.random.default_rng(7)
    cell = workcell()
    for _ in range(100):
        q = rng.uniform(-0.5, 0.5, 6) + [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]
        state = ToolState.from_joints(q, 0.5, cell.arm_to_board("PSM1"))
        hinge = state.tip[:3, 3] + cell.tool.jaw_length * state.tip[:3, 2]
        starts, ends, radii = state.segments(cell.tool)
        assert starts.tobytes() == np.array([state.shaft[0], state.shaft[1], hinge]).tobytes()
        assert ends.tobytes() == np.array([state.shaft[1], hinge, state.tip[:3, 3]]).tobytes()
        assert radii.tolist() == [cell.tool.shaft_radius, cell.tool.wrist_radius, cell.tool.jaw_radius]


def _reference_shaft_end_and_tip(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The modified-DH chain on floats, each link's cos and sin of α taken afresh."""
    from pegbt.motion.kinematics import _dh_table

    xx, xy, xz, yx, yy, yz, zx, zy, zz = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    px = py = pz = 0.0
    shaft_end = (0.0, 0.0, 0.0)
    for link, (a, alpha, d, theta) in enumerate(_dh_table(q.tolist(), zero=0.0)):
        ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(theta), math.sin(theta)
        px, py, pz = px + a * xx, py + a * xy, pz + a * xz
        yx, yy, yz, zx, zy, zz = (
            ca * yx + sa * zx,
            ca * yy + sa * zy,
            ca * yz + sa * zz,
            ca * zx - sa * yx,
            ca * zy - sa * yy,
            ca * zz - sa * yz,
        )
        xx, xy, xz, yx, yy, yz = (
            ct * xx + st * yx,
            ct * xy + st * yy,
            ct * xz + st * yz,
            ct * yx - st * xx,
            ct * yy - st * xy,
            ct * yz - st * xz,
        )
        px, py, pz = px + d * zx, py + d * zy, pz + d * zz
        if link == 2:
            shaft_end = (px, py, pz)
    tip = np.array([[xx, yx, zx, px], [xy, yy, zy, py], [xz, yz, zz, pz], [0.0, 0.0, 0.0, 1.0]])
    return np.array(shaft_end), tip


def test_the_tools_kinematics_equal_the_chain_with_each_links_twist_taken_afresh():
    from pegbt.motion.kinematics import shaft_end_and_tip

    rng = np.random.default_rng(8)
    for q in rng.uniform(-1.0, 1.0, (200, 6)) + [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]:
        shaft_end, tip = shaft_end_and_tip(q)
        reference_end, reference_tip = _reference_shaft_end_and_tip(q)
        assert shaft_end.tobytes() == reference_end.tobytes() and tip.tobytes() == reference_tip.tobytes()


def test_contacts_are_the_same_with_the_boxes_of_a_tool_state_kept():
    from pegbt.sim.tools import tool_pointing_down
    from pegbt.sim.world import World

    rng = np.random.default_rng(9)
    cell = workcell()
    moved = replace(cell, pegs=replace(cell.pegs, positions=cell.pegs.positions + [0.002, -0.001]))
    kept, fresh = World(3), World(3)  # the same tool states, asked again; each step's states afresh
    kept_moved, fresh_moved = World(3, cell=moved), World(3, cell=moved)  # another cell, the same states
    for step in range(600):
        arm = ("PSM1", "PSM2")[step % 2 if step % 7 else 0]  # now and then one arm several steps running
        near = cell.pegs.tops[int(rng.integers(len(cell.pegs.tops)))] + rng.normal(0.0, 0.004, 3)
        centre = cell.arm_to_board(arm)[:3, 3]
        tool = tool_pointing_down(near, float(rng.uniform(0, np.pi)), 0.5, centre, cell.tool)
        for world in (fresh, fresh_moved):
            world.tools = {name: _copied(state) for name, state in world.tools.items()}  # nothing kept
        events = [world.update(0.01 * step, {arm: tool}) for world in (kept, kept_moved)]
        afresh = [world.update(0.01 * step, {arm: _copied(tool)}) for world in (fresh, fresh_moved)]
        assert events == afresh
        assert [kept._contacts, kept_moved._contacts] == [fresh._contacts, fresh_moved._contacts]
    assert {event.detail for event in kept.events} >= {"tool-peg", "tool-tool"}
    assert [e for e in kept.events if e.detail == "tool-peg"] != [
        e for e in kept_moved.events if e.detail == "tool-peg"
    ]


def test_a_tool_kept_while_the_other_moves_is_checked_against_the_other_as_it_is_now():
    from pegbt.sim.tools import tool_pointing_down
    from pegbt.sim.world import World

    cell = workcell()
    world = World(3)
    centre = {arm: cell.arm_to_board(arm)[:3, 3] for arm in ("PSM1", "PSM2")}
    meeting, apart = np.array([0.06, 0.04, -0.03]), np.array([-0.03, 0.04, -0.03])
    still = tool_pointing_down(meeting, 0.0, 0.5, centre["PSM1"], cell.tool)
    world.update(0.0, {"PSM1": still})
    seen = []
    for step, where in enumerate([meeting, apart, meeting, apart]):
        moving = tool_pointing_down(where, 0.3, 0.5, centre["PSM2"], cell.tool)
        world.update(0.01 * (step + 1), {"PSM2": moving})
        seen.append(sorted(kind for kind, *_ in world._contacts))
    assert seen == [["tool-tool"], [], ["tool-tool"], []]


def _copied(state: ToolState) -> ToolState:
    return ToolState(state.tip.copy(), state.jaw, state.shaft.copy(), state.give)


def test_a_tools_boxes_bound_its_segments_and_are_kept_for_its_geometry():
    rng = np.random.default_rng(12)
    cell = workcell()
    thick = type(cell.tool)(**{**vars(cell.tool), "shaft_radius": 0.01})
    for _ in range(100):
        q = rng.uniform(-0.5, 0.5, 6) + [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]
        state = _copied(ToolState.from_joints(q, 0.5, cell.arm_to_board("PSM1")))
        for tool in (cell.tool, thick, cell.tool, cell.tool):
            starts, ends, radii = state.segments(tool)
            low = np.array([np.minimum(s, e) - r for s, e, r in zip(starts, ends, radii)])
            high = np.array([np.maximum(s, e) + r for s, e, r in zip(starts, ends, radii)])
            boxes = state.boxes(tool)
            assert [b.tobytes() for b in boxes[:5]] == [a.tobytes() for a in (starts, ends, radii, low, high)]
            assert boxes[5] == max(high[:, 2].tolist())
            assert boxes[6] == (*low.min(axis=0).tolist(), *high.max(axis=0).tolist())
        assert state.boxes(cell.tool) is state.boxes(cell.tool)


def _reference_tools_touching(a, b) -> tuple[bool, bool]:
    """`world._tools_touching` as first written: every pair of segments' boxes, then their distances."""
    from pegbt.frames import segment_distances
    from pegbt.sim.world import boxes_overlap

    first, second = np.nonzero(boxes_overlap(a[3][:, None], a[4][:, None], b[3][None], b[4][None]))
    touching = (
        segment_distances(a[0][first], a[1][first], b[0][second], b[1][second]) < a[2][first] + b[2][second]
    )
    shafts = (first == 0) & (second == 0)
    return bool((touching & shafts).any()), bool((touching & ~shafts).any())


def test_two_tools_apart_as_wholes_touch_as_their_segments_say():
    from pegbt.sim.tools import tool_pointing_down
    from pegbt.sim.world import _tools_touching

    rng = np.random.default_rng(13)
    cell = workcell()
    centre = {arm: cell.arm_to_board(arm)[:3, 3] for arm in ("PSM1", "PSM2")}
    found = set()
    for _ in range(400):
        spread = float(rng.choice([0.002, 0.01, 0.05]))
        tools = [
            tool_pointing_down(
                np.array([0.02, 0.04, -0.03]) + rng.normal(0.0, spread, 3),
                float(rng.uniform(0, np.pi)),
                0.5,
                centre[arm],
                cell.tool,
            ).boxes(cell.tool)
            for arm in ("PSM1", "PSM2")
        ]
        shafts, others = _tools_touching(*tools)
        assert (shafts, bool(others)) == _reference_tools_touching(*tools)
        found.add((shafts, bool(others)))
    assert (False, False) in found and any(any(pair) for pair in found)


def test_a_tool_from_joints_seen_before_is_the_tool_computed_afresh():
    from pegbt.motion.kinematics import shaft_end_and_tip

    rng = np.random.default_rng(10)
    cell = workcell()
    to_board = cell.arm_to_board("PSM2")
    joints = rng.uniform(-0.5, 0.5, (50, 6)) + [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]
    moved = to_board.copy()
    moved[0, 3] += 0.003  # another world's registration offset
    inputs = [
        (jaw, give) for jaw in (0.4, -0.0, 0.0) for give in ((0.0, 0.0, 0.0, 0.0), (1e-3, 0.0, -0.0, 2e-3))
    ]
    for q in [*joints, *joints[::-1], *joints]:  # each seen again, as another world replays the arm
        for board in (to_board, moved):
            for jaw, give in inputs:
                state = ToolState.from_joints(q.copy(), jaw, board.copy(), give)
                shaft_end, tip = shaft_end_and_tip(q)
                rotation, origin = board[:3, :3], board[:3, 3]
                assert state.tip.tobytes() == (board @ tip).tobytes()
                assert state.shaft.tobytes() == np.array([origin, rotation @ shaft_end + origin]).tobytes()
                assert struct.pack("5d", state.jaw, *state.give) == struct.pack("5d", jaw, *give)
                assert not state.tip.flags.writeable and not state.shaft.flags.writeable  # shared


def _reference_command_for_target(arm, target: np.ndarray, drives: np.ndarray) -> np.ndarray:
    """`SettledArm.command_for_target`'s Newton steps as first written: each step's right-hand side from
    the target, the drives and the pieces afresh."""
    offset = arm.physics.offset

    def solve_one(pieces):
        in_band = (pieces[None] == 0).astype(float)
        matrices = arm.matrix[None] - np.einsum("jn,kn,ni->kji", arm.into, in_band * arm.gain, arm.drive_rows)
        if not np.abs(np.linalg.det(matrices))[0] > 1e-12:
            return np.full(len(target), np.nan)
        constant = in_band * (drives - arm.drive_offsets) + (1.0 - in_band) * pieces[None] * arm.play
        rhs = target - offset - (constant * arm.gain) @ arm.into.T
        return np.linalg.solve(matrices, rhs[..., None])[0, :, 0]

    pieces = arm._pieces(np.linalg.solve(arm.matrix, target - offset), drives)
    candidates, seen = [], set()
    for _ in range(20):
        q = solve_one(pieces)
        if arm._miss(q, target, drives) < 1e-9:
            return q
        candidates.append(q)
        seen.add(pieces.tobytes())
        pieces = arm._pieces(q, drives)
        if pieces.tobytes() in seen:
            break
    return None  # the enumeration of every piece is not exercised here


@pytest.mark.parametrize("name", ["PSM1", "PSM2"])
def test_the_compensators_newton_steps_equal_their_formula(name):
    from pegbt.calibration.physics_model import SettledArm

    rng = np.random.default_rng(12)
    arm = SettledArm(ArmPhysics.load("dvrk-real", name))
    state = arm.settle(np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0]))
    reached = 0
    for q in _walk(rng, 300):
        target = arm.physics.static_map(q) + rng.normal(0.0, 0.002, 6)
        expected = _reference_command_for_target(arm, target, state.drives)
        found = arm.command_for_target(target, state.drives)
        if expected is not None:
            reached += 1
            assert found.tobytes() == expected.tobytes()
        state = arm.step(found, state)
    assert reached > 250


def _reference_segment_distances(p0, p1, q0, q1):
    """`segment_distances` as first written: every clamp by `np.clip`, the nearest point to p's start
    clamped twice."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e = np.einsum("...i,...i->...", d1, d1), np.einsum("...i,...i->...", d2, d2)
    b, c = np.einsum("...i,...i->...", d1, d2), np.einsum("...i,...i->...", d1, r)
    f = np.einsum("...i,...i->...", d2, r)
    eps = 1e-12
    safe_a, safe_e = np.maximum(a, eps), np.maximum(e, eps)
    denominator = a * e - b * b
    s = np.where(
        denominator > eps,
        np.clip((b * f - c * e) / np.maximum(denominator, eps), 0.0, 1.0),
        np.clip(-c / safe_a, 0.0, 1.0),
    )
    t = (b * s + f) / safe_e
    s = np.where(
        t < 0.0, np.clip(-c / safe_a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / safe_a, 0.0, 1.0), s)
    )
    t = np.clip(t, 0.0, 1.0)
    s, t = np.where(a > eps, s, 0.0), np.where(e > eps, t, 0.0)
    return np.linalg.norm((p0 + s[..., None] * d1) - (q0 + t[..., None] * d2), axis=-1)


def test_segment_distances_equal_their_formula_with_every_clamp_by_np_clip():
    from pegbt.frames import _EPS, segment_distances

    assert _EPS == 1e-12
    rng = np.random.default_rng(14)
    for _ in range(300):
        n = int(rng.integers(1, 8))
        p0, p1, q0, q1 = (rng.normal(0.0, 0.02, (n, 3)) for _ in range(4))
        points = rng.random(n) < 0.2
        p1[points] = p0[points]  # some of p points
        q1[::3] = q0[::3]  # some of q points
        p1[1::4] = p0[1::4] + 2.0 * (q1[1::4] - q0[1::4])  # some parallel pairs
        p1[2::5] = -0.0 * p1[2::5]  # signed zeros
        assert (
            segment_distances(p0, p1, q0, q1).tobytes()
            == _reference_segment_distances(p0, p1, q0, q1).tobytes()
        )
        assert float(segment_distances(p0[0], p1[0], q0[0], q1[0])) == float(
            _reference_segment_distances(p0[0], p1[0], q0[0], q1[0])
        )
