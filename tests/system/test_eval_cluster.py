"""`pegbt eval --cluster`: trials on a real Dask scheduler and workers (loopback) give, seed for seed, what
local workers give; a worker killed mid-trial costs a retry, not the campaign; a worker running other code
is refused; and a local eval never imports Dask."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from cluster_helpers import REPO, LocalDaskCluster, another_commit, temporary_certificates

from pegbt.evaluation.campaign import Cell, trial_specs
from pegbt.evaluation.output import write_cell
from pegbt.evaluation.summary import summarise
from pegbt.evaluation.trial import truth_path

pytestmark = pytest.mark.slow

CELL = Cell("bilateral", "optimized", trials=2, seed=5)  # the shortest variant, one trial per worker
WALL_COLUMNS = {
    "wall_time_s",
    "run_wall_s",
    "log",
    "overruns",
    "compute_waited_s",
    "compute_s",
}  # the machine's


def results(out: Path) -> dict[str, list[dict[str, object]]]:
    """The per-trial and per-transfer CSV rows without wall-clock columns, numbers as floats."""

    def read(name: str) -> list[dict[str, object]]:
        with (out / f"{name}-{CELL.variant}-{CELL.condition}.csv").open() as file:
            return [
                {k: _number(v) for k, v in row.items() if k not in WALL_COLUMNS}
                for row in csv.DictReader(file)
            ]

    return {"trials": read("trials"), "transfers": read("transfers")}


def _number(text: str) -> object:
    try:
        return pytest.approx(float(text), abs=1e-6)
    except ValueError:
        return text


def eval_args(out: Path) -> list[str]:
    return [
        "eval", "--variant", CELL.variant, "--condition", CELL.condition, "--trials", str(CELL.trials),
        "--seed", str(CELL.seed), "--out", str(out), "--json", "--keep-logs",
    ]  # fmt: skip


@pytest.fixture(scope="module")
def local(tmp_path_factory) -> tuple[Path, list[str]]:
    """The cell run by local workers, and the Dask modules that eval imported."""
    out = tmp_path_factory.mktemp("local")
    script = (
        "import sys; from pegbt.cli import main; status = main(sys.argv[1:]); "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')), file=sys.stderr); "
        "raise SystemExit(status)"
    )
    run = subprocess.run(
        [sys.executable, "-c", script, *eval_args(out)],
        check=False,
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    return out, json.loads(run.stderr.strip().splitlines()[-1].replace("'", '"'))


def test_a_local_eval_imports_no_dask(local):
    assert local[1] == []


def test_a_campaign_on_two_workers_gives_the_local_results_seed_for_seed(local, tmp_path, pegbt_cli):
    out = tmp_path / "cluster"
    with LocalDaskCluster(workers=2) as cluster:
        run = pegbt_cli(*eval_args(out), "--cluster", cluster.address, timeout=300)
    assert run.returncode == 0, run.stderr
    assert results(out) == results(local[0])
    assert json.loads(run.stdout)["workers"] == 2
    assert sorted(line.split(":")[0] for line in run.stderr.splitlines() if line.startswith("seed ")) == [
        "seed 5",
        "seed 6",
    ]  # the per-trial progress, as locally
    for seed in CELL.seeds:
        assert (out / "logs" / f"{CELL.name}-{seed}.jsonl").stat().st_size > 0
        assert (out / "logs" / f"{CELL.name}-{seed}.truth.jsonl").stat().st_size > 0


def test_a_campaign_over_tls_on_loopback_gives_the_local_results_seed_for_seed(local, tmp_path, pegbt_cli):
    certificates = temporary_certificates(tmp_path)
    tls = [
        "--tls-ca-file",
        certificates.ca_file,
        "--tls-cert",
        certificates.cert,
        "--tls-key",
        certificates.key,
    ]
    out = tmp_path / "cluster"
    with LocalDaskCluster(workers=2, tls=certificates) as cluster:
        assert cluster.address.startswith("tls://127.0.0.1:")
        run = pegbt_cli(*eval_args(out), "--cluster", cluster.address, *tls, timeout=300)
        (tmp_path / "other").mkdir()
        other = temporary_certificates(tmp_path / "other")  # a CA the cluster does not trust
        stranger = [
            "--tls-ca-file", other.ca_file, "--tls-cert", other.cert, "--tls-key", other.key,
        ]  # fmt: skip
        refused = pegbt_cli(
            *eval_args(tmp_path / "refused"), "--cluster", cluster.address, *stranger, timeout=300
        )
    assert run.returncode == 0, run.stderr
    assert results(out) == results(local[0])
    assert json.loads(run.stdout)["workers"] == 2
    assert "warning" not in run.stderr
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1, refused.stderr
    assert f"cannot reach the Dask scheduler at {cluster.address}" in refused.stderr


def test_a_worker_killed_mid_trial_costs_a_retry_and_the_logs_come_back(local, tmp_path):
    from pegbt.evaluation.cluster import run_trials_on_cluster

    out = tmp_path / "cluster"
    specs = trial_specs(CELL, out, keep_logs=True)
    with LocalDaskCluster(workers=2) as cluster:
        killer = threading.Thread(target=cluster.kill_worker_mid_trial, args=(cluster.workers[0],))
        killer.start()
        records, _ = run_trials_on_cluster(specs, cluster.address, shared=False)  # logs sent back
        killer.join()
        assert cluster.workers[0].poll() is not None  # it did die mid-campaign
    write_cell(out, CELL, records, summarise(CELL, records))
    assert results(out) == results(local[0])
    for spec in specs:
        assert spec.log.read_bytes()[:1] == b"{" and truth_path(spec.log).stat().st_size > 0


def test_a_worker_from_another_commit_is_refused(tmp_path, pegbt_cli):
    checkout = another_commit(tmp_path)
    with LocalDaskCluster(workers=1, pythonpath=checkout) as cluster:
        run = pegbt_cli(*eval_args(tmp_path / "out"), "--cluster", cluster.address, timeout=300)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert "runs pegbt 0.1.0 at commit" in run.stderr and str(checkout) in run.stderr
    assert "start every worker from a checkout of the same commit" in run.stderr
