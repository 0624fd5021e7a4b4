"""Choose which effects are missing: forward selection by blocked cross-validation, with guards.

Per joint, starting from an intercept (a nuisance term, so that no other test is confounded by a
constant error), every candidate is scored at every width of its grid by its held-out error (backlash,
lag and delay at unit gain, as the physics has them; backlash also with a free gain, for play of which
only part reaches the joint). The best few have their widths refined between grid values (so that a
grid step is not mistaken for a second effect) and the best of them that passes all guards is added:

1. it reduces held-out error by at least `MIN_GAIN` of what is left,
2. it reduces it in *every* fold that excites it (an effect that is real holds everywhere the data
   excite it; a fold where its column hardly moves cannot show it), and in at least two,
3. its association with the residual passes an effective-sample-size t-test (robust to autocorrelated
   noise, see `significance`) at the Bonferroni level α / m, where m counts every candidate over all
   joints × effects (the whole family of hypotheses the tool could have named).

The intercept itself is named an `offset` only if its delete-one-block jackknife t-test passes the same
level and it too gains in every fold. Candidates the data cannot test (a joint that never reverses,
two commands that move together, lag and delay on settled set-points) are set aside with the reason;
a rival that explains nearly as much and is not beaten in every fold is reported as not separable.
Between near-equivalent explanations of different size (full backlash versus partial play, coupling or
scale versus hysteresis) the one with fewer parameters is kept unless the richer one gains more in every
held-out fold and by `PARSIMONY_GUARD`; the report then says the two were not separable.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

from pegbt.physics import ArmPhysics, EffectKind, effect_kinds
from pegbt.physics.kernels import play_grid
from pegbt.psm import JOINT_NAMES
from pegbt.sim2real.crossval import BlockedGrams
from pegbt.sim2real.library import Candidate, width_bounds, width_column
from pegbt.sim2real.significance import shift_pvalue, t_pvalue

Array = NDArray[np.float64]

ALPHA = 0.05
MIN_GAIN = 0.002
MAX_EFFECTS_PER_JOINT = 6
MIN_REVERSALS = 3
REVERSAL_TRAVEL = 0.02  # a reversal counts when the command comes back by this fraction of its range
COLLINEAR = 0.98
AMBIGUOUS_GAIN = 0.9  # a rival explaining this fraction of the winner's gain, not beaten in every fold
PARSIMONY_GUARD = 0.01  # of what is left: how much more a richer explanation must gain than a simpler one
WIDTH_SEARCH_RATIO = 1.8  # a chosen width is refined within [w / r, w · r] of its grid value
EXCITED = 0.05  # a fold excites a candidate when its column's energy there is this fraction of the mean
TRIES_PER_STEP = 5  # when the best candidate fails a guard, the next ones (by held-out gain) may pass


@dataclass(frozen=True)
class Chosen:
    """A selected candidate (its bank column and width), with the evidence for it."""

    candidate: Candidate
    column: int
    width: float
    explains: float  # held-out SSE removed, as a fraction of the joint's error before
    pvalue: float
    fold_gains: tuple[float, ...]
    rival: str | None = None  # a different explanation the data could not tell apart
    fixed: bool = False  # enters with coefficient 1 (full backlash, lag, delay act at unit gain)


@dataclass
class JointSelection:
    joint: int
    chosen: list[Chosen] = field(default_factory=list)
    offset: Chosen | None = None
    stopped: str = ""  # why selection stopped: the best remaining candidate and the guard it failed

    def columns(self) -> set[int]:
        """The bank columns of every effect it holds (0 for the offset)."""
        return {c.column for c in ([self.offset] if self.offset else []) + self.chosen}

    def free_columns(self) -> list[int]:
        """Bank columns fitted with free coefficients: the intercept, then the free effects in order."""
        return [0] + [c.column for c in self.chosen if not c.fixed]

    def fixed_columns(self) -> list[int]:
        return [c.column for c in self.chosen if c.fixed]


@dataclass(frozen=True)
class Unidentifiable:
    """Candidates set aside before testing, with the reason a person can check."""

    keys: frozenset[tuple[str, int, int]]
    statements: tuple[str, ...]


def count_reversals(command: Array) -> int:
    """Direction reversals of a command, counting only those that come back a real distance."""
    span = float(np.ptp(command))
    if span == 0:
        return 0
    path = play_grid(command, 0.5 * REVERSAL_TRAVEL * span)[:, 0]
    moves = np.sign(np.diff(path))
    moves = moves[moves != 0]
    return int((moves[1:] != moves[:-1]).sum())


def find_unidentifiable(q_cmd: Array, is_stream: bool, base: ArmPhysics) -> Unidentifiable:
    """What these data cannot test, and why (reversals, motion, collinearity, sampling, the base model)."""
    n_joints = q_cmd.shape[1]
    keys: set[tuple[str, int, int]] = set()
    statements: list[str] = []
    moving = np.ptp(q_cmd, axis=0) > 0
    reversals = [count_reversals(q_cmd[:, s]) for s in range(n_joints)]
    kinds = effect_kinds()

    def driven_by(s: int, which: list[EffectKind]) -> set[tuple[str, int, int]]:
        """Candidate keys of these kinds whose column moves with s's command."""
        return {(k.name, j, s) for k in which for j in (range(n_joints) if k.takes_source else [s])}

    for s in range(n_joints):
        name = JOINT_NAMES[s]
        driven_by_s = driven_by(s, [k for k in kinds if k.needs_reversals])
        if not moving[s]:
            keys |= driven_by(s, [k for k in kinds if not k.is_intercept])
            statements.append(
                f"scale, backlash, lag and delay on {name}, couplings and hysteresis driven by {name}: "
                f"not identifiable: {name} is never commanded to move"
            )
        elif reversals[s] < MIN_REVERSALS:
            keys |= driven_by_s
            how = "never reverses" if reversals[s] == 0 else f"reverses only {reversals[s]} time(s)"
            statements.append(
                f"backlash on {name} and hysteresis driven by {name}: not identifiable: {name} {how}"
            )
    corr = np.atleast_2d(np.corrcoef(q_cmd[:, moving].T)) if moving.sum() > 1 else np.ones((1, 1))
    index = np.flatnonzero(moving)
    cross = [k.name for k in kinds if k.is_linear and k.takes_source]
    for a in range(len(index)):
        for b in range(a + 1, len(index)):
            if abs(corr[a, b]) > COLLINEAR:
                j, s = index[a], index[b]
                keys |= {(name, j, s) for name in cross} | {(name, s, j) for name in cross}
                statements.append(
                    f"coupling between {JOINT_NAMES[j]} and {JOINT_NAMES[s]} versus their scales: not "
                    f"identifiable: their commands move together (r = {corr[a, b]:.3f})"
                )
    if not is_stream:
        keys |= {(k.name, j, j) for j in range(n_joints) for k in kinds if k.streams_only}
        statements.append(
            "lag and delay on every joint: not identifiable: the samples are settled set-points"
        )
    for effect in base.effects:  # play and time effects the base already has are kept as they are
        if effect.kind.width is not None:
            keys.add(effect.kind.candidate_key(effect))
    return Unidentifiable(frozenset(keys), tuple(statements))


def hypotheses_count(candidates: list[Candidate], excluded: frozenset[tuple[str, int, int]]) -> int:
    """m for the Bonferroni level: every (joint, effect, source) the tool could have named."""
    return max(1, sum(1 for c in candidates if c.key not in excluded))


def select_joint(
    joint: int,
    grams: BlockedGrams,
    t: Array | None,
    candidates: list[Candidate],
    excluded: frozenset[tuple[str, int, int]],
    level: float,
) -> JointSelection:
    """Forward selection for one joint (see the module docstring for the rules)."""
    result = JointSelection(joint)
    pool = [
        c for c in candidates if c.joint == joint and not c.effect_kind.is_intercept and c.key not in excluded
    ]
    before = float(grams.cv_sse(joint, np.array([], dtype=np.int64)).sum())
    if before <= 0:
        result.stopped = "no error left to explain"
        return result
    current = grams.cv_sse(joint, np.array(result.free_columns()))
    while pool and len(result.chosen) < MAX_EFFECTS_PER_JOINT:
        free, fixed = result.free_columns(), result.fixed_columns()
        options, sse = _score_options(grams, joint, pool, free, fixed)
        gain = (current.sum() - sse.sum(1)) / max(float(current.sum()), 1e-300)
        residual = _residual(grams, joint, free, fixed)
        shortlist = _best_per_candidate(options, gain)[:TRIES_PER_STEP]
        refined: dict[int, tuple[int, float]] = {}  # option → (bank column, width) between grid values

        def refine(indices: list[int]) -> None:
            """Each option's width refined between grid values, its column added (all in one pass over
            the bank) and its held-out error taken again."""
            chosen = [
                i
                for i in dict.fromkeys(indices)
                if options[i][0].has_width and gain[i] >= MIN_GAIN and i not in refined
            ]
            widths = [
                _refine_width(
                    options[i][0], float(options[i][0].widths[options[i][1]]), residual, t, options[i][2]
                )
                for i in chosen
            ]
            columns = grams.add_columns(
                width_column(options[i][0].kind, options[i][0].signal, t, w) for i, w in zip(chosen, widths)
            )
            for index, column, width in zip(chosen, columns, widths):
                refined[index] = column, width
                unit_gain = options[index][2]
                trial_free, trial_fixed = (free, fixed + [column]) if unit_gain else (free + [column], fixed)
                sse[index] = grams.cv_sse(joint, np.array(trial_free), np.array(trial_fixed, dtype=np.int64))
                gain[index] = (current.sum() - sse[index].sum()) / max(float(current.sum()), 1e-300)

        refine(shortlist)
        shortlist.sort(key=lambda index: -gain[index])
        parsimonious: dict[int, str] = {}  # a simpler option chosen over a richer one → the richer's label
        simpler = _simpler(options, sse, gain, shortlist[0]) if shortlist else None
        if simpler is not None:
            refine([simpler])
            if not _richer_wins(sse, gain, shortlist[0], simpler):
                parsimonious[simpler] = options[shortlist[0]][0].label + _mode(options[shortlist[0]])
                shortlist = [simpler] + [index for index in shortlist if index != simpler]
        accepted = None
        for rank, index in enumerate(shortlist):
            cand, g, unit_gain = options[index]
            if gain[index] < MIN_GAIN:
                reason = f"gains only {100 * max(gain[index], 0):.2f} % held out"
            elif not _gains_where_excited(
                grams, refined.get(index, (int(cand.columns[g]), 0.0))[0], current - sse[index]
            ):
                reason = "does not gain in every fold that excites it"
            else:
                pvalue = shift_pvalue(
                    residual, lambda k: grams.column_values(cand.columns[k : k + 1])[:, 0], len(cand.columns)
                )
                if pvalue <= level:
                    accepted = index, pvalue
                    break
                reason = f"p = {pvalue:.2g} above the corrected level {level:.2g}"
            if rank == 0:
                result.stopped = f"best remaining candidate {cand.label} {reason}"
        if accepted is None:
            break
        index, pvalue = accepted
        cand, g, unit_gain = options[index]
        column, width = refined.get(index, (int(cand.columns[g]), float(cand.widths[g])))
        result.chosen.append(
            Chosen(
                cand,
                column,
                width,
                float((current.sum() - sse[index].sum()) / before),
                pvalue,
                tuple(float(x) for x in current - sse[index]),
                parsimonious.get(index) or _rival(options, sse, gain, index),
                unit_gain,
            )
        )
        result.stopped = ""
        current = sse[index]
        pool = [c for c in pool if c.key != cand.key]
    free_at = np.array(result.free_columns(), dtype=np.int64)
    fixed_at = np.array(result.fixed_columns(), dtype=np.int64)
    without = grams.cv_sse(joint, free_at[1:], fixed_at)
    estimate, se = grams.blocks_jackknife(joint, free_at, 0, fixed_at)
    pvalue = t_pvalue(estimate, se, len(grams.edges) - 2)
    gains = without - current
    offset_gain = float(gains.sum() / max(float(without.sum()), 1e-300))
    if pvalue <= level and (gains > 0).all() and offset_gain >= MIN_GAIN:
        offset = next(c for c in candidates if c.joint == joint and c.effect_kind.is_intercept)
        result.offset = Chosen(
            offset, 0, float("nan"), float(gains.sum() / before), pvalue, tuple(float(x) for x in gains)
        )
    return result


def _score_options(
    grams: BlockedGrams, joint: int, pool: list[Candidate], free: list[int], fixed: list[int]
) -> tuple[list[tuple[Candidate, int, bool]], Array]:
    """Every (candidate, grid width, unit gain?) added to the current model, and its held-out SSE per fold."""
    options: list[tuple[Candidate, int, bool]] = []
    parts = []
    for unit_gain in (False, True):
        batch = [
            (c, g, unit_gain) for c in pool if unit_gain in _gains_allowed(c) for g in range(len(c.columns))
        ]
        if not batch:
            continue
        extra = np.array([[int(c.columns[g])] for c, g, _ in batch])
        trial_free = np.array([free] * len(batch))
        trial_fixed = np.array([fixed] * len(batch), dtype=np.int64).reshape(len(batch), len(fixed))
        if unit_gain:
            parts.append(grams.cv_sse_many(joint, trial_free, np.hstack([trial_fixed, extra])))
        else:
            parts.append(grams.cv_sse_many(joint, np.hstack([trial_free, extra]), trial_fixed))
        options += batch
    return options, np.vstack(parts)


def _residual(grams: BlockedGrams, joint: int, free: list[int], fixed: list[int]) -> Array:
    """In-sample residual of the current model (fixed columns at coefficient 1)."""
    beta = grams.fit(joint, np.array(free), np.array(fixed, dtype=np.int64))
    return grams.targets[:, joint] - grams.column_values(fixed).sum(1) - grams.column_values(free) @ beta


def _refine_width(
    candidate: Candidate, width: float, residual: Array, t: Array | None, unit_gain: bool
) -> float:
    """The width between grid values that best explains the current residual (so that a grid step
    is not mistaken for a second effect)."""
    e = residual - residual.mean()

    def sse(log_width: float) -> float:
        column = width_column(candidate.kind, candidate.signal, t, float(np.exp(log_width)))
        column = column - column.mean()
        if unit_gain:
            return float(((e - column) ** 2).sum())
        return float(e @ e - (column @ e) ** 2 / max(float(column @ column), 1e-300))

    lo, hi = width_bounds(candidate.kind, candidate.signal, t)
    bounds = (np.log(max(width / WIDTH_SEARCH_RATIO, lo)), np.log(min(width * WIDTH_SEARCH_RATIO, hi)))
    found = minimize_scalar(sse, bounds=bounds, method="bounded", options={"xatol": 0.01})
    return float(np.exp(found.x)) if found.fun <= sse(np.log(width)) else width


def _gains_where_excited(grams: BlockedGrams, column: int, fold_gains: Array) -> bool:
    """Gain in every held-out fold where the candidate's column moves at all (an effect excited only
    by a few fast moves or reversals cannot show in a segment without any), and in at least two."""
    energy = grams.fold_energy(column)
    excited = energy >= EXCITED * energy.mean()
    return bool(excited.sum() >= 2 and (fold_gains[excited] > 0).all())


def _gains_allowed(candidate: Candidate) -> tuple[bool, ...]:
    """Whether a candidate enters with a free coefficient (False), at unit gain (True), or either."""
    return candidate.effect_kind.gains


def _best_per_candidate(options: list[tuple[Candidate, int, bool]], gain: Array) -> list[int]:
    """Option indices by decreasing gain, keeping each candidate's best width and gain mode only."""
    seen: set[tuple[str, int, int]] = set()
    order = []
    for index in np.argsort(gain)[::-1]:
        key = options[index][0].key
        if key not in seen:
            seen.add(key)
            order.append(int(index))
    return order


def _n_params(option: tuple[Candidate, int, bool]) -> int:
    """Parameters an option adds: its width, if it has one, and its coefficient, unless at unit gain."""
    cand, _, unit_gain = option
    return int(cand.has_width) + int(not unit_gain)


def _mode(option: tuple[Candidate, int, bool]) -> str:
    """How an option of a kind that may enter either way enters (partial play versus full backlash)."""
    cand, _, unit_gain = option
    if set(cand.effect_kind.gains) != {False, True}:
        return ""
    return " at unit gain" if unit_gain else " with a free gain"


def _simpler(options: list[tuple[Candidate, int, bool]], sse: Array, gain: Array, best: int) -> int | None:
    """The best option with fewer parameters than `best` that explains nearly as much (nested or
    near-equivalent explanations: full versus partial play, coupling or scale versus hysteresis)."""
    needed = _n_params(options[best])
    seen: set[tuple[tuple[str, int, int], bool]] = set()
    for index in np.argsort(gain)[::-1]:
        option = options[index]
        key = (option[0].key, option[2])
        if key in seen:
            continue
        seen.add(key)
        if gain[index] < AMBIGUOUS_GAIN * gain[best]:
            return None
        if int(index) != best and _n_params(option) < needed:
            return int(index)
    return None


def _richer_wins(sse: Array, gain: Array, richer: int, simpler: int) -> bool:
    """Whether the richer explanation beats the simpler one in every held-out fold and by the guard."""
    return bool((sse[richer] < sse[simpler]).all() and gain[richer] - gain[simpler] >= PARSIMONY_GUARD)


def _rival(options: list[tuple[Candidate, int, bool]], sse: Array, gain: Array, best: int) -> str | None:
    """A different candidate explaining almost as much that the winner does not beat in every fold."""
    winner = options[best][0]
    for index in _best_per_candidate(options, gain)[:8]:
        other = options[index][0]
        if other.key == winner.key or gain[index] < AMBIGUOUS_GAIN * gain[best]:
            continue
        if not (sse[best] < sse[index]).all():
            return other.label
    return None


def select(
    grams: BlockedGrams,
    t: Array | None,
    candidates: list[Candidate],
    unidentifiable: Unidentifiable,
    alpha: float = ALPHA,
) -> tuple[list[JointSelection], int]:
    """Selections for every joint at the Bonferroni level over all joints × effects, and that m."""
    hypotheses = hypotheses_count(candidates, unidentifiable.keys)
    selections = [
        select_joint(j, grams, t, candidates, unidentifiable.keys, alpha / hypotheses)
        for j in range(grams.targets.shape[1])
    ]
    return selections, hypotheses
