"""`pegbt bench limit`'s bound against pegbt's own plans over a whole unilateral order: never above what pegbt
plans, and lower through the fewest constraints than through pegbt's waypoints. A system test: the twelve
carries' bounds take about ten seconds of CPU per arm."""

from __future__ import annotations

from functools import partial

import pytest

from pegbt.bench.limit_bound import Bound, Heights, trial_bound
from pegbt.motion.limits import arm_settings
from pegbt.motion.transfer import TransferPlanner
from pegbt.motion.waypoints import transfer_waypoints
from pegbt.workcell import UNILATERAL_ORDER, workcell

pytestmark = pytest.mark.system


@pytest.mark.parametrize("arm", ["PSM1", "PSM2"])
def test_carry_bound_is_below_pegbts_planned_carry(arm: str) -> None:
    bound, cell, settings = Bound(), workcell(), arm_settings(arm)
    planner = TransferPlanner(settings)
    tops, up = cell.peg_tops_in(arm), cell.up_in(arm)
    for pick, place in UNILATERAL_ORDER:
        grasp = bound.joints(arm, pick, bound.grasp_height())
        _, carry, fall = bound.lower(arm, place, partial(bound.lift_to, arm, grasp, pick))
        planned = planner.plan(transfer_waypoints(tops[pick], tops[place], up=up)).trajectory.duration
        assert 0 < carry and carry + fall <= planned + bound.fall_s(bound.heights.lowers[-1]), (pick, place)
        assert carry <= planned, (pick, place, carry, planned)


def test_pegbts_waypoints_cost_more_than_the_fewest_constraints() -> None:
    transfers = [("PSM1", pick, place) for pick, place in UNILATERAL_ORDER]
    least = trial_bound(transfers)
    through_pegbts = trial_bound(transfers, Bound(Heights.pegbt(Bound().motion)))
    assert 0 < least.arms["PSM1"].total < through_pegbts.arms["PSM1"].total
    assert least.arms["PSM2"].total == 0.0
    assert len(least.intervals) == 12 and least.per_transfer_s > 0
