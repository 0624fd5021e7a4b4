"""`pegbt eval`: its JSON and files from a real trial on the embedded simulator, and the same result for the
same seed whether run by the command or in-process."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from pegbt.evaluation.trial import TrialSpec, run_trial

REPO = Path(__file__).resolve().parents[2]
JSON_KEYS = {
    "variant",
    "condition",
    "trials",
    "transfers_attempted",
    "transfers_succeeded",
    "success_rate",
    "mean_transfer_time_s",
    "collisions_per_trial",
    "trial_time_s_mean",
    "trial_time_s_std",
}


def pegbt(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    """`python -m pegbt ARGS`; whole trials, which a loaded machine can slow several times over."""
    return subprocess.run(
        [sys.executable, "-m", "pegbt", *args], capture_output=True, text=True, cwd=REPO, timeout=timeout
    )


@pytest.mark.slow
def test_eval_prints_the_figures_writes_csv_and_plots_and_repeats_a_seed_exactly(tmp_path):
    out = tmp_path / "results"
    run = pegbt(
        "eval",
        "--variant",
        "bilateral",
        "--trials",
        "1",
        "--seed",
        "5",
        "--json",
        "--out",
        str(out),
        "--quiet",
    )
    assert run.returncode == 0, run.stderr
    figures = json.loads(run.stdout)
    assert JSON_KEYS <= set(figures)
    assert (figures["variant"], figures["condition"], figures["trials"]) == ("bilateral", "optimized", 1)
    assert figures["transfers_attempted"] == 12 and 0 <= figures["transfers_succeeded"] <= 12
    assert figures["success_rate"] == figures["transfers_succeeded"] / 12
    assert figures["trial_time_s_mean"] > 10 and figures["trial_time_s_std"] == 0.0

    with (out / "trials-bilateral-optimized.csv").open() as file:
        trials = list(csv.DictReader(file))
    with (out / "transfers-bilateral-optimized.csv").open() as file:
        transfers = list(csv.DictReader(file))
    assert [row["seed"] for row in trials] == ["5"] and len(transfers) == 12
    assert (out / "transfer_times.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((out / "summary-bilateral-optimized.json").read_text()) == figures

    # the same seed, in this process: the same transfers, to the simulator's control period
    again = run_trial(TrialSpec("bilateral", "optimized", 5, tmp_path / "again.jsonl"))
    assert again.transfers_succeeded == figures["transfers_succeeded"]
    assert [t["succeeded"] for t in again.transfers] == [row["succeeded"] == "True" for row in transfers]
    assert [t["seconds"] for t in again.transfers] == pytest.approx(
        [float(row["seconds"]) if row["seconds"] else None for row in transfers], abs=1e-6
    )
    assert again.trial_time_s == pytest.approx(figures["trial_time_s_mean"], abs=1e-6)
