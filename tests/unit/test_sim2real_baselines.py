"""The nearest-commands bound: it takes from a residual what the command and its play state determine,
and nothing from noise they do not."""

import numpy as np

from pegbt.sim2real.baselines import last_moves, neighbours_of_commands
from pegbt.sim2real.crossval import fold_ranges


def _play(x: np.ndarray, half_width: float) -> np.ndarray:
    """A backlash's output, written out sample by sample."""
    out, state = np.empty_like(x), x[0]
    for i, value in enumerate(x):
        state = min(max(state, value - half_width), value + half_width)
        out[i] = state
    return out


def _rmse(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def test_last_moves_keeps_the_direction_through_pauses() -> None:
    q = np.array([[0.0], [1.0], [1.0], [0.5], [0.5], [0.7]])
    assert last_moves(q)[:, 0].tolist() == [0.0, 1.0, 1.0, -1.0, -1.0, 1.0]


def test_a_play_state_residual_is_taken_and_noise_is_not() -> None:
    rng = np.random.default_rng(0)
    q = np.sin(np.cumsum(rng.normal(0, 0.1, (3000, 2)), axis=0))  # a bounded random path
    play = q[:, :1] - _play(q[:, 0], 0.02)[:, None]  # ±0.02 by the direction last moved, between in turns
    noise = rng.normal(0, 0.05, (3000, 1))
    folds = fold_ranges(3000, 5)
    residual = np.column_stack([play, noise])
    left = residual - neighbours_of_commands(residual, q, folds)
    assert _rmse(left[:, 0]) < 0.7 * _rmse(play)
    assert _rmse(left[:, 1]) > 0.98 * _rmse(noise)
