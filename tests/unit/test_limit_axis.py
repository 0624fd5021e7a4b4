"""The handover's bound with the receiver's jaw entering the block only on its final axis: its one-joint
times exact, its least over boxes never above any point of them, its relaxation the old one when nothing
waits on the axis, and above it when the receiver's descent does."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ruckig

from pegbt.bench.limit_axis import Limits, on_axis_s
from pegbt.bench.limit_bound import Bound, trial_bound, via_s
from pegbt.bench.limit_joint import between_s, least_between


def _ruckig_1d(distance: float, start: float, end: float, vmax: float, amax: float) -> float | None:
    generator, inputs, trajectory = ruckig.Ruckig(1), ruckig.InputParameter(1), ruckig.Trajectory(1)
    inputs.current_position, inputs.current_velocity = [0.0], [start]
    inputs.target_position, inputs.target_velocity = [distance], [end]
    inputs.max_velocity, inputs.max_acceleration, inputs.max_jerk = [vmax], [amax], [math.inf]
    if generator.calculate(inputs, trajectory) not in (ruckig.Result.Working, ruckig.Result.Finished):
        return None
    return float(trajectory.duration)


def test_one_joints_time_between_moving_states_is_ruckigs_time_optimal_duration() -> None:
    rng = np.random.default_rng(11)
    for _ in range(400):
        distance, (start, end) = rng.normal() * 0.05, rng.uniform(-0.2, 0.2, 2)
        if rng.random() < 0.1:
            end = start
        expected = _ruckig_1d(distance, start, end, 0.2, 0.2)
        if expected is None:
            continue
        got = between_s(np.array(distance), np.array(start), np.array(end), np.array(0.2), np.array(0.2))
        assert float(got) == pytest.approx(expected, abs=1e-9), (distance, start, end)


@pytest.mark.parametrize(("vmax", "amax", "scale"), [(0.2, 0.2, 0.03), (3.14, 3.14, 0.3), (18.8, 12.6, 0.3)])
def test_the_least_over_a_box_is_never_above_any_point_of_it(vmax: float, amax: float, scale: float) -> None:
    """The least time is discontinuous (a joint arriving too fast overshoots and comes back), so a least
    taken at clipped points alone misses it; this one never lies above a dense sample of the box (the
    first version, edges only, did in 30 of 400 boxes)."""
    rng = np.random.default_rng(5)
    for _ in range(150):
        u = np.sort(rng.uniform(-vmax, vmax, 2))
        v = np.sort(rng.uniform(-vmax, vmax, 2))
        d = np.sort(rng.normal(size=2) * scale)
        if rng.random() < 0.3:
            d[1] = d[0]
        least = least_between((u[0], u[1]), (v[0], v[1]), (d[0], d[1]), np.array(vmax), np.array(amax))
        grid = np.meshgrid(*(np.linspace(lo, hi, 25) for lo, hi in (u, v, d)), indexing="ij")
        assert float(least) <= float(np.min(between_s(grid[2], grid[0], grid[1], vmax, amax))) + 1e-9


def _limits(bound: Bound, arm: str) -> Limits:
    settings = bound.settings[arm]
    return Limits(settings.planner_velocity.astype(float), settings.planner_acceleration.astype(float))


@pytest.mark.parametrize(("giver", "pick"), [("PSM2", 1), ("PSM1", 7)])
def test_with_the_meeting_point_as_the_axis_and_nothing_waiting_it_is_the_lift_and_carry_bound(
    giver: str, pick: int
) -> None:
    """Passing the meeting point itself and coming to rest there is the carry of the bound without the
    condition (`via_s` through the lift): the two searches of one relaxation agree to a few milliseconds."""
    bound = Bound()
    grasp, meet = bound.joints(giver, pick, bound.grasp_height()), bound.meeting(giver)
    lift = bound.joints(giver, pick, bound.heights.lifts[0])
    chain = on_axis_s(grasp, lift, meet[None], meet[None], meet, np.zeros(1), _limits(bound, giver))
    assert chain == pytest.approx(via_s(grasp, lift, meet, bound.settings[giver]), abs=0.005)


@pytest.mark.parametrize(
    ("giver", "receiver", "pick", "place"), [("PSM2", "PSM1", 1, 7), ("PSM1", "PSM2", 7, 1)]
)
def test_the_receivers_descent_on_the_axis_makes_the_handover_longer(
    giver: str, receiver: str, pick: int, place: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without a floor on the time from the axis to rest, the giver may pass the meeting point at speed and
    come back, and the receiver rest at its grasp as the giver stops, its jaw having entered while the
    block still moved anywhere: the old rendezvous, which this relaxation then contains. The receiver's
    least time from the block's top in each cell of the axis to its grasp makes it longer, and the
    trial's bound with it."""
    bound = Bound()
    low, high, after = bound.axis_cells(giver, receiver)
    grasp, meet = bound.joints(giver, pick, bound.grasp_height()), bound.meeting(giver)
    lifts = [bound.joints(giver, pick, height) for height in bound.heights.lifts]
    limits = _limits(bound, giver)
    free = min(on_axis_s(grasp, lift, low, high, meet, np.zeros_like(after), limits) for lift in lifts)
    old = bound.lift_to(giver, grasp, pick, meet)
    assert free <= old + 0.005  # the meeting point is on the axis: without the floor, nothing is added
    held = bound.held_on_axis(giver, receiver, pick)
    assert held > old + 0.03
    handover = [(f"{giver}→{receiver}", pick, place)]
    ((start, end),) = trial_bound(handover, bound).intervals
    monkeypatch.setattr(bound, "held_on_axis", lambda *_: 0.0)
    ((old_start, old_end),) = trial_bound(handover, bound).intervals
    assert end - start == pytest.approx(old_end - old_start + held - old, abs=1e-9)
