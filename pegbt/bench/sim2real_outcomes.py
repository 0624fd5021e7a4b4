"""`pegbt bench sim2real-outcomes`: does the task-level tool find world effects it was not told about?

Per family (each world effect alone, two together, none) and seed, "real" outcomes are made by the phase
simulator in a world with the family's concealed effects, on seeds the fit never uses, with the phase of
each failure (what tick logs give); `pegbt sim2real outcomes` then fits them on the unilateral cells and
predicts the bilateral and handover cells. Figures per family: how often every concealed effect is named
(naming rate), how often something else is (false discoveries), how often they were held in a tie
instead (the report naming neither of worlds the data could not tell apart: why a naming rate falls short),
the median relative error of the fitted parameters (read from the profile between grid values,
`fit.estimate`), and the share of held-out cells inside their 95 % predictive interval.

The size of each family's "real" campaign is fixed before any diagnosis runs, by the power of the test
that could see its world, not by what the tool names. A pilot (`pilot`, `shifts`) simulates, in the fit
cells, what each concealed effect alone changes against the default world; from it, `detectable_at` is the
fewest real transfers a fit cell at which the gate's own test sees one of its changes nine times in ten
(`outcomes_power.POWER`, the naming rate the goal asks for; at 0.9 a family meets 5 of 5 seeds only about
59 % of the time), each change tested at α over the testable rows of its family, placed or phase, as the
gate counts them (`outcomes_power`), the simulated side growing with it in the ratio of the diagnosis's
`located` to 120 real. The pilot is sequential: a size is only trusted when read from at least as many
paired transfers as it sets. The family's fit cells then get the smallest whole number of 12-transfer
trials at least the concealed campaign's 120 transfers and at least every one of its effects'
`detectable_at` (`fit_size`); its held-out cells keep 120, the concealed campaign's size, since they test
the predictions. A naming rate at 120 alone measured the sample: three of the realistic concealed values
change a fit cell by less than 120 transfers resolve. A family whose effects change no fit cell at any
size (`detectable_at` "never"), or need more than a seed's block of real transfers (too large), is kept
at 120 and scored as a further null: its naming rate is not applicable ("n/a": no campaign here can show
what it changes), its false discoveries count. The diagnosis's own simulated side grows with
the largest real fit cell (`Settings.for_campaign`). The sizes are fixed before any diagnosis, from the
worlds' own changes and the gate's stated test: design, not tuning.
"""

from __future__ import annotations

import math
import resource
import statistics
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.bench.outcomes_power import Change, detectability, detectable_at, surely_beyond
from pegbt.bench.outcomes_records import Records, StoredMemo, code_identity, simulator_identity
from pegbt.errors import PegbtError
from pegbt.runconditions import VARIANTS
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cache import MemoMapper
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import FRESH_SEED, Diagnosis, Settings, diagnose
from pegbt.sim2real.outcomes.fit import Profile
from pegbt.sim2real.outcomes.simulate import CATEGORIES, Mapper, category_of, simulate_cells
from pegbt.sim2real.outcomes.workers import ClusterMapper, LocalMapper

if TYPE_CHECKING:
    from pegbt.evaluation.cluster import ClusterTls

# Every concealed value lies between the fit's coarse grid values (`SETTINGS.points`; `fit.candidates`), so a
# parameter error measures the estimate the refined profile gives (`fit.refined`), not a grid that happens
# to hold the truth.
FAMILIES: dict[str, dict[str, dict[str, float]]] = {
    "peg_compliance": {"peg_compliance": {"deflection": 0.0012}},
    "chamfer_capture": {"chamfer_capture": {"capture_radius": 0.0032}},
    "grip_compliance": {"grip_compliance": {"displacement": 0.0012}},
    "registration_offset": {"registration_offset": {"x": 0.002}},
    # The lobes of the paper's block model (its registry source), 0.3 mm short: a printed hole comes out small.
    "hole_lobes": {"hole_lobes": {"lobe_radius": 0.0042}},
    # Each remaining registered effect alone, at a value its registry source (`pegbt sim2real outcomes
    # --effects`) gives a real set-up, not one picked to be found.
    # The wrist's cable deflection under load, 1.2-2.0 mm on the 9.5 mm jaw: its middle.
    "grasp_capture": {"grasp_capture": {"width": 0.0016}},
    # The jaw tip's rounding, about 0.5 mm, and a printed wall's edge rounding, 0.2-0.4 mm, added.
    "jaw_tip_slide": {"jaw_tip_slide": {"width": 0.0008}},
    # Structured-light depth on translucent plastic: about 1 mm at 0.55 m.
    "depth_bias": {"depth_bias": {"bias": 0.001}},
    # A cloud's registration error a look: 0.3 mm, the camera's depth noise at one point, what the phase
    # simulator once took for the paper's robot's perception (its registry source).
    "perception_noise": {"perception_noise": {"sd": 0.0003}},
    # No source measures the grip's friction; the registry's one figure is the block's 0.020 N weight.
    # 0.2 N, ten times it, is a light grip (`max_load`: the parameter the fit searches). With a rigid peg the
    # grip's only load is that weight as the tip accelerates, so a grip that carries blocks at all is seldom
    # beaten: alone, this effect tests false discoveries as the null does, which its detectability shows.
    "jaw_friction": {"jaw_friction": {"max_load": 0.2}},
    "peg_and_chamfer": {
        "peg_compliance": {"deflection": 0.0012},
        "chamfer_capture": {"capture_radius": 0.0032},
    },
    "null": {},
}
CELLS = [(v, c) for v in VARIANTS for c in ("uncalibrated", "calibrated")]
SEEDS = 5
REAL_TRANSFERS = 120  # "real" transfers per cell at least: the concealed campaign's 10 trials × 12 transfers
TRIAL = 12  # transfers in one trial: a fit cell's size is a whole number of them
SETTINGS = Settings(fit="unilateral", transfers=12, points=4)
REAL_SEED = 100_000  # the real runs' seeds start here, far from the fit's
SEED_BLOCK = 10_000  # each seed's real transfers: a block of seeds larger than any family's campaign
# The last seed whose real transfers stay below the diagnosis's fresh seeds (`FRESH_SEED`, then `RANK_SEED`
# and `TIE_SEED`): beyond it the replication would simulate the "real" outcomes' own random numbers.
LAST_SEED = (FRESH_SEED - REAL_SEED) // SEED_BLOCK - 1
NOT_APPLICABLE = "n/a"  # the naming rate of a family whose world changes no fit cell at any size


def concealed_outcomes(
    mapper: Mapper,
    hidden: Sequence[WorldEffects],
    seed: int,
    fit_transfers: int,
    held_out: int,
    fit: str = SETTINGS.fit,
) -> list[Outcomes]:
    """Cells in each of the `hidden` worlds, with the phase of each failure: `fit_transfers` transfers in
    each fit cell, `held_out` in the others (one batch per size: each transfer's arm simulated once for
    every world). `fit` names the fit cells, as `Settings.fit` does."""
    if max(fit_transfers, held_out) > SEED_BLOCK:
        raise PegbtError(
            f"at most {SEED_BLOCK} real transfers a cell, got {max(fit_transfers, held_out)}", field="size"
        )
    first = REAL_SEED + SEED_BLOCK * seed
    fit_keys = [key for key in CELLS if _fitted(key, fit)]
    other = [key for key in CELLS if not _fitted(key, fit)]
    fits = simulate_cells(mapper, list(hidden), fit_keys, fit_transfers, first_seed=first)
    rest = simulate_cells(mapper, list(hidden), other, held_out, first_seed=first)
    return [
        Outcomes(
            tuple(
                Cell(
                    v,
                    c,
                    s.attempted,
                    s.succeeded,
                    s.seconds,
                    {k: s.counts[k] for k in CATEGORIES[1:] if s.counts[k]},
                )
                for (v, c), s in ((key, sim[key]) for key in CELLS)
            ),
            f"concealed world, seed {seed}",
        )
        for sim in ({**a, **b} for a, b in zip(fits, rest))
    ]


def _fitted(key: tuple[str, str], fit: str) -> bool:
    """Whether a diagnosis fitting on `fit` (`Settings.fit`: all, a variant or a condition) sees cell `key`."""
    return fit in ("all", *key)


World = Mapping[str, Mapping[str, float]]  # concealed effects: kind → parameter → value


def shifts(
    mapper: Mapper, worlds: Mapping[str, World], settings: Settings, transfers: int | None = None
) -> dict[str, list[Change]]:
    """Per named world of concealed effects (a family's, or one effect's alone), what it changes in each
    fit cell: for the share of transfers placed and of those failed first in each phase, a `Change`. On
    the phase simulator, `transfers` a cell (by default `settings.located`) on the seeds the default world
    is located on, so the two worlds share their random numbers and the change is the effect's; the pairs
    that differ in a row (`Change.discordant`) say how precisely it is read."""
    hidden = {name: WorldEffects.of(effects) for name, effects in worlds.items() if effects}
    keys = [key for key in CELLS if _fitted(key, settings.fit)]
    run = [WorldEffects(), *dict.fromkeys(hidden.values())]  # a pair's effect alone is also its own family's
    n = settings.located if transfers is None else transfers
    results = mapper(
        [(tuple(run), variant, condition, seed) for variant, condition in keys for seed in range(n)]
    )
    out = {}
    for name, world in hidden.items():
        w, changes = run.index(world), []
        for k in range(len(keys)):
            pairs = [(category_of(r[0]), category_of(r[w])) for r in results[k * n : (k + 1) * n]]
            pairs = [(old, new) for old, new in pairs if old is not None and new is not None]
            for category in CATEGORIES:
                a = sum(new == category for _, new in pairs) / len(pairs)
                b = sum(old == category for old, _ in pairs) / len(pairs)
                apart = sum((old == category) != (new == category) for old, new in pairs) / len(pairs)
                changes.append(Change(category == CATEGORIES[0], (a + b) / 2, a - b, apart))
        out[name] = changes
    return out


@dataclass(frozen=True)
class Reading:
    """What one concealed world changes in the fit cells (`shifts`), read from `transfers` paired
    transfers a cell."""

    changes: list[Change]
    transfers: int


def pilot(
    mapper: Mapper, worlds: Mapping[str, World], settings: Settings, cap: int = SEED_BLOCK
) -> dict[str, Reading]:
    """Each world's `Reading`, read until the size it sets is read from at least as many paired transfers.

    A change in a category of a few per cent read from n paired transfers carries noise of about what n
    real transfers resolve, so the `detectable_at` it gives is only trusted up to n (depth bias's grasp
    failures, 2 → 0 of 48, ask for 432; 54 → 18 of 1,152 for 1,141). So the pilot starts at
    `settings.located` a cell; each world whose `detectable_at` exceeds the transfers it was read from is
    read again from that many, in whole trials (the same seeds grown, so
    the memo keeps what is already simulated), until it is read from at least as many as it asks for or
    from `cap` (then `detectable_at` above `cap` says the family is too large for the benchmark), or until
    even the far end of each change's 95 % interval asks for more than `cap` (`surely_beyond`): then it is
    too large with 95 % confidence, and reading it at `cap` (grasp capture and jaw tip slide, 53,000 paired
    transfers) would only confirm it. A world that changes no transfer of its reading is read once more at the largest size the pilot reaches, where
    the default world is already simulated: no change in n paired transfers bounds a change only to about
    3/n. The rule uses the worlds' own changes, never a diagnosis."""
    out: dict[str, Reading] = {}
    todo = {name: settings.located for name, effects in worlds.items() if effects}
    rechecked = False
    while todo:
        following: dict[str, int] = {}
        for size in sorted(set(todo.values())):
            group = [name for name, n in todo.items() if n == size]
            read = shifts(mapper, {name: worlds[name] for name in group}, settings, size)
            for name in group:
                out[name] = Reading(read[name], size)
                needed = detectable_at(read[name], settings.real, settings.located)
                if (
                    needed is not None
                    and size < needed
                    and size < cap
                    and not surely_beyond(read[name], size, cap, settings.real, settings.located)
                ):
                    following[name] = min(cap, TRIAL * math.ceil(needed / TRIAL))
        largest = max(r.transfers for r in out.values())
        if not following and not rechecked:
            rechecked = True
            following = {
                name: largest
                for name, r in out.items()
                if r.transfers < largest and detectable_at(r.changes, settings.real, settings.located) is None
            }
        todo = following
    return out


def alone(families: Sequence[str]) -> dict[str, dict[str, dict[str, float]]]:
    """Each concealed effect of `families` alone at its concealed values, named `family:kind`."""
    return {f"{f}:{kind}": {kind: dict(values)} for f in families for kind, values in FAMILIES[f].items()}


def fit_size(needed: Sequence[int | None], least: int = REAL_TRANSFERS) -> int:
    """The real transfers of a family's fit cells: the smallest whole number of trials at least `least`
    and at least each of its effects' `detectable_at` (`needed`; None, an effect no size shows, asks for
    nothing more)."""
    return TRIAL * math.ceil(max([least, *(n for n in needed if n is not None)]) / TRIAL)


PLAN_FIELDS = ("detectability", "detectable_at", "size", "read_from")


@dataclass(frozen=True)
class Plan:
    """A family's campaign, fixed from the pilot before any diagnosis: its weakest effect's
    `detectability` at `least` real transfers, the size at which every effect it conceals that shows at
    all is detectable (None: none shows at any size, so naming it is not applicable), the real transfers of
    its fit cells (`fit_size`), and the most paired transfers a cell the pilot read its effects from."""

    detectability: float
    detectable_at: int | None
    size: int
    read_from: int = 0

    @property
    def too_large(self) -> bool:
        """Whether an effect needs more real transfers a cell than a seed's block holds: no campaign of the
        benchmark shows it, so naming it is not applicable either."""
        return self.detectable_at is not None and self.detectable_at > SEED_BLOCK

    @property
    def applicable(self) -> bool:
        return self.detectable_at is not None and not self.too_large


def plan(mapper: Mapper, families: Sequence[str], least: int, settings: Settings) -> dict[str, Plan]:
    """Each family's `Plan`, from what each of its concealed effects alone changes in the fit cells
    (`pilot`): its detectability with the diagnosis's `settings.located` simulated transfers against
    `least` real ones, and the sizes at which they show with the simulated side growing as the
    diagnosis grows it (`settings.located` per `settings.real` real transfers)."""
    readings = pilot(mapper, alone(families), settings)
    out = {}
    for family in families:
        read = [readings[f"{family}:{kind}"] for kind in FAMILIES[family]]
        needed = [detectable_at(r.changes, settings.real, settings.located) for r in read]
        shown = [n for n in needed if n is not None]
        out[family] = Plan(
            min((detectability(r.changes, least, settings.located) for r in read), default=0.0),
            max(shown) if shown else None,
            fit_size([n if n is not None and n <= SEED_BLOCK else None for n in needed], least),
            max((r.transfers for r in read), default=0),
        )
    return out


def score(d: Diagnosis, hidden: Mapping[str, Mapping[str, float]]) -> dict[str, float]:
    """Whether every concealed kind was named, whether another was, whether they were instead one of the
    tied worlds the report names neither of (`tied`), the estimates' relative errors (median), whether
    each concealed parameter was resolved as the goal asks (within ± 30 %, or an interval no wider than
    ± 50 % that holds it), and the share of held-out cells inside their predictive intervals."""
    named = {p.candidate.kind: p for p in d.verdict.named}
    ties = [{p.candidate.kind for p in d.verdict.path_of(end)} for end in d.verdict.tied]
    errors, resolved = [], []
    for kind, p in named.items():
        truth = hidden.get(kind, {}).get(p.candidate.parameter)
        if truth is None:
            continue
        low, high = p.interval()
        errors.append(abs(p.estimate - truth) / abs(truth))
        tight = low <= truth <= high and (high - low) / 2 <= 0.5 * abs(truth)
        resolved.append(errors[-1] <= 0.3 or tight)
    inside = [d.predictions[c.key].inside for c in d.held_out]
    return {
        "named": float(bool(hidden) and set(hidden) <= set(named)),
        "false": float(bool(set(named) - set(hidden))),
        "tied": float(bool(hidden) and not set(hidden) <= set(named) and any(set(hidden) <= t for t in ties)),
        "error": statistics.median(errors) if errors else float("nan"),
        "resolved": float(set(hidden) <= set(named) and all(resolved)) if hidden else float("nan"),
        "inside": sum(inside) / len(inside) if inside else float("nan"),
    }


def measure(
    families: Sequence[str],
    seeds: int,
    real_transfers: int,
    settings: Settings,
    workers: int = 2,
    simulator: Mapper | None = None,
    records: Records | None = None,
    first_seed: int = 0,
) -> dict[str, float | int | str]:
    """The figures of `families` over `seeds` seeds each from `first_seed` on, simulated by `simulator`
    (by default the phase simulator in `workers` local processes). One memo of simulated transfers serves every diagnosis
    (`cache.MemoMapper`): their fits simulate the same worlds on the same seeds. With `records`, the plan,
    each score and each simulated transfer are kept as they come (`StoredMemo`), and those already kept are
    read back, not simulated again."""
    pool = None
    if simulator is None:
        pool = simulator = LocalMapper(workers)
    memo = (
        MemoMapper(simulator)
        if records is None
        else StoredMemo(simulator, records.path.parent, simulator_identity())
    )
    figures: dict[str, float | int | str] = {}
    started, cpu = time.monotonic(), _cpu_seconds()
    scores: dict[str, list[dict[str, float]]] = {family: [] for family in families}
    needed = 0
    try:
        plans, figures["pilot_transfers_simulated"] = _planned(
            memo, families, real_transfers, settings, records
        )
        for family in families:
            p = plans[family]
            figures[f"{family}_real_transfers_per_fit_cell"] = p.size
            grown = settings.for_campaign(p.size)  # what its diagnoses simulate (`diagnose`)
            figures[f"{family}_simulated_transfers_per_fit_cell"] = grown.transfers
            figures[f"{family}_located_transfers_per_fit_cell"] = grown.located
            if FAMILIES[family]:
                figures[f"{family}_detectability"] = p.detectability
                figures[f"{family}_detectable_at"] = "never" if p.detectable_at is None else p.detectable_at
                figures[f"{family}_pilot_transfers_per_fit_cell"] = p.read_from
                figures[f"{family}_too_large"] = str(p.too_large).lower()
                print(
                    f"{family}: detectability {p.detectability:.2f} at {real_transfers} (1 or more: "
                    f"detectable), read from {p.read_from} paired transfers a fit cell, "
                    + (
                        f"from {p.detectable_at} real transfers a fit cell; fit cells of {p.size}"
                        if p.applicable
                        else f"beyond the {SEED_BLOCK} of a seed's block, too large; fit cells of {p.size}, "
                        "naming n/a"
                        if p.too_large
                        else f"at no size: it changes no fit cell; fit cells of {p.size}, naming n/a"
                    ),
                    file=sys.stderr,
                    flush=True,
                )
        for seed in range(first_seed, first_seed + seeds):
            kept = {f: records.scores[(f, seed)] for f in families if records and (f, seed) in records.scores}
            for family, record in kept.items():
                needed += record["simulated"]
                scores[family].append(record["score"])
            missing = [f for f in families if f not in kept]
            real: dict[str, Outcomes] = {}
            for size in sorted({plans[f].size for f in missing}):
                group = [f for f in missing if plans[f].size == size]
                worlds = [WorldEffects.of(FAMILIES[f]) for f in group]
                real.update(
                    zip(group, concealed_outcomes(memo, worlds, seed, size, real_transfers, settings.fit))
                )
            for family in missing:
                before = memo.simulated
                d = diagnose(real[family], settings, memo)
                needed += d.simulated
                scores[family].append(score(d, FAMILIES[family]))
                if records:
                    records.save_score(family, seed, scores[family][-1], d.simulated)
                print(
                    f"{family} seed {seed}: named {', '.join(map(_named, d.verdict.named)) or 'nothing'} "
                    f"{scores[family][-1]}; {plans[family].size} real transfers a fit cell, "
                    f"{d.settings.transfers} simulated a world, {d.settings.located} located; "
                    f"{d.simulated} transfers needed, {memo.simulated - before} simulated, {d.seconds:.0f} s "
                    f"({time.monotonic() - started:.0f} s in all)",
                    file=sys.stderr,
                    flush=True,
                )
    finally:
        if pool is not None:
            pool.close()
    for family in families:
        for name in ("named", "false", "inside"):
            figures[f"{family}_{name}"] = statistics.mean(s[name] for s in scores[family])
        errors = [s["error"] for s in scores[family] if s["error"] == s["error"]]
        figures[f"{family}_parameter_error_median"] = statistics.median(errors) if errors else "none named"
        if FAMILIES[family]:
            figures[f"{family}_resolved"] = statistics.mean(s["resolved"] for s in scores[family])
            figures[f"{family}_tied"] = statistics.mean(s["tied"] for s in scores[family])
        if not plans[family].applicable:
            figures[f"{family}_named"] = figures[f"{family}_resolved"] = NOT_APPLICABLE
    figures["seeds_per_family"] = seeds
    figures["seed_range"] = f"{first_seed}-{first_seed + seeds - 1}"
    figures["real_transfers_per_cell"] = real_transfers  # held-out cells; fit cells: per family
    figures["simulated_transfers_per_cell"] = settings.transfers  # at 120 real; fit cells: per family
    figures["transfers_the_diagnoses_simulate"] = needed
    figures["transfers_simulated"] = memo.simulated
    figures["wall_s"] = time.monotonic() - started
    figures["cpu_s"] = _cpu_seconds() - cpu  # this process's and its local workers' (ended, so counted)
    return figures


def _planned(
    memo: MemoMapper, families: Sequence[str], least: int, settings: Settings, records: Records | None
) -> tuple[dict[str, Plan], int]:
    """Each family's `Plan` and the transfers its pilot simulated: kept in `records` if it holds them,
    else from `plan` (and kept there)."""
    if records and records.plan:
        kept = records.plan["plans"]
        return {f: Plan(**{k: kept[f][k] for k in PLAN_FIELDS}) for f in families}, records.plan[
            "pilot_transfers"
        ]
    before = memo.simulated
    plans = plan(memo, families, least, settings)
    simulated = memo.simulated - before
    if records:
        records.save_plan({f: {**asdict(p), "too_large": p.too_large} for f, p in plans.items()}, simulated)
    return plans, simulated


def _named(fitted: Profile) -> str:
    """A named effect as the progress line gives it: its estimate and interval."""
    low, high = fitted.interval()
    return f"{fitted.label} ({fitted.candidate.parameter} {fitted.estimate:.4g}, 95 % {low:.4g}–{high:.4g})"


def _cpu_seconds() -> float:
    """CPU seconds of this process and of its ended children (the worker pool, once closed)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def run(
    seeds: int = SEEDS,
    families: Sequence[str] | None = None,
    out: str | None = None,
    first_seed: int = 0,
    workers: int = 2,
    cluster: str | None = None,
    tls: ClusterTls | None = None,
) -> dict[str, float | int | str]:
    """The benchmark at the goal's size by default (every family, `SEEDS` seeds); `seeds` and `families`
    (`pegbt bench sim2real-outcomes --seeds N --families A,B`) run a reduced one, named in its figures.
    `first_seed` (`--first-seed K`) runs seeds K to K + N - 1: a run longer than a session split over
    sessions or machines, each seed's "real" transfers the same wherever it runs. With `out` (`--out DIR`)
    the run keeps its plan and scores there and resumes from them (`outcomes_records`). It simulates in
    `workers` local processes (`--workers`), or on the Dask scheduler at `cluster` (`--cluster`, with the
    certificates `tls` for a `tls://` address)."""
    chosen = list(FAMILIES) if families is None else list(families)
    unknown = [f for f in chosen if f not in FAMILIES]
    if unknown or not chosen:
        raise PegbtError(
            f"unknown families {', '.join(unknown) or '(none given)'}; known: {', '.join(FAMILIES)}",
            field="--families",
        )
    if seeds < 1:
        raise PegbtError(f"expected at least 1 seed, got {seeds}", field="--seeds")
    if first_seed < 0:
        raise PegbtError(f"expected a seed of 0 or more, got {first_seed}", field="--first-seed")
    if first_seed + seeds - 1 > LAST_SEED:
        raise PegbtError(
            f"seeds run to {first_seed + seeds - 1}, beyond {LAST_SEED}: a later seed's real transfers would be "
            "simulated on the seeds the diagnosis replicates its fit on",
            field="--first-seed",
        )
    if workers < 1:
        raise PegbtError(f"expected at least 1 worker, got {workers}", field="--workers")
    records = None if out is None else Records(Path(out), chosen, code_identity())
    cluster_mapper = None if cluster is None else ClusterMapper(cluster, tls=tls)
    try:
        figures = measure(
            chosen,
            seeds,
            REAL_TRANSFERS,
            SETTINGS,
            workers,
            cluster_mapper,
            records=records,
            first_seed=first_seed,
        )
    finally:
        if cluster_mapper is not None:
            cluster_mapper.close()
    figures["workers"] = cluster or workers
    if cluster is not None:
        figures["cpu_s"] = "n/a"  # the cluster's workers' CPU is not this machine's to count
    figures["families"] = ",".join(chosen)
    figures["full_size"] = str(seeds >= SEEDS and set(chosen) == set(FAMILIES)).lower()
    return figures
