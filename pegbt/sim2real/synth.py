"""Recordings with concealed effects and a ground truth the diagnosis never sees.

A ground-truth arm (`pegbt.physics.ArmPhysics` with hidden effects) follows random smooth commands,
and measurement noise (white, or AR(1) with ρ = 0.9) is added. Each effect's size is set by its SNR:
the RMS of what it changes in the joint (its mean removed, except for an offset) over the noise σ.

Families (how the effect is concealed):
- `weak`: one effect at or below the noise level;
- `masked`: a small effect next to a much larger one on the same or another joint;
- `regime`: play driven by a joint that reverses only a few times, or lag/delay that only fast moves
  (a handful among slow ones) reveal;
- `coupled`: an effect on one joint driven by another joint's command (coupling, hysteresis);
- `null-white`, `null-ar1`: negative controls with no effect at all.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq

from pegbt.errors import PegbtError
from pegbt.motion.robot_config import DVRK_LIMITS, RobotLimits
from pegbt.physics import ArmPhysics, Effect, effect_kinds, kind_of
from pegbt.physics.faults import TRACKING_TOLERANCE
from pegbt.physics.recording import Recording, write_recording
from pegbt.psm import JOINT_NAMES

Array = NDArray[np.float64]

FAMILIES = ("weak", "masked", "regime", "coupled", "null-white", "null-ar1")
CENTRE = np.array([0.0, 0.0, 0.17, 0.0, 0.0, 0.0])
AMPLITUDE = np.array([0.5, 0.4, 0.05, 1.0, 0.7, 0.7])
NOISE_SIGMA = np.array([0.002, 0.002, 0.0001, 0.003, 0.003, 0.003])
AR1_RHO = 0.9
SETPOINT_INTERVAL_S = 0.8
MASKING_RATIO = 10.0  # a masking effect's RMS over the concealed one's


def effect_label(effect: Effect) -> str:
    """`kind joint[ source]`: which effect, where, driven by what (its parameters aside)."""
    source = effect.params.get("source")
    return f"{effect.effect} {effect.joint}" + (f" {source}" if source else "")


@dataclass
class Synthetic:
    recording: Recording
    effects: list[Effect]
    snr: dict[str, float]  # by effect label
    concealed: list[str]  # labels of the effects hidden on purpose (a masking effect is not one)
    noise: dict
    family: str
    seed: int

    def truth(self) -> dict:
        return {
            "family": self.family,
            "seed": self.seed,
            "effects": [e.to_dict() for e in self.effects],
            "snr": self.snr,
            "concealed": self.concealed,
            "noise": self.noise,
            "sampling": self.recording.sampling.mode,
        }


def smooth_commands(rng: np.random.Generator, t: Array, hold_s: Array) -> Array:
    """Random smooth joint commands: monotone cubic through random waypoints `hold_s` seconds apart."""
    q = np.empty((len(t), len(JOINT_NAMES)))
    for j in range(len(JOINT_NAMES)):
        knots = np.arange(t[0], t[-1] + 2 * hold_s[j], hold_s[j]) + rng.uniform(-0.3, 0.3) * hold_s[j]
        values = CENTRE[j] + AMPLITUDE[j] * rng.uniform(-1, 1, len(knots))
        q[:, j] = PchipInterpolator(knots, values)(t)
    return q


def few_fast_moves(rng: np.random.Generator, t: Array, joint: int, moves: int = 4) -> Array:
    """A command that drifts slowly but jumps quickly (in 0.15 s) a few times: lag shows only there."""
    slow = CENTRE[joint] + 0.3 * AMPLITUDE[joint] * np.sin(2 * np.pi * t / (t[-1] - t[0]) + rng.uniform(0, 6))
    steps = np.zeros_like(t)
    level = 0.0
    for start in np.sort(rng.uniform(t[0] + 1, t[-1] - 1, moves)):
        target = rng.choice([-1, 1]) * 0.6 * AMPLITUDE[joint]
        ramp = np.clip((t - start) / 0.15, 0, 1)
        steps = steps + (target - level) * ramp
        level = target
    return slow + steps


def _contribution(effect: Effect, q_cmd: Array, t: Array | None) -> float:
    """RMS of what the effect changes in its joint (its mean removed, except for an offset)."""
    change = ArmPhysics([effect]).simulate(q_cmd, t)[:, effect.index] - q_cmd[:, effect.index]
    return float(np.sqrt((change**2).mean())) if effect.kind.is_intercept else float(change.std())


def plausible_effect(kind: str, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
    """An effect with parameters in the range a cable-driven arm shows (sign at random)."""
    return kind_of(kind).plausible(joint, source, q_cmd, rng)


def sized_effect(
    kind: str, joint: int, source: int, target: float, q_cmd: Array, t: Array | None, rng: np.random.Generator
) -> Effect:
    """An effect of `kind` whose contribution has RMS `target` (for masking effects of a chosen size)."""
    shape = plausible_effect(kind, joint, source, q_cmd, rng)
    resized = shape.kind.resized(shape, target / _contribution(shape, q_cmd, t))
    if resized is not None:
        return resized
    width = shape.kind.width
    assert width is not None, f"{kind} can be sized neither by a coefficient nor by a width"
    upper = shape.kind.largest(q_cmd, joint)

    def excess(value: float) -> float:
        return _contribution(Effect(kind, shape.joint, {**shape.params, width: value}), q_cmd, t) - target

    if excess(upper) < 0:
        return Effect(kind, shape.joint, {**shape.params, width: upper})
    value = float(brentq(excess, upper * 1e-7, upper, xtol=upper * 1e-9))
    return Effect(kind, shape.joint, {**shape.params, width: value})


def concealable(sampling: str) -> tuple[str, ...]:
    """The kinds a recording of this sampling can hide (and show): stream-only kinds need streams."""
    return tuple(k.name for k in effect_kinds() if sampling == "stream" or not k.streams_only)


def _pick(rng: np.random.Generator, options: Sequence[str]) -> str:
    return str(options[int(rng.integers(len(options)))])


def zigzag(rng: np.random.Generator, t: Array, joint: int, reversals: int) -> Array:
    """A smooth command that reverses exactly `reversals` times, between alternating high and low values."""
    knots = np.linspace(t[0], t[-1], reversals + 2)
    values = CENTRE[joint] + AMPLITUDE[joint] * rng.uniform(0.3, 1.0, len(knots)) * (-1.0) ** np.arange(
        len(knots)
    )
    return PchipInterpolator(knots, values)(t)


def generate(
    family: str,
    seed: int,
    seconds: float = 30.0,
    rate_hz: float = 100.0,
    sampling: str = "stream",
    snr: float | None = None,
    effect: str | None = None,
) -> Synthetic:
    """One synthetic recording of `family`, reproducible from `seed`.

    The concealed effect has parameters in a plausible physical range; its SNR (drawn per family, or
    `snr`) then sets the noise σ of its joint. Masking effects are sized `MASKING_RATIO`× the concealed one.
    `effect` names the kind the `weak` family conceals (default: drawn from every registered kind).
    """
    if family not in FAMILIES:
        raise PegbtError(f"unknown family {family!r}; known: {', '.join(FAMILIES)}", field="family")
    if sampling not in ("stream", "setpoints"):
        raise PegbtError(f"unknown sampling {sampling!r}; expected stream or setpoints", field="sampling")
    if effect is not None and (family != "weak" or effect not in concealable(sampling)):
        raise PegbtError(
            f"--effect names the kind the weak family conceals, one of {', '.join(concealable(sampling))} "
            f"for {sampling}; got {effect!r} for {family}",
            field="effect",
        )
    rng = np.random.default_rng(seed)
    interval = 1.0 / rate_hz if sampling == "stream" else SETPOINT_INTERVAL_S
    t = np.arange(0.0, seconds, interval)
    hold = (
        rng.uniform(0.8, 2.0, len(JOINT_NAMES))
        if sampling == "stream"
        else rng.uniform(2.5, 5.0, len(JOINT_NAMES))
    )
    q_cmd = smooth_commands(rng, t, hold)
    stream_t = t if sampling == "stream" else None
    kinds = concealable(sampling)
    sourced = tuple(k for k in kinds if kind_of(k).takes_source)
    joint = int(rng.integers(len(JOINT_NAMES)))
    other = int((joint + rng.integers(1, len(JOINT_NAMES))) % len(JOINT_NAMES))
    sigma = NOISE_SIGMA.copy()
    effects: list[Effect] = []
    snrs: dict[str, float] = {}
    concealed: list[str] = []

    def conceal(kind: str, where: int, source: int, low: float, high: float) -> Effect:
        effect = plausible_effect(kind, where, source, q_cmd, rng)
        level = snr if snr is not None else float(rng.uniform(low, high))
        sigma[where] = _contribution(effect, q_cmd, stream_t) / level
        snrs[effect_label(effect)] = level
        concealed.append(effect_label(effect))
        return effect

    if family == "weak":
        kind = effect or _pick(rng, kinds)
        effects.append(conceal(kind, joint, other if kind in sourced else joint, 0.5, 1.0))
    elif family == "masked":
        big = _pick(rng, ("offset", "scale", "coupling", "backlash"))
        small = _pick(rng, [k for k in kinds if k != big])
        where = joint if rng.random() < 0.5 else other
        source = int((where + 1 + rng.integers(len(JOINT_NAMES) - 1)) % len(JOINT_NAMES))
        hidden = conceal(small, where, source if small in sourced else where, 1.0, 2.0)
        masking = sized_effect(
            big,
            joint,
            other if big == "coupling" else joint,
            MASKING_RATIO * _contribution(hidden, q_cmd, stream_t),
            q_cmd,
            stream_t,
            rng,
        )
        snrs[effect_label(masking)] = float(_contribution(masking, q_cmd, stream_t) / sigma[joint])
        effects += [masking, hidden]
    elif family == "regime":
        kind = _pick(rng, [k for k in kinds if kind_of(k).needs_reversals or kind_of(k).streams_only])
        driver = other if kind in sourced else joint
        if kind_of(kind).needs_reversals:
            q_cmd[:, driver] = zigzag(rng, t, driver, int(rng.integers(4, 7)))
        else:
            q_cmd[:, joint] = few_fast_moves(rng, t, joint)
        effects.append(conceal(kind, joint, driver, 2.0, 3.0))
    elif family == "coupled":
        effects.append(conceal(_pick(rng, sourced), joint, other, 1.0, 3.0))
    noise_kind = "ar1" if family == "null-ar1" or (family != "null-white" and seed % 2) else "white"
    noise = _noise(rng, len(t), noise_kind) * sigma
    q_phy = within_reach(ArmPhysics(effects).simulate(q_cmd, stream_t) + noise, q_cmd)
    recording = Recording(Path(f"<synth {family} {seed}>"), q_cmd, q_phy, t)
    return Synthetic(
        recording,
        effects,
        snrs,
        concealed,
        {"kind": noise_kind, "sigma": sigma.tolist(), "rho": AR1_RHO if noise_kind == "ar1" else 0.0},
        family,
        seed,
    )


def within_reach(q_phy: Array, q_cmd: Array, limits: RobotLimits = DVRK_LIMITS) -> Array:
    """The measured joints as the robot could be: within its joint limits, and q1–q3 within the distance
    from their command its controller allows (`pegbt.physics.faults`). The noise an SNR sets can be a
    large fraction of a radian, and over an hour its tails would reach where no arm is."""
    lower = np.broadcast_to(limits.lower, q_phy.shape).copy()
    upper = np.broadcast_to(limits.upper, q_phy.shape).copy()
    arm = slice(0, len(TRACKING_TOLERANCE))
    lower[:, arm] = np.maximum(lower[:, arm], q_cmd[:, arm] - TRACKING_TOLERANCE)
    upper[:, arm] = np.minimum(upper[:, arm], q_cmd[:, arm] + TRACKING_TOLERANCE)
    return np.clip(q_phy, lower, upper)


def _noise(rng: np.random.Generator, n: int, kind: str) -> Array:
    """Unit-variance measurement noise: white, or AR(1) with ρ = 0.9."""
    white = rng.standard_normal((n, len(JOINT_NAMES)))
    if kind == "white":
        return white
    from scipy.signal import lfilter

    innovations = white * np.sqrt(1 - AR1_RHO**2)
    first = white[:1]
    series, _ = lfilter([1.0], [1.0, -AR1_RHO], innovations, axis=0, zi=AR1_RHO * first)
    return series


def write_synthetic(synthetic: Synthetic, out: str | Path) -> tuple[Path, Path]:
    """Write OUT/recording/ (what diagnose reads) and OUT/truth.json (what it never reads)."""
    out = Path(out)
    rec = synthetic.recording
    folder = write_recording(out / "recording", rec.q_cmd, rec.q_phy, rec.t)
    truth = out / "truth.json"
    truth.write_text(json.dumps(synthetic.truth(), indent=2) + "\n")
    return folder, truth


GLITCH_SIZE = np.array([0.3, 0.3, 0.01, 0.3, 0.3, 0.3])  # σ of a glitch's jump per joint (rad; m for q3)


def with_tracker_faults(
    recording: Recording, glitches: int, rng: np.random.Generator, noise: Array = NOISE_SIGMA
) -> tuple[Recording, NDArray[np.bool_]]:
    """`recording` as a fiducial tracker that glitches and loses the tool would have measured it, and the
    true fault mask: the middle third of its last sixth reports the pose before it (plus `noise`), as a
    tracker that lost the tool does, and `glitches` other samples jump on every joint at once (by up to
    about a radian, even on q1–q3), as when it loses a sphere (`../shared/data/dvrk/README.md`)."""
    q_phy, n = recording.q_phy.copy(), recording.n
    truth = np.zeros(n, dtype=bool)
    lost = slice(n - n // 6 + n // 18, n - n // 18)
    q_phy[lost] = q_phy[lost.start - 1] + rng.normal(0, 1, q_phy[lost].shape) * noise
    truth[lost] = True
    jumps = rng.choice(np.flatnonzero(~truth), glitches, replace=False)
    q_phy[jumps] += rng.normal(0, 1, (glitches, q_phy.shape[1])) * GLITCH_SIZE
    truth[jumps] = True
    faulty = Recording(
        recording.path, recording.q_cmd, q_phy, recording.t, recording.arm, recording.resolution
    )
    return faulty, truth
