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
from pegbt.sim2real import geometry
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
        error, _ = _geometry(q_cmd, displacement_columns(q_cmd))
        tracemalloc.start()
        removal = displacement_removal(q_cmd, error, None)
        held.append(tracemalloc.get_traced_memory()[0])
        tracemalloc.stop()
        assert removal(np.ones(n, dtype=bool)).shape == (n, 6)
    # the design (N, 3, 6) was 144 bytes a sample, kept for the rest of the diagnosis
    assert held[1] - held[0] < 8 * (LONG - SHORT)


def test_the_geometry_check_holds_no_displacement_columns(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(geometry, "CHUNK_ROWS", 500)
    peaks = []
    for n in (SHORT, LONG):
        q_cmd, _ = _commands(n)
        error, folds = _geometry(q_cmd, displacement_columns(q_cmd))
        physics_error = 3 * error
        peaks.append(_peak_bytes(lambda: check_geometry(q_cmd, error, physics_error, folds, None)))
        removal = displacement_removal(q_cmd, error, None)
        keep = np.ones(n, dtype=bool)
        keep[folds[1][0] : folds[1][1]] = False
        peaks[-1] = max(peaks[-1], _peak_bytes(lambda: removal(keep)))
    # q1–q3's held-out error and a few (N, 3) or (N, 6) arrays of the shift; the displacement columns
    # (N, 6, 3, 144 bytes a sample), their design and its least-squares copy were 447 together (76 now)
    assert (peaks[1] - peaks[0]) / (LONG - SHORT) <= 2.5 * ROW


def test_the_displacement_fitted_piece_by_piece_is_the_least_squares_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    q_cmd, _ = _commands(SHORT)
    columns = displacement_columns(q_cmd)
    error, folds = _geometry(q_cmd, columns)
    weights = np.sqrt((error[:, :3] ** 2).mean(axis=0))
    design = np.concatenate([np.broadcast_to(np.eye(3), (SHORT, 3, 3)), columns[:, :3]], axis=2)
    design /= weights[None, :, None]
    whole = np.linalg.lstsq(design.reshape(-1, 6), (error[:, :3] / weights).reshape(-1), rcond=None)[0]
    monkeypatch.setattr(geometry, "CHUNK_ROWS", 97)  # pieces that cut no fold at its edge
    found = check_geometry(q_cmd, error, 3 * error, folds, None)
    assert found is not None
    np.testing.assert_allclose(found.displacement_m, whole[3:], rtol=1e-12)
    shift = displacement_removal(q_cmd, error, None)(np.ones(SHORT, dtype=bool))
    expected = columns @ whole[3:]
    np.testing.assert_allclose(shift, expected - expected.mean(axis=0), rtol=1e-9, atol=1e-15)


def test_a_held_out_segment_is_replayed_without_the_whole_replay(monkeypatch: pytest.MonkeyPatch) -> None:
    from pegbt.physics import model
    from pegbt.sim2real.diagnose import replay_segment

    monkeypatch.setattr(model, "REPLAY_ROWS", 500)
    physics = ArmPhysics(
        [
            Effect("hysteresis", "q6", {"source": "q6", "half_width": 0.02, "k": 0.6}),
            Effect("backlash", "q4", {"half_width": 0.01}),
            Effect("lag", "q5", {"tau": 0.04}),
        ]
    )
    peaks = []
    for n in (300, SHORT, LONG):  # the first imports what a lag needs
        q_cmd, t = _commands(n)
        out = np.zeros_like(q_cmd)  # the caller's: only what the replay adds is traced
        peaks.append(_peak_bytes(lambda: replay_segment(physics, q_cmd, t, (4 * n // 5, n), out)))
    # a whole replay sliced to the segment held its output and a static map: 2 ROW a sample or more
    assert (peaks[2] - peaks[1]) / (LONG - SHORT) <= 0.25 * ROW
    q_cmd, t = _commands(SHORT)
    out = np.zeros_like(q_cmd)
    replay_segment(physics, q_cmd, t, (1234, 3456), out)
    assert np.array_equal(out[1234:3456], physics.simulate(q_cmd, t)[1234:3456])
    assert not out[:1234].any() and not out[3456:].any()
