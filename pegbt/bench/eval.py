"""`pegbt bench eval`: a small `pegbt eval` over the three variants, clean and with injected faults.

Per variant, `CLEAN_TRIALS` calibrated + optimised trials (success rate, mean transfer time, arm-arm
collisions, median wall time of a trial) and `FAULTY_TRIALS` with a fault plan per seed (a missed grasp,
slips, depth-noise bursts). Over the faulty trials: `recovery_rate`, the share of injected faults the trial
got over (the transfer it hit still succeeded), and `why_agreement`, the share of failures for which
`pegbt log why` names a step the simulator's log confirms. The full figures come from `pegbt eval`; this is
the quick check, in a scratch directory.

Throughput: the same `THROUGHPUT_TRIALS` bilateral trials as one campaign of `WORKERS` local worker
processes and as one on a Dask cluster of `WORKERS` single-thread workers started here on loopback
(`distributed.LocalCluster`), alternately, `THROUGHPUT_ROUNDS` times each; trials per hour of campaign
wall time, medians. On one machine the difference is the engine's overhead (`cluster_overhead`, a
fraction of the local wall time; negative when the cluster's warm workers outrun fresh local processes),
beside each trial's own wall time (simulator start-up included) wherever it ran.
"""

from __future__ import annotations

import logging
import statistics
import tempfile
import time
from pathlib import Path

from pegbt.bench import Figures

CLEAN_TRIALS = 2
FAULTY_TRIALS = 3
FIRST_SEED = 100  # apart from the seeds the README's tables use
WORKERS = 2
THROUGHPUT_TRIALS = 4
THROUGHPUT_ROUNDS = 3


def run() -> Figures:
    from pegbt.evaluation.campaign import Cell, run_trials, trial_specs
    from pegbt.evaluation.summary import summarise
    from pegbt.runconditions import VARIANTS

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
    figures.update(throughput())
    return {key: value for key, value in figures.items() if value is not None}


def throughput() -> Figures:
    """Trials per hour of one campaign, local workers against a loopback Dask cluster (see the docstring)."""
    from distributed import LocalCluster

    from pegbt.evaluation.campaign import Cell, run_trials, trial_specs
    from pegbt.evaluation.cluster import run_trials_on_cluster

    cell = Cell("bilateral", "optimized", THROUGHPUT_TRIALS, FIRST_SEED)
    walls: dict[str, list[float]] = {"local": [], "cluster": []}
    trial_walls: dict[str, list[float]] = {"local": [], "cluster": []}
    with (
        tempfile.TemporaryDirectory(prefix="pegbt-bench-throughput-") as scratch,
        LocalCluster(
            n_workers=WORKERS,
            threads_per_worker=1,
            host="127.0.0.1",
            dashboard_address=None,
            scheduler_port=0,
            silence_logs=logging.ERROR,
        ) as cluster,
    ):
        for round_ in range(THROUGHPUT_ROUNDS):
            for where, wall in walls.items():
                specs = trial_specs(cell, Path(scratch) / f"{where}-{round_}")
                started = time.perf_counter()
                if where == "local":
                    records = run_trials(specs, WORKERS)
                else:
                    records, _ = run_trials_on_cluster(specs, cluster.scheduler_address)
                wall.append(time.perf_counter() - started)
                trial_walls[where] += [record.run_wall_s for record in records]
                if any(record.outcome == "error" for record in records):
                    raise RuntimeError(f"a {where} trial failed: {[r.error for r in records if r.error]}")
    local, remote = (statistics.median(walls[where]) for where in ("local", "cluster"))
    return {
        "local_trials_per_hour": THROUGHPUT_TRIALS * 3600 / local,
        "cluster_trials_per_hour": THROUGHPUT_TRIALS * 3600 / remote,
        "cluster_overhead": remote / local - 1,
        "local_trial_run_wall_s_median": statistics.median(trial_walls["local"]),
        "cluster_trial_run_wall_s_median": statistics.median(trial_walls["cluster"]),
    }
