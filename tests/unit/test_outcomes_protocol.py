"""The real outcomes' protocol sets how many attempts a simulated transfer gets: the paper's robot moved
each block once, pegbt's trees regrasp a dropped block."""

import logging
from pathlib import Path

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer
from pegbt.sim2real.outcomes.simulate import attempts_for, registered_for
from pegbt.sim2real.outcomes.table import paper_table, read_table
from pegbt.sim2real.outcomes.workers import LocalMapper

# Transfer 2 of the unilateral order in a world whose pegs bend: the first pick is lost lowering onto the
# goal peg, the regrasp from where it fell places it.
BENDING = WorldEffects.of({"peg_compliance": {"deflection": 0.0015}})
SEED = 2


def test_the_paper_counts_one_attempt_per_transfer(tmp_path: Path) -> None:
    assert attempts_for(paper_table()) == 1
    table = tmp_path / "ours.yaml"
    table.write_text(
        "cells:\n  - {variant: unilateral, condition: uncalibrated, attempted: 10, succeeded: 3}\n"
    )
    assert attempts_for(read_table(table)) == 4


def test_one_attempt_fails_where_the_recovery_places() -> None:
    logging.getLogger("pegbt").setLevel(logging.ERROR)
    recovered = simulate_transfer(BENDING, "unilateral", "uncalibrated", SEED)
    assert recovered.succeeded and recovered.phase == "lower"
    once = LocalMapper(0, attempts_for(paper_table()))([((BENDING,), "unilateral", "uncalibrated", SEED)])
    [[first]] = once
    assert not first.succeeded and first.phase == "lower"
    assert first.seconds < recovered.seconds


def test_a_giver_passes_over_a_grasp_its_receiver_cannot_take_the_block_from() -> None:
    """As `select_grasp` with `handover_to` does: calibrated handover transfer 2 under the paper's protocol,
    where the grasp the selector prefers cannot reach the meeting point, is handed over with no failure."""
    logging.getLogger("pegbt").setLevel(logging.ERROR)
    paper = paper_table()
    once = simulate_transfer(
        WorldEffects(),
        "handover",
        "calibrated",
        2,
        attempts=attempts_for(paper),
        registered=registered_for(paper),
    )
    assert once.succeeded and once.phase is None


def test_a_way_back_whose_block_was_lost_is_no_attempt_under_the_papers_protocol() -> None:
    """The paper's attempts (75, 68, 79 of 120) leave out the ways back it skipped; pegbt's trees try them
    and fail at sense, as their tick logs say."""
    from pegbt.sim2real.outcomes.simulate import simulate_cells

    logging.getLogger("pegbt").setLevel(logging.ERROR)
    way_back = 6 + 1  # the way back of the unilateral order's second block, which the default world loses
    key = ("unilateral", "uncalibrated")
    paper = simulate_cells(LocalMapper(0, attempts_for(paper_table())), [WorldEffects()], [key], 1, way_back)
    ours = simulate_cells(LocalMapper(0, 4), [WorldEffects()], [key], 1, way_back)
    assert (paper[0][key].attempted, paper[0][key].skipped) == (0, 1)
    assert (ours[0][key].attempted, ours[0][key].counts["sense"]) == (1, 1)
