"""Diagnose a recording against the simulator's arm physics: locate, explain, fit, and score held out.

The recording's commands are replayed through `pegbt.physics.ArmPhysics` (the model the simulator
endpoint runs, ideal unless told otherwise), the residual real − sim is located, the missing effects
are chosen by `select`, fitted by `fit`, and merged into the model. The held-out RMSE after is measured
by re-fitting the chosen effects on the training folds and replaying the *merged physics model* (not
the linearised fit) over each held-out segment, so the figure is what the simulator would reproduce.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.faults import MeasurementFaults, detect_faults
from pegbt.physics.model import REPLAY_ROWS
from pegbt.physics.recording import Recording, Sampling, validate
from pegbt.psm import JOINT_NAMES
from pegbt.scratch import scratch, scratch_rows
from pegbt.sim2real.crossval import BlockedGrams, fold_ranges
from pegbt.sim2real.explain import effect_sentence, remaining_sentence, rival_sentence
from pegbt.sim2real.fit import (
    JointFit,
    Term,
    bootstrap,
    fit_joint,
    merged_physics,
    settle_backlash,
    to_effects,
)
from pegbt.sim2real.geometry import (
    GeometryCheck,
    check_geometry,
    displacement_removal,
    is_arm_zero,
)
from pegbt.sim2real.library import build_columns
from pegbt.sim2real.locate import JointMismatch, locate
from pegbt.sim2real.practical import BelowResolution, settle_joint
from pegbt.sim2real.select import JointSelection, Unidentifiable, find_unidentifiable, select

Array = NDArray[np.float64]

N_BOOTSTRAP = 100


@dataclass(frozen=True)
class NamedEffect:
    """An effect the diagnosis names, with its evidence and a sentence for a person."""

    effect: Effect
    ci: dict[str, tuple[float, float]]
    explains: float  # share of the joint's held-out error before any effect (greedy order)
    pvalue: float
    text: str
    contribution: float = 0.0  # held-out RMS it removes, in the joint's units

    def to_dict(self) -> dict:
        return {
            **self.effect.to_dict(),
            "ci": {k: list(v) for k, v in self.ci.items()},
            "explains": self.explains,
            "contribution": self.contribution,
            "p_value": self.pvalue,
            "text": self.text,
        }


@dataclass
class Diagnosis:
    recording: Recording
    sim: str
    arm: str
    sampling: Sampling
    base: ArmPhysics
    simulated: Array
    mismatch: list[JointMismatch]
    selections: list[JointSelection]
    fits: list[JointFit]
    effects: list[NamedEffect]  # the cable effects named, in order of what they contribute
    physics: ArmPhysics
    heldout_prediction: Array
    fold_ranges: list[tuple[int, int]]
    not_identifiable: list[str]
    hypotheses: int
    below_resolution: list[BelowResolution]
    resolution: tuple[float, ...] | None
    faults: MeasurementFaults  # over the whole recording; `recording` holds the kept samples
    times_before_exclusion: Array
    fold_named: list[list[str]]  # the effects each nested training part named, per held-out segment
    geometry: GeometryCheck | None = None  # q1–q3 moving as one displacement of the tool, if they do
    zero_offsets: list[NamedEffect] = field(default_factory=list)  # constant offsets on q1–q3: geometry

    @property
    def residual_before(self) -> Array:
        return np.subtract(self.recording.q_phy, self.simulated, out=scratch(self.simulated.shape))

    @property
    def residual_after(self) -> Array:
        return np.subtract(self.recording.q_phy, self.heldout_prediction, out=scratch(self.simulated.shape))

    def rmse_before(self) -> dict[str, float]:
        return dict(zip(JOINT_NAMES, rms(self.residual_before).tolist()))

    def rmse_after(self) -> dict[str, float]:
        return dict(zip(JOINT_NAMES, rms(self.residual_after).tolist()))

    def remaining(self) -> list[str]:
        after_located = locate(
            self.residual_after, self.recording.q_cmd, self.recording.times, self.sampling.is_stream
        )
        before, after = self.rmse_before(), self.rmse_after()
        unit = "s" if self.recording.t is not None else "samples"
        return [remaining_sentence(m, after[m.joint], before[m.joint], unit) for m in after_located]


def rms(values: Array) -> Array:
    """Root mean square of each column, its squares in scratch (`pegbt.scratch`), not memory."""
    return np.asarray(np.sqrt(np.square(values, out=scratch(values.shape)).mean(0)), dtype=float)


def structure_of(selection: JointSelection) -> JointFit:
    """The unfitted structure (intercept and terms) the selection chose for its joint.

    Selection only decides which effects a joint has; the parameters are fitted afterwards on the whole
    recording (and on bootstrap resamples), from this structure."""
    terms = [
        Term(c.candidate.kind, c.candidate.source, c.width, coef=1.0 if c.fixed else 0.0, fixed=c.fixed)
        for c in selection.chosen
    ]
    return JointFit(selection.joint, selection.offset is not None, terms)


def structure_from_effects(effects: list[Effect]) -> list[JointFit]:
    """The fit structure that a known list of effects would need (the oracle in benchmarks)."""
    structures = [JointFit(j, False, []) for j in range(len(JOINT_NAMES))]
    for effect in effects:
        fit = structures[effect.index]
        if effect.kind.is_intercept:
            fit.intercept = True
            continue
        kind, source, width, fixed = effect.kind.term(effect)
        fit.terms.append(Term(kind, source, width, coef=1.0 if fixed else 0.0, fixed=fixed))
    return structures


def crossval_predict(
    structures: list[JointFit],
    base: ArmPhysics,
    recording: Recording,
    t: Array | None,
    residual: Array,
    fold_ranges: list[tuple[int, int]],
) -> Array:
    """Held-out predictions of the merged physics: coefficients refitted without each segment in turn."""
    prediction = np.empty_like(recording.q_phy)
    drivers = base.static_map(recording.q_cmd)
    for a, b in fold_ranges:
        rows = np.ones(recording.n, dtype=bool)
        rows[a:b] = False
        fits = [
            fit_joint(s, recording.q_cmd, t, residual[:, s.joint], drivers[:, s.joint], rows, refine=False)
            for s in structures
        ]
        replay_segment(merged_physics(fits, base), recording.q_cmd, t, (a, b), prediction)
    return prediction


def replay_segment(
    physics: ArmPhysics, q_cmd: Array, t: Array | None, segment: tuple[int, int], out: Array
) -> None:
    """Write rows `segment` of `physics`'s replay of the whole command sequence into `out`, replaying a
    chunk at a time up to the segment's end (`ArmPhysics.replay`): a recording's length is never held."""
    a, b = segment
    for start, rows in physics.replay(q_cmd, t, stop=b):
        first = max(a, start)
        if first < start + len(rows):
            out[first : start + len(rows)] = rows[first - start :]


SELECTION_ROUNDS = 2


def static_drivers(base: ArmPhysics, q_cmd: Array) -> Array:
    """`base.static_map(q_cmd)` (each joint's driver) in scratch, mapped a replay's chunk at a time."""
    drivers = scratch(q_cmd.shape)
    for a in range(0, len(q_cmd), REPLAY_ROWS):
        drivers[a : a + REPLAY_ROWS] = base.static_map(q_cmd[a : a + REPLAY_ROWS])
    return drivers


def choose_effects(
    q_cmd: Array, t: Array | None, residual: Array, base: ArmPhysics, unidentifiable: Unidentifiable
) -> tuple[list[JointSelection], int, BlockedGrams]:
    """Selection, repeated once with each joint's driver updated by the scale and couplings it found."""
    base_drivers = static_drivers(base, q_cmd)
    drivers = base_drivers
    chosen: tuple[list[JointSelection], int, BlockedGrams, Array] | None = None
    for _ in range(SELECTION_ROUNDS):
        chosen = None  # the previous round's bank goes before this one is built: never both at once
        chosen = _selection_round(q_cmd, t, residual, base_drivers, drivers, unidentifiable)
        if np.array_equal(chosen[3], drivers):
            break
        drivers = chosen[3]
    assert chosen is not None, "SELECTION_ROUNDS is at least 1"
    return chosen[0], chosen[1], chosen[2]


def _selection_round(
    q_cmd: Array,
    t: Array | None,
    residual: Array,
    base_drivers: Array,
    drivers: Array,
    unidentifiable: Unidentifiable,
) -> tuple[list[JointSelection], int, BlockedGrams, Array]:
    """One selection on the bank built from `drivers`, and the drivers its scales and couplings give."""
    bank, candidates = build_columns(q_cmd, t, drivers)
    grams = BlockedGrams(bank, residual)
    selections, hypotheses = select(grams, t, candidates, unidentifiable)
    updated = scratch(base_drivers.shape)
    updated[:] = base_drivers
    for selection in selections:
        free = selection.free_columns()
        beta = grams.fit(selection.joint, np.array(free), np.array(selection.fixed_columns(), dtype=np.int64))
        for column, b in zip(free[1:], beta[1:]):
            if 1 <= column <= q_cmd.shape[1]:  # a command column: scale or coupling
                updated[:, selection.joint] += b * q_cmd[:, column - 1]
    return selections, hypotheses, grams, updated


@dataclass(frozen=True)
class ModelChoice:
    """What selection and fitting chose on some samples: per joint, what the model holds (every effect
    the tests and guards chose) and its fit; what of it is named (practical significance) and its fit."""

    selections: list[JointSelection]  # the named effects, in greedy order with their shares
    modelled: list[JointSelection]  # everything the model holds, named or below resolution
    fits: list[JointFit]  # of `modelled`: what the model predicts with
    below_resolution: list[BelowResolution]
    hypotheses: int
    unidentifiable: Unidentifiable
    fit: Callable[[JointSelection], JointFit]  # a selection fitted on the same samples

    def named_fits(self) -> list[JointFit]:
        """What the named effects alone predict with (fitted only where they differ from the model's)."""
        return [
            whole if named.columns() == modelled.columns() else self.fit(named)
            for named, modelled, whole in zip(self.selections, self.modelled, self.fits)
        ]

    def labels(self) -> list[str]:
        """The named effects, as `kind on joint` or `kind source→joint`."""
        return [
            label
            for s in self.selections
            for label in ([f"offset on {JOINT_NAMES[s.joint]}"] if s.offset else [])
            + [c.candidate.label for c in s.chosen]
        ]


def choose_and_fit(
    q_cmd: Array,
    t: Array | None,
    residual: Array,
    base: ArmPhysics,
    is_stream: bool,
    resolution: tuple[float, ...] | None,
) -> ModelChoice:
    """The whole choice on these samples alone: which effects the model holds (tests and guards), which
    of them are named (practical significance), their widths and coefficients. Run on the whole recording
    it names the effects; run without a held-out segment it is what that segment is predicted by (nested
    cross-validation). An effect too small to name still predicts: it held up in every fold."""
    unidentifiable = find_unidentifiable(q_cmd, is_stream, base)
    modelled, hypotheses, grams = choose_effects(q_cmd, t, residual, base, unidentifiable)
    named: list[JointSelection] = []
    below: list[BelowResolution] = []
    for selection in modelled:
        settled, dropped = settle_joint(
            grams, selection, None if resolution is None else resolution[selection.joint]
        )
        named.append(settled)
        below += dropped
    folds = grams.fold_ranges()
    drivers = static_drivers(base, q_cmd)

    def fit(s: JointSelection) -> JointFit:
        target, driver = residual[:, s.joint], drivers[:, s.joint]
        return settle_backlash(
            fit_joint(structure_of(s), q_cmd, t, target, driver), q_cmd, t, target, driver, folds
        )

    return ModelChoice(named, modelled, [fit(s) for s in modelled], below, hypotheses, unidentifiable, fit)


def nested_predict(
    recording: Recording,
    t: Array | None,
    residual: Array,
    base: ArmPhysics,
    resolution: tuple[float, ...] | None,
    fold_ranges: list[tuple[int, int]],
    removal: Callable[[NDArray[np.bool_]], Array] | None = None,
    with_named: bool = True,
) -> tuple[Array, Array | None, list[list[str]]]:
    """Held-out predictions by nested cross-validation, of the whole model and of its named effects
    alone (None without `with_named`: a replay a segment less, and no array the recording's size),
    and the effects each training part named.

    For each segment the whole choice (effects, widths, coefficients; its own inner folds) is made on
    the rest of the recording, and the merged physics model replays the whole command sequence (commands
    are inputs, known everywhere), scored on the segment. No figure sees its own segment's measurements.
    With a `removal` (`pegbt.sim2real.geometry.displacement_removal`), what it fits on the rest is taken
    out of the residual before the choice and added back to the prediction."""
    prediction = scratch(recording.q_phy.shape)
    named_prediction = scratch(recording.q_phy.shape) if with_named else None
    named = []
    for a, b in fold_ranges:
        keep = np.ones(recording.n, dtype=bool)
        keep[a:b] = False
        shift = None if removal is None else removal(keep)
        named.append(
            _predict_segment(
                recording, t, residual, shift, base, resolution, (a, b), (prediction, named_prediction)
            )
        )
        if shift is not None:
            prediction[a:b] += shift[a:b]
            if named_prediction is not None:
                named_prediction[a:b] += shift[a:b]
    return prediction, named_prediction, named


def _predict_segment(
    recording: Recording,
    t: Array | None,
    residual: Array,
    shift: Array | None,
    base: ArmPhysics,
    resolution: tuple[float, ...] | None,
    segment: tuple[int, int],
    out: tuple[Array, Array | None],
) -> list[str]:
    """One segment of `nested_predict`: the choice made without it (on `residual − shift`), its whole
    model's and its named effects' replays written into the segment's rows of `out`, and its labels. A
    function of its own so that the choice (and the training copies its fits keep) and each whole replay
    are gone before the next segment's choice."""
    a, b = segment
    training = scratch_rows(residual, segment)
    if shift is not None:
        training[:a] -= shift[:a]
        training[a:] -= shift[b:]
    choice = choose_and_fit(
        scratch_rows(recording.q_cmd, segment),
        None if t is None else scratch_rows(t, segment),
        training,
        base,
        recording.sampling.is_stream,
        resolution,
    )
    replay_segment(merged_physics(choice.fits, base), recording.q_cmd, t, (a, b), out[0])
    if out[1] is not None:
        replay_segment(merged_physics(choice.named_fits(), base), recording.q_cmd, t, (a, b), out[1])
    return choice.labels()


def diagnose(
    recording: Recording,
    sim: str | Path = "ideal",
    arm: str | None = None,
    n_bootstrap: int = N_BOOTSTRAP,
    seed: int = 0,
    resolution: tuple[float, ...] | None = None,
) -> Diagnosis:
    """Locate, explain and fit the mismatch between a recording and the simulator's physics.

    `resolution` (per joint; default: the recording's own, when its metadata says) sets what is too
    small to name (`pegbt.sim2real.practical`). Samples no arm could produce (`pegbt.physics.faults`)
    are left out of everything: selection, fit and the held-out figures. When q1–q3 move as one
    displacement of the tool (`pegbt.sim2real.geometry`), it is taken out before the effects are chosen
    again, and reported as geometry; so are constant offsets on q1–q3, which the model keeps. The effects
    are named from the whole recording; the held-out figures come from nested cross-validation
    (`nested_predict`)."""
    arm = arm or recording.arm or "PSM1"
    times_before_exclusion = recording.times
    base, faults, recording, t, simulated = _prepare(recording, sim, arm)
    sampling = recording.sampling
    q_cmd = recording.q_cmd
    residual = np.subtract(recording.q_phy, simulated, out=scratch(simulated.shape))
    mismatch = locate(residual, q_cmd, recording.times, sampling.is_stream)
    resolution = resolution if resolution is not None else recording.resolution
    folds = fold_ranges(recording.n)
    heldout, named_heldout, fold_named = nested_predict(recording, t, residual, base, resolution, folds)
    assert named_heldout is not None, "asked for"
    np.subtract(recording.q_phy, named_heldout, out=named_heldout)  # its error, in place: held once
    geometry = check_geometry(q_cmd, residual, named_heldout, folds, resolution)
    del named_heldout
    cable_residual = residual
    if geometry is not None:
        del heldout  # the first held-out predictions go before the second are made
        removal = displacement_removal(q_cmd, residual, resolution)
        cable_residual = np.subtract(
            residual, removal(np.ones(recording.n, dtype=bool)), out=scratch(residual.shape)
        )
        heldout, _, fold_named = nested_predict(
            recording, t, residual, base, resolution, folds, removal, with_named=False
        )
    # made once the held-out work is done (what it keeps is not held through it), and only on the
    # residual the effects are named from: with a displacement, the one it leaves
    choice = choose_and_fit(q_cmd, t, cable_residual, base, sampling.is_stream, resolution)
    fits = choice.fits
    drivers = static_drivers(base, q_cmd)
    rng = np.random.default_rng(seed)
    effects: list[NamedEffect] = []
    statements = list(choice.unidentifiable.statements)
    for modelled, selection, fit in zip(choice.modelled, choice.selections, fits):
        target, driver = cable_residual[:, fit.joint], drivers[:, fit.joint]
        named = {c.column: c for c in ([selection.offset] if selection.offset else []) + selection.chosen}
        samples = bootstrap(fit, q_cmd, t, target, driver, n_bootstrap, rng) if n_bootstrap and named else []
        evidence = ([modelled.offset] if modelled.offset else []) + modelled.chosen
        changed = to_effects(fit, base)[1]
        sampled = [to_effects(sample, base)[1] for sample in samples]
        for position, (effect, candidate) in enumerate(zip(changed, evidence)):
            if candidate.column not in named:
                continue  # in the model, below resolution: listed, not named
            chosen = named[candidate.column]
            ci = _intervals(effect, [s[position] for s in sampled])
            before = next((e for e in base.effects if e.slot == effect.slot), None)
            effects.append(
                NamedEffect(effect, ci, chosen.explains, chosen.pvalue, effect_sentence(effect, before))
            )
            if chosen.rival:
                statements.append(rival_sentence(chosen.candidate.label, chosen.rival))
    physics = merged_physics(fits, base)
    error_before = rms(residual)
    effects = sorted(
        (
            replace(e, contribution=float(error_before[e.effect.index] * np.sqrt(max(e.explains, 0.0))))
            for e in effects
        ),
        key=lambda e: -e.contribution,
    )
    zero_offsets = [e for e in effects if is_arm_zero(e.effect)]
    effects = [e for e in effects if not is_arm_zero(e.effect)]
    return Diagnosis(
        recording,
        str(sim),
        arm,
        sampling,
        base,
        simulated,
        mismatch,
        choice.selections,
        fits,
        effects,
        physics,
        heldout,
        folds,
        statements,
        choice.hypotheses,
        choice.below_resolution,
        resolution,
        faults,
        times_before_exclusion,
        fold_named,
        geometry,
        zero_offsets,
    )


def _intervals(effect: Effect, samples: list[Effect]) -> dict[str, tuple[float, float]]:
    """95 % bootstrap intervals of each numeric parameter (over resamples that named the same kind)."""
    ci = {}
    for name, value in effect.params.items():
        if name == "source":
            continue
        values = [s.params[name] for s in samples if s.effect == effect.effect and name in s.params]
        if len(values) >= 10:
            lo, hi = np.percentile(values, [2.5, 97.5])
            ci[name] = (float(min(lo, value)), float(max(hi, value)))
    return ci


def identify(
    q_cmd: Array, q_phy: Array, t: Array | None = None, base: str | Path = "ideal", arm: str = "PSM1"
) -> list[Effect]:
    """The whole arm-physics model (base plus what the data add) fitted to commanded vs measured joints.

    `t=None` treats samples as settled set-points. This is the entry point calibration can reuse.
    """
    q_cmd, q_phy = np.asarray(q_cmd, float), np.asarray(q_phy, float)
    t = None if t is None else np.asarray(t, float)
    validate(q_cmd, q_phy, t, Path("<arrays>"))
    return list(identify_physics(Recording(Path("<arrays>"), q_cmd, q_phy, t), base, arm).effects)


def identify_physics(
    recording: Recording,
    sim: str | Path = "ideal",
    arm: str | None = None,
    resolution: tuple[float, ...] | None = None,
) -> ArmPhysics:
    """The merged physics model `diagnose` would name, without its held-out figures, intervals or
    report (what a calibration or a benchmark's training part needs)."""
    base, _, kept, t, simulated = _prepare(recording, sim, arm or recording.arm or "PSM1")
    resolution = resolution if resolution is not None else kept.resolution
    residual = np.subtract(kept.q_phy, simulated, out=scratch(simulated.shape))
    choice = choose_and_fit(kept.q_cmd, t, residual, base, kept.sampling.is_stream, resolution)
    return merged_physics(choice.fits, base)


def _prepare(
    recording: Recording, sim: str | Path, arm: str
) -> tuple[ArmPhysics, MeasurementFaults, Recording, Array | None, Array]:
    """(base physics, the faults, the kept samples, their times if a stream, the base's replay of them)."""
    base = ArmPhysics.load(sim, arm)  # presets differ per arm; the recording's meta.json or name says which
    faults = detect_faults(recording.q_cmd, recording.q_phy, recording.limits)
    kept = recording.subset(faults.kept)
    t = kept.t if kept.sampling.is_stream else None
    simulated = scratch(kept.q_cmd.shape)
    replay_segment(base, kept.q_cmd, t, (0, kept.n), simulated)
    return base, faults, kept, t, simulated
