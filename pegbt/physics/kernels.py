"""Fast sequence kernels for the stateful cable effects: play (backlash), first-order lag, delay.

Play is a sequential operator, but on a run where the input moves one way it has a closed form: while
the input rises the output is `max(output before the run, input − h)` (and `min(…, input + h)` while it
falls). So only the run boundaries are visited one by one; every sample inside a run is filled in one
vectorised step, for a whole grid of half-widths at once (what width searches need).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
FLOAT_LOOP_WIDTHS = 8  # up to this many half-widths, play's run-by-run step runs on floats, not NumPy


def play_grid(u: ArrayLike, half_widths: ArrayLike, initial: ArrayLike | None = None) -> Array:
    """Play operator on one input sequence u (N,) for each half-width in a grid (G,): output (N, G).

    The output starts at `initial` (default: centred on u[0]) clipped into the play band.
    """
    u = np.asarray(u, dtype=float)
    h = np.atleast_1d(np.asarray(half_widths, dtype=float))
    start = (
        np.full(h.shape, u[0]) if initial is None else np.broadcast_to(np.asarray(initial, float), h.shape)
    )
    out = np.empty((len(u), len(h)))
    out[0] = np.clip(start, u[0] - h, u[0] + h)
    if len(u) == 1:
        return out
    step = np.sign(np.diff(u))
    nonzero = np.flatnonzero(step)
    if nonzero.size == 0:
        out[1:] = out[0]
        return out
    # Steps that do not move belong to the run before them (either direction describes them).
    carried = step[nonzero][np.maximum(np.searchsorted(nonzero, np.arange(len(step)), side="right") - 1, 0)]
    rising = carried > 0
    starts = np.flatnonzero(np.r_[True, rising[1:] != rising[:-1]])
    ends = np.r_[starts[1:], len(rising)] - 1
    before = _run_starts(out[0], h, u[ends + 1], rising[starts])
    run_of_step = np.repeat(np.arange(len(starts)), ends - starts + 1)
    held = before[run_of_step]
    following = u[1:, None]
    out[1:] = np.where(rising[:, None], np.maximum(held, following - h), np.minimum(held, following + h))
    return out


def _run_starts(first: Array, h: Array, reached: Array, up: NDArray[np.bool_]) -> Array:
    """The play output (R, G) as each of R runs begins: from `first`, each run (rising or not, `up`) that
    ends at input `reached` pushes the output to within h of it. Sequential over runs; a set-point
    recording reverses every few samples, so there are about as many runs as samples. For a few widths
    (a width search's refinement asks for one at a time) plain floats do each step in a tenth of the time
    a NumPy call on a few values takes; for a grid, one NumPy step moves every width."""
    before = np.empty((len(reached), len(h)))
    if len(h) <= FLOAT_LOOP_WIDTHS:
        ups, values = up.tolist(), reached.tolist()
        for g, width in enumerate(h.tolist()):
            state, column = float(first[g]), []
            for rises, value in zip(ups, values):
                column.append(state)
                state = max(state, value - width) if rises else min(state, value + width)
            before[:, g] = column
        return before
    states = first.copy()
    for r, (value, rises) in enumerate(zip(reached, up)):
        before[r] = states
        states = np.maximum(states, value - h) if rises else np.minimum(states, value + h)
    return before


def play_blocks(u: Array, half_widths: Array, edges: Sequence[int]) -> Iterator[Array]:
    """`play_grid(u, half_widths)` block by block (rows edges[k]:edges[k+1]), each block starting from
    the last output of the one before: the same values, without the (N, G) output held at once."""
    state = None
    for a, b in zip(edges[:-1], edges[1:]):
        out = play_grid(u[a:b], half_widths, state)
        state = out[-1]
        yield out


def apply_play(u: ArrayLike, half_width: ArrayLike, initial: ArrayLike | None = None) -> Array:
    """Backlash (play) along a sequence u (N, J) with per-column half widths; starts centred unless `initial`."""
    u = np.asarray(u, dtype=float)
    half_width = np.broadcast_to(np.asarray(half_width, dtype=float), u.shape[1:])
    out = u.copy()
    starts = u[0] if initial is None else np.broadcast_to(np.asarray(initial, float), u.shape[1:])
    for j in np.flatnonzero(half_width):
        out[:, j] = play_grid(u[:, j], half_width[j], starts[j])[:, 0]
    return out


def is_uniform(t: ArrayLike, tolerance: float = 1e-6) -> bool:
    """Whether the sample times are evenly spaced (then filters run as linear recursions in C)."""
    dt = np.diff(np.asarray(t, dtype=float))
    return bool(dt.size == 0 or np.ptp(dt) <= tolerance * max(float(np.mean(dt)), 1e-12))


def lag_series(u: ArrayLike, t: ArrayLike, tau: float) -> Array:
    """First-order lag y' = (u − y)/tau of one sequence u (N,) sampled at times t, starting settled at u[0].

    Each interval holds the input at its end value (the controller's zero-order hold), so the discrete
    step is exact for any spacing of samples.
    """
    u = np.asarray(u, dtype=float)
    if tau <= 0 or len(u) < 2:
        return u.copy()
    t = np.asarray(t, dtype=float)
    if is_uniform(t):
        from scipy.signal import lfilter  # seconds to import: only where a lag is computed

        alpha = 1.0 - np.exp(-float(t[1] - t[0]) / tau)
        y, _ = lfilter([alpha], [1.0, alpha - 1.0], u, zi=[(1.0 - alpha) * u[0]])
        return np.asarray(y)
    alphas = (1.0 - np.exp(-np.diff(t) / tau)).tolist()
    values = u.tolist()
    y = [values[0]]
    last = values[0]
    for alpha, value in zip(alphas, values[1:]):
        last += alpha * (value - last)
        y.append(last)
    return np.asarray(y)


def lag_blocks(u: Array, t: Array, tau: float, edges: Sequence[int]) -> Iterator[Array]:
    """`lag_series(u, t, tau)` block by block (rows edges[k]:edges[k+1]), the filter's state carried
    across each boundary (`lag_chunk`): the same values, in memory bounded by a block."""
    state: Any = None
    for a, b in zip(edges[:-1], edges[1:]):
        y, state = lag_chunk(u[a:b], t, a, tau, state)
        yield y


def lag_chunk(u: Array, t: Array, start: int, tau: float, state: Any) -> tuple[Array, Any]:
    """Rows start:start+len(u) of `lag_series(whole, t, tau)` (`t` the whole sequence's times), from the
    `state` the rows before left (None at row 0), and the state these rows leave: the same values as one
    call, a chunk at a time (a replay through the physics in memory bounded by a chunk)."""
    u = np.asarray(u, dtype=float)
    if tau <= 0 or len(t) < 2:
        return u.copy(), state
    if state is None:
        uniform = is_uniform(t)
        alpha = 1.0 - np.exp(-float(t[1] - t[0]) / tau) if uniform else 0.0
        state = (uniform, alpha, np.array([(1.0 - alpha) * u[0]]) if uniform else float(u[0]))
    uniform, alpha, carried = state
    if uniform:
        from scipy.signal import lfilter  # seconds to import: only where a lag is computed

        y, carried = lfilter([alpha], [1.0, alpha - 1.0], u, zi=carried)
        return np.asarray(y), (uniform, alpha, carried)
    alphas = (1.0 - np.exp(-np.diff(t[max(start - 1, 0) : start + len(u)]) / tau)).tolist()
    values = u.tolist()
    last = carried
    y = []
    if start == 0:
        y.append(last)
        values = values[1:]
    for step, value in zip(alphas, values):
        last += step * (value - last)
        y.append(last)
    return np.asarray(y), (uniform, alpha, last)


def delay_chunk(u: Array, t: Array, start: int, stop: int, seconds: float) -> Array:
    """Rows start:stop of `delay_series(u, t, seconds)` (u (N, J), `t` whole), reading only the rows of
    `u` those samples interpolate between."""
    if seconds <= 0:
        return np.array(u[start:stop], dtype=float)
    when = t[start:stop] - seconds
    lo = max(int(np.searchsorted(t, when[0], side="right")) - 2, 0)
    hi = min(int(np.searchsorted(t, when[-1], side="right")) + 2, len(t))
    window, values = t[lo:hi], u[lo:hi]
    return np.column_stack([np.interp(when, window, values[:, k]) for k in range(u.shape[1])])


def apply_lag(u: ArrayLike, t: ArrayLike, tau: ArrayLike) -> Array:
    """First-order lag along a sequence u (N, J) sampled at times t, per-column time constants."""
    u = np.asarray(u, dtype=float)
    tau = np.broadcast_to(np.asarray(tau, dtype=float), u.shape[1:])
    out = u.copy()
    for j in np.flatnonzero(tau > 0):
        out[:, j] = lag_series(u[:, j], t, float(tau[j]))
    return out


def delay_series(u: ArrayLike, t: ArrayLike, seconds: float) -> Array:
    """The sequence u (N, ...) as seen `seconds` later: u(t − seconds), held at u[0] before the start."""
    u = np.asarray(u, dtype=float)
    if seconds <= 0:
        return u.copy()
    t = np.asarray(t, dtype=float)
    flat = u.reshape(len(u), -1)
    shifted = np.column_stack([np.interp(t - seconds, t, flat[:, k]) for k in range(flat.shape[1])])
    return shifted.reshape(u.shape)


def delay_blocks(u: Array, t: Array, seconds: float, edges: Sequence[int]) -> Iterator[Array]:
    """`delay_series(u, t, seconds)` of one sequence (N,), block by block (rows edges[k]:edges[k+1])."""
    for a, b in zip(edges[:-1], edges[1:]):
        yield u[a:b].copy() if seconds <= 0 else np.interp(t[a:b] - seconds, t, u)
