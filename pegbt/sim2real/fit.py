"""Fit the chosen effects of one joint: refine widths, solve coefficients, bootstrap their spread.

A joint's correction to the simulator is linear in its coefficients once the widths (play half-width,
lag, delay) are fixed, so widths are refined by a bounded scalar search around the grid value chosen in
selection, and coefficients by least squares. Backlash, lag and delay act on the joint's *driver* (the
static target: the base model's plus the fitted scale and couplings), so the fit alternates between
coefficients and driver a few times. Backlash, lag and delay enter with coefficient 1, as in the
physics; a backlash whose play shows only partly (coefficient ≠ 1) is kept free, and named own
hysteresis, only when that holds up in every held-out fold.

Uncertainty comes from a circular block bootstrap of the residual (blocks as long as the residual
stays correlated), refitting coefficients and re-choosing widths on a local grid for every resample.
`to_effects` turns the coefficients into `Effect`s of the shared arm-physics model, merged with the
model the recording was diagnosed against.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

from pegbt.physics import ArmPhysics, Effect, EffectKind, effect_kinds, kind_of
from pegbt.scratch import scratch
from pegbt.sim2real.library import play_widths, width_bounds, width_column
from pegbt.sim2real.significance import block_bootstrap_indices, correlation_length

Array = NDArray[np.float64]
Rows = NDArray[np.bool_] | slice  # the samples a fit uses: a mask, or all of them

WIDTH_SEARCH_RATIO = 1.8  # refine a grid width within [w / r, w · r]
DRIVER_ITERATIONS = 3
PARTIAL_PLAY_MIN_GAIN = 0.01  # freeing a backlash coefficient must gain this much held out, in every fold
BOOTSTRAP_LOCAL = 2.0 ** np.linspace(-0.5, 0.5, 7)


@dataclass(frozen=True)
class Term:
    """One correction: a candidate of a registered effect kind (not the intercept), driven by `source`.

    `fixed` terms enter with coefficient 1 (full backlash, lag, delay); the others are fitted.
    """

    kind: str
    source: int
    width: float = float("nan")
    coef: float = 0.0
    fixed: bool = False

    @property
    def effect_kind(self) -> EffectKind:
        return kind_of(self.kind)

    @property
    def has_width(self) -> bool:
        return self.effect_kind.width is not None

    @property
    def driven(self) -> bool:
        """Acts on the joint's driver (its static target), not on a command."""
        return self.effect_kind.signal == "driver"


@dataclass
class JointFit:
    """The correction for one joint: optional intercept plus terms, with their fitted coefficients."""

    joint: int
    intercept: bool
    terms: list[Term]
    intercept_value: float = 0.0

    def driver(self, q_cmd: Array, base_driver: Array) -> Array:
        """The joint's static target: the base model's plus this fit's scale and couplings."""
        driver = base_driver.copy()
        for term in self.terms:
            if term.effect_kind.is_linear:
                driver += term.coef * q_cmd[:, term.source]
        return driver

    def columns(self, q_cmd: Array, t: Array | None, base_driver: Array) -> tuple[Array, Array]:
        """(free columns (N, p), sum of the fixed terms (N,)); intercept first among the free ones."""
        driver = self.driver(q_cmd, base_driver)
        free = [np.ones(len(q_cmd))] if self.intercept else []
        fixed = np.zeros(len(q_cmd))
        for term in self.terms:
            if term.driven:
                column = width_column(term.kind, driver, t, term.width)
            elif term.has_width:
                column = width_column(term.kind, q_cmd[:, term.source], t, term.width)
            else:
                column = q_cmd[:, term.source]
            if term.fixed:
                fixed += column
            else:
                free.append(column)
        return (np.column_stack(free) if free else np.zeros((len(q_cmd), 0))), fixed

    def free_coefficients(self) -> Array:
        return np.array(
            ([self.intercept_value] if self.intercept else []) + [t.coef for t in self.terms if not t.fixed]
        )

    def with_coefficients(self, beta: Array) -> JointFit:
        values = iter(beta[1:] if self.intercept else beta)
        terms = [term if term.fixed else replace(term, coef=float(next(values))) for term in self.terms]
        return JointFit(self.joint, self.intercept, terms, float(beta[0]) if self.intercept else 0.0)

    def correction(self, q_cmd: Array, t: Array | None, base_driver: Array) -> Array:
        """The linearised correction this fit adds to the simulator's output for its joint."""
        free, fixed = self.columns(q_cmd, t, base_driver)
        return fixed + free @ self.free_coefficients()


def _least_squares(design: Array, target: Array) -> tuple[Array, float]:
    if design.shape[1] == 0:
        return np.zeros(0), float(target @ target)
    beta, *_ = np.linalg.lstsq(design, target, rcond=None)
    error = target - design @ beta
    return beta.astype(np.float64, copy=False), float(error @ error)


def _solve(
    fit: JointFit, q_cmd: Array, t: Array | None, target: Array, base_driver: Array, rows: Rows
) -> JointFit:
    free, fixed = fit.columns(q_cmd, t, base_driver)
    beta, _ = _least_squares(free[rows], (target - fixed)[rows])
    return fit.with_coefficients(beta)


def fit_joint(
    structure: JointFit,
    q_cmd: Array,
    t: Array | None,
    target: Array,
    base_driver: Array,
    rows: Rows | None = None,
    refine: bool = True,
) -> JointFit:
    """Coefficients (and, with `refine`, widths) of `structure` fitted to `target` on `rows`."""
    rows = slice(None) if rows is None else rows
    fit = JointFit(structure.joint, structure.intercept, list(structure.terms), structure.intercept_value)
    for iteration in range(DRIVER_ITERATIONS):
        if refine and iteration == 1:
            passes = 2 if sum(term.has_width for term in fit.terms) > 1 else 1
            for _ in range(passes):
                for i, term in enumerate(fit.terms):
                    if term.has_width:
                        width = _refine_width(fit, i, q_cmd, t, target, base_driver, rows)
                        fit.terms[i] = replace(term, width=width)
        fit = _solve(fit, q_cmd, t, target, base_driver, rows)
    return fit


def _refine_width(
    fit: JointFit, i: int, q_cmd: Array, t: Array | None, target: Array, base_driver: Array, rows: Rows
) -> float:
    term = fit.terms[i]

    def sse(log_width: float) -> float:
        terms = list(fit.terms)
        terms[i] = replace(term, width=float(np.exp(log_width)))
        free, fixed = JointFit(fit.joint, fit.intercept, terms, fit.intercept_value).columns(
            q_cmd, t, base_driver
        )
        return _least_squares(free[rows], (target - fixed)[rows])[1]

    signal = fit.driver(q_cmd, base_driver) if term.driven else q_cmd[:, term.source]
    lo, hi = width_bounds(term.kind, signal, t)
    lo, hi = min(lo, term.width), max(hi, term.width)  # a width given from outside the grid stays reachable
    bounds = (
        np.log(max(term.width / WIDTH_SEARCH_RATIO, lo)),
        np.log(min(term.width * WIDTH_SEARCH_RATIO, hi)),
    )
    found = minimize_scalar(sse, bounds=bounds, method="bounded", options={"xatol": 0.01})
    return float(np.exp(found.x)) if found.fun <= sse(np.log(term.width)) else term.width


def heldout_sse(
    structure: JointFit,
    q_cmd: Array,
    t: Array | None,
    target: Array,
    base_driver: Array,
    fold_ranges: list[tuple[int, int]],
) -> Array:
    """Held-out SSE per fold of the linearised correction, coefficients refitted without each fold."""
    sse = []
    for a, b in fold_ranges:
        rows = np.ones(len(target), dtype=bool)
        rows[a:b] = False
        fit = fit_joint(structure, q_cmd, t, target, base_driver, rows, refine=False)
        error = (target - fit.correction(q_cmd, t, base_driver))[a:b]
        sse.append(float(error @ error))
    return np.array(sse)


def settle_backlash(
    fit: JointFit,
    q_cmd: Array,
    t: Array | None,
    target: Array,
    base_driver: Array,
    fold_ranges: list[tuple[int, int]],
) -> JointFit:
    """Keep each backlash at coefficient 1 unless partial play (free coefficient, width searched
    afresh on the grid) wins in every held-out fold and by `PARTIAL_PLAY_MIN_GAIN` overall."""
    for i, term in enumerate(fit.terms):
        if set(term.effect_kind.gains) != {False, True}:
            continue
        full = JointFit(fit.joint, fit.intercept, list(fit.terms), fit.intercept_value)
        full.terms[i] = replace(term, fixed=True, coef=1.0)
        full = fit_joint(full, q_cmd, t, target, base_driver)
        partial = JointFit(fit.joint, fit.intercept, list(fit.terms), fit.intercept_value)
        options = []
        for width in play_widths(fit.driver(q_cmd, base_driver)):
            partial.terms[i] = replace(term, fixed=False, width=float(width))
            trial = fit_joint(partial, q_cmd, t, target, base_driver, refine=False)
            options.append(
                (float(((target - trial.correction(q_cmd, t, base_driver)) ** 2).sum()), float(width))
            )
        partial.terms[i] = replace(term, fixed=False, width=min(options)[1])
        partial = fit_joint(partial, q_cmd, t, target, base_driver)
        sse_full = heldout_sse(full, q_cmd, t, target, base_driver, fold_ranges)
        sse_partial = heldout_sse(partial, q_cmd, t, target, base_driver, fold_ranges)
        wins = (
            sse_full > sse_partial
        ).all() and sse_full.sum() - sse_partial.sum() >= PARTIAL_PLAY_MIN_GAIN * sse_full.sum()
        fit = partial if wins else full
    return fit


def _gram_solve(gram: Array, rhs: Array, free: list[int], fixed: list[int]) -> tuple[Array, float]:
    """Least squares on bank columns `free` with the `fixed` columns' coefficients at 1, from Gram sums.

    Returns the coefficients and the SSE up to the target's own energy (constant across choices).
    """
    b = rhs[free] - gram[np.ix_(free, fixed)].sum(1)
    beta = np.linalg.solve(gram[np.ix_(free, free)], b) if free else np.zeros(0)
    constant = -2 * rhs[fixed].sum() + gram[np.ix_(fixed, fixed)].sum()
    return beta, float(constant - b @ beta)


def bootstrap(
    fit: JointFit,
    q_cmd: Array,
    t: Array | None,
    target: Array,
    base_driver: Array,
    n_resamples: int,
    rng: np.random.Generator,
) -> list[JointFit]:
    """Refits of `fit` on circular-block-bootstrap resamples of its residual.

    Widths are re-chosen on a local grid (×2^±0.5 around the fit) for each resample, one width at a
    time; the driver is held at the full fit's.
    """
    driver = fit.driver(q_cmd, base_driver)
    static = JointFit(fit.joint, fit.intercept, [term for term in fit.terms if not term.has_width])
    width_terms = [term for term in fit.terms if term.has_width]
    static_columns = static.columns(q_cmd, t, base_driver)[0]
    n_static = static_columns.shape[1]
    local = len(BOOTSTRAP_LOCAL)
    bank = scratch((len(q_cmd), n_static + local * len(width_terms)))  # 8 bytes a sample a column
    bank[:, :n_static] = static_columns
    del static_columns
    for k, term in enumerate(width_terms):
        signal = driver if term.driven else q_cmd[:, term.source]
        for i, r in enumerate(BOOTSTRAP_LOCAL):
            bank[:, n_static + k * local + i] = width_column(term.kind, signal, t, term.width * r)
    gram = bank.T @ bank
    gram += 1e-12 * np.trace(gram) / len(gram) * np.eye(len(gram))
    prediction = fit.correction(q_cmd, t, base_driver)
    residual = target - prediction
    block = max(10, correlation_length(residual))
    rhs_all = np.column_stack(  # one resample at a time: all of them at once are 100 numbers a sample
        [
            bank.T @ (prediction + residual[block_bootstrap_indices(len(target), block, rng)])
            for _ in range(n_resamples)
        ]
    ).reshape(bank.shape[1], n_resamples)
    refits = []
    for b in range(n_resamples):
        rhs = rhs_all[:, b]
        choice = [local // 2] * len(width_terms)

        def solve(choice: list[int]) -> tuple[Array, float]:
            free: list[int] = list(range(n_static))
            fixed: list[int] = []
            for k, (term, c) in enumerate(zip(width_terms, choice)):
                (fixed if term.fixed else free).append(n_static + k * local + c)
            return _gram_solve(gram, rhs, free, fixed)

        for k in range(len(width_terms)):
            scores = [solve(choice[:k] + [c] + choice[k + 1 :])[1] for c in range(local)]
            choice[k] = int(np.argmin(scores))
        beta, _ = solve(choice)
        static_coefs = iter(beta[1 if fit.intercept else 0 : n_static])
        width_coefs = iter(beta[n_static:])
        widths = iter(term.width * BOOTSTRAP_LOCAL[c] for term, c in zip(width_terms, choice))
        terms = []
        for term in fit.terms:
            if not term.has_width:
                terms.append(replace(term, coef=float(next(static_coefs))))
            else:
                coef = term.coef if term.fixed else float(next(width_coefs))
                terms.append(replace(term, width=float(next(widths)), coef=coef))
        refits.append(JointFit(fit.joint, fit.intercept, terms, float(beta[0]) if fit.intercept else 0.0))
    return refits


def to_effects(fit: JointFit, base: ArmPhysics) -> tuple[list[Effect], list[Effect]]:
    """(this joint's effects in the merged model, the effects that are new or changed, in fit order:
    the offset first when the fit has an intercept, then one per term).

    Each term becomes the effect its kind says (`EffectKind.to_effect`): offsets, scales and couplings
    add to the base model's values; a full backlash is `backlash`, a partial one the joint's own
    `hysteresis`; a delay adds to the base model's.
    """
    j = fit.joint
    changed: list[Effect] = []
    if fit.intercept:
        intercept = next(kind for kind in effect_kinds() if kind.is_intercept)
        changed.append(intercept.to_effect(j, j, float("nan"), fit.intercept_value, False, base))
    for term in fit.terms:
        changed.append(term.effect_kind.to_effect(j, term.source, term.width, term.coef, term.fixed, base))
    replaced = {effect.slot for effect in changed}
    kept = [effect for effect in base.effects if effect.index == j and effect.slot not in replaced]
    return kept + changed, changed


def merged_physics(fits: list[JointFit], base: ArmPhysics) -> ArmPhysics:
    """The base model with every joint's fitted corrections merged in."""
    effects: list[Effect] = []
    fitted = {fit.joint for fit in fits}
    for fit in fits:
        effects += to_effects(fit, base)[0]
    effects += [effect for effect in base.effects if effect.index not in fitted]
    return ArmPhysics(effects)
