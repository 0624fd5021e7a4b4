"""`pegbt bench sim2real-outcomes --seeds N [--first-seed K] --families A,B [--out DIR]`: a reduced benchmark the command
line states, each bad choice one clear line."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.bench import sim2real_outcomes
from pegbt.bench.outcomes_records import RECORDS, Records, code_identity
from pegbt.cli import main


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--families", "peg_compliance,nope"], "--families: unknown families nope"),
        (["--seeds", "0"], "--seeds: expected at least 1 seed"),
        (["--first-seed", "-1"], "--first-seed: expected a seed of 0 or more"),
        (["--first-seed", "88", "--seeds", "3"], "--first-seed: seeds run to 90, beyond 89"),
        (["--workers", "0"], "--workers: expected at least 1 worker"),
        (["--workers", "3", "--cluster", "tcp://127.0.0.1:1"], "--workers: --workers sizes the local pool"),
    ],
)
def test_a_bad_size_is_one_clear_line(
    argv: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", "sim2real-outcomes", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1


@pytest.mark.parametrize(
    "option",
    [
        ["--seeds", "1"],
        ["--first-seed", "4"],
        ["--workers", "4"],
        ["--cluster", "tcp://127.0.0.1:1"],
        ["--cluster", "bad", "--tls-ca-file", "x"],  # named as the benchmark's alone, not checked first
        ["--tls-key", "x"],
        ["--out", "x"],
    ],
)
def test_the_size_options_belong_to_sim2real_outcomes_alone(
    option: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", "world", *option]) == 2
    assert f"{option[0]}: " in capsys.readouterr().err


def test_the_reduced_run_measures_the_families_and_seeds_asked_for(monkeypatch: pytest.MonkeyPatch) -> None:
    asked = []
    monkeypatch.setattr(
        sim2real_outcomes, "measure", lambda families, seeds, *_, **__: asked.append((families, seeds)) or {}
    )
    assert main(["bench", "sim2real-outcomes", "--seeds", "2", "--families", "null,peg_compliance"]) == 0
    assert asked == [(["null", "peg_compliance"], 2)]
    first: list[int] = []
    monkeypatch.setattr(
        sim2real_outcomes, "measure", lambda *_, first_seed=0, **__: first.append(first_seed) or {}
    )
    assert (
        main(["bench", "sim2real-outcomes", "--seeds", "1", "--first-seed", "4", "--families", "null"]) == 0
    )
    assert first == [4]
    monkeypatch.setattr(
        sim2real_outcomes, "measure", lambda families, seeds, *_, **__: asked.append((families, seeds)) or {}
    )
    figures = sim2real_outcomes.run()
    assert asked[-1] == (list(sim2real_outcomes.FAMILIES), sim2real_outcomes.SEEDS)
    assert figures["full_size"] == "true"


def test_out_keeps_the_run_in_the_folder_under_this_codes_identity(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    kept: list[Records | None] = []
    monkeypatch.setattr(
        sim2real_outcomes, "measure", lambda *_, records=None, **__: kept.append(records) or {}
    )
    assert (
        main(["bench", "sim2real-outcomes", "--seeds", "1", "--families", "null", "--out", str(tmp_path)])
        == 0
    )
    (records,) = kept
    assert (
        records is not None
        and records.path == tmp_path / RECORDS.format(code_identity()[:16])
        and records.code == code_identity()
    )


def test_workers_and_a_cluster_reach_the_simulator(monkeypatch: pytest.MonkeyPatch) -> None:
    """`--workers K` sizes the local pool; `--cluster ADDRESS` simulates on that scheduler instead, its
    client closed when the run ends."""
    asked: list[tuple[int, object]] = []
    monkeypatch.setattr(
        sim2real_outcomes,
        "measure",
        lambda families, seeds, real, settings, workers, simulator, **_: (
            asked.append((workers, simulator)) or {}
        ),
    )
    opened: list[FakeCluster] = []

    class FakeCluster:
        def __init__(self, address: str, tls: object = None) -> None:
            self.address, self.closed = address, False
            opened.append(self)

        def close(self) -> None:
            self.closed = True

    monkeypatch.setattr(sim2real_outcomes, "ClusterMapper", FakeCluster)
    assert main(["bench", "sim2real-outcomes", "--families", "null", "--seeds", "1", "--workers", "4"]) == 0
    assert asked == [(4, None)]
    address = "tcp://127.0.0.1:8786"
    assert (
        main(["bench", "sim2real-outcomes", "--families", "null", "--seeds", "1", "--cluster", address]) == 0
    )
    (cluster,) = opened
    assert asked[-1] == (2, cluster) and cluster.address == address and cluster.closed
