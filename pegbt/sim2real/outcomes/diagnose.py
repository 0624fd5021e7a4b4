"""The whole diagnosis of one set of real outcomes: locate, name, model, prove."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from pegbt.errors import PegbtError
from pegbt.runconditions import CONDITIONS, VARIANTS
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.alternatives import Alternative, changes_held_out, open_effects, shares
from pegbt.sim2real.outcomes.cache import MemoMapper
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.fit import LR_95, TIE, Fresh, Profile, Verdict, fit
from pegbt.sim2real.outcomes.gate import gate
from pegbt.sim2real.outcomes.likelihood import log_likelihood
from pegbt.sim2real.outcomes.locate import Row, locate
from pegbt.sim2real.outcomes.predict import PREDICT_SEED, Prediction, predict, predict_null, predict_world
from pegbt.sim2real.outcomes.simulate import Key, Mapper, SimCounts, simulate_cells

SIZED_FOR = 120  # real transfers a fit cell the default counts are sized for: 10 trials of 12 transfers
FRESH_SEED = 1_000_000  # the replication's simulated transfers: seeds no other simulation here uses
RANK_SEED = 2_000_000  # where the fit ranks the additions that pass: neither the fit's nor the replication's
TIE_SEED = 3_000_000  # where a tie is weighed again (`_resolved`): seeds no other simulation here uses
# A tie is weighed on this many times as many simulated transfers a fit cell as the real ones (`as_precise`):
# on as many, the lead's own simulation noise is about 0.8 log units (the grip's seed-1 tie, 456 a cell:
# two fresh draws put it 1.1 apart) against a margin (`TIE`) of 1, which decides a sixth of true ties by
# luck; on four times as many it halves.
TIE_DRAWS = 4
OPEN_NODES = 4  # worlds across an open effect's range per prediction: its posterior is as wide as the range
OPEN_MIXED = "what is open, mixed"  # the held-out cells predicted by every open effect over its range


@dataclass(frozen=True)
class Settings:
    """`fit`: which cells the fit sees (`all`, a variant or a condition); the rest are predicted.
    `transfers`: simulated transfers per cell and world in the fit; `located`: in the default world, which
    every comparison is against (more, so a disagreement is seen); `points`: grid values per parameter,
    before each profile's maximum joins them (`fit.refined`). The counts are sized for fit cells of up to
    `real` real transfers (`for_campaign`)."""

    fit: str = "all"
    transfers: int = 16
    located: int = 48
    points: int = 5
    phases: bool = True
    real: int = SIZED_FOR

    def for_campaign(self, real: int) -> Settings:
        """These settings for fit cells of up to `real` real transfers. Above `self.real` the simulated
        transfers grow in proportion: the real counts resolve differences that shrink so, and a fit whose
        simulated side stayed fixed would weigh them against simulation noise that does not (`likelihood`: the simulated counts' own uncertainty is in every
        cell's likelihood), so a large campaign would be fitted no better than a small one."""
        if real <= self.real:
            return self
        scale = real / self.real
        return replace(
            self,
            transfers=math.ceil(self.transfers * scale),
            located=math.ceil(self.located * scale),
            real=real,
        )


@dataclass
class Diagnosis:
    outcomes: Outcomes
    settings: Settings
    fit_cells: tuple[Cell, ...]
    held_out: tuple[Cell, ...]
    before: dict[Key, SimCounts]
    rows: list[Row]
    verdict: Verdict
    predictions: dict[Key, Prediction]
    predicted_by: dict[str, dict[Key, Prediction]] = field(default_factory=dict)
    remaining: list[Row] = field(default_factory=list)  # fit cells' rows at the fitted world
    seconds: float = 0.0
    simulated: int = 0
    unreplicated: tuple[str, ...] = ()  # effects the fit chose whose gain did not hold on fresh seeds
    alternatives: tuple[Alternative, ...] = ()  # effects the fit cells leave open that change a held-out cell
    resolved: str = ""  # how a tie on the fit's simulations was decided on as many as the real transfers

    @property
    def unexplained(self) -> list[Row]:
        """Fit-cell rows that still disagree beyond chance once the fitted world is simulated."""
        return [row for row in self.remaining if row.disagrees]

    def world(self) -> WorldEffects:
        return self.verdict.world()

    @property
    def pools_after(self) -> bool:
        """Whether what the prediction simulates "after" is several worlds pooled (`predict.weighted_pool`),
        its counts effective transfers rather than simulated ones: a tie's best values, or the open mixture."""
        return not self.verdict.named and (len(self.verdict.tied) > 1 or self.predicts_open_mixture)

    @property
    def predicts_open_mixture(self) -> bool:
        """Whether `predictions` are what the fit cells leave open, mixed: they reject the default world
        (the gate opened), nothing explains them, and something is left open (`diagnose`)."""
        return self.verdict.explanation is None and bool(self.alternatives)


def split(cells: Sequence[Cell], fit_on: str) -> tuple[tuple[Cell, ...], tuple[Cell, ...]]:
    """The cells the fit sees (`fit_on`: all, a variant or a condition) and the rest."""
    if fit_on not in ("all", *VARIANTS, *CONDITIONS):
        raise PegbtError(
            f"expected all, a variant ({', '.join(VARIANTS)}) or a condition ({', '.join(CONDITIONS)}), got {fit_on!r}",
            field="--fit",
        )
    seen = tuple(c for c in cells if fit_on in ("all", c.variant, c.condition))
    if not seen:
        raise PegbtError(f"no cell of the outcomes is {fit_on}: nothing to fit on", field="--fit")
    return seen, tuple(c for c in cells if c not in seen)


class _Counting(MemoMapper):
    """The diagnosis's own memo (the fit simulates every candidate's grid in one batch, so the arm's motion
    is shared, and its profiles then find them here), telling `progress` after each batch that simulated."""

    def __init__(self, mapper: Mapper, progress: Callable[[str], None] | None) -> None:
        super().__init__(mapper)
        self.progress = progress
        self.started = time.monotonic()

    def batch(self, simulated: int) -> None:
        if self.progress is not None and simulated:
            self.progress(f"{self.simulated} transfers simulated ({time.monotonic() - self.started:.0f} s)")


def diagnose(
    outcomes: Outcomes, settings: Settings, mapper: Mapper, progress: Callable[[str], None] | None = None
) -> Diagnosis:
    """Locate, name and fit on the fit cells, then predict every cell with the fitted world(s); the
    simulated side grows with the largest fit cell (`Settings.for_campaign`). Fit cells that reject the
    default world (the gate opened) but that no effect explains are predicted with what they leave open,
    mixed (`alternatives`): the default world they reject is then a comparison, not the prediction. Beside a
    world that explains the fit cells, what is left open predicts the held-out cells alone."""
    started = time.monotonic()
    counting = _Counting(mapper, progress)
    cells = outcomes.cells
    fit_cells, held_out = split(cells, settings.fit)
    settings = settings.for_campaign(max(c.attempted for c in fit_cells))
    before = _located(counting, cells, fit_cells, settings)
    rows = locate(cells, before)
    phased = {(r.variant, r.condition) for r in rows if r.phase} if settings.phases else set()
    opened = gate(fit_cells, before, bool(phased & {c.key for c in fit_cells}))
    if opened.opens:
        loud = set(opened.loud)
        ordered = [c for c in fit_cells if c.key in loud] + [c for c in fit_cells if c.key not in loud]
        verdict = fit(
            counting,
            ordered,
            before,
            settings.transfers,
            settings.points,
            settings.phases,
            opened.phases,
            len(loud),
            Fresh(RANK_SEED, as_precise(settings, fit_cells)),
            settings.located,
            checkable=len(loud) > 1 or bool(phased & loud),  # more than one informative count
        )
        fit_cells = tuple(ordered)
        informative = len(loud)
    else:
        informative = len(fit_cells)
        verdict = Verdict((), (), (), _null(fit_cells, before, settings.phases), ())
    verdict, unreplicated = _replicated(counting, verdict, fit_cells, settings, progress)
    verdict, resolved, stood_in = _resolved(counting, verdict, fit_cells, settings, progress)
    unreplicated += stood_in
    predicted_by: dict[str, dict[Key, Prediction]] = {}
    if verdict.named:
        predictions, _ = predict(counting, [verdict.named[-1]], cells, settings.transfers)
    elif verdict.tied:
        predictions, each = predict(counting, list(verdict.tied), cells, settings.transfers)
        if len(verdict.tied) > 1:
            predicted_by = {tied.label: alone for tied, alone in zip(verdict.tied, each)}
    else:
        predictions = predict_null(counting, before, cells)
    alternatives: list[Alternative] = []
    if verdict.tried and len(verdict.tied) <= 1 and held_out:
        alternatives = _alternatives(counting, verdict, fit_cells, held_out, settings, informative)
    if alternatives:
        explanation = verdict.explanation
        mixed, each = predict(
            counting,
            [a.profile for a in alternatives],
            held_out if explanation else cells,  # the fit cells are the explanation's to predict
            settings.transfers,
            count=OPEN_NODES,
            shares=shares(alternatives),
            best_value=False,
        )
        predicted_by = {
            explanation.label if explanation else "default world": predictions
            if explanation
            else predict_world(counting, WorldEffects(), cells, settings.transfers),
            **{a.label: alone for a, alone in zip(alternatives, each)},
            OPEN_MIXED: mixed,
        }
        if explanation is None:  # the fit cells reject the default world and nothing named explains them
            predictions = mixed
    after = {key: p.at_best for key, p in predictions.items()}
    remaining = locate(fit_cells, after) if verdict.named else []
    return Diagnosis(
        outcomes,
        settings,
        fit_cells,
        held_out,
        before,
        rows,
        verdict,
        predictions,
        predicted_by,
        remaining,
        time.monotonic() - started,
        counting.simulated,
        unreplicated,
        tuple(alternatives),
        resolved,
    )


def _alternatives(
    mapper: Mapper,
    verdict: Verdict,
    fit_cells: Sequence[Cell],
    held_out: Sequence[Cell],
    settings: Settings,
    informative: int,
) -> list[Alternative]:
    """The effects the fit cells leave open on top of the world that explains them (`Verdict.explanation`;
    the default world if none does) that change a held-out cell's simulated counts."""
    last = verdict.explanation
    base = last.world() if last is not None else WorldEffects()
    before = last.per_cell[last.best] if last is not None else verdict.null
    allowed = open_effects(
        mapper, base, before, fit_cells, settings.transfers, settings.points, informative, settings.phases
    )
    return changes_held_out(mapper, base, allowed, held_out, settings.transfers, PREDICT_SEED)


def _replicated(
    mapper: Mapper,
    verdict: Verdict,
    cells: Sequence[Cell],
    settings: Settings,
    progress: Callable[[str], None] | None,
) -> tuple[Verdict, tuple[str, ...]]:
    """The named and tied effects whose gain holds on simulations the choice never saw. The fit picks the
    best of every candidate's grid on the same simulated transfers, so its likelihood ratio is biased
    upwards by the pick (most where an effect only reshuffles chaotic outcomes, as a registration offset
    does). Each is simulated again at its fitted value on fresh seeds beside the world before it (the
    default world, or for a second effect the first), `located` transfers per fit cell each, and kept only
    if it still fits the fit cells better beyond chance (the same χ² test). A named effect that fails takes
    those named after it along. Of two effects named so, one after the other, the first must also earn its
    place beside the second (`_paired`). A tie of which none holds is dropped, which leaves nothing
    explained; one of which some hold is kept whole for `_resolved`, which names a world only where it leads
    the others by `TIE` and itself held: that one passes this test and another just misses it says nothing
    of which fits better (their gains may differ by a tenth of a log unit)."""
    worlds = [WorldEffects(), *(p.world() for p in (*verdict.named, *verdict.tied))]
    if len(worlds) > 1:  # one batch: each transfer's arm simulated once for every world (`bench.Replay`)
        simulate_cells(mapper, worlds, [c.key for c in cells], settings.located, first_seed=FRESH_SEED)
    kept: list[Profile] = []
    dropped: list[str] = []
    base = WorldEffects()
    for fitted in verdict.named:
        if not dropped and _holds(mapper, base, fitted, cells, settings, progress):
            kept.append(fitted)
            base = fitted.world()
        else:
            dropped.append(fitted.candidate.name)
    named, stood_in = _paired(mapper, verdict, kept, cells, settings, progress)
    dropped += stood_in
    held = [t for t in verdict.tied if _holds(mapper, WorldEffects(), t, cells, settings, progress)]
    tied = verdict.tied if held else ()
    dropped += [t.candidate.name for t in verdict.tied if not held]
    if not dropped:
        return verdict, ()
    unchecked = verdict.unchecked and bool(tied)
    return replace(verdict, named=named, tied=tied, unchecked=unchecked), tuple(dropped)


def _paired(
    mapper: Mapper,
    verdict: Verdict,
    path: Sequence[Profile],
    cells: Sequence[Cell],
    settings: Settings,
    progress: Callable[[str], None] | None,
) -> tuple[tuple[Profile, ...], tuple[str, ...]]:
    """What is named of `path` (effects in the order the fit added them), and the effect dropped from it.
    Of two, the first is kept only if the pair also fits better than the second alone on fresh seeds: the
    first was chosen before the second was in the world, so an effect that only stood in for it (a
    registration offset beside a bending peg) is dropped, and the second is named at the value it was
    fitted alone (`verdict.tried`) if that, too, holds on fresh seeds against the default world: it may
    never have passed alone, and nothing is named unreplicated (else neither is named). Named and tied
    paths alike: a tie does not make the first earn its place."""
    if len(path) != 2 or _holds(
        mapper, _without(path[-1].world(), path[0]), path[-1], cells, settings, progress
    ):
        return tuple(path), ()
    alone = next((p for p in verdict.tried if p.candidate.name == path[-1].candidate.name), None)
    if alone is None:
        return tuple(path), ()
    if not _holds(mapper, WorldEffects(), alone, cells, settings, progress):
        return (), (path[0].candidate.name, alone.candidate.name)
    return (alone,), (path[0].candidate.name,)


def _resolved(
    mapper: Mapper,
    verdict: Verdict,
    cells: Sequence[Cell],
    settings: Settings,
    progress: Callable[[str], None] | None = None,
) -> tuple[Verdict, str, tuple[str, ...]]:
    """A tie weighed again where only the real counts can leave it: each tied world simulated on fresh seeds,
    `TIE_DRAWS` times as many transfers a fit cell as the largest real fit cell holds. The fit's tie is
    read on a few dozen simulated transfers a world, whose own noise can hide a difference the real counts
    show (the benchmark's yielding grip, tied at 0.6 log units on 46, led a bending peg by 1.7 and 1.9 on two
    sets of 400); with the simulated side more precise than the real one, worlds still within `TIE` are ones
    the data cannot tell apart. One that leads the others by `TIE` or more, and held on fresh seeds against
    the default world (`_replicated`, whose simulations it reads again), stands alone: named, or the one
    explanation if `unchecked`; a named two-effect path is checked as a pair (`_paired`), and what that drops
    is returned with the verdict and what is said of the tie."""
    if len(verdict.tied) < 2:
        return verdict, "", ()
    size = TIE_DRAWS * as_precise(settings, cells)
    keys = [c.key for c in cells]
    sims = simulate_cells(mapper, [t.world() for t in verdict.tied], keys, size, first_seed=TIE_SEED)
    scores = [sum(log_likelihood(c, sim[c.key], settings.phases) for c in cells) for sim in sims]
    order = sorted(range(len(scores)), key=lambda i: -scores[i])
    lead = scores[order[0]] - scores[order[1]]
    best = verdict.tied[order[0]]
    said = (
        f"on {size} fresh simulated transfers a fit cell {best.label} leads {verdict.tied[order[1]].label} by "
        f"{lead:.1f} log units"
    )
    if lead < TIE:
        return verdict, f"The tie stands: {said} (within {TIE:g}).", ()
    if not _holds(mapper, WorldEffects(), best, cells, settings, None):
        return verdict, f"The tie stands: {said}, but did not hold on fresh seeds.", ()
    if verdict.unchecked:
        return replace(verdict, tied=(best,)), f"The tie is decided: {said}.", ()
    named, stood_in = _paired(mapper, verdict, verdict.path_of(best), cells, settings, progress)
    held = "" if named else ", but no effect of its path holds alone on fresh seeds"
    return replace(verdict, named=named, tied=()), f"The tie is decided: {said}{held}.", stood_in


def as_precise(settings: Settings, cells: Sequence[Cell]) -> int:
    """Simulated transfers a fit cell where worlds are told apart on fresh seeds (the fit's ranking of
    the additions that pass; a tie weighed again, `TIE_DRAWS` times this): as many as the largest real fit
    cell holds, at least
    `located`. On fewer, the simulated side's own noise decides: the benchmark's yielding grip, ahead of a
    0.18 mm bend by 0.3 log units on the fit's seeds, trailed it by 1.1 on 183 fresh transfers a cell
    beside 456 real ones, and so was never followed as a tie (grip seed 1)."""
    return max(settings.located, max(c.attempted for c in cells))


def _without(world: WorldEffects, named: Profile) -> WorldEffects:
    """`world` less the effect `named` fitted."""
    return WorldEffects.of({e.kind: dict(e.values) for e in world if e.kind != named.candidate.kind})


def _holds(
    mapper: Mapper,
    base: WorldEffects,
    fitted: Profile,
    cells: Sequence[Cell],
    settings: Settings,
    progress: Callable[[str], None] | None,
) -> bool:
    """Whether `fitted`'s world fits `cells` better than `base` beyond chance on fresh seeds."""
    keys = [c.key for c in cells]
    sims = simulate_cells(mapper, [base, fitted.world()], keys, settings.located, first_seed=FRESH_SEED)
    before, after = (sum(log_likelihood(c, sim[c.key], settings.phases) for c in cells) for sim in sims)
    holds = 2 * (after - before) >= LR_95
    if progress is not None:
        progress(
            f"{fitted.candidate.name} = {fitted.value:.4g} on fresh seeds: {after - before:+.1f} log units "
            f"(needs {LR_95 / 2:.1f}): {'holds' if holds else 'not named'}"
        )
    return holds


def _located(
    mapper: Mapper, cells: Sequence[Cell], fit_cells: Sequence[Cell], settings: Settings
) -> dict[Key, SimCounts]:
    """The default world's transfers per cell: `transfers` each, every fit cell `located`. Whether a fit
    cell's real rate is near the default world's cannot be judged on `transfers` alone (at 816 real, 82
    simulated transfers put a 7.7 % rate at 11 %, beside the chamfers' real 11.8 %, and a judge of nearness
    on them kept the gate shut), and locating a fit cell costs little beside one fit."""
    keys = [c.key for c in cells]
    before = simulate_cells(mapper, [WorldEffects()], keys, settings.transfers)[0]
    extra = settings.located - settings.transfers
    if extra > 0:
        fit_keys = [c.key for c in fit_cells]
        more = simulate_cells(mapper, [WorldEffects()], fit_keys, extra, first_seed=settings.transfers)[0]
        for key, counts in more.items():
            before[key].merge(counts)
    return before


def _null(cells: Sequence[Cell], before: dict[Key, SimCounts], phases: bool) -> np.ndarray:
    return np.array([log_likelihood(c, before[c.key], phases) for c in cells])


def profile_parameters(fitted: Profile) -> tuple[dict[str, float], dict[str, list[float]]]:
    """The fitted effect's parameters (all, defaults filled in; the fitted one at its estimate) and the
    interval of the one fitted."""
    effect = next(e for e in fitted.estimated_world() if e.kind == fitted.candidate.kind)
    low, high = fitted.interval()
    return dict(effect.values), {fitted.candidate.parameter: [low, high]}
