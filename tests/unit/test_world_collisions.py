"""Contacts between tools, shafts, pegs and carried blocks, each logged once when it begins."""

import numpy as np

from pegbt.sim.events import Event
from pegbt.sim.scripted import Driver, Keyframe, carry_height, grasp_candidate_facing, grasp_keyframes, lifted
from pegbt.sim.tools import ToolState, tool_pointing_down
from pegbt.sim.world import World


def collisions(events):
    return [(event.detail, event.arm, event.peg) for event in events if event.kind == "collision"]


def _tool(world, arm, position, remote_centre=None):
    centre = world.cell.remote_centre(arm) if remote_centre is None else remote_centre
    return tool_pointing_down(np.asarray(position, dtype=float), 0.0, 0.0, centre, world.cell.tool)


def test_a_tool_lowered_beside_a_peg_touches_it_once():
    world = World(seed=0)
    peg = world.cell.pegs.top(8)
    park = _tool(world, "PSM2", world.cell.remote_centre("PSM2") + [0, 0, 0.095])
    events = []
    for z in np.linspace(peg[2] - 0.01, peg[2] + 0.01, 21):  # down past the peg top, 2 mm from its axis
        events += world.update(
            world.time + 0.01, {"PSM1": _tool(world, "PSM1", peg + [0.002, 0, z - peg[2]]), "PSM2": park}
        )
    assert collisions(events) == [("tool-peg", "PSM1", 8)]


def test_shafts_crossing_collide_and_again_after_parting():
    world = World(seed=0)
    a0, a1 = np.array([0.0, 0.0, -0.2]), np.array([0.1, 0.0, -0.1])
    b0, b1 = np.array([0.0, 0.05, -0.15]), np.array([0.1, -0.05, -0.15])  # crosses a at (0.05, 0, -0.15)

    def tool(shaft_end_a, shaft_end_b, position):
        tip = np.eye(4)
        tip[:3, 3] = position
        return ToolState(tip, 0.0, np.array([shaft_end_a, shaft_end_b]))

    far_tips = (np.array([0.1, 0.0, -0.09]), np.array([0.1, -0.05, -0.14]))
    crossing = {"PSM1": tool(a0, a1, far_tips[0]), "PSM2": tool(b0, b1, far_tips[1])}
    parted = {
        "PSM1": crossing["PSM1"],
        "PSM2": tool(b0 + [0, 0, -0.02], b1 + [0, 0, -0.02], far_tips[1] + [0, 0, -0.02]),
    }
    events = []
    for tools in (crossing, crossing, parted, crossing):
        events += world.update(world.time + 0.01, tools)
    assert collisions(events) == [("shaft-shaft", "PSM1+PSM2", None)] * 2


def test_two_tools_at_one_place_collide():
    world = World(seed=0)
    point = np.array([0.06, 0.07, -0.03])
    events = world.update(
        0.01, {"PSM1": _tool(world, "PSM1", point), "PSM2": _tool(world, "PSM2", point + [0.001, 0, 0])}
    )
    assert ("tool-tool", "PSM1+PSM2", None) in collisions(events)


def test_a_tool_tool_contact_names_the_parts_that_touch():
    world = World(seed=0)
    high, low = np.array([0.06, 0.07, -0.03]), np.array([0.06, 0.07, -0.03 + 0.009])
    events = world.update(0.01, {"PSM1": _tool(world, "PSM1", high), "PSM2": _tool(world, "PSM2", low)})
    (hit,) = [event for event in events if event.detail == "tool-tool"]
    assert "PSM1 jaw on PSM2 wrist" in hit.parts and "PSM1 wrist" not in hit.parts
    assert hit.to_dict()["parts"] == hit.parts
    assert "parts" not in Event(0.0, "grasp").to_dict()


def test_the_simulators_log_keeps_a_contacts_parts(tmp_path):
    from pegbt.sim.log import SimLog, read_sim_log

    world = World(seed=0)
    point = np.array([0.06, 0.07, -0.03])
    log = SimLog(tmp_path / "sim.jsonl")
    for event in world.update(
        0.01, {"PSM1": _tool(world, "PSM1", point), "PSM2": _tool(world, "PSM2", point + [0.0, 0.0, 0.009])}
    ):
        log.record_event(event)
    log.close()
    (entry,) = [entry for entry in read_sim_log(tmp_path / "sim.jsonl") if entry["detail"] == "tool-tool"]
    assert entry["parts"] == "PSM1 jaw on PSM2 wrist, PSM1 jaw on PSM2 jaw" and entry["arm"] == "PSM1+PSM2"


def test_a_block_carried_low_into_another_peg_is_knocked_loose():
    world = World(seed=0)
    driver = Driver(world)
    grasp = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM1"))
    driver.play({"PSM1": [*grasp, lifted(world, grasp[-1])]})
    holding = driver.at("PSM1")
    tip_from_block = holding.position - world.blocks[1].pose[:3, 3]
    pegs = world.cell.pegs.positions
    clear_spot = np.append(pegs[1] + (pegs[7] - pegs[1]) / 3, world.blocks[1].pose[2, 3]) + tip_from_block
    down = [0.0, 0.0, 0.006]  # the block's bottom 2 mm below the peg tops
    beyond_peg_7 = (
        np.append(pegs[7] + (pegs[7] - pegs[1]) / 3, world.blocks[1].pose[2, 3]) + tip_from_block + down
    )
    path = [Keyframe(p, holding.yaw, holding.jaw) for p in (clear_spot, clear_spot + down, beyond_peg_7)]
    events = driver.play({"PSM1": path})
    kinds = [event.kind for event in events]
    assert kinds[:2] == ["collision", "drop"] and events[0].detail.startswith(
        "block-peg: struck peg 7: hole "
    )
    assert world.blocks[1].state == "on_board"


def test_the_scripted_transfer_touches_nothing():
    world = World(seed=0)
    driver = Driver(world)
    grasp = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM1"))
    events = driver.play({"PSM1": [*grasp, lifted(world, grasp[-1])]})
    assert carry_height(world) < world.cell.pegs.top_z and not collisions(events)
