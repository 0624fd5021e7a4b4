"""`pegbt bench sim2real`: naming, false discoveries, parameters and speed on concealed synthetic data.

Every family of `pegbt.sim2real.synth` runs over `SEEDS` seeds (30 s of 100 Hz data each, half with
AR(1) ρ = 0.9 noise); the `weak` family is swept over SNR levels to find the detection threshold; the
oracle is the true structure refitted on the same data by the same fitting code. Timing: one 10-minute,
6-joint, 100 Hz recording with the dVRK wrist effects, diagnosed with bootstrap intervals and written
out as report.json, report.md and plots.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from pegbt.physics import ArmPhysics
from pegbt.physics.recording import Recording
from pegbt.sim2real.diagnose import diagnose
from pegbt.sim2real.report import write_report
from pegbt.sim2real.scoring import Score, detection_threshold, score
from pegbt.sim2real.synth import NOISE_SIGMA, generate, smooth_commands

SEEDS = 20
SNR_LEVELS = [0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.5, 2.0]
CONCEALED_FAMILIES = ("masked", "regime", "coupled")
NULL_FAMILIES = ("null-white", "null-ar1")


def _run(family: str, seed: int, snr: float | None = None) -> tuple[Score, list[bool]]:
    """The score of one recording, and whether each concealed effect at SNR ≥ 1 was named."""
    synthetic = generate(family, seed, snr=snr)
    result = score(synthetic, diagnose(synthetic.recording, n_bootstrap=0))
    return result, [result.found[label] for label in synthetic.concealed if synthetic.snr[label] >= 1.0]


def _ten_minutes_seconds() -> float:
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 600.0, 0.01)
    q_cmd = smooth_commands(rng, t, rng.uniform(0.8, 2.0, 6))
    q_phy = (
        ArmPhysics.load("dvrk-real", "PSM1").simulate(q_cmd, t)
        + rng.standard_normal(q_cmd.shape) * NOISE_SIGMA
    )
    recording = Recording(Path("<10 min synthetic PSM1>"), q_cmd, q_phy, t)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        write_report(diagnose(recording), out)
    return time.perf_counter() - start


def run() -> dict[str, float | int | str]:
    found_at_1: list[bool] = []
    param_errors: list[float] = []
    oracle: list[float] = []
    false_names = named = 0
    rates = []
    for level in SNR_LEVELS:
        hits = []
        for seed in range(SEEDS):
            result, concealed = _run("weak", seed, level)
            hits += list(result.found.values())
            if level >= 1.0:
                found_at_1 += concealed
                param_errors += result.param_errors
                oracle += [result.oracle_gain_fraction] if result.oracle_gain_fraction is not None else []
                false_names += result.false_names
                named += result.named
        rates.append(float(np.mean(hits)))
    per_family = {}
    for family in CONCEALED_FAMILIES:
        hits = []
        for seed in range(SEEDS):
            result, concealed = _run(family, seed)
            hits += concealed
            found_at_1 += concealed
            param_errors += result.param_errors
            oracle += [result.oracle_gain_fraction] if result.oracle_gain_fraction is not None else []
            false_names += result.false_names
            named += result.named
        per_family[family] = float(np.mean(hits))
    null_named = {}
    for family in NULL_FAMILIES:
        null_named[family] = float(np.mean([_run(family, seed)[0].named > 0 for seed in range(SEEDS)]))
    figures: dict[str, float | int | str] = {
        "naming_accuracy": float(np.mean(found_at_1)),
        "false_discovery_rate": float(np.mean(list(null_named.values()))),
        "param_error_median": float(np.median(param_errors)),
        "oracle_gain_fraction": float(np.median(oracle)),
        "oracle_gain_fraction_p10": float(np.percentile(oracle, 10)),
        "min_detectable_snr": detection_threshold(SNR_LEVELS, rates),
    }
    figures.update({f"naming_accuracy_{family}": value for family, value in per_family.items()})
    figures.update(
        {f"false_discovery_rate_{family.split('-')[1]}": value for family, value in null_named.items()}
    )
    figures["wrong_name_fraction"] = false_names / max(named, 1)
    figures.update({f"naming_rate_snr_{level:g}": rate for level, rate in zip(SNR_LEVELS, rates)})
    figures["seeds_per_family"] = SEEDS
    figures["diagnose_s_10min"] = _ten_minutes_seconds()
    return figures
