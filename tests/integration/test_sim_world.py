"""The simulator endpoint with its pegboard world and depth camera, driven over real zenoh on loopback."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest
from world_helpers import block_points, in_board

from pegbt.errors import PegbtError
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.settings import motion_settings
from pegbt.perception.colour import red
from pegbt.sim.arm import DEFAULT_JOINTS
from pegbt.sim.arm_script import MotionPlayer, descending_motions, transfer_motions
from pegbt.sim.camera import DepthCamera
from pegbt.sim.endpoint import EndpointConfig, SimEndpoint
from pegbt.sim.fault_plan import FaultPlan
from pegbt.sim.faults import NoiseBurst
from pegbt.sim.process import SimProcess, free_port
from pegbt.sim.scripted import grasp_candidate_facing, grasp_keyframes, lifted
from pegbt.sim.tools import ToolState
from pegbt.sim.truth import ask_truth
from pegbt.sim.world import World
from pegbt.transport import ArmClient, CameraClient, SimClock, codec, connect, endpoint_settings, open_session
from pegbt.transport.keys import SimKeys
from pegbt.workcell import N_PEGS

TICK = 0.01
SPEED = 0.05
SEED = 0


def lift_motions(world: World):
    """PSM1 grasps block 1 on peg 1 and lifts it clear."""
    grasp = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM1"))
    return descending_motions(world, "PSM1", [*grasp, lifted(world, grasp[-1])], TICK, SPEED)


def connected(endpoint: str):
    """A link, its lockstep clock, PSM1, and the sim/events stream as it arrives (a list of dicts)."""
    link = connect([endpoint])
    events: list[dict] = []
    link.inlet(
        SimKeys().events, codec.decode_string, lambda received: events.append(json.loads(received.value))
    )
    clock = SimClock(link)
    psm1 = ArmClient(link, "PSM1", clock=clock)
    psm1.wait_until_ready(30.0)
    return link, clock, psm1, events


def play(clock: SimClock, psm1: ArmClient, motions, until: float = 0.0) -> list[tuple[float, ...]]:
    """Play the motions tick by tick, then idle until simulated time `until`; per tick: time, jaw measured
    and set-point, measured joints."""
    player, trace = MotionPlayer(psm1, motions), []
    while player.poll() or clock.now() < until - 1e-9:
        clock.wait(TICK)
        trace.append(
            (
                clock.now(),
                *psm1.jaw.measured_js.position,
                *psm1.jaw.setpoint_js.position,
                *psm1.measured_js.position,
            )
        )
    return trace


@pytest.fixture(scope="module")
def transfer():
    """PSM1 carries block 1 from peg 1 to peg 7 through a lockstep simulator in another process."""
    with SimProcess(["--lockstep", "--seed", str(SEED)]) as sim:
        link, clock, psm1, events = connected(sim.endpoint)
        trace = play(clock, psm1, transfer_motions(World(SEED), "PSM1", 1, 7, TICK, SPEED))
        truth = ask_truth(link)
        cloud = CameraClient(link, clock=clock).capture()
        yield link, trace, events, truth, cloud
        link.close()


def test_a_scripted_transfer_grasps_lifts_and_places_on_the_event_stream_and_in_the_truth(transfer):
    link, _, events, truth, _ = transfer
    happened = [(e["kind"], e["arm"], e["block"], e["peg"]) for e in truth.log if e["kind"] != "start"]
    assert happened == [
        ("grasp", "PSM1", 1, 1),
        ("lift", "PSM1", 1, 1),
        ("release", "PSM1", 1, 7),
        ("place", "PSM1", 1, 7),
    ]
    assert (
        events == truth.log[-len(events) :] and len(events) >= 4
    )  # the stream (from when it was subscribed) and the truth agree
    blocks = {b["block"]: b for b in truth.blocks}
    assert blocks[1]["state"] == "on_peg" and blocks[1]["peg"] == 7 and blocks[1]["holders"] == []
    assert [blocks[i]["peg"] for i in (0, 2, 3, 4, 5)] == [0, 2, 3, 4, 5]
    assert ask_truth(link, since=truth.next).log == []
    with pytest.raises(PegbtError, match="since must be >= 0"):
        ask_truth(link, since=-1)


def test_the_jaw_stops_at_the_gripped_block_and_measured_js_reports_it(transfer):
    _, trace, _, truth, _ = transfer
    grasped, released = (
        next(e["time"] for e in truth.log if e["kind"] == kind) for kind in ("grasp", "release")
    )
    cell = World(SEED).cell
    closed = motion_settings().transfer.jaw_closed
    wall = 2 * np.arcsin((cell.block.edge_distance - cell.block.hole_radius) / 2 / cell.tool.jaw_length)
    holding = [(measured, setpoint) for t, measured, setpoint, *_ in trace if grasped < t < released - 0.1]
    assert len(holding) > 50
    assert all(setpoint == pytest.approx(closed) for _, setpoint in holding[10:])
    assert all(measured == pytest.approx(wall, abs=1e-9) for measured, _ in holding[10:])


def test_a_capture_over_zenoh_shows_the_12_pegs_and_6_blocks_where_the_truth_has_them_in_red(transfer):
    _, _, _, truth, cloud = transfer
    cell = World(SEED).cell
    xyz = np.asarray(cloud)
    assert xyz.dtype == np.float32 and xyz.shape[1] == 3 and len(xyz) > 50_000
    points, seen_red = in_board(cell, xyz), red(cloud.rgba)
    for peg in range(N_PEGS):
        assert np.sum(np.linalg.norm(points[seen_red] - cell.pegs.top(peg), axis=1) < 0.002) >= 30, peg
    raised = cell.board.surface_z - points[:, 2] > 0.001  # board z runs down; the noise is 0.2 mm
    for block in truth.blocks:
        pose = np.array(block["pose"])
        assert len(block_points(cell, points[seen_red], pose)) >= 1000, block["block"]
        assert len(block_points(cell, points[~seen_red & raised], pose)) == 0, block["block"]
    blocks = np.array([block["pose"][i][3] for block in truth.blocks for i in (0, 1)]).reshape(-1, 2)
    axes, clear = np.vstack([blocks, cell.pegs.positions]), cell.block.corner_distance + 0.001
    bare = np.all(np.linalg.norm(points[:, None, :2] - axes[None], axis=2) > clear, axis=1)
    on_board = bare & (np.abs(points[:, 2] - cell.board.surface_z) < 0.001)
    assert on_board.sum() > 10_000 and not seen_red[on_board].any()


def test_a_slip_in_the_fault_plan_happens_at_its_time_and_is_logged(tmp_path):
    plan = tmp_path / "faults.yaml"
    plan.write_text("world:\n  slips:\n    - {time: 4.0, arm: PSM1}\n")
    log = tmp_path / "sim.jsonl"
    with SimProcess(["--lockstep", "--seed", str(SEED), "--faults", str(plan), "--log", str(log)]) as sim:
        link, clock, psm1, _ = connected(sim.endpoint)
        trace = play(clock, psm1, lift_motions(World(SEED)), until=4.5)
        link.close()
    entries = [json.loads(line) for line in log.read_text().splitlines()]
    kinds = [(e["kind"], e["time"]) for e in entries if e["kind"] != "start"]
    assert [kind for kind, _ in kinds] == ["grasp", "lift", "fault", "slip", "drop"]
    assert kinds[1][1] < 4.0 and kinds[2][1] == pytest.approx(4.0) and kinds[3][1] == pytest.approx(4.0)
    assert "slip injected" in entries[3]["detail"] and entries[5]["detail"] == "onto peg 1"
    jaw_after = [measured for t, measured, *_ in trace if t > 4.1]
    assert jaw_after and all(
        m == pytest.approx(motion_settings().transfer.jaw_closed, abs=1e-6) for m in jaw_after
    )


def test_the_fault_plan_hands_world_and_camera_faults_on_and_locates_errors(tmp_path):
    plan = tmp_path / "faults.yaml"
    plan.write_text(
        "seed: 4\nworld:\n  miss_attempts: [0, 2]\ncamera:\n  bursts:\n    - {start: 1.0, duration: 0.5}\n"
    )
    loaded = FaultPlan.load(plan)
    assert loaded.seed == 4 and loaded.world.miss_attempts == {0, 2}
    assert loaded.camera.bursts == (NoiseBurst(1.0, 0.5),)
    plan.write_text("world:\n  slips:\n    - {time: 1.0}\n    - {time: 2.0, arm: PSM3}\n")
    with pytest.raises(
        PegbtError, match=r"faults.yaml:4:24: world.slips\[1\].arm: expected one of PSM1, PSM2"
    ):
        FaultPlan.load(plan)


def run_with_world_faults(tmp_path, run: int) -> tuple[list, list[str], np.ndarray]:
    plan = tmp_path / "faults.yaml"
    plan.write_text("world: {slip_rate: 1.5}\n")
    log = tmp_path / f"run{run}.jsonl"
    args = ["--lockstep", "--physics", "dvrk-real", "--seed", "3", "--faults", str(plan), "--log", str(log)]
    with SimProcess(args) as sim:
        link, clock, psm1, _ = connected(sim.endpoint)
        trace = play(clock, psm1, lift_motions(World(3)), until=4.0)
        cloud = CameraClient(link, clock=clock).capture()
        link.close()
    return trace, log.read_text().splitlines(), cloud


def test_lockstep_runs_with_the_world_are_deterministic_for_a_seed(tmp_path):
    first, second = run_with_world_faults(tmp_path, 0), run_with_world_faults(tmp_path, 1)
    assert first[0] == second[0]
    assert first[1] == second[1] and any('"kind": "grasp' in line for line in first[1])
    assert np.array_equal(first[2], second[2])


@pytest.fixture()
def in_process():
    """An endpoint with its world in this process (the world inspectable), dvrk-real cables."""
    address = f"tcp/127.0.0.1:{free_port()}"
    session = open_session(endpoint_settings([address]))
    world = World(SEED)
    endpoint = SimEndpoint(session, EndpointConfig(lockstep=True, physics="dvrk-real"), world=world)
    thread = threading.Thread(target=endpoint.run, daemon=True)
    thread.start()
    link = connect([address])
    yield world, link
    link.close()
    endpoint.stop()
    thread.join(timeout=5)
    endpoint.close()
    session.close()


def test_the_world_sees_each_tool_where_its_physical_joints_put_it(in_process):
    world, link = in_process
    clock = SimClock(link)
    psm1 = ArmClient(link, "PSM1", clock=clock)
    psm1.wait_until_ready(30.0)
    move = psm1.move_jp([0.3, 0.1, 0.14, 0.2, 0.3, -0.2])
    while move.busy:
        clock.wait(TICK)
    clock.wait(0.3)
    physical = psm1.fiducial_js.position
    assert not np.allclose(physical, psm1.measured_js.position, atol=0.01)  # dvrk-real: they differ
    tool = world.tools["PSM1"]
    assert world.time == pytest.approx(clock.now())
    assert np.allclose(tool.tip, world.cell.arm_to_board("PSM1") @ forward_kinematics(physical), atol=1e-9)
    assert np.allclose(tool.shaft[0], world.cell.remote_centre("PSM1"))
    assert tool.jaw == pytest.approx(psm1.jaw.measured_js.position[0], abs=1e-12)


def test_a_capture_is_the_cameras_view_of_the_world_at_the_request():
    with SimProcess(["--lockstep", "--seed", str(SEED)]) as sim, connect([sim.endpoint]) as link:
        clock = SimClock(link)
        clock.wait(0.1)
        handle = CameraClient(link, clock=clock).capture_async()
        points = handle.result(timeout=5.0)
        assert handle.stamp == pytest.approx(clock.now())
    world = World(SEED)  # the simulator's world: same seed, arms resting where they start
    world.update(
        0.1,
        {
            arm: ToolState.from_joints(DEFAULT_JOINTS, 0.0, world.cell.arm_to_board(arm))
            for arm in ("PSM1", "PSM2")
        },
    )
    assert np.array_equal(points, DepthCamera(seed=SEED).capture(world))  # same seed, same scene: same noise
