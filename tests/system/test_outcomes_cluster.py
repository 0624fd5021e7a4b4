"""`pegbt sim2real outcomes --cluster` (and the benchmark's): transfers simulated by a real Dask scheduler's
workers on loopback are, world for world and seed for seed, those local workers simulate; a worker on
another commit is refused, in one line, before any transfer is simulated or kept."""

from __future__ import annotations

import pytest
from cluster_helpers import LocalDaskCluster, another_commit

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.workers import ClusterMapper, LocalMapper

pytestmark = pytest.mark.slow

WORLDS = (WorldEffects(), WorldEffects.of({"peg_compliance": {"deflection": 0.0015}}))
TASKS = [
    (WORLDS, variant, "uncalibrated", seed) for variant in ("unilateral", "bilateral") for seed in (3, 4)
]


def test_transfers_simulated_on_a_cluster_are_the_local_ones() -> None:
    local = LocalMapper(0)(TASKS)
    with LocalDaskCluster(workers=2) as cluster:
        mapper = ClusterMapper(cluster.address)
        try:
            remote = mapper(TASKS)
            parts = list(mapper.parts(TASKS))  # each job handed back once, as it is done
        finally:
            mapper.close()
    assert remote == local
    assert len(remote) == len(TASKS) and all(len(row) == len(WORLDS) for row in remote)
    covered = sorted((i, w) for job, _ in parts for i in job.tasks for w in range(len(WORLDS))[job.worlds])
    assert covered == [(i, w) for i in range(len(TASKS)) for w in range(len(WORLDS))]
    assert all(outcome == [local[i][job.worlds] for i in job.tasks] for job, outcome in parts)


def test_a_worker_from_another_commit_is_refused_before_any_simulation(tmp_path, pegbt_cli):
    checkout = another_commit(tmp_path)
    out = tmp_path / "out"
    with LocalDaskCluster(workers=1, pythonpath=checkout) as cluster:
        run = pegbt_cli(
            "sim2real", "outcomes", "--table", "paper", "--fit", "unilateral", "--out", str(out),
            "--cluster", cluster.address, timeout=300,
        )  # fmt: skip
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert "runs pegbt 0.1.0 at commit" in run.stderr and str(checkout) in run.stderr
    assert not out.exists()
