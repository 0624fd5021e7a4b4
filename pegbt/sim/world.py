"""The world the arms act in: a pegboard, six FLS blocks, and geometry that decides what happens.

The endpoint calls `World.update(time, tools)` every simulation step with each arm's tool state (from
its physical joints). Nothing is scripted: a closing jaw grips a block only if its open jaws straddle one
of the block's walls and the block can slide (on its peg, within the hole's clearance) until the wall
sits centred between them, the wrist's cable play (`ToolState.give`) taking what the peg stops; a
gripped block moves rigidly with the jaw (held by two, with the jaw that holds it, the other sliding along
its wall: `World._carry`); lifting it clears its peg only if the hole stays around the
peg all the way up (a peg pressing on the hole pushes the block, and the jaw
holding it, aside as far as the wrist's cable play gives: `ToolState.give`); a released block lands on a
peg only if its hole is over one within the clearance, and otherwise drops onto the board (or off it).
Every such outcome, every collision and every injected fault is appended to `World.events`, the ground
truth of a trial.

That world is rigid. `World(effects=...)` relaxes it with the world effects of `pegbt.sim.world_effects`:
a peg that bends, chamfers that catch a hole near a peg, closing jaws that grip a wall off their centre
as far as the wrist yields, a block that slides and turns in the jaws, jaws that let a block slip under load, and a camera-to-robot registration offset (the arms' bases truly stand
off the work cell's figures, `arm_to_board`; the camera applies the depth bias). With none, or all at
their defaults, the world takes exactly the rigid paths, outcome for outcome.
"""

from __future__ import annotations

import math
from bisect import insort
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from itertools import combinations

import numpy as np

from pegbt.frames import (
    Matrix,
    invert_rigid,
    rigid_transform,
    segment_distances,
    yaw_of,
    yaw_pose,
    yaw_rotation,
)
from pegbt.sim.blocks import Block
from pegbt.sim.events import Event, EventLog
from pegbt.sim.faults import SlipAt, WorldFaults
from pegbt.sim.grasp_tilt import tilt_problem
from pegbt.sim.hole import HoleRoom
from pegbt.sim.interfaces import WorldSnapshot
from pegbt.sim.tools import RIGID, TOOL_PARTS, Boxes, Give, ToolState
from pegbt.sim.world_effects import BLOCK_MASS, GRAVITY, WorldEffects
from pegbt.workcell import Workcell, workcell

_LOST_BELOW_BOARD = 0.1  # where a block that left the workspace lies: on the floor, 10 cm below the board
_SLIDE_STEP = 0.0005  # m: a block that fell against pegs slides off them in steps this long
_SLIDE_STEPS = 200  # at most this many (10 cm): a block cannot rest inside a peg
_GUIDED_INSIDE = 1e-6  # m: a block the chamfers guide ends this far inside the clearance, clear of the peg
_YIELD_ROUNDS = 8  # alternations between what the arm's compliance takes and what the peg still pushes
_ACCELERATION_WINDOW = 0.02  # s between the tip positions a held block's acceleration is taken from


@dataclass(frozen=True)
class WorldConfig:
    """Tolerances of the world's physics (metres, radians)."""

    jaw_closed_below: float = 0.25  # a jaw closing past this angle grips (it meets a 2 mm wall at 0.21)
    jaw_open_above: float = 0.35  # a gripping jaw opening past this angle lets go
    grasp_edge_margin: float = 0.001  # the jaw tip must stay this far inside the ends of the flat edge
    grasp_min_bite: float = 0.001  # the jaw tip must reach this far below the block's top face
    grasp_max_misalignment: float = math.radians(30)  # between the jaw-closing axis and the wall's normal
    grasp_search_radius: float = 0.015  # a closing jaw this near a block's centre is a grasp attempt
    handover_pull_apart: float = 0.003  # a block dragged this far through a squeezing jaw pulls out of it
    grip_give: float = 0.0002  # m: two grips disagreeing less than this hold the block between them
    peg_slack: float = 0.0  # extra clearance allowed between hole and peg before the block catches
    tip_off_clearance: float = (
        0.003  # m: a block that fell against pegs slides off until this far clear of them
    )
    board_press_tolerance: float = 0.0005  # a held block pushed this far into the board is a collision
    initial_yaw_spread: float = math.pi / 3  # initial yaws are drawn from ± this


class World:
    """Pegboard, blocks and ground-truth events; deterministic for a given seed and tool history."""

    def __init__(
        self,
        seed: int = 0,
        *,
        cell: Workcell | None = None,
        config: WorldConfig = WorldConfig(),
        faults: WorldFaults = WorldFaults(),
        effects: WorldEffects = WorldEffects(),
    ) -> None:
        self.cell = cell or workcell()
        self.config = config
        self.faults = faults
        self.effects = effects
        self.seed = seed
        layout_seed, fault_seed = np.random.SeedSequence(seed).spawn(2)
        self._rng = np.random.default_rng(fault_seed)
        self.events = EventLog()
        self.time = 0.0
        self.tools: dict[str, ToolState] = {}
        self._closed: dict[str, bool] = {}
        self._widest: dict[str, float] = {}  # widest jaw angle of each arm since its jaw last opened
        self._contacts: set[tuple[str, str, int, int]] = set()
        self._attempts = 0
        self._timed = [slip for slip in faults.slips if slip.after is None]  # sorted by time
        self._marked = [slip for slip in faults.slips if slip.after is not None]
        self._counted = [0] * len(self._marked)  # events each marked slip's mark has seen
        pegs, board = self.cell.pegs, self.cell.board
        self._peg_tops = pegs.tops
        self._peg_feet = np.column_stack([pegs.positions, np.full(len(pegs.positions), board.surface_z)])
        self._peg_low = self._peg_tops - [pegs.radius, pegs.radius, 0.0]  # bounding boxes of the pegs
        self._peg_high = self._peg_feet + [pegs.radius, pegs.radius, 0.0]
        self._peg_boxes = self._peg_low[None], self._peg_high[None]  # as `boxes_overlap` broadcasts them
        self._peg_top_z = float(self._peg_low[0, 2])
        clearance = self.cell.block.hole_radius - pegs.radius + config.peg_slack
        wall = self.cell.block.edge_distance - self.cell.block.hole_radius
        self._jaw_on_wall = 2.0 * math.asin(min(1.0, wall / 2.0 / self.cell.tool.jaw_length))  # `jaw_stop`
        # how far beyond the hole's room the chamfers catch a peg: what their capture radius adds to the clearance
        self._chamfers = max(0.0, effects.values("chamfer_capture")["capture_radius"] - clearance)
        self._room = _hole_room(self.cell, effects.values("hole_lobes")["lobe_radius"], config.peg_slack)
        self._grasp_capture = effects.values("grasp_capture")["width"]
        self._tip_slide = effects.values("jaw_tip_slide")["width"]
        bending, grip = effects.values("peg_compliance"), effects.values("grip_compliance")
        self._peg_bend, self._peg_stiffness = bending["deflection"], bending["stiffness"]
        self._grip_angle, self._grip_slide = grip["angle"], grip["displacement"]
        self._yielding = self._peg_bend > 0 or self._grip_angle > 0 or self._grip_slide > 0
        self._friction = effects.values("jaw_friction") if effects.has("jaw_friction") else None
        self._peg_load: dict[int, float] = {}  # N: what a bent peg pushes each threaded block with
        self._drags: dict[tuple[int, str], tuple[str, float]] = {}  # (block, jaw): (dragged by, m so far)
        self._bites: dict[tuple[int, str], float] = {}  # (block, jaw): its tip below the top as it gripped
        self._tip_samples: dict[str, list[tuple[float, Matrix]]] = {}  # (time, tip position), the last 3
        layout = np.random.default_rng(layout_seed)
        self.blocks: list[Block] = []
        for index, peg in enumerate(pegs.left_group):
            block = Block(index, np.eye(4), peg)
            self._rest_on_peg(
                block, peg, layout.uniform(-config.initial_yaw_spread, config.initial_yaw_spread)
            )
            self.blocks.append(block)

    # ----------------------------------------------------------------------------------------- queries

    def block_poses(self) -> Matrix:
        """(6, 4, 4) pose of every block in the board frame."""
        return np.array([block.pose for block in self.blocks])

    def held_by(self, arm: str) -> int | None:
        """Index of the block `arm` grips, if any."""
        for block in self.blocks:
            if arm in block.grips:
                return block.index
        return None

    def jaw_stop(self, arm: str) -> float | None:
        """The jaw angle at which the gripped block's wall stops `arm`'s jaw (None when it grips nothing).

        The endpoint may hold the physical jaw there, as a real jaw closing on a block would.
        """
        if self.held_by(arm) is None:
            return None
        return self._jaw_on_wall

    @property
    def registration_offset(self) -> Matrix:
        """(3,) m, board frame: how far every instrument truly is from where the robot places it
        (`registration_offset`; zero by default)."""
        offset = self.effects.values("registration_offset")
        return np.array([offset["x"], offset["y"], offset["z"]])

    def arm_to_board(self, arm: str) -> Matrix:
        """Where `arm`'s base truly stands in the board frame: the work cell's figure, displaced by the
        registration offset. The robot plans by the work cell's, so each of its targets is off by it."""
        nominal = self.cell.arm_to_board(arm)
        if not self.effects.has("registration_offset"):
            return nominal
        return rigid_transform(None, self.registration_offset) @ nominal

    def snapshot(self) -> WorldSnapshot:
        """JSON-ready state of the world: time and every block."""
        return {"time": self.time, "blocks": [block.to_dict() for block in self.blocks]}

    # ------------------------------------------------------------------------------------------ update

    def update(self, time: float, tools: Mapping[str, ToolState]) -> list[Event]:
        """Advance to `time` (s) with each arm's tool state; returns the events of this step."""
        start = len(self.events)
        elapsed = max(0.0, time - self.time)
        self.time = time
        self.tools.update(tools)
        if self._friction is not None:
            self._sample_tips(tools)
        for block in self.blocks:
            if block.grips:
                self._carry(block)
            elif self._drags:
                self._end_drags(block)
        for arm in sorted(tools):
            self._follow_jaw(arm, tools[arm])
        self._inject_slips(elapsed)
        self._detect_contacts()
        return self.events.since(start)

    def _log(
        self,
        kind: str,
        arm: str | None = None,
        block: int | None = None,
        peg: int | None = None,
        detail: str = "",
        parts: str = "",
    ) -> None:
        event = Event(self.time, kind, arm, block, peg, detail, parts)
        self.events.append(event)
        self._schedule_marked_slips(event)

    def _schedule_marked_slips(self, event: Event) -> None:
        """A slip timed after the nth event of a kind is scheduled when that event happens."""
        for index, slip in enumerate(self._marked):
            mark = slip.after
            if mark is None or not mark.matches(event):
                continue
            self._counted[index] += 1
            if self._counted[index] == mark.nth:
                insort(self._timed, SlipAt(event.time + slip.time, slip.arm), key=lambda s: s.time)

    # ----------------------------------------------------------------------------------- jaw and grips

    def _follow_jaw(self, arm: str, tool: ToolState) -> None:
        closed = self._closed.get(arm)
        if not closed:
            self._widest[arm] = max(self._widest.get(arm, tool.jaw), tool.jaw)
        if closed is None:  # first sight of this arm: its jaw state, without a transition
            self._closed[arm] = tool.jaw < self.config.jaw_closed_below
        elif not closed and tool.jaw < self.config.jaw_closed_below:
            self._closed[arm] = True
            self._try_grasp(arm, tool, self._widest.pop(arm, tool.jaw))
        elif closed and tool.jaw > self.config.jaw_open_above:
            self._closed[arm] = False
            for block in self.blocks:
                if arm in block.grips:
                    del block.grips[arm]
                    self._log("release", arm, block.index, block.peg)
                    if not block.grips:
                        self._settle(block, arm, deliberate=True)

    def _try_grasp(self, arm: str, tool: ToolState, opened: float) -> None:
        """`arm`'s jaw, opened to `opened` (rad), has just closed at `tool`: grip the nearest block it can."""
        attempt = self._attempts
        self._attempts += 1
        best: tuple[float, Block, str | None, int, Matrix] | None = None
        for block in self.blocks:
            if block.lost or arm in block.grips:
                continue
            local = invert_rigid(block.pose) @ tool.tip
            distance = float(np.linalg.norm(local[:3, 3] + [0.0, 0.0, self.cell.block.height / 2]))
            if distance > self.config.grasp_search_radius:
                continue
            problem, edge, slide = self._grip_problem(block, local, opened, tool.give)
            candidate = (int(problem is not None), distance)
            if best is None or candidate < (int(best[2] is not None), best[0]):
                best = (distance, block, problem, edge, slide)
        if best is None:
            return  # closing in the air: not a grasp attempt
        _, block, problem, edge, slide = best
        if problem is not None:
            self._log("grasp_miss", arm, block.index, block.peg, problem)
            return
        if attempt in self.faults.miss_attempts or (
            self.faults.miss_probability > 0 and self._rng.random() < self.faults.miss_probability
        ):
            self._log("fault", arm, block.index, block.peg, f"grasp miss injected (attempt {attempt})")
            self._log("grasp_miss", arm, block.index, block.peg, "injected fault")
            return
        giver = next(iter(block.grips), None)
        if giver is None:  # a free block slides until its wall sits centred between the closing jaws
            block.pose = block.pose @ rigid_transform(None, [slide[0], slide[1], 0.0])
        block.grips[arm] = invert_rigid(tool.tip) @ block.pose
        self._bites[block.index, arm] = float(invert_rigid(block.grips[arm])[2, 3]) + self.cell.block.height
        detail = f"edge {edge}"
        if giver is not None:  # a held block does not slide: the jaw holds it as far off the wall's centre
            detail += (
                f", handover from {giver}, {1000 * float(np.linalg.norm(slide)):.1f} mm off the wall's centre"
            )
        self._log("grasp", arm, block.index, block.peg, detail)

    def _grip_problem(
        self, block: Block, local: Matrix, opened: float, give: Give = RIGID
    ) -> tuple[str | None, int, Matrix]:
        """Why a jaw opened to `opened` and closing at `local` (tip pose in the block frame) would not
        grip `block`, which edge it closes on, and how far (block x, y) the block slides into the jaws.

        The open jaw tips lie `jaw_length`·sin(opened/2) either side of the tool's axis. They grip when
        they straddle a wall (one tip in the hole, the other beyond the flat edge), the closing axis
        crosses that wall, the tips bite below the top face and, the wall centred under the tip, a tool
        standing off the block's axis still closes both jaws on the wall (`grasp_tilt.tilt_problem`:
        the jaws' and the wall's geometry, not an angle). The first jaw to touch pushes the block until
        the wall is centred between the jaws: a free block slides that far, a block on a peg only as far
        as the hole's clearance lets it; the rest pushes the tip aside, as a peg pressing on a held block
        does, within the wrist's cable play (`give`, the tool's along its x and y) and then its compliance
        (`grasp_capture`); beyond both, the peg holds the wall against one jaw and the other closes beside it. A block held by another jaw
        cannot slide; the holders' disagreement is judged as it is carried.
        """
        model, config = self.cell.block, self.config
        rotation, tip = local[:3, :3], local[:3, 3]
        alignment = np.abs(model.edge_normals @ rotation[:2, 0])
        edge = int(np.argmax(alignment))
        no_slide = np.zeros(2)
        if alignment[edge] < math.cos(config.grasp_max_misalignment):
            return "jaws do not close across a wall", edge, no_slide
        normal = model.edge_normals[edge]
        along = float(tip[:2] @ [-normal[1], normal[0]])
        if abs(along) > model.edge_half_length - config.grasp_edge_margin:
            return "jaw beyond the end of the wall", edge, no_slide
        if tip[2] > 0.0:
            return "jaw below the block", edge, no_slide
        if tip[2] + model.height < config.grasp_min_bite:
            return "jaw above the block", edge, no_slide
        wall_half = (model.edge_distance - model.hole_radius) / 2
        off_centre = float(tip[:2] @ normal) - (model.hole_radius + wall_half)
        reach = self.cell.tool.jaw_length * math.sin(max(opened, 0.0) / 2) * alignment[edge] - wall_half
        if abs(off_centre) >= reach + self._tip_slide:  # a tip on the wall's top slides off its edge
            return (
                f"jaws open {max(reach, 0.0) * 1000:.1f} mm either side of the wall's centre miss it by {abs(off_centre) * 1000:.1f} mm",
                edge,
                no_slide,
            )
        tilted = tilt_problem(local, opened, normal, model, self.cell.tool.jaw_length, config.grasp_min_bite)
        if tilted is not None:
            return tilted, edge, no_slide
        slide = off_centre * normal
        if block.peg is not None and not block.grips:
            peg_xy = self._pegs_in_block_frame(block)[block.peg]  # where the peg stands in the hole
            if not self._room.within(peg_xy - slide)[0]:
                stopped = self._room.slide(peg_xy, normal, off_centre, _GUIDED_INSIDE)
                beyond_play = _beyond_play(-(off_centre - stopped) * normal, local[:2, :2], give)
                if beyond_play > self._grasp_capture + 1e-9:  # what the play takes is rounded
                    return (
                        f"jaw {abs(off_centre) * 1000:.1f} mm off the wall's centre: peg {block.peg} stops the block",
                        edge,
                        no_slide,
                    )
                slide = stopped * normal  # the wrist yields the rest (its play, then `grasp_capture`)
        return None, edge, slide

    def _slip(self, arm: str, block: Block, detail: str) -> None:
        """`arm`'s grip on `block` is lost without its jaw opening."""
        del block.grips[arm]
        self._log("slip", arm, block.index, block.peg, detail)
        if not block.grips:
            self._settle(block, arm, deliberate=False)

    def _inject_slips(self, elapsed: float) -> None:
        while self._timed and self._timed[0].time <= self.time:
            scheduled = self._timed.pop(0)
            arms = [scheduled.arm] if scheduled.arm else sorted(self.tools)
            held = [(arm, index) for arm in arms if (index := self.held_by(arm)) is not None]
            if not held:
                self._log(
                    "fault", scheduled.arm, detail=f"slip scheduled at {scheduled.time:g} s: nothing held"
                )
                continue
            arm, index = held[0]
            self._log(
                "fault",
                arm,
                index,
                self.blocks[index].peg,
                f"slip injected (scheduled at {scheduled.time:g} s)",
            )
            self._slip(arm, self.blocks[index], "injected fault")
        if self.faults.slip_rate <= 0 or elapsed <= 0:
            return
        chance = -math.expm1(-self.faults.slip_rate * elapsed)
        for arm in sorted(self.tools):
            index = self.held_by(arm)
            if index is not None and self._rng.random() < chance:
                self._log("fault", arm, index, self.blocks[index].peg, "slip injected (random)")
                self._slip(arm, self.blocks[index], "injected fault")

    # ------------------------------------------------------------------------------ blocks among pegs

    def _carry(self, block: Block) -> None:
        """Move a gripped block with the jaw that holds it (`_holder`). A block held by two jaws that move
        apart cannot follow both: it slides along its wall in the other jaw, whose grip moves with it. A
        jaw opened off the wall lets it slide freely; a jaw still squeezing is dragged along it: a `drag`
        event (its length) once either jaw lets go, a `slip` (pulled out) once it passes
        `handover_pull_apart`."""
        holders = list(block.grips)
        poses = {arm: self.tools[arm].tip @ block.grips[arm] for arm in holders}
        holder = self._holder(block, poses)
        carried = poses[holder]
        for other in holders:
            if other == holder:
                continue
            slide = float(np.linalg.norm(poses[other][:3, 3] - carried[:3, 3]))
            if slide <= self.config.grip_give:
                continue
            block.grips[other] = invert_rigid(self.tools[other].tip) @ carried
            if not self._squeezing(other):
                continue
            by, dragged = self._drags.pop((block.index, other), (holder, 0.0))
            if dragged + slide > self.config.handover_pull_apart:
                self._slip(
                    other, block, f"pulled out of the jaw by {by}: dragged {(dragged + slide) * 1000:.1f} mm"
                )
                continue
            self._drags[block.index, other] = (by, dragged + slide)
        if self._drags:
            self._end_drags(block)
        block.pose = carried
        self._peg_load.pop(block.index, None)
        self._check_pegs(block)
        if self._friction is not None and block.grips:
            self._hold_or_slip(block)

    def _holder(self, block: Block, poses: dict[str, Matrix]) -> str:
        """Which of the jaws gripping `block` (`poses`: where each puts it) holds it: the first, unless the
        grips disagree by more than `grip_give`; then a jaw squeezing the wall (its encoder stopped on it)
        before one opened off it, then the deepest grip as it closed (more of the wall between its jaws: the
        tip below the block's top, by more than `grip_give`), then the first. The world reads the jaws'
        encoders, not their squeeze: two jaws on the wall at one depth leave it with the first."""
        holders = list(poses)
        if len(holders) == 1:
            return holders[0]
        first = poses[holders[0]][:3, 3]
        if all(np.linalg.norm(pose[:3, 3] - first) <= self.config.grip_give for pose in poses.values()):
            return holders[0]
        give = self.config.grip_give

        def hold(arm: str) -> tuple[bool, float, int]:
            bite = self._bites.get((block.index, arm), 0.0)
            return (not self._squeezing(arm), -round(bite / give), holders.index(arm))

        return min(holders, key=hold)

    def _squeezing(self, arm: str) -> bool:
        """Whether `arm`'s jaw presses on the wall it grips: its encoder stopped there (`jaw_stop`), not
        opened off it (it lets go only at `jaw_open_above`, the wall slides freely in it meanwhile)."""
        return self.tools[arm].jaw <= self._jaw_on_wall + 1e-9

    def _end_drags(self, block: Block) -> None:
        """Log each drag of `block` that is over: the jaw it was dragged through, or the one that dragged
        it, let go."""
        over = [
            key
            for key, (by, _) in self._drags.items()
            if key[0] == block.index and not {key[1], by} <= set(block.grips)
        ]
        for index, arm in over:
            by, dragged = self._drags.pop((index, arm))
            self._log(
                "drag", arm, index, block.peg, f"dragged {dragged * 1000:.1f} mm through {arm}'s jaw by {by}"
            )

    def _hole_axis(self, block: Block) -> tuple[Matrix, Matrix]:
        """Board-frame points where the hole's axis leaves the bottom and the top face."""
        bottom = block.pose[:3, 3]
        return bottom, bottom - self.cell.block.height * block.pose[:3, 2]

    def _pegs_in_block_frame(self, block: Block) -> Matrix:
        """(12, 2) where each peg's axis crosses the block's bottom plane, in block x, y."""
        bottom = block.pose[:3, 3]
        feet = np.column_stack([self.cell.pegs.positions, np.full(len(self._peg_tops), bottom[2])])
        return ((feet - bottom) @ block.pose[:3, :3])[:, :2]

    def _in_footprint(self, points: Matrix, margin: float = 0.0) -> Matrix:
        """Which (n, 2) block-frame peg positions touch the block's solid outline (or come within `margin`)."""
        normals, offsets = self.cell.block.outline_planes
        return (points @ normals.T - offsets).max(axis=1) <= self.cell.pegs.radius + margin

    def _check_pegs(self, block: Block) -> None:
        """A carried block must keep its hole around the peg it is threaded on, and hit no other peg."""
        peg_top_z = self.cell.pegs.top_z
        if block.peg is None and block.pose[2, 3] <= peg_top_z:
            return  # above every peg
        bottom, top = self._hole_axis(block)
        if block.peg is not None:
            peg = block.peg
            if bottom[2] < peg_top_z:  # the whole block is above the peg top (z points down)
                self._log("lift", "+".join(block.grips), block.index, peg, f"cleared peg {peg}")
                block.peg = None
                return
            span = bottom[2] - top[2]
            if span < self.cell.block.height / 2:  # tipped more than 60° while around the peg
                self._knock_loose(block, peg, f"caught on peg {peg}: block tipped over")
                return
            low = min(bottom[2], self.cell.board.surface_z)
            high = max(top[2], peg_top_z)
            points = [bottom + (bottom[2] - z) / span * (top - bottom) for z in (low, high)]
            offsets = np.array([p[:2] - self.cell.pegs.positions[peg] for p in points])
            push = self._peg_push(block, offsets)
            if push is None:
                return
            if self._yielding:
                if self._yield_to_peg(block, offsets, np.array(points), push):
                    return
            elif (
                self._beyond_room(block, offsets + push).max() <= 1e-9  # not tipped across it
                and self._holders_give(block, push)
            ):
                block.pose[:2, 3] += push  # the peg guides the hole; the holders' wrists yield
                return
            offset = float(np.linalg.norm(offsets, axis=1).max())
            self._knock_loose(block, peg, f"caught on peg {peg}: hole {offset * 1000:.1f} mm off its axis")
            return
        local = self._pegs_in_block_frame(block)
        radial = np.linalg.norm(local, axis=1)
        beyond = np.full(len(local), np.inf)  # a peg farther than the lobes and chamfers reach is not near
        near = radial <= self._room.lobe + self._chamfers
        beyond[near] = self._room.outside(local[near])
        entering = np.flatnonzero(beyond <= 1e-12)
        if len(entering):
            block.peg = int(entering[0])
            return
        caught = np.flatnonzero(beyond <= self._chamfers + 1e-12)
        if len(caught):
            self._guide_onto(block, int(caught[np.argmin(beyond[caught])]), local)
            return
        struck = np.flatnonzero(self._in_footprint(local))
        if len(struck):
            peg = int(struck[0])
            self._knock_loose(block, peg, f"struck peg {peg}: hole {radial[peg] * 1000:.1f} mm off its axis")

    def _beyond_room(self, block: Block, offsets: Matrix) -> Matrix:
        """How far (m) the peg stands beyond its room in `block`'s hole at each of the hole axis's
        `offsets` (n, 2, board x, y, from the peg's axis)."""
        return self._room.outside(-offsets @ yaw_rotation(yaw_of(block.pose))[:2, :2])

    def _peg_push(self, block: Block, offsets: Matrix) -> Matrix | None:
        """The sideways push (board x, y) with which the peg keeps the hole around it, given the hole
        axis's offsets (n, 2) from the peg's axis along their overlap; None when the hole is clear of it."""
        rotation = yaw_rotation(yaw_of(block.pose))[:2, :2]
        pegs = -offsets @ rotation  # the peg's axis in the hole, block x, y
        beyond = pegs - self._room.nearest(pegs)
        worst = int(np.argmax(np.linalg.norm(beyond, axis=1)))
        if np.linalg.norm(beyond[worst]) <= 1e-12:
            return None
        return rotation @ beyond[worst]

    def _holders_give(self, block: Block, push: Matrix) -> bool:
        """Whether every jaw holding `block` yields to `push` (board x, y) within its wrist's play."""
        for arm in block.grips:
            tool = self.tools[arm]
            x, y = tool.tip[:2, :2].T @ push  # along the tip's x and y
            minus_x, plus_x, minus_y, plus_y = tool.give
            if not (-minus_x <= x <= plus_x and -minus_y <= y <= plus_y):
                return False
        return True

    def _yield_to_peg(self, block: Block, offsets: Matrix, points: Matrix, push: Matrix) -> bool:
        """Whether the peg keeps the hole of `block` around it with the world effects' compliance: the
        holders' wrists take what they can (their play), then a single holder's grip (the block sliding
        along the jaws, and turning about their closing axis as far as that moves the point the peg
        presses), then the peg bends; the block moves by what the wrists and the grip took (found by
        alternating between them and the peg's push). False when the peg would have to bend further than
        it can, or the hole is tipped across it."""
        room, along = 0.0, np.zeros(2)
        if len(block.grips) == 1 and (self._grip_slide > 0 or self._grip_angle > 0):
            tip = self.tools[next(iter(block.grips))].tip
            along = tip[:2, 1] / max(float(np.linalg.norm(tip[:2, 1])), 1e-9)
            pressed = points[int(np.argmax(np.linalg.norm(offsets, axis=1)))]
            lever = float(np.linalg.norm(np.cross(tip[:3, 0], pressed - tip[:3, 3])))
            room = self._grip_slide + lever * math.sin(self._grip_angle)
        moved = np.zeros(2)
        rest: Matrix | None = push
        for _ in range(_YIELD_ROUNDS):
            assert rest is not None  # the loop ends once the peg pushes no more
            wanted = moved + rest
            taken = self._wrists_take(block, wanted)
            taken = taken + float(np.clip((wanted - taken) @ along, -room, room)) * along
            settled = np.allclose(taken, moved, rtol=0.0, atol=1e-12)
            moved = taken
            rest = self._peg_push(block, offsets + moved)
            if rest is None or settled:
                break
        bend = 0.0 if rest is None else float(np.linalg.norm(rest))
        if bend > self._peg_bend + 1e-12:
            return False
        if self._beyond_room(block, offsets + moved).max() > bend + 1e-9:
            return False  # tipped across the peg
        block.pose[:2, 3] += moved
        self._peg_load[block.index] = self._peg_stiffness * bend
        return True

    def _wrists_take(self, block: Block, push: Matrix) -> Matrix:
        """The part of `push` (board x, y) within every holder's wrist play (`ToolState.give`)."""
        taken = np.array(push, dtype=float)
        for arm in block.grips:
            tool = self.tools[arm]
            axes = tool.tip[:2, :2]  # the tip's x and y, in board x, y
            x, y = axes.T @ taken
            minus_x, plus_x, minus_y, plus_y = tool.give
            taken = (
                taken
                - (x - np.clip(x, -minus_x, plus_x)) * axes[:, 0]
                - (y - np.clip(y, -minus_y, plus_y)) * axes[:, 1]
            )
        return taken

    def _guide_onto(self, block: Block, peg: int, local: Matrix) -> None:
        """The chamfers of hole and peg catch a block lowered within the capture radius: it slides (in
        the jaws holding it) until the peg stands within the hole's room, threaded on it."""
        shift = local[peg] - self._room.shrunk(_GUIDED_INSIDE).nearest(local[peg])[0]  # block x, y
        block.pose[:3, 3] += block.pose[:3, :2] @ shift
        for arm in block.grips:
            block.grips[arm] = invert_rigid(self.tools[arm].tip) @ block.pose
        block.peg = peg

    def _sample_tips(self, tools: Mapping[str, ToolState]) -> None:
        """Keep each tip's last three positions, `_ACCELERATION_WINDOW` apart, for its acceleration."""
        for arm, tool in tools.items():
            samples = self._tip_samples.setdefault(arm, [])
            if not samples or self.time - samples[-1][0] >= _ACCELERATION_WINDOW:
                samples.append((self.time, tool.tip[:3, 3].copy()))
                del samples[:-3]

    def _acceleration(self, arm: str) -> Matrix:
        """`arm`'s tip acceleration (board frame, m/s²) over its last three samples; zero before it has them."""
        samples = self._tip_samples.get(arm, [])
        if len(samples) < 3:
            return np.zeros(3)
        (t0, p0), (t1, p1), (t2, p2) = samples
        return 2.0 * ((p2 - p1) / (t2 - t1) - (p1 - p0) / (t1 - t0)) / (t2 - t0)

    def _hold_or_slip(self, block: Block) -> None:
        """`jaw_friction`: a holder whose tip accelerates beyond the grip's limit, or whose share of the load
        (a carried block's weight as the tip accelerates, a bent peg's push) exceeds it, loses the block."""
        assert self._friction is not None  # only called with jaw friction configured
        holders = list(block.grips)
        for arm in holders:
            acceleration = self._acceleration(arm)
            carried = block.peg is None
            weight = (
                BLOCK_MASS * float(np.linalg.norm(acceleration - [0.0, 0.0, GRAVITY])) if carried else 0.0
            )
            load = (weight + self._peg_load.get(block.index, 0.0)) / len(holders)
            shaken = float(np.linalg.norm(acceleration)) if carried else 0.0
            if shaken > self._friction["max_acceleration"]:
                self._slip(arm, block, f"shaken out of the jaw: tip accelerating {shaken:.2f} m/s²")
            elif load > self._friction["max_load"]:
                self._slip(arm, block, f"slipped out of the jaw: load {load:.3f} N")
            if not block.grips:
                return

    def _knock_loose(self, block: Block, peg: int, detail: str) -> None:
        """A peg stops a carried block: the contact tears it out of every jaw and it falls."""
        holders = "+".join(block.grips)
        self._log("collision", holders, block.index, peg, f"block-peg: {detail}")
        block.grips.clear()
        self._settle(block, holders, deliberate=False)

    def _settle(self, block: Block, arm: str, deliberate: bool) -> None:
        """Let a block no jaw holds fall: onto a peg through its hole, else onto the board or off it."""
        yaw = yaw_of(block.pose)
        peg = block.peg
        if peg is None:
            beyond = self._room.outside(self._pegs_in_block_frame(block))
            peg = int(np.argmin(beyond)) if beyond.min() <= self._chamfers + 1e-12 else None
        if peg is not None:
            self._rest_on_peg(block, peg, yaw)
            if deliberate:
                self._log("place", arm, block.index, peg)
            else:
                self._log("drop", arm, block.index, peg, f"onto peg {peg}")
            return
        struck = np.flatnonzero(self._in_footprint(self._pegs_in_block_frame(block)))
        detail = f" off the top of peg {struck[0]}" if len(struck) else ""
        xy = self._clear_of_pegs(block)
        board = self.cell.board
        if board.contains_xy(*xy):
            block.pose = yaw_pose([xy[0], xy[1], board.surface_z], yaw)
            self._log("drop", arm, block.index, None, f"onto the board{detail}")
        else:
            block.lost = True
            block.pose = yaw_pose([xy[0], xy[1], board.surface_z + _LOST_BELOW_BOARD], yaw)
            self._log("drop", arm, block.index, None, f"off the workspace{detail}")

    def _clear_of_pegs(self, block: Block) -> Matrix:
        """Where (board x, y) a block falling at its pose comes to rest: one landing on a peg's top (or
        between pegs) tips and slides off, away from every peg it touches, until it rests
        `tip_off_clearance` clear of them all, so a later grasp does not find it pressed against a peg.
        Wedged between pegs (sliding off one onto another, back and forth), it comes to rest at the spot
        nearest to where it fell that is that clear of them all."""
        fell = block.pose[:2, 3].copy()
        for _ in range(_SLIDE_STEPS):
            touching = np.flatnonzero(self._touching_pegs(block))
            if not len(touching):
                return block.pose[:2, 3].copy()
            away = sum(
                (_unit(block.pose[:2, 3] - self.cell.pegs.positions[peg]) for peg in touching), np.zeros(2)
            )
            block.pose[:2, 3] += _SLIDE_STEP * _unit(away)
        for ring in range(1, _SLIDE_STEPS + 1):
            for turn in np.linspace(0.0, 2 * math.pi, 8 * ring, endpoint=False):
                block.pose[:2, 3] = fell + ring * _SLIDE_STEP * np.array([math.cos(turn), math.sin(turn)])
                if not self._touching_pegs(block).any():
                    return block.pose[:2, 3].copy()
        return block.pose[:2, 3].copy()

    def _touching_pegs(self, block: Block) -> Matrix:
        """Which pegs `block`, where it lies, touches or comes within `tip_off_clearance` of."""
        return self._in_footprint(self._pegs_in_block_frame(block), self.config.tip_off_clearance)

    def _rest_on_peg(self, block: Block, peg: int, yaw: float) -> None:
        """Seat a block on a peg, on top of any blocks already resting there."""
        below = sum(1 for other in self.blocks if other is not block and other.peg == peg and not other.grips)
        x, y = self.cell.pegs.positions[peg]
        z = self.cell.board.surface_z - below * self.cell.block.height
        block.pose = yaw_pose([x, y, z], yaw)
        block.peg = peg

    # ------------------------------------------------------------------------------------- collisions

    def _pegs_touched(self, boxes: Boxes) -> tuple[int, ...]:
        """The pegs, in increasing order, that a tool's segments (`ToolState.boxes`) touch: a result of the
        tool and the work cell alone."""
        starts, ends, radii, low, high, _, _ = boxes
        seg, peg = np.nonzero(boxes_overlap(low[:, None], high[:, None], *self._peg_boxes))
        if not seg.size:
            return ()
        gaps = segment_distances(starts[seg], ends[seg], self._peg_tops[peg], self._peg_feet[peg])
        return tuple(int(touched) for touched in np.unique(peg[gaps < radii[seg] + self.cell.pegs.radius]))

    def _detect_contacts(self) -> None:
        """Log each contact when it begins: tool-peg, tool-tool, shaft-shaft, block-board."""
        current: set[tuple[str, str, int, int]] = set()
        tool = self.cell.tool
        segments = [(arm, self.tools[arm].boxes(tool)) for arm in sorted(self.tools)]
        for arm, boxes in segments:
            if boxes[5] < self._peg_top_z:  # the whole tool is above the peg tops (z points down)
                continue
            for touched in self.tools[arm].touched_pegs(self.cell, partial(self._pegs_touched, boxes)):
                current.add(("tool-peg", arm, -1, touched))
        parts: dict[str, tuple[str, str, tuple[tuple[str, str], ...]]] = {}  # named only as a contact begins
        for (arm_a, a), (arm_b, b) in combinations(segments, 2):
            shafts, others = self.tools[arm_a].touching(
                self.tools[arm_b], self.cell, partial(_tools_touching, a, b)
            )
            pair = f"{arm_a}+{arm_b}"
            if shafts:
                current.add(("shaft-shaft", pair, -1, -1))
            if others:
                current.add(("tool-tool", pair, -1, -1))
                parts[pair] = (arm_a, arm_b, others)
        surface = self.cell.board.surface_z + self.config.board_press_tolerance
        for block in self.blocks:
            if block.grips and block.pose[2, 3] > surface:
                current.add(("block-board", "+".join(block.grips), block.index, -1))
        if current != self._contacts:
            for kind, arm, block_index, peg_index in sorted(current - self._contacts):
                block_or_none = None if block_index < 0 else block_index
                peg_or_none = None if peg_index < 0 else peg_index
                named = _parts_named(*parts[arm]) if kind == "tool-tool" else ""
                self._log("collision", arm, block_or_none, peg_or_none, kind, named)
            self._contacts = current


def _tools_touching(a: Boxes, b: Boxes) -> tuple[bool, tuple[tuple[str, str], ...]]:
    """Whether two tools' shafts touch, and which other pairs of their segments (`ToolState.boxes`) do,
    named by `TOOL_PARTS` (the first tool's part, the second's), in segment order."""
    if any(a[6][axis] > b[6][axis + 3] or b[6][axis] > a[6][axis + 3] for axis in range(3)):
        return False, ()  # the boxes around the whole tools are apart, so are their segments'
    first, second = np.nonzero(boxes_overlap(a[3][:, None], a[4][:, None], b[3][None], b[4][None]))
    if not first.size:
        return False, ()
    touching = (
        segment_distances(a[0][first], a[1][first], b[0][second], b[1][second]) < a[2][first] + b[2][second]
    )
    shafts = (first == 0) & (second == 0)
    others = touching & ~shafts
    named = tuple(
        (TOOL_PARTS[one], TOOL_PARTS[other])
        for one, other in zip(first[others].tolist(), second[others].tolist())
    )
    return bool((touching & shafts).any()), named


def _parts_named(arm_a: str, arm_b: str, touching: tuple[tuple[str, str], ...]) -> str:
    """A tool-tool contact's parts as the simulator's log gives them: "PSM1 jaw on PSM2 wrist, ..."."""
    return ", ".join(f"{arm_a} {one} on {arm_b} {other}" for one, other in touching)


def _hole_room(cell: Workcell, lobe_radius: float, slack: float) -> HoleRoom:
    """The room a peg's axis has in a block's hole (`pegbt.sim.hole`), widened by `slack`: round but for
    the lobes (`hole_lobes`) towards its corners."""
    block, peg = cell.block, cell.pegs.radius
    lobe = max(block.hole_radius, lobe_radius)
    return HoleRoom(lobe - peg + slack, block.hole_radius - peg + slack, block.edge_normals)


def _beyond_play(move: Matrix, axes: Matrix, give: Give) -> float:
    """How far (m) the tip must still move by `move` (x, y) once the wrist's play `give` (along the tip's
    -x, +x, -y, +y, whose axes are the columns of `axes` in the same frame) has taken what it can: the
    share of the move left over in the tip's axes, of the move's length (all of it for a rigid wrist)."""
    x, y = axes.T @ move
    minus_x, plus_x, minus_y, plus_y = give
    whole = math.hypot(x, y)
    if whole == 0.0:
        return float(np.linalg.norm(move))
    left = math.hypot(x - np.clip(x, -minus_x, plus_x), y - np.clip(y, -minus_y, plus_y))
    return float(np.linalg.norm(move)) * left / whole


def _unit(vector: Matrix) -> Matrix:
    """`vector` scaled to length 1 (board x if it is zero)."""
    length = float(np.linalg.norm(vector))
    return vector / length if length > 1e-9 else np.array([1.0, 0.0])


def boxes_overlap(low_a: Matrix, high_a: Matrix, low_b: Matrix, high_b: Matrix) -> Matrix:
    """Whether axis-aligned boxes overlap, broadcast over leading dimensions (…, 3) -> (…)."""
    return np.all((low_a <= high_b) & (low_b <= high_a), axis=-1)
