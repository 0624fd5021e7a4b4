"""Each world effect, applied by the world: a scripted lift, carry, grasp or placement that fails in the
rigid world and succeeds with the effect, and the reverse where the effect can do harm."""

import math

import numpy as np
import pytest
from world_effects_helpers import YieldingDriver, grasp_block, lift_block, outward, place_block, shifted

from pegbt.frames import yaw_of
from pegbt.sim.scripted import Driver, grasp_candidate_facing, transfer_keyframes
from pegbt.sim.tools import ToolState
from pegbt.sim.world import World
from pegbt.sim.world_effects import BLOCK_MASS, GRAVITY, WorldEffects

CLEARANCE = 0.002  # hole radius 3.6 mm less peg radius 1.6 mm
BEYOND = 0.0005  # how far past the clearance the scripted arm drags the hole against its peg


def kinds(events):
    return [event.kind for event in events]


def _grasp_and_drag(world, along):
    """Grasp block 1 on peg 1 with a rigid wrist, drag the jaw `BEYOND` past the clearance along the tip's
    x (across the wall) or y (along the jaws), then lift; the events of the drag and the lift."""
    driver = YieldingDriver(world, (0.0,) * 4)
    _, holding = grasp_block(world, driver, 1)
    tip = driver.tool("PSM1", holding).tip
    axis = tip[:2, 0 if along == "x" else 1]
    slid = float((world.blocks[1].pose[:2, 3] - world.cell.pegs.positions[1]) @ axis)
    dragged = shifted(holding, (CLEARANCE - slid + BEYOND) * axis)
    return driver.play({"PSM1": [dragged]}) + lift_block(world, driver, dragged)


def _carried_off(events):
    return "lift" in kinds(events) and "collision" not in kinds(events)


def test_a_bending_peg_holds_a_hole_dragged_past_the_clearance_that_a_rigid_one_knocks_loose():
    rigid = World(2)
    events = _grasp_and_drag(rigid, "x")
    assert kinds(events)[:2] == ["collision", "drop"] and "caught on peg 1" in events[0].detail
    assert not _carried_off(events) and rigid.held_by("PSM1") is None

    bending = World(2, effects=WorldEffects.of({"peg_compliance": {"deflection": 0.001}}))
    assert _carried_off(_grasp_and_drag(bending, "x")) and bending.held_by("PSM1") == 1

    short = World(
        2, effects=WorldEffects.of({"peg_compliance": {"deflection": 0.0004}})
    )  # bends 0.4 of 0.5 mm
    assert not _carried_off(_grasp_and_drag(short, "x"))


@pytest.mark.parametrize(
    "grip",
    [
        {"displacement": 0.0007},
        {"angle": 0.07},
    ],  # 0.07 rad at the block's bottom, 10 mm below the jaw: 0.7 mm
    ids=["slides", "turns"],
)
def test_a_block_that_gives_in_the_jaws_is_lifted_where_a_rigid_grip_catches_it(grip):
    rigid = World(2)
    assert not _carried_off(_grasp_and_drag(rigid, "y"))
    compliant = World(2, effects=WorldEffects.of({"grip_compliance": grip}))
    assert _carried_off(_grasp_and_drag(compliant, "y")) and compliant.held_by("PSM1") == 1


def test_a_grip_gives_along_the_jaws_not_across_them():
    compliant = World(2, effects=WorldEffects.of({"grip_compliance": {"displacement": 0.003, "angle": 0.3}}))
    assert not _carried_off(_grasp_and_drag(compliant, "x"))  # the jaws clamp across the wall


def _carry_and_place(world, error=(0.0, 0.0)):
    driver = Driver(world)
    events, holding = grasp_block(world, driver, 1)
    events += lift_block(world, driver, holding)
    if world.held_by("PSM1") == 1:
        events += place_block(world, driver, 1, 7, error=error)
    return events


def test_chamfers_catch_a_block_lowered_past_the_clearance_that_strikes_a_rigid_peg():
    off = (0.0, CLEARANCE + 0.0007)
    rigid = World(1)
    events = _carry_and_place(rigid, off)
    assert "place" not in kinds(events)
    assert "block-peg: struck peg 7: hole 2.7 mm off its axis" in [
        e.detail for e in events
    ]  # clearance + 0.7

    chamfered = World(1, effects=WorldEffects.of({"chamfer_capture": {"capture_radius": 0.003}}))
    events = _carry_and_place(chamfered, off)
    assert kinds(events) == ["grasp", "lift", "release", "place"] and chamfered.blocks[1].peg == 7
    assert np.linalg.norm(chamfered.blocks[1].pose[:2, 3] - chamfered.cell.pegs.positions[7]) < 1e-9

    narrow = World(1, effects=WorldEffects.of({"chamfer_capture": {"capture_radius": 0.0025}}))
    assert "place" not in kinds(_carry_and_place(narrow, off))


def _peg_towards(world: World, degrees: float, distance: float) -> np.ndarray:
    """The placing error (board x, y) that lowers block 1 onto peg 7 with the peg `distance` off the hole's
    axis towards `degrees` in the block's frame (edge normals 90, 210, 330; corners between)."""
    placed = World(1)
    _carry_and_place(placed)
    yaw = yaw_of(placed.blocks[1].pose)
    towards = yaw + math.radians(degrees)
    return -distance * np.array([math.cos(towards), math.sin(towards)])  # the hole moves the other way


def test_the_hole_s_lobes_take_a_peg_lowered_towards_a_corner_that_strikes_a_round_hole_not_towards_a_wall():
    lobes = WorldEffects.of({"hole_lobes": {"lobe_radius": 0.0045}})  # the paper's block model
    corner, wall = _peg_towards(World(1), 30.0, 0.0025), _peg_towards(World(1), 90.0, 0.0025)
    events = _carry_and_place(World(1), corner)
    assert "place" not in kinds(events) and any("struck peg 7" in e.detail for e in events)
    lobed = World(1, effects=lobes)
    assert kinds(_carry_and_place(lobed, corner)) == ["grasp", "lift", "release", "place"]
    assert lobed.blocks[1].peg == 7
    for world in (World(1), World(1, effects=lobes)):
        assert "place" not in kinds(_carry_and_place(world, wall))  # a wall leaves the peg 2.0 mm


def test_jaw_friction_loses_a_block_that_a_rigid_grip_carries_when_the_tip_accelerates_too_hard():
    assert kinds(_carry_and_place(World(1))) == ["grasp", "lift", "release", "place"]
    # the scripted arm starts each straight move at once: 0.05 m/s within 20 ms, about 2.5 m/s²
    for limit, carried in ((1.0, False), (1000.0, True)):
        world = World(1, effects=WorldEffects.of({"jaw_friction": {"max_acceleration": limit}}))
        events = _carry_and_place(world)
        assert (kinds(events) == ["grasp", "lift", "release", "place"]) is carried, limit
        if not carried:
            slip = next(event for event in events if event.kind == "slip")
            assert slip.detail.startswith("shaken out of the jaw: tip accelerating")


def test_jaw_friction_weaker_than_the_block_s_weight_drops_it_once_it_leaves_its_peg():
    weight = BLOCK_MASS * GRAVITY
    world = World(1, effects=WorldEffects.of({"jaw_friction": {"max_load": 0.5 * weight}}))
    events = _carry_and_place(world)
    assert kinds(events)[:4] == ["grasp", "lift", "slip", "drop"] and "place" not in kinds(events)
    assert events[2].detail.startswith("slipped out of the jaw: load 0.02")


def test_a_bent_peg_pushes_on_the_grip_and_tears_the_block_out_of_weak_jaws():
    # bent 0.5 mm at 2900 N/m: 1.45 N on the grip
    holding = WorldEffects.of({"peg_compliance": {"deflection": 0.001}, "jaw_friction": {"max_load": 2.0}})
    assert _carried_off(_grasp_and_drag(World(2, effects=holding), "x"))
    weak = World(
        2,
        effects=WorldEffects.of({"peg_compliance": {"deflection": 0.001}, "jaw_friction": {"max_load": 1.0}}),
    )
    events = _grasp_and_drag(weak, "x")
    assert (
        kinds(events)[:2] == ["slip", "drop"] and events[0].detail == "slipped out of the jaw: load 1.450 N"
    )
    assert weak.blocks[1].peg == 1 and weak.held_by("PSM1") is None  # it falls back down its peg


def test_a_registration_offset_sends_every_tool_off_its_target():
    offset = WorldEffects.of({"registration_offset": {"x": 0.003, "y": 0.0, "z": 0.0}})
    world = World(1, effects=offset)
    shifted_base = world.arm_to_board("PSM1")
    assert np.allclose(shifted_base[:3, 3] - world.cell.arm_to_board("PSM1")[:3, 3], [0.003, 0.0, 0.0])
    q = np.array([0.0, 0.0, 0.15, 0.0, 0.0, 0.0])
    moved = ToolState.from_joints(q, 0.5, shifted_base).tip[:3, 3]
    nominal = ToolState.from_joints(q, 0.5, world.cell.arm_to_board("PSM1")).tip[:3, 3]
    assert np.allclose(moved - nominal, [0.003, 0.0, 0.0])
    assert World(1).arm_to_board("PSM1") is not None and np.array_equal(
        World(1).arm_to_board("PSM1"), World(1).cell.arm_to_board("PSM1")
    )


def test_a_registration_offset_makes_a_grasp_on_target_miss_and_one_off_target_hit():
    rigid = World(1)
    error = 0.0028 * outward(rigid)  # an arm that misses the wall's centre by 2.8 mm: the peg stops the block
    assert kinds(grasp_block(rigid, Driver(rigid), 1, error=error)[0]) == ["grasp_miss"]
    assert kinds(grasp_block(World(1), Driver(World(1)), 1)[0]) == ["grasp"]

    x, y, _ = -error
    registered = WorldEffects.of({"registration_offset": {"x": x, "y": y}})
    world = World(1, effects=registered)  # the tool truly lands 2.8 mm the other way: back on target
    assert kinds(grasp_block(world, Driver(world), 1, error=error)[0]) == ["grasp"]
    world = World(1, effects=registered)
    assert (
        kinds(grasp_block(world, Driver(world), 1)[0])[-1:] == ["grasp_miss"]
        and world.held_by("PSM1") is None
    )


def test_a_transfer_in_a_world_with_inert_effects_is_the_rigid_world_s():
    inert = WorldEffects.of({"jaw_friction": {}, "peg_compliance": {}, "grip_compliance": {}})
    events = []
    for world in (World(4), World(4, effects=inert)):
        driver = Driver(world)
        events.append(
            driver.play({"PSM1": transfer_keyframes(world, 1, 7, grasp_candidate_facing(world, 1, "PSM1"))})
        )
    assert events[0] == events[1]


def _grasp_off_centre(effects, by=0.0024):
    """PSM1 closes on block 1's wall `by` (m) outward of its centre, further than the peg lets it slide."""
    world = World(1, effects=effects)
    driver = Driver(world)
    events, holding = grasp_block(world, driver, 1, error=by * outward(world))
    return world, driver, events, holding


def test_jaws_closing_off_a_wall_the_peg_stops_grip_it_within_the_wrist_s_capture_width():
    rigid, _, events, _ = _grasp_off_centre(WorldEffects())
    assert kinds(events) == ["grasp_miss"] and "peg 1 stops the block" in events[0].detail

    world, _, events, _ = _grasp_off_centre(WorldEffects.of({"grasp_capture": {"width": 0.0015}}))
    assert kinds(events) == ["grasp"] and world.held_by("PSM1") == 1
    hole = world.blocks[1].pose[:2, 3] - world.cell.pegs.positions[1]
    assert np.linalg.norm(hole) == pytest.approx(CLEARANCE, abs=1e-5)  # slid until the peg stopped it

    narrow, _, events, _ = _grasp_off_centre(WorldEffects.of({"grasp_capture": {"width": 0.0003}}))
    assert kinds(events) == ["grasp_miss"] and narrow.held_by("PSM1") is None


def test_a_captured_grip_holds_the_wall_off_centre_so_a_lift_drifting_outward_catches_on_the_peg():
    drift = 0.0004 * outward(World(1))[:2]
    world, driver, _, holding = _grasp_off_centre(WorldEffects.of({"grasp_capture": {"width": 0.0015}}))
    events = lift_block(world, driver, holding, drift=drift)
    assert kinds(events)[:2] == ["collision", "drop"] and "caught on peg 1" in events[0].detail

    centred = World(1)
    driver = Driver(centred)
    _, holding = grasp_block(centred, driver, 1)
    assert kinds(lift_block(centred, driver, holding, drift=drift)) == ["lift"]


def test_an_open_jaw_s_tip_landing_on_a_wall_s_top_slides_off_its_edge_within_the_tip_slide_width():
    capturing = {"grasp_capture": {"width": 0.003}}  # so the peg does not stop the block either
    # 0.2 mm onto the wall's top: the jaws 3.0 mm either side of the tip miss a wall 3.2 mm off their centre
    world, _, events, _ = _grasp_off_centre(WorldEffects.of(capturing), by=0.0028)
    assert kinds(events) == ["grasp_miss"] and "jaws open" in events[0].detail

    sliding = WorldEffects.of({**capturing, "jaw_tip_slide": {"width": 0.0005}})
    world, _, events, _ = _grasp_off_centre(sliding, by=0.0028)
    assert kinds(events) == ["grasp"] and world.held_by("PSM1") == 1

    # 0.6 mm onto the top, beyond the 0.5 mm the tip slides back: still on the wall, still a miss
    deep, _, events, _ = _grasp_off_centre(sliding, by=0.0032)
    assert kinds(events) == ["grasp_miss"] and deep.held_by("PSM1") is None
