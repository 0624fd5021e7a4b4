"""Grasp, lift, transfer, place and handover in the simulated world, decided by geometry alone."""

import copy

import numpy as np
import pytest
from world_effects_helpers import YieldingDriver

from pegbt.frames import yaw_pose
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.settings import motion_settings
from pegbt.sim.scripted import (
    Driver,
    Keyframe,
    grasp_candidate_facing,
    grasp_keyframes,
    lifted,
    place_keyframes,
    transfer_keyframes,
)
from pegbt.sim.world import World


def kinds(events):
    return [event.kind for event in events]


def test_blocks_start_on_the_left_pegs_at_a_yaw_set_by_the_seed():
    first, again, other = World(seed=3), World(seed=3), World(seed=4)
    assert [block.peg for block in first.blocks] == [0, 1, 2, 3, 4, 5]
    assert np.array_equal(first.block_poses(), again.block_poses())
    assert not np.allclose(first.block_poses(), other.block_poses())
    for block in first.blocks:
        assert np.allclose(block.pose[:2, 3], first.cell.pegs.positions[block.peg])
        assert block.pose[2, 3] == pytest.approx(first.cell.board.surface_z)


def test_a_scripted_transfer_moves_block_1_from_peg_1_to_peg_7():
    world = World(seed=1)
    driver = Driver(world)
    candidate = grasp_candidate_facing(world, 1, "PSM1")
    events = driver.play({"PSM1": transfer_keyframes(world, 1, 7, candidate)})
    assert kinds(events) == ["grasp", "lift", "release", "place"]
    assert all(event.arm == "PSM1" and event.block == 1 for event in events)
    assert [events[0].peg, events[1].peg, events[3].peg] == [1, 1, 7]
    block = world.blocks[1]
    assert block.state == "on_peg" and block.peg == 7
    assert np.allclose(block.pose[:2, 3], world.cell.pegs.positions[7])
    assert list(world.events) == events


def _grasp_off_the_wall_centre(world, driver, off, jaw_open=None):
    """Close PSM1's jaw on block 1 `off` metres outward from the centre of the wall it faces."""
    candidate = grasp_candidate_facing(world, 1, "PSM1")
    model = world.cell.block
    outward = np.append(world.blocks[1].pose[:2, :2] @ model.edge_normals[candidate // 2], 0.0)
    centre = (model.hole_radius + model.edge_distance) / 2
    frames = grasp_keyframes(world, 1, candidate, error=(centre - model.grasp_radial + off) * outward)
    if jaw_open is not None:
        frames = [Keyframe(f.position, f.yaw, jaw_open if f.jaw > 0.5 else f.jaw) for f in frames]
    return driver.play({"PSM1": frames}), outward


@pytest.mark.parametrize("off", [0.001, -0.001, 0.0018])
def test_a_grasp_up_to_the_pegs_clearance_off_the_wall_centre_grips_and_slides_the_block_into_the_jaws(off):
    world = World(seed=1)
    driver = Driver(world)
    events, outward = _grasp_off_the_wall_centre(world, driver, off)
    assert kinds(events) == ["grasp"] and world.held_by("PSM1") == 1
    slid = world.blocks[1].pose[:3, 3] - np.append(world.cell.pegs.positions[1], world.cell.board.surface_z)
    assert np.allclose(slid, off * outward, atol=1e-6)  # the wall now sits centred between the jaws


def test_a_grasp_beyond_the_pegs_clearance_misses_because_the_peg_stops_the_block():
    world = World(seed=1)
    driver = Driver(world)
    clearance = world.cell.block.hole_radius - world.cell.pegs.radius  # 2.0 mm
    events, _ = _grasp_off_the_wall_centre(world, driver, clearance + 0.0004)
    assert (
        kinds(events) == ["grasp_miss"]
        and events[0].detail == "jaw 2.4 mm off the wall's centre: peg 1 stops the block"
    )
    assert np.allclose(world.blocks[1].pose[:2, 3], world.cell.pegs.positions[1])


def test_a_grasp_3_mm_off_the_wall_centre_misses_and_leaves_the_block_on_its_peg():
    world = World(seed=1)
    driver = Driver(world)
    events, _ = _grasp_off_the_wall_centre(world, driver, 0.003)
    assert (
        kinds(events) == ["grasp_miss"]
        and events[0].detail == "jaw 3.0 mm off the wall's centre: peg 1 stops the block"
    )
    events = driver.play({"PSM1": [lifted(world, driver.at("PSM1"))]})
    assert world.blocks[1].state == "on_peg" and world.held_by("PSM1") is None


def _move_block_1_onto_the_board(world):
    block = world.blocks[1]
    block.peg = None
    block.pose[:2, 3] = [0.030, 0.065]  # clear of every peg
    return block


def test_a_jaw_opened_too_little_cannot_straddle_the_wall():
    world = World(seed=1)
    driver = Driver(world)
    events, _ = _grasp_off_the_wall_centre(world, driver, 0.001, jaw_open=np.radians(22))
    # 22° open: the tips are 9.5·sin 11° = 1.8 mm either side of the axis, 0.8 mm beyond the wall's faces
    assert kinds(events) == ["grasp_miss"] and events[0].detail.startswith("jaws open 0.8 mm")


def test_a_grasp_beyond_the_open_jaws_misses_even_a_free_block():
    world = World(seed=1)
    driver = Driver(world)
    _move_block_1_onto_the_board(world)
    events, _ = _grasp_off_the_wall_centre(world, driver, 0.0035)
    # 50° open: the tips are 9.5·sin 25° = 4.0 mm either side of the axis, 3.0 mm beyond the 2 mm wall's faces
    assert kinds(events) == ["grasp_miss"]
    assert events[0].detail == "jaws open 3.0 mm either side of the wall's centre miss it by 3.5 mm"


def test_a_block_on_the_board_slides_further_into_the_jaws_than_one_on_a_peg():
    world = World(seed=1)
    driver = Driver(world)
    block = _move_block_1_onto_the_board(world)
    events, outward = _grasp_off_the_wall_centre(world, driver, 0.0025)
    assert kinds(events) == ["grasp"] and world.held_by("PSM1") == 1
    assert np.allclose(block.pose[:2, 3], np.array([0.030, 0.065]) + 0.0025 * outward[:2], atol=1e-6)


def test_lifting_sideways_catches_the_block_on_its_peg():
    world = World(seed=2)
    driver = Driver(world)
    candidate = grasp_candidate_facing(world, 1, "PSM1")
    grasp = grasp_keyframes(world, 1, candidate)
    driver.play({"PSM1": grasp})
    diagonal = lifted(world, grasp[-1])
    diagonal = type(diagonal)(diagonal.position + [0.006, 0.0, 0.0], diagonal.yaw, diagonal.jaw)
    events = driver.play({"PSM1": [diagonal]})
    assert kinds(events)[:2] == ["collision", "drop"]
    assert events[0].detail.startswith("block-peg: caught on peg 1")
    assert events[1].peg == 1  # it falls back down its peg
    assert world.blocks[1].state == "on_peg" and world.held_by("PSM1") is None


@pytest.mark.parametrize(("give", "caught"), [(0.0, True), (0.0003, True), (0.001, False)])
def test_a_peg_guides_a_block_lifted_against_it_as_far_as_the_wrist_gives(give, caught):
    world = World(seed=2)
    driver = YieldingDriver(world, (give,) * 4)
    candidate = grasp_candidate_facing(world, 1, "PSM1")
    grasp = grasp_keyframes(world, 1, candidate)
    driver.play({"PSM1": grasp})
    slid = np.linalg.norm(
        world.blocks[1].pose[:2, 3] - world.cell.pegs.positions[1]
    )  # into the jaws, outward
    clearance = world.cell.block.hole_radius - world.cell.pegs.radius
    outward = (world.blocks[1].pose[:2, 3] - world.cell.pegs.positions[1]) / slid
    # pull the tool outward until the hole presses the peg 0.5 mm beyond the clearance, then lift
    pulled = Keyframe(
        grasp[-1].position + np.append((clearance - slid + 0.0005) * outward, 0.0),
        grasp[-1].yaw,
        grasp[-1].jaw,
    )
    events = driver.play({"PSM1": [pulled, lifted(world, pulled)]})
    if caught:
        assert kinds(events)[:2] == ["collision", "drop"] and world.held_by("PSM1") is None
    else:
        assert kinds(events) == ["lift"] and world.held_by("PSM1") == 1


def _carry_block_1(world, driver):
    candidate = grasp_candidate_facing(world, 1, "PSM1")
    grasp = grasp_keyframes(world, 1, candidate)
    driver.play({"PSM1": [*grasp, lifted(world, grasp[-1])]})


def test_a_block_lowered_within_the_clearance_is_placed():
    world = World(seed=1)
    driver = Driver(world)
    _carry_block_1(world, driver)
    clearance = world.cell.block.hole_radius - world.cell.pegs.radius
    error = np.array([0.0, 0.75 * clearance])
    events = driver.play({"PSM1": place_keyframes(world, 1, 7, driver.at("PSM1"), error=error)})
    assert kinds(events) == ["release", "place"] and events[-1].peg == 7
    assert np.allclose(world.blocks[1].pose[:2, 3], world.cell.pegs.positions[7])


def test_a_block_lowered_beyond_the_clearance_strikes_the_peg_and_drops():
    world = World(seed=1)
    driver = Driver(world)
    _carry_block_1(world, driver)
    clearance = world.cell.block.hole_radius - world.cell.pegs.radius
    error = np.array([0.0, 1.5 * clearance])
    events = driver.play({"PSM1": place_keyframes(world, 1, 7, driver.at("PSM1"), error=error)})
    assert kinds(events)[:2] == ["collision", "drop"]
    assert (
        events[0].detail == "block-peg: struck peg 7: hole 3.0 mm off its axis"
    )  # 1.5 × the 2.0 mm clearance
    assert world.blocks[1].state == "on_board" and world.held_by("PSM1") is None


def test_a_block_released_over_a_peg_top_off_the_clearance_tips_off_and_can_be_picked_again():
    world = World(seed=1)
    driver = Driver(world)
    _carry_block_1(world, driver)
    clearance = world.cell.block.hole_radius - world.cell.pegs.radius
    above, *_ = place_keyframes(world, 1, 7, driver.at("PSM1"), error=np.array([0.0, 1.5 * clearance]))
    opened = type(above)(above.position, above.yaw, motion_settings().transfer.jaw_open)
    events = driver.play({"PSM1": [above, opened]})
    assert kinds(events) == ["release", "drop"] and events[-1].detail == "onto the board off the top of peg 7"
    block = world.blocks[1]
    assert block.state == "on_board"
    assert np.linalg.norm(block.pose[:2, 3] - world.cell.pegs.positions[7]) > world.cell.block.corner_distance

    candidate = grasp_candidate_facing(world, 1, "PSM1")
    events = driver.play({"PSM1": transfer_keyframes(world, 1, 7, candidate)})
    assert kinds(events) == ["grasp", "release", "place"] and world.blocks[1].peg == 7


def test_a_block_released_beyond_the_board_is_lost():
    world = World(seed=1)
    driver = Driver(world)
    _carry_block_1(world, driver)
    beyond = world.cell.board.extent_x[1] + 0.02 - world.cell.pegs.positions[7][0]
    events = driver.play(
        {"PSM1": place_keyframes(world, 1, 7, driver.at("PSM1"), error=np.array([beyond, 0.0]))}
    )
    assert kinds(events)[-2:] == ["release", "drop"] and events[-1].detail == "off the workspace"
    assert world.blocks[1].state == "lost"


def test_a_handover_leaves_the_block_with_the_receiver():
    world = World(seed=5)
    driver = _both_holding_at_the_meeting_point(world)
    holding = driver.at("PSM2")
    meeting = holding.position
    jaw_open = motion_settings().transfer.jaw_open
    events = driver.play(
        {
            "PSM2": [
                Keyframe(meeting, holding.yaw, jaw_open),
                Keyframe(meeting - [0, 0, 0.01], holding.yaw, jaw_open),
            ]
        }
    )
    assert kinds(events) == ["release"] and events[0].arm == "PSM2"
    assert world.blocks[1].state == "held" and world.held_by("PSM1") == 1

    events = driver.play(
        {"PSM1": [lifted(world, driver.at("PSM1")), *place_keyframes(world, 1, 7, driver.at("PSM1"))]}
    )
    assert kinds(events) == ["release", "place"] and events[-1].arm == "PSM1" and events[-1].peg == 7


def test_a_second_grip_pulled_away_slips_and_the_first_keeps_the_block():
    world = World(seed=5)
    driver = Driver(world)
    grasp = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM2"))
    driver.play({"PSM2": [*grasp, lifted(world, grasp[-1])]})
    driver.play({"PSM1": grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM1"))})
    away = driver.at("PSM1")
    events = driver.play({"PSM1": [Keyframe(away.position + [0.01, 0, 0], away.yaw, away.jaw)]})
    assert (
        kinds(events) == ["slip"]
        and events[0].arm == "PSM1"
        and "pulled out of the jaw by PSM2" in events[0].detail
    )
    assert world.held_by("PSM2") == 1 and world.held_by("PSM1") is None


def _both_holding_at_the_meeting_point(world):
    """PSM2 holds block 1 out at the meeting point and PSM1 has gripped it too, both jaws squeezing."""
    driver = Driver(world)
    grasp = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM2"))
    driver.play({"PSM2": [*grasp, lifted(world, grasp[-1])]})
    holding = driver.at("PSM2")
    tip_from_block = holding.position[:2] - world.blocks[1].pose[:2, 3]
    meeting = np.append(handover_meeting_point(world.cell)[:2] + tip_from_block, holding.position[2])
    driver.play({"PSM2": [Keyframe(meeting, holding.yaw, holding.jaw)]})
    events = driver.play({"PSM1": grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM1"))})
    assert kinds(events) == ["grasp"] and "handover from PSM2, " in events[0].detail
    return driver


def test_a_receivers_grasp_says_how_far_off_the_walls_centre_its_jaw_holds_the_held_block():
    """A held block does not slide into the closing jaw: the receiver holds it where its jaw closed, and the
    simulator's log says how far that is from the wall's centre (what its carry then puts off the peg)."""
    found = []
    for shift in (0.0, 0.001):
        world = World(seed=0)
        driver = Driver(world)
        grasp = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM2"))
        driver.play({"PSM2": [*grasp, lifted(world, grasp[-1])]})
        keyframes = grasp_keyframes(world, 1, grasp_candidate_facing(world, 1, "PSM1"))
        across = np.array(
            [np.cos(keyframes[-1].yaw), np.sin(keyframes[-1].yaw), 0.0]
        )  # the jaws close along it
        moved = [Keyframe(k.position + shift * across, k.yaw, k.jaw) for k in keyframes]
        (event,) = [e for e in driver.play({"PSM1": moved}) if e.kind == "grasp"]
        found.append(event.detail)
    off = [float(detail.split(", ")[-1].removesuffix(" mm off the wall's centre")) for detail in found]
    assert all(", handover from PSM2, " in detail for detail in found)
    assert off[0] < 0.5 and off[1] - off[0] == pytest.approx(1.0, abs=0.05)


def test_a_giver_rising_with_its_jaw_still_squeezing_drags_the_block_through_the_receivers_jaw():
    """Two jaws squeezing one wall at one depth: the first keeps the block and it slides in the other. The
    giver rising 2 mm before it opens drags the block 2 mm up through the receiver's grip: a `drag` event
    once the giver has let go, and the block stays where the receiver's jaw now holds it, not back where it
    gripped."""
    world = World(seed=5)
    driver = _both_holding_at_the_meeting_point(world)
    before = world.blocks[1].pose.copy()
    giver = driver.at("PSM2")
    up = giver.position - [0.0, 0.0, 0.002]  # board z points down
    events = driver.play({"PSM2": [Keyframe(up, giver.yaw, giver.jaw)]})
    events += driver.play(
        {
            "PSM2": [
                Keyframe(up, giver.yaw, motion_settings().transfer.jaw_open),
                Keyframe(up - [0.0, 0.0, 0.01], giver.yaw, motion_settings().transfer.jaw_open),
            ]
        }
    )
    assert kinds(events) == ["release", "drag"]
    assert events[1].arm == "PSM1" and events[1].detail == "dragged 2.0 mm through PSM1's jaw by PSM2"
    assert world.held_by("PSM1") == 1 and world.held_by("PSM2") is None
    assert world.blocks[1].pose[:3, 3] - before[:3, 3] == pytest.approx([0.0, 0.0, -0.002], abs=1e-6)


def test_a_giver_whose_jaw_opened_off_the_wall_rises_without_moving_the_block_the_receiver_squeezes():
    """The giver's jaw opened past the wall (still short of where the world lets go): the receiver's
    squeezing jaw holds the block, which slides freely in the giver's; nothing is dragged."""
    world = World(seed=5)
    driver = _both_holding_at_the_meeting_point(world)
    before = world.blocks[1].pose.copy()
    giver = driver.at("PSM2")
    off_the_wall = (world.jaw_stop("PSM2") + world.config.jaw_open_above) / 2
    up = giver.position - [0.0, 0.0, 0.002]
    events = driver.play(
        {"PSM2": [Keyframe(giver.position, giver.yaw, off_the_wall), Keyframe(up, giver.yaw, off_the_wall)]}
    )
    assert events == [] and world.held_by("PSM2") == 1 and world.held_by("PSM1") == 1
    assert world.blocks[1].pose == pytest.approx(before, abs=1e-9)


@pytest.mark.parametrize("direction_deg", range(0, 360, 45))
def test_a_block_that_tipped_off_a_peg_rests_clear_of_every_peg_and_any_grasp_lifts_it(direction_deg):
    world = World(seed=1)
    driver = Driver(world)
    _carry_block_1(world, driver)
    clearance = world.cell.block.hole_radius - world.cell.pegs.radius
    direction = np.radians(direction_deg)
    error = 1.5 * clearance * np.array([np.cos(direction), np.sin(direction)])
    above, *_ = place_keyframes(world, 1, 7, driver.at("PSM1"), error=error)
    driver.play(
        {"PSM1": [above, type(above)(above.position, above.yaw, motion_settings().transfer.jaw_open)]}
    )
    assert world.blocks[1].state == "on_board"
    for candidate in range(6):  # none finds the block pressed against a peg (the tool may still hit one)
        again = copy.deepcopy(world)
        grasp = grasp_keyframes(again, 1, candidate)
        events = Driver(again).play({"PSM1": [*grasp, lifted(again, grasp[-1])]})
        tool_hit = any(event.detail == "tool-peg" for event in events)
        assert tool_hit or not any(event.detail.startswith("block-peg") for event in events), (
            candidate,
            events,
        )


def test_a_block_dropped_between_the_peg_groups_rests_clear_of_every_peg():
    """Around the handover's meeting point a falling block lands between pegs 3, 6 and 9, where sliding off
    one peg runs onto another: it must still come to rest clear of them all (a block left inside peg 6
    would make every later grasp of it strike the peg)."""
    world = World(seed=0)
    block = world.blocks[1]
    normals, offsets = world.cell.block.outline_planes
    meeting = handover_meeting_point(world.cell)
    rng = np.random.default_rng(7)
    for _ in range(200):
        xy = meeting[:2] + rng.uniform(-0.012, 0.012, size=2)
        block.pose = yaw_pose([xy[0], xy[1], meeting[2]], rng.uniform(-np.pi, np.pi))
        block.peg, block.grips = None, {}
        world._settle(block, "PSM2", deliberate=False)
        if block.peg is not None:
            continue  # its hole came down around a peg: it rests on it
        gaps = (world._pegs_in_block_frame(block) @ normals.T - offsets).max(axis=1) - world.cell.pegs.radius
        assert gaps.min() >= world.config.tip_off_clearance - 1e-9, (xy, gaps.min())
        assert np.linalg.norm(block.pose[:2, 3] - xy) < 0.03  # it slid off nearby, not across the board
