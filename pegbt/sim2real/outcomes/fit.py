"""Name and fit the world effects that explain where real outcomes disagree with the simulator's.

Each registered world effect is a candidate through the parameters that make it act (`FITTED`): the
fit cells are simulated on a grid of each parameter's range (the same seeds at every value) and the real
counts weigh each value (`likelihood`). An effect is named only if it fits the fit cells better than the
world before it beyond chance (likelihood ratio, χ² at 95 %) and improves the held-out fit (each fit cell
predicted from the others, leave-one-out). Effects are added one at a time (greedy forward selection):
a transfer passes its phases in turn, so one that fails at the grasp and again at the lift is placed only
when two effects act together, and each step profiles every candidate on top of the world chosen so far.
Where the data cannot tell two additions apart (log-likelihoods within `TIE`) each is followed as its own
path; paths that end in different worlds are reported as a tie, none of them named, and each predicts.
A large campaign's real counts resolve more than the grid's simulated transfers do, so each step screens
every candidate on `transfers` against the world before it on the same seeds, and profiles again only the
leaders (`leaders_to_weigh`) on as many transfers as the default world is located with, a candidate that
trails them on the screen probed at its best value there first; the χ² test, the leave-one-out gain and
every later step read those (`fit`'s `weighed`).
The additions that pass are ranked on fresh seeds, not on the ones their best value was picked on: the
pick favours whichever candidate's grid drew the luckiest outcomes (a registration offset reshuffles
them), and the first choice decides every later step.

What is named is decided on the grid; the value named is not limited to it: a grid coarse enough to be
affordable steps a parameter by half its value, so the estimate and its interval are read from the
profile log-likelihood between grid values and the inert default (`with_inert`, `between`, `estimate`).
A large campaign's profile can peak inside one grid step (a peg bending 0.5 mm where the grid steps by
1 mm from a rigid peg), where the counts interpolated between two grid values only point at it: each
profile's maximum between grid values joins its grid and is simulated, at every precision a candidate is
weighed at (`refined`), so what is named is decided on a simulated value there, whatever the grid's step.

The leave-one-out test needs a fit cell to hold out: where the fit cells hold one informative count (one
cell disagrees and no phases are known, as in the paper's table), there is none, so an effect that passes
the χ² test is not named but kept as an explanation the data cannot check (`Verdict.unchecked`): each
predicts the other cells, and they are mixed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.likelihood import log_likelihood, vector_log_likelihood
from pegbt.sim2real.outcomes.simulate import Key, Mapper, SimCounts, simulate_cells

# The parameters fitted per kind: one dimension each, the others at their defaults. Registration is
# fitted per axis of the board (z moves a grasp along the tool, which the bite tolerates).
FITTED: dict[str, tuple[str, ...]] = {
    "peg_compliance": ("deflection",),
    "chamfer_capture": ("capture_radius",),
    "hole_lobes": ("lobe_radius",),
    "grip_compliance": ("displacement", "angle"),
    "grasp_capture": ("width",),
    "jaw_tip_slide": ("width",),
    "jaw_friction": ("max_load",),
    "registration_offset": ("x", "y"),
    "depth_bias": ("bias",),
    "perception_noise": ("sd",),
}
# The phases each kind can change an outcome in: with failures per phase, a candidate is simulated only if
# the real and simulated rates disagree in one of its phases (a kind that cannot act there cannot explain it).
PHASES_OF: dict[str, frozenset[str]] = {
    "peg_compliance": frozenset({"lift", "lower"}),
    "chamfer_capture": frozenset({"lower", "release"}),
    "hole_lobes": frozenset({"grasp", "lift", "lower", "release"}),
    "grip_compliance": frozenset({"lift", "carry", "lower"}),
    "grasp_capture": frozenset({"grasp"}),
    "jaw_tip_slide": frozenset({"grasp", "handover"}),
    "jaw_friction": frozenset({"lift", "carry", "handover", "lower"}),
    "registration_offset": frozenset({"grasp", "lift", "handover", "lower", "release"}),
    "depth_bias": frozenset({"grasp", "lift", "handover", "lower", "release"}),
    "perception_noise": frozenset({"grasp", "lift", "handover", "lower", "release"}),
}
# A way back fails at `sense` where its way out lost the block (`likelihood`), so every kind that can lose a
# block changes it: a disagreement there (with the placed rate, the mirror of it) admits every kind.
AFTER_A_LOSS = frozenset({"sense"})
LR_95 = float(stats.chi2.ppf(0.95, 1))  # one fitted parameter
TIE = 1.0  # log-likelihoods closer than this: the data do not tell the two effects apart
MAX_EFFECTS = 4  # effects in one fitted world: the phases a transfer can fail in that several kinds share
MAX_PATHS = 4  # tied paths followed at once (the rest, less likely, are dropped)
STEPS = 16  # points per grid step at which the profile is read between grid values (`between`)


@dataclass(frozen=True)
class Candidate:
    """One parameter of one world effect, and the grid of values it is simulated at."""

    kind: str
    parameter: str
    grid: tuple[float, ...]

    @property
    def name(self) -> str:
        return f"{self.kind}.{self.parameter}"

    def world(self, value: float, base: WorldEffects = WorldEffects()) -> WorldEffects:
        """`base` with this parameter set to `value` (a second effect joins the first)."""
        effects = {effect.kind: dict(effect.values) for effect in base}
        effects.setdefault(self.kind, {})[self.parameter] = value
        return WorldEffects.of(effects)


def candidates(points: int) -> list[Candidate]:
    """Every fitted parameter of every registered kind on `points` + 1 values spanning its range, less its
    inert default (log-spaced where the range spans decades)."""
    out = []
    for kind, names in FITTED.items():
        if kind not in WORLD_EFFECT_KINDS:
            continue
        for name in names:
            p = WORLD_EFFECT_KINDS[kind].parameters[name]
            if p.low > 0 and p.high / p.low > 100:
                values = np.geomspace(p.low, p.high, points + 1)
            else:
                values = np.linspace(p.low, p.high, points + 1)
            grid = tuple(float(v) for v in values if not math.isclose(v, p.default, abs_tol=1e-12))
            out.append(Candidate(kind, name, grid))
    return out


@dataclass
class Profile:
    """A candidate's fit: the simulated fit cells and the log-likelihood at each grid value."""

    candidate: Candidate
    values: tuple[float, ...]
    sims: list[dict[Key, SimCounts]]
    per_cell: np.ndarray  # (values, cells) log-likelihoods
    base: WorldEffects = WorldEffects()
    fresh_total: float | None = None  # the fitted world's log-likelihood on fresh seeds, once ranked there
    dense: tuple[np.ndarray, np.ndarray] | None = None  # the profile between grid values (`between`)
    reference: np.ndarray | None = None  # (cells,) `base`'s log-likelihoods on the same seeds and sizes

    @property
    def paired_gain(self) -> float:
        """How much better the best grid value fits than `base` simulated on the same seeds and as many
        transfers (log units): the screen's comparison, at equal precision on both sides."""
        reference = self.reference if self.reference is not None else np.zeros(self.per_cell.shape[1])
        return float(self.total.max() - reference.sum())

    @property
    def total(self) -> np.ndarray:
        return self.per_cell.sum(axis=1)

    @property
    def score(self) -> float:
        """What additions are ranked by: the fresh seeds' log-likelihood if known, else the best total."""
        return float(self.total.max()) if self.fresh_total is None else self.fresh_total

    @property
    def best(self) -> int:
        return int(np.argmax(self.total))

    @property
    def value(self) -> float:
        return self.values[self.best]

    def weights(self, without: int | None = None) -> np.ndarray:
        """Posterior weights of the grid values (flat prior), leaving out fit cell `without` if given."""
        total = self.total if without is None else self.total - self.per_cell[:, without]
        return np.exp(total - logsumexp(total))

    def posterior(self) -> tuple[np.ndarray, np.ndarray]:
        """The parameter's posterior (flat prior) over the profile between grid values (`between`; the
        grid's, if not known): its values and their weights, which sum to 1."""
        values, totals = self.dense or (np.asarray(self.values), self.total)
        return np.asarray(values, dtype=float), np.exp(totals - logsumexp(totals))

    def evidence(self) -> float:
        """How well the candidate fits the fit cells on average over its range (the log of the mean
        likelihood over the profile between grid values, a flat prior over the range): what weighs it
        against another candidate whose value the fit cells cannot pin either."""
        _, totals = self.dense or (self.values, self.total)
        return float(logsumexp(totals) - math.log(len(totals)))

    @property
    def estimate(self) -> float:
        """The parameter's estimate: the maximum of the profile between grid values (of the grid's, if
        not known)."""
        return estimate(*(self.dense or (self.values, self.total)))[0]

    def interval(self) -> tuple[float, float]:
        """The 95 % likelihood-ratio interval of the profile between grid values (`estimate`)."""
        _, low, high = estimate(*(self.dense or (self.values, self.total)))
        return low, high

    def world(self) -> WorldEffects:
        """`base` with the best grid value (what the fit simulated)."""
        return self.candidate.world(self.value, self.base)

    def estimated_world(self, base: WorldEffects | None = None) -> WorldEffects:
        """`base` (its own base by default) with the estimate: the world the fit names."""
        return self.candidate.world(self.estimate, self.base if base is None else base)

    @property
    def label(self) -> str:
        """The kinds of its fitted world, in order (a path of several effects is named by all of them)."""
        return "+".join(effect.kind for effect in self.world())


@dataclass(frozen=True)
class Verdict:
    """What the fit found: the profiles named, tied (indistinguishable), tried, and the null's fit."""

    named: tuple[Profile, ...]
    tied: tuple[Profile, ...]
    tried: tuple[Profile, ...]
    null: np.ndarray  # (cells,) the default world's log-likelihood per fit cell
    passing: tuple[str, ...]  # candidates that passed on their own (the χ² test alone if unchecked)
    unchecked: bool = False  # one informative count: the `tied` passed the χ² test with nothing to hold out
    paths: tuple[tuple[Profile, ...], ...] = ()  # each tied end's path, its effects in the order added
    tested: tuple[str, ...] = ()  # candidates of `tried` tested alone; the rest trailed the screen's leaders

    def path_of(self, end: Profile) -> tuple[Profile, ...]:
        """The path that `end` (one of `tied`) ends: what is named when it alone is kept, since `named` is
        read as a path (`world`, the report, the benchmark's score) and `end` alone holds only its own kind."""
        return next((path for path in self.paths if path[-1] is end), (end,))

    @property
    def explanation(self) -> Profile | None:
        """The one world that explains the fit cells, if one does: the last named effect's (its path), or
        the one explanation an `unchecked` fit keeps unnamed. What the fit cells leave open is sought on top
        of it (`alternatives`): one informative count can leave an effect open that decides a held-out cell."""
        if self.named:
            return self.named[-1]
        return self.tied[0] if len(self.tied) == 1 else None

    def world(self) -> WorldEffects:
        """The fitted world: every named effect at its estimate."""
        world = WorldEffects()
        for fitted in self.named:
            world = fitted.estimated_world(world)
        return world


def estimate(
    values: Sequence[float] | np.ndarray, totals: Sequence[float] | np.ndarray
) -> tuple[float, float, float]:
    """The value of a profile log-likelihood's maximum, and its 95 % interval: where the profile, linear
    between `values` (ascending), is within χ²₁,₀.₉₅ / 2 of the maximum. A profile with two maxima (a
    registration offset of either sign) gets the interval spanning both, as the grid's did. Nothing is
    extrapolated beyond the values given: an interval that reaches an end of them ends there."""
    x = np.asarray(values, dtype=float)
    y = np.asarray(totals, dtype=float)
    best = int(np.argmax(y))
    dense = np.linspace(x[0], x[-1], 4001)
    inside = dense[np.interp(dense, x, y) >= y[best] - LR_95 / 2]
    return float(x[best]), float(min(inside.min(), x[best])), float(max(inside.max(), x[best]))


def between(
    values: Sequence[float],
    sims: Sequence[dict[Key, SimCounts]],
    cells: Sequence[Cell],
    per_cell: np.ndarray,
    phases: bool,
    steps: int = STEPS,
) -> tuple[np.ndarray, np.ndarray]:
    """The profile between grid values: each fit cell's simulated counts per category interpolated
    linearly between neighbouring grid values (in the log of the value on a log-spaced grid), and the real
    counts weighed against them. The grid's worlds share their seeds, so a cell's counts change with the
    parameter through the transfers the effect tips over, not through luck, and a rate between two grid
    values lies between theirs; the likelihood itself is far from linear (sharp where real transfers are
    many), which is why the counts are interpolated and not the log-likelihood. A cell not simulated at
    the grid keeps its one log-likelihood (`per_cell`'s)."""
    x = np.asarray(values, dtype=float)
    log = bool(x[0] > 0 and x[-1] / x[0] > 100)
    u = np.log(x) if log else x
    t = np.linspace(0.0, 1.0, steps + 1)[:-1]
    dense = np.concatenate([*(u[i] + t * (u[i + 1] - u[i]) for i in range(len(u) - 1)), u[-1:]])
    totals = np.zeros(len(dense))
    for j, cell in enumerate(cells):
        if not all(cell.key in sim for sim in sims):
            totals += per_cell[0, j]
            continue
        counts = np.array([sim[cell.key].vector() for sim in sims])
        for k, point in enumerate(dense):
            vector = np.array([np.interp(point, u, counts[:, c]) for c in range(counts.shape[1])])
            totals[k] += vector_log_likelihood(cell, vector, phases)
    return (np.exp(dense) if log else dense), totals


def profile(
    mapper: Mapper,
    candidate: Candidate,
    cells: Sequence[Cell],
    transfers: int,
    null: np.ndarray,
    informative: int,
    base: WorldEffects = WorldEffects(),
    phases: bool = True,
    quiet_transfers: int | None = None,
    every_cell: bool = False,
) -> Profile:
    """Simulate the fit `cells` at every grid value of `candidate` (on top of `base`) and weigh each. The
    first `informative` cells (those that disagree) get `transfers` each; the others, which agree with the
    default world, are simulated (with `quiet_transfers`, a third of `transfers` by default) only for a
    candidate that fits the informative ones beyond chance, and otherwise keep the default world's
    likelihood, which they agree with. A quiet cell so simulated weighs what the candidate changes there
    against `base` on the same seeds, added to its likelihood in `null`: its own likelihood on a third of
    the transfers would fall below `null`'s (simulated on more) for the imprecision alone, a penalty on
    every candidate that a world placing every calibrated transfer as the default does never earned.
    `every_cell`: the quiet cells are simulated whatever the informative ones say (an open effect's
    posterior, `alternatives`, must see the calibrated rows that exclude part of its range).
    `base` is simulated beside the grid on the same seeds (the profile's `reference`)."""
    quiet_transfers = max(2, transfers // 3) if quiet_transfers is None else quiet_transfers
    worlds = [candidate.world(v, base) for v in candidate.grid]
    loud, quiet = list(cells[:informative]), list(cells[informative:])
    *sims, at_default = simulate_cells(mapper, [*worlds, base], [c.key for c in loud], transfers)
    per_cell = np.array([[log_likelihood(c, sim[c.key], phases) for c in loud] for sim in sims])
    reference = np.array([log_likelihood(c, at_default[c.key], phases) for c in loud])
    rest = np.tile(null[informative:], (len(worlds), 1))
    if quiet and (every_cell or 2 * (per_cell.sum(axis=1).max() - null[:informative].sum()) >= LR_95):
        *more, quiet_default = simulate_cells(
            mapper, [*worlds, base], [c.key for c in quiet], quiet_transfers
        )
        rest = np.array([[log_likelihood(c, sim[c.key], phases) for c in quiet] for sim in more])
        rest += null[informative:] - np.array(
            [log_likelihood(c, quiet_default[c.key], phases) for c in quiet]
        )
        sims = [{**a, **b} for a, b in zip(sims, more)]
        at_default = {**at_default, **quiet_default}
    per_cell = np.hstack([per_cell, rest])
    values, with_default = with_inert(candidate, sims, at_default)
    dense = between(values, with_default, cells, per_cell, phases)
    reference = np.concatenate([reference, null[informative:]])
    return Profile(candidate, candidate.grid, sims, per_cell, base, dense=dense, reference=reference)


def leaders_to_weigh(screened: Sequence[Profile]) -> tuple[list[Profile], list[Profile]]:
    """The screened candidates weighed again on more transfers, and those probed first. Weighed: those whose
    paired gain over the world before them (`Profile.paired_gain`, the grid and that world on the same seeds
    and as many transfers) is within the χ² margin (χ²₁,₀.₉₅ / 2 log units) of the best one's, whatever its
    sign: a candidate the screen cannot tell from the best (on the screen's transfers a small change, a
    chamfer's 4 points in 12 %, moves a few simulated transfers, so its gain may be below 0). Probed: the
    others that already fit better than the world before them; one whose luck on the screen hid a better
    fit shows it at its best screened value on the weighed transfers (`fit`'s `probe_gains`), and only then
    is its whole grid weighed, so a clear leader does not cost every chance gain a grid."""
    if not screened:
        return [], []
    best = max(p.paired_gain for p in screened)
    near = [p for p in screened if p.paired_gain >= best - LR_95 / 2]
    return near, [p for p in screened if p not in near and p.paired_gain > 0]


def with_inert(
    candidate: Candidate, sims: list[dict[Key, SimCounts]], at_default: dict[Key, SimCounts]
) -> tuple[list[float], list[dict[Key, SimCounts]]]:
    """The grid's values and counts with the parameter's inert default among them (the world before the
    candidate, `at_default`), for the profile between grid values: the grid leaves the default out (the
    world before already has it), and without it the profile between the grid values either side of it
    (a registration offset of −2.5 and +2.5 mm) would read the default world as their average, and none
    below the grid's first value (a peg bending less than 0.75 mm) at all. A log-spaced grid whose default
    is not positive keeps its values alone."""
    default = WORLD_EFFECT_KINDS[candidate.kind].parameters[candidate.parameter].default
    grid = list(candidate.grid)
    if default <= 0 and grid[0] > 0 and grid[-1] / grid[0] > 100:
        return grid, sims
    at = int(np.searchsorted(grid, default))
    return [*grid[:at], default, *grid[at:]], [*sims[:at], at_default, *sims[at:]]


def loo_gain(fitted: Profile, null: np.ndarray) -> float:
    """How much better each fit cell is predicted from the other fit cells than by the null (log units)."""
    gain = 0.0
    for index in range(fitted.per_cell.shape[1]):
        weights = fitted.weights(without=index)
        predicted = logsumexp(fitted.per_cell[:, index], b=weights)
        gain += float(predicted - null[index])
    return gain


def passes(fitted: Profile, null: np.ndarray, checkable: bool = True) -> bool:
    """Better than `null` beyond chance on the fit cells, and (if `checkable`: more than one informative
    count) on each fit cell held out in turn."""
    beyond = 2 * (fitted.total.max() - null.sum()) >= LR_95
    return beyond and (not checkable or loo_gain(fitted, null) > 0)


def refined(fitted: Profile) -> Candidate:
    """`fitted`'s candidate with the maximum of its profile between grid values (`Profile.estimate`) on its
    grid, if that lies off the grid and the inert default: the counts interpolated there point at a peak
    the grid's step may straddle, and only a simulation there can show it."""
    candidate = fitted.candidate
    value = fitted.estimate
    default = WORLD_EFFECT_KINDS[candidate.kind].parameters[candidate.parameter].default
    if any(math.isclose(value, v, rel_tol=1e-6, abs_tol=1e-12) for v in (*candidate.grid, default)):
        return candidate
    return replace(candidate, grid=tuple(sorted((*candidate.grid, value))))


@dataclass(frozen=True)
class Fresh:
    """Seeds no fit simulation uses, `transfers` per fit cell from `first_seed`, to rank passing additions."""

    first_seed: int
    transfers: int


def fit(
    mapper: Mapper,
    cells: Sequence[Cell],
    null_sims: dict[Key, SimCounts],
    transfers: int,
    points: int,
    phases: bool = True,
    disagreeing: frozenset[str] | None = None,
    informative: int | None = None,
    fresh: Fresh | None = None,
    weighed: int | None = None,
    checkable: bool = True,
) -> Verdict:
    """Profile every candidate (only those that can act in a `disagreeing` phase, when phases are known)
    on the fit `cells` (the first `informative` of them disagree; all, if not given), then add effects one
    at a time while the best addition passes (best on `fresh` seeds, when given); a tie is followed down
    each of its paths.

    With `weighed` (the transfers `null_sims` holds in the informative cells), every candidate is first
    screened on `transfers` against the world before it on the same seeds (`Profile.paired_gain`), and only
    the leaders (`leaders_to_weigh`, and those probed that rise to them) are profiled again on `weighed`
    transfers, where they are tested against the world before them at the same precision: weighed on fewer
    simulated transfers than the default world, a candidate saw a large campaign's real counts as a tenth
    of them and the null as a third, and could not beat it. Without `weighed`, every candidate is tested as
    screened.

    Not `checkable` (one informative count): nothing is named; the ends that pass the χ² test are returned
    as `tied`, `unchecked`."""
    informative = len(cells) if informative is None else informative
    null = np.array([log_likelihood(c, null_sims[c.key], phases) for c in cells])
    loud = [c.key for c in cells[:informative]]
    chosen = [
        candidate
        for candidate in candidates(points)
        if disagreeing is None or (PHASES_OF.get(candidate.kind, disagreeing) | AFTER_A_LOSS) & disagreeing
    ]
    screened_alone: list[Profile] = []
    alone: dict[str, Profile] = {}  # each candidate alone, as weighed
    tested: list[str] = []  # the candidates whose passing alone was tested (`passes`)

    def weigh(candidate: Candidate, base: WorldEffects, before: np.ndarray, size: int) -> Profile:
        return profile(
            mapper, candidate, cells, size, before, informative, base, phases, max(2, transfers // 3)
        )

    def weigh_refined(
        some: list[Candidate], base: WorldEffects, before: np.ndarray, size: int
    ) -> list[Profile]:
        """Each of `some` profiled on top of `base` on `size` transfers, its grid `refined` by the maximum
        of that profile between grid values (each batch one simulation: every transfer's arm once)."""
        worlds = [candidate.world(value, base) for candidate in some for value in candidate.grid]
        simulate_cells(mapper, [*worlds, base], loud, size)
        coarse = [weigh(c, base, before, size) for c in some]
        sharper = [refined(p) for p in coarse]
        new = [c.world(v, base) for c, p in zip(sharper, coarse) for v in c.grid if v not in p.candidate.grid]
        if new:
            simulate_cells(mapper, [*new, base], loud, size)
        return [p if c is p.candidate else weigh(c, base, before, size) for c, p in zip(sharper, coarse)]

    def step(base: WorldEffects, before: np.ndarray) -> list[Profile]:
        """Every candidate of a kind not yet in `base` profiled on top of it, the best first, that passes
        against `before` (the per-cell log-likelihoods of `base`)."""
        others = [c for c in chosen if c.kind not in {e.kind for e in base}]
        screened = weigh_refined(others, base, before, transfers)
        profiles = screened
        if weighed is not None:
            near, probed = leaders_to_weigh(screened)
            profiles = weigh_refined([p.candidate for p in near], base, before, weighed)
            best = max((p.paired_gain for p in profiles), default=-math.inf)
            gains = probe_gains(mapper, probed, base, cells[:informative], weighed, phases)
            risen = [p.candidate for p, gain in zip(probed, gains) if gain >= best - LR_95 / 2]
            profiles += weigh_refined(risen, base, before, weighed)
        if not base:
            screened_alone.extend(screened)
            alone.update({p.candidate.name: p for p in profiles})
            tested.extend(p.candidate.name for p in profiles)
        passing = sorted((p for p in profiles if passes(p, before, checkable)), key=lambda p: -p.total.max())
        return passing if fresh is None else ranked_on_fresh_seeds(mapper, passing, cells, fresh, phases)

    def alone_as_weighed(candidate: Candidate) -> Profile:
        if candidate.name not in alone:
            alone[candidate.name] = weigh(candidate, WorldEffects(), null, weighed or transfers)
        return alone[candidate.name]

    first = step(WorldEffects(), null)
    paths: list[list[Profile]] = [[p] for p in _leaders(first)]
    done: list[list[Profile]] = []
    while paths:
        path = paths.pop(0)
        last = path[-1]
        ahead = [] if len(path) == MAX_EFFECTS else step(last.world(), last.per_cell[last.best])
        ahead = [p for p in ahead if not _ties_alone(p, alone_as_weighed(p.candidate))]
        if not ahead:
            done.append(path)
        paths = (paths + [[*path, p] for p in _leaders(ahead)])[:MAX_PATHS]
    names = tuple(p.candidate.name for p in first)
    tried = tuple(alone.get(p.candidate.name, p) for p in screened_alone)
    ends = _distinct([path[-1] for path in done])
    whole = tuple(next(tuple(path) for path in done if path[-1] is end) for end in ends)
    if len(ends) > 1 or (ends and not checkable):
        return Verdict((), tuple(ends), tried, null, names, not checkable, whole, tuple(tested))
    if not ends:
        return Verdict((), (), tried, null, names, tested=tuple(tested))
    return Verdict(whole[0], (), tried, null, names, tested=tuple(tested))


def probe_gains(
    mapper: Mapper,
    probed: Sequence[Profile],
    base: WorldEffects,
    loud: Sequence[Cell],
    transfers: int,
    phases: bool,
) -> list[float]:
    """Each of `probed` at its best screened value against `base`, both on `transfers` transfers of the
    `loud` cells (the same seeds): its paired gain there (log units), one world a candidate."""
    if not probed:
        return []
    keys = [c.key for c in loud]
    *sims, at_base = simulate_cells(mapper, [*(p.world() for p in probed), base], keys, transfers)
    reference = sum(log_likelihood(c, at_base[c.key], phases) for c in loud)
    return [sum(log_likelihood(c, sim[c.key], phases) for c in loud) - reference for sim in sims]


def ranked_on_fresh_seeds(
    mapper: Mapper, passing: list[Profile], cells: Sequence[Cell], fresh: Fresh, phases: bool
) -> list[Profile]:
    """`passing`, each with its fitted world simulated on `fresh` seeds, best first by the fit cells'
    log-likelihood there; each profile's own scores are kept (its interval and later steps use them)."""
    if len(passing) < 2:
        return passing
    sims = simulate_cells(
        mapper,
        [p.world() for p in passing],
        [c.key for c in cells],
        fresh.transfers,
        first_seed=fresh.first_seed,
    )
    scores = [sum(log_likelihood(c, sim[c.key], phases) for c in cells) for sim in sims]
    order = sorted(range(len(passing)), key=lambda i: -scores[i])
    return [replace(passing[i], fresh_total=scores[i]) for i in order]


def _leaders(passing: list[Profile]) -> list[Profile]:
    """The best of `passing` (sorted, best first) and those of other kinds the data cannot tell from it."""
    if not passing:
        return []
    best = passing[0]
    return [best] + [
        p for p in passing[1:] if p.candidate.kind != best.candidate.kind and best.score - p.score < TIE
    ]


def _distinct(ends: list[Profile]) -> list[Profile]:
    """One end per fitted world's set of kinds (two orders of the same effects are one world), the most
    likely first."""
    best: dict[frozenset[str], Profile] = {}
    for end in sorted(ends, key=lambda p: -p.total.max()):
        best.setdefault(frozenset(e.kind for e in end.world()), end)
    return list(best.values())


def _ties_alone(pair: Profile, own: Profile) -> bool:
    """Whether the last effect added explains the data alone (`own`, weighed as `pair` is) as well as with
    the effects before it (they add nothing)."""
    return pair.total.max() - own.total.max() < TIE
