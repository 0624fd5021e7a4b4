"""`pegbt bench eval`: a small `pegbt eval` over the three variants, clean and with injected faults.

Per variant, `CLEAN_TRIALS` calibrated + optimised trials (success rate, mean transfer time, arm-arm
collisions, median wall time of a trial) and `FAULTY_TRIALS` with a fault plan per seed (a missed grasp,
slips, depth-noise bursts). Over the faulty trials: `recovery_rate`, the share of injected faults the trial
got over (the transfer it hit still succeeded), and `why_agreement`, the share of failures for which
`pegbt log why` names a step the simulator's log confirms. The full figures come from `pegbt eval`; this is
the quick check, in a scratch directory.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from pegbt.bench import Figures

CLEAN_TRIALS = 2
FAULTY_TRIALS = 3
FIRST_SEED = 100  # apart from the seeds the README's tables use
WORKERS = 2


def run() -> Figures:
    from pegbt.evaluation.campaign import Cell, run_trials, trial_specs
    from pegbt.evaluation.paper import VARIANTS
    from pegbt.evaluation.summary import summarise

    figures: Figures = {}
    faulty = {"faults_injected": 0, "faults_recovered": 0, "why_checked": 0, "why_agreed": 0}
    with tempfile.TemporaryDirectory(prefix="pegbt-bench-eval-") as scratch:
        for variant in VARIANTS:
            for cell in (
                Cell(variant, "optimized", CLEAN_TRIALS, FIRST_SEED),
                Cell(variant, "optimized", FAULTY_TRIALS, FIRST_SEED, inject_faults=True),
            ):
                summary = summarise(
                    cell, run_trials(trial_specs(cell, Path(scratch) / cell.name), WORKERS), WORKERS
                )
                if cell.inject_faults:
                    for key in faulty:
                        faulty[key] += summary[key]
                    figures[f"{variant}_faulty_success_rate"] = summary["success_rate"]
                    continue
                figures[f"{variant}_success_rate"] = summary["success_rate"]
                figures[f"{variant}_mean_transfer_time_s"] = summary["mean_transfer_time_s"]
                figures[f"{variant}_collisions_per_trial"] = summary["collisions_per_trial"]
                figures[f"{variant}_wall_time_s_median"] = summary["wall_time_s_median"]
    figures["recovery_rate"] = (
        faulty["faults_recovered"] / faulty["faults_injected"] if faulty["faults_injected"] else float("nan")
    )
    figures["why_agreement"] = (
        faulty["why_agreed"] / faulty["why_checked"] if faulty["why_checked"] else float("nan")
    )
    figures.update(faulty)
    return {key: value for key, value in figures.items() if value is not None}
