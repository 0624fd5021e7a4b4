"""Under the paper's protocol each simulated arm is registered to the camera as the paper's robot registered
its own, with the uncalibrated arm itself (`calibration_dvrk_RGBD.py`) and PSM2's hand adjustment
(`FLSPegTransfer_dual.py`): the registration absorbs the rigid part of the arm's cable error."""

import logging
from pathlib import Path

import numpy as np

from pegbt.calibration.registration import registered_arm_from_board
from pegbt.frames import invert_rigid
from pegbt.motion.kinematics import shaft_end_and_tip
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.simulate import attempts_for, registered_for
from pegbt.sim2real.outcomes.table import paper_table, read_table
from pegbt.sim2real.outcomes.workers import LocalMapper
from pegbt.workcell import workcell


def test_an_arm_without_cable_error_registers_where_the_work_cell_stands() -> None:
    assert np.allclose(registered_arm_from_board("PSM1", "ideal"), workcell().board_to_arm("PSM1"), atol=1e-9)
    shifted = registered_arm_from_board("PSM2", "ideal") - workcell().board_to_arm("PSM2")
    assert np.allclose(shifted[:3, 3], [-0.001, 0.0, 0.0], atol=1e-9)  # the paper's hand adjustment


def test_the_registration_takes_up_psm1s_static_error_where_it_was_made() -> None:
    """PSM1's `dvrk-real` q1 offset puts its pitch axis millimetres off the commanded: the registered
    robot aims that much the other way."""
    nominal, registered = workcell().board_to_arm("PSM1"), registered_arm_from_board("PSM1", "dvrk-real")
    q = np.array([0.0, 0.0, 0.15, 0.0, 0.0, 0.0])
    target = invert_rigid(nominal) @ np.append(shaft_end_and_tip(q)[0], 1.0)
    moved = (registered @ target)[:3] - (nominal @ target)[:3]
    assert 0.001 < np.linalg.norm(moved) < 0.004


def test_only_the_papers_protocol_registers_the_arms(tmp_path: Path) -> None:
    assert registered_for(paper_table())
    table = tmp_path / "ours.yaml"
    table.write_text(
        "cells:\n  - {variant: unilateral, condition: uncalibrated, attempted: 10, succeeded: 3}\n"
    )
    assert not registered_for(read_table(table))


def test_psm2_registered_as_the_papers_grips_the_block_it_misses_on_the_work_cells_figures() -> None:
    """Bilateral transfer 1 (PSM2, peg 2 to 6) on layout 13 (seed 13), default world: on the work cell's
    figures PSM2's open jaws miss the wall; registered as the paper's, it places the block."""
    logging.getLogger("pegbt").setLevel(logging.ERROR)
    task = ((WorldEffects(),), "bilateral", "uncalibrated", 13)
    paper = paper_table()
    [[unregistered]] = LocalMapper(0, attempts_for(paper))([task])
    [[registered]] = LocalMapper(0, attempts_for(paper), registered_for(paper))([task])
    assert not unregistered.succeeded and unregistered.phase == "grasp"
    assert registered.succeeded


def test_a_compensated_arm_is_not_registered_again() -> None:
    """The simulator's calibration corrects the whole cable error, the rigid part a registration would
    take up included: registering a calibrated arm too would correct that part twice."""
    from pegbt.sim2real.outcomes.bench import START, Bench, Replay
    from pegbt.sim2real.outcomes.phasesim import _skills

    world = World(0, effects=WorldEffects())
    for condition, moved in (("uncalibrated", True), ("calibrated", False), ("optimized", False)):
        bench = Bench(world, "PSM1", _skills(condition).arm("PSM1"), START, Replay(), registered=True)
        assert np.allclose(bench.to_board, world.arm_to_board("PSM1")) != moved, condition
