"""Memory of the physics replay and the geometry check bounded by a few arrays the recording's size.

As in `test_sim2real_memory.py`, each test measures the peak of traced memory at two lengths: what grows
with the recording is the difference. A (N, 6) array of floats is 48 bytes a sample."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from pegbt.physics import ArmPhysics, Effect
from pegbt.sim2real.geometry import check_geometry, displacement_columns, displacement_removal

SHORT, LONG = 5_000, 10_000
ROW = 6 * 8  # bytes of one sample of (N, 6) floats


def _peak_bytes(action: Callable[[], Any]) -> int:
    tracemalloc.start()
    try:
        action()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _commands(n: int) -> tuple[np.ndarray, np.ndarray]:
    t = 0.01 * np.arange(n)
    q_cmd = 0.3 * np.sin(np.outer(t, np.linspace(0.2, 1.0, 6)))
    q_cmd[:, 2] += 0.1  # an insertion the kinematics can invert
    return q_cmd, t


def _growth(action: Callable[[np.ndarray, np.ndarray], Any]) -> float:
    """Bytes a sample that `action`'s peak grows by from SHORT to LONG samples."""
    action(*_commands(300))  # imports and caches
    short = _peak_bytes(lambda: action(*_commands(SHORT)))
    long = _peak_bytes(lambda: action(*_commands(LONG)))
    return (long - short) / (LONG - SHORT) - 2 * ROW  # less the commands and times made inside


@pytest.mark.parametrize("stream", [True, False])
def test_the_ideal_replay_holds_no_copy_of_the_commands(stream: bool) -> None:
    physics = ArmPhysics()
    # the output and one term of the static map while it is summed; it was 12 such arrays a sample
    # (a delayed copy and a static map per joint, the targets and their copy)
    growth = _growth(lambda q, t: physics.simulate(q, t if stream else None))
    assert growth <= 2.5 * ROW


def test_joints_with_one_delay_share_its_replay() -> None:
    effects = [Effect("delay", j, {"seconds": 0.02}) for j in ("q1", "q2")]
    physics = ArmPhysics(effects)
    # one delayed copy for q1 and q2, the commands themselves for q3–q6, the output and a static map
    assert _growth(lambda q, t: physics.simulate(q, t)) <= 4.5 * ROW
    q_cmd, t = _commands(SHORT)
    expected = physics.static_map(np.column_stack([np.interp(t - 0.02, t, q_cmd[:, k]) for k in range(6)]))
    np.testing.assert_array_equal(physics.simulate(q_cmd, t)[:, :2], expected[:, :2])
    np.testing.assert_array_equal(physics.simulate(q_cmd, t)[:, 2:], q_cmd[:, 2:])


def _geometry(q_cmd: np.ndarray, columns: np.ndarray) -> tuple[np.ndarray, list[tuple[int, int]]]:
    n = len(q_cmd)
    error = 1e-3 * np.random.default_rng(0).normal(size=(n, 6))
    error[:, :3] += columns[:, :3] @ np.array([2e-3, -1e-3, 1e-3])
    return error, [(k * n // 5, (k + 1) * n // 5) for k in range(5)]


def test_the_displacement_removal_keeps_no_design_matrix() -> None:
    held = []
    for n in (SHORT, LONG):
        q_cmd, _ = _commands(n)
        columns = displacement_columns(q_cmd)
        error, _ = _geometry(q_cmd, columns)
        tracemalloc.start()
        removal = displacement_removal(columns, error, None)
        held.append(tracemalloc.get_traced_memory()[0])
        tracemalloc.stop()
        assert removal(np.ones(n, dtype=bool)).shape == (n, 6)
    # the design (N, 3, 6) was 144 bytes a sample, kept for the rest of the diagnosis
    assert held[1] - held[0] < 8 * (LONG - SHORT)


def test_the_geometry_check_builds_its_design_fold_by_fold() -> None:
    peaks = []
    for n in (SHORT, LONG):
        q_cmd, _ = _commands(n)
        columns = displacement_columns(q_cmd)
        error, folds = _geometry(q_cmd, columns)
        physics_error = 3 * error
        peaks.append(_peak_bytes(lambda: check_geometry(columns, error, physics_error, folds, None)))
        assert check_geometry(columns, error, physics_error, folds, None) is not None
    # the whole design, weighed and copied by the least squares (2 × 144 bytes a sample), and small
    # (N, 3) arrays; the design of the whole and that of the rows fitted (4/5 of it) were held together
    assert (peaks[1] - peaks[0]) / (LONG - SHORT) <= 330
