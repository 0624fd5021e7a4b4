"""`pegbt bench sim2real-outcomes --out DIR` keeps its plan, scores and simulated transfers as they
complete, resumes from them with the same code, never mixes in another code's scores, reuses transfers
only of the same simulator, and survives a line torn by a killed run."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import pytest

from pegbt.bench import sim2real_outcomes as bench
from pegbt.bench.outcomes_records import (
    RECORDS,
    ROOT,
    SIMULATOR,
    TRANSFERS,
    Records,
    StoredMemo,
    code_identity,
    imported_sources,
    simulator_identity,
)
from pegbt.errors import PegbtError
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import workers
from pegbt.sim2real.outcomes.cells import Outcomes
from pegbt.sim2real.outcomes.diagnose import Diagnosis
from pegbt.sim2real.outcomes.transfer_result import TransferResult
from tests.outcomes_helpers import fake_mapper

FAMILIES = ["peg_compliance", "null"]
PER_RUN = ("wall_s", "cpu_s", "transfers_simulated")  # this run's own costs, not the records'


class Counting:
    """The stand-in simulator, counting the transfers asked of it."""

    def __init__(self) -> None:
        self.transfers = 0

    def __call__(
        self, tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]]
    ) -> list[list[TransferResult]]:
        self.transfers += sum(len(worlds) for worlds, *_ in tasks)
        return fake_mapper(tasks)


def _measure(
    seeds: int, records: Records | None, simulator: Counting, first_seed: int = 0
) -> dict[str, float | int | str]:
    return bench.measure(
        FAMILIES, seeds, 12, bench.SETTINGS, simulator=simulator, records=records, first_seed=first_seed
    )


def _same(a: dict[str, float | int | str], b: dict[str, float | int | str]) -> None:
    assert a.keys() == b.keys()
    for key in a:
        if key not in PER_RUN:
            x, y = a[key], b[key]
            assert x == y or (
                isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y)
            ), key


def test_a_rerun_simulates_only_the_missing_seeds_and_gives_the_uninterrupted_figures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One seed kept, then two asked for: the pilot is not run again, only seed 1 is diagnosed, and the
    figures are those of a run of two seeds straight through."""
    straight = _measure(2, None, Counting())
    _measure(1, Records(tmp_path, FAMILIES, "code"), Counting())
    diagnosed: list[Outcomes] = []
    diagnose = bench.diagnose

    def counted(outcomes: Outcomes, *args: object) -> Diagnosis:
        diagnosed.append(outcomes)
        return diagnose(outcomes, *args)  # type: ignore[arg-type]

    def no_pilot(*args: object) -> None:
        raise AssertionError("the pilot ran again")

    monkeypatch.setattr(bench, "diagnose", counted)
    monkeypatch.setattr(bench, "plan", no_pilot)
    resumed = _measure(2, Records(tmp_path, FAMILIES, "code"), Counting())
    assert [o.source for o in diagnosed] == ["concealed world, seed 1"] * len(FAMILIES)
    _same(resumed, straight)
    diagnosed.clear()
    again = _measure(2, Records(tmp_path, FAMILIES, "code"), simulator := Counting())
    assert not diagnosed and simulator.transfers == 0
    _same(again, straight)


def test_a_run_split_by_first_seed_gives_the_figures_of_one_run(tmp_path: Path) -> None:
    """Seed 1 run alone (`--first-seed 1`) on another machine, its records appended to those of seed 0:
    the two seeds asked for again simulate nothing and give the figures of one run straight through."""
    straight = _measure(2, None, Counting())
    alone = _measure(1, None, Counting(), first_seed=1)
    assert alone["seed_range"] == "1-1" and straight["seed_range"] == "0-1"
    _measure(1, Records(tmp_path / "a", FAMILIES, "code"), Counting())
    _measure(1, Records(tmp_path / "b", FAMILIES, "code"), Counting(), first_seed=1)
    name = RECORDS.format("code")
    seed1 = (tmp_path / "b" / name).read_text().splitlines()[1:]  # its scores, not its plan again
    with (tmp_path / "a" / name).open("a") as merged:
        merged.write("".join(line + "\n" for line in seed1))
    again = _measure(2, Records(tmp_path / "a", FAMILIES, "code"), simulator := Counting())
    assert simulator.transfers == 0
    _same(again, straight)


def test_a_diagnosis_a_stopped_run_left_unfinished_costs_its_rerun_no_simulation(tmp_path: Path) -> None:
    """Killed after its transfers were simulated but before any score was kept: the rerun diagnoses every
    family again from the kept transfers, asks the simulator for none, and gives the same figures."""
    straight = _measure(1, None, Counting())
    _measure(1, Records(tmp_path, FAMILIES, "code"), Counting())
    path = tmp_path / RECORDS.format("code")
    path.write_text(path.read_text().splitlines()[0] + "\n")  # the plan only: the scores never written
    resumed = _measure(1, Records(tmp_path, FAMILIES, "code"), simulator := Counting())
    assert simulator.transfers == 0
    _same(resumed, straight)


def _never(tasks: object) -> list[list[TransferResult]]:
    raise AssertionError("simulated a transfer the store holds")


WORLDS = (
    WorldEffects(),
    WorldEffects.of({"peg_compliance": {"deflection": 0.0012}}),
    WorldEffects.of(
        {"peg_compliance": {"deflection": 0.0012}, "chamfer_capture": {"capture_radius": 0.0032}}
    ),
)


def test_stored_transfers_read_back_as_simulated_and_a_torn_last_batch_is_dropped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tasks = [
        (WORLDS, v, c, seed)
        for v in ("unilateral", "handover")
        for c in ("uncalibrated",)
        for seed in range(5)
    ]
    simulated = StoredMemo(fake_mapper, tmp_path, "aaa")(tasks)
    with (tmp_path / TRANSFERS.format("aaa")).open("a") as file:
        file.write('{"kind": "transfers", "worlds": [{}], "rows": [[0, "unil')
    stored = StoredMemo(_never, tmp_path, "aaa")
    assert "torn last line" in capsys.readouterr().err
    assert stored.stored == len(tasks) * len(WORLDS)
    assert stored(tasks) == simulated and stored.simulated == 0
    assert StoredMemo(fake_mapper, tmp_path, "bbb").stored == 0  # another simulator's transfers are not its


def test_records_of_other_code_lie_beside_and_are_never_read(tmp_path: Path) -> None:
    Records(tmp_path, FAMILIES, "aaa").save_plan({}, 0)
    other = Records(tmp_path, FAMILIES, "bbb")
    assert other.plan is None and not other.scores
    other.save_plan({}, 5)
    assert Records(tmp_path, FAMILIES, "aaa").plan["pilot_transfers"] == 0  # type: ignore[index]


def test_a_line_of_other_code_in_a_codes_file_is_an_error_naming_folder_line_and_both_identities(
    tmp_path: Path,
) -> None:
    Records(tmp_path, FAMILIES, "aaa").save_plan({}, 0)
    path = tmp_path / RECORDS.format("aaa")
    path.write_text(path.read_text().replace('"aaa"', '"ccc"'))
    with pytest.raises(PegbtError, match=rf"{tmp_path}.*ccc.*aaa") as error:
        Records(tmp_path, FAMILIES, "aaa")
    assert (error.value.file, error.value.line) == (str(path), 1)


def test_a_rerun_of_other_families_is_refused(tmp_path: Path) -> None:
    Records(tmp_path, FAMILIES, "aaa").save_plan({}, 0)
    with pytest.raises(PegbtError, match="families"):
        Records(tmp_path, ["null"], "aaa")


def test_a_torn_last_line_is_dropped_with_a_message_and_the_next_record_starts_a_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    records = Records(tmp_path, FAMILIES, "aaa")
    records.save_plan({}, 7)
    records.save_score("null", 0, {"named": 0.0, "error": math.nan}, 5)
    with (tmp_path / RECORDS.format("aaa")).open("a") as file:
        file.write('{"kind": "score", "family": "null", "se')
    resumed = Records(tmp_path, FAMILIES, "aaa")
    assert "torn last line" in capsys.readouterr().err
    assert resumed.plan is not None and resumed.plan["pilot_transfers"] == 7
    assert list(resumed.scores) == [("null", 0)] and math.isnan(resumed.scores[("null", 0)]["score"]["error"])
    resumed.save_score("null", 1, {"named": 0.0}, 3)
    assert list(Records(tmp_path, FAMILIES, "aaa").scores) == [("null", 0), ("null", 1)]


def test_a_bad_line_before_the_last_is_an_error_naming_its_line(tmp_path: Path) -> None:
    (tmp_path / RECORDS.format("aaa")).write_text('{"kind": "plan"\n{"kind": "score"}\n')
    with pytest.raises(PegbtError) as error:
        Records(tmp_path, FAMILIES, "aaa")
    assert (error.value.file, error.value.line) == (str(tmp_path / RECORDS.format("aaa")), 1)


def test_a_score_missing_a_field_is_an_error_naming_its_line_not_a_key_error(tmp_path: Path) -> None:
    (tmp_path / RECORDS.format("aaa")).write_text(
        '{"kind": "score", "family": "null", "code": "aaa"}\n{"kind": "plan"}\n'
    )
    with pytest.raises(PegbtError) as error:
        Records(tmp_path, FAMILIES, "aaa")
    assert (error.value.file, error.value.line) == (str(tmp_path / RECORDS.format("aaa")), 1)
    assert "all its fields" in str(error.value)


def test_the_code_identity_changes_with_a_source_data_or_a_tree_and_nothing_else(tmp_path: Path) -> None:
    for path, text in {
        "pegbt/a.py": "x = 1\n",
        "pegbt/physics/presets/arm.json": "{}\n",
        "trees/t.yaml": "a: 1\n",
        "skills/s.yaml": "b: 2\n",
    }.items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    first = code_identity(tmp_path)
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "guide.md").write_text("notes\n")
    assert code_identity(tmp_path) == first
    (tmp_path / "trees" / "t.yaml").write_text("a: 2\n")
    assert code_identity(tmp_path) != first
    second = code_identity(tmp_path)
    (tmp_path / "pegbt/physics/presets/arm.json").write_text('{"k": 1}\n')
    assert code_identity(tmp_path) != second


SOURCES = {
    "pegbt/__init__.py": "",
    "pegbt/sim/__init__.py": "",
    "pegbt/sim/run.py": "from pegbt.sim import world\n\ndef later():\n    from .faults import slip\n",
    "pegbt/sim/world.py": "import math\n",
    "pegbt/sim/faults.py": "slip = 1\n",
    "pegbt/fit.py": "from pegbt.sim import run\n",
    "pegbt/presets/arm.json": "{}\n",
    "skills/s.yaml": "b: 2\n",
}


@pytest.mark.parametrize(
    ("edited", "moves"),
    [
        ("pegbt/sim/run.py", True),
        ("pegbt/sim/world.py", True),  # imported at module level
        ("pegbt/sim/faults.py", True),  # imported relatively, inside a function that may never run
        ("pegbt/sim/__init__.py", True),  # the package it is in
        ("pegbt/presets/arm.json", True),
        ("skills/s.yaml", True),
        ("pegbt/fit.py", False),  # imports the simulator, is not imported by it: the diagnosis
    ],
)
def test_the_simulator_identity_moves_with_what_a_transfer_imports_or_reads_only(
    tmp_path: Path, edited: str, moves: bool
) -> None:
    for path, text in SOURCES.items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    first = simulator_identity(tmp_path, "pegbt.sim.run")
    (tmp_path / edited).write_text(SOURCES[edited] + "# edited\n")
    assert (simulator_identity(tmp_path, "pegbt.sim.run") != first) is moves


def test_the_simulator_identity_leaves_out_the_diagnosis() -> None:
    """The benchmark's transfers stay valid across changes to the fit, gate and predictions and to how jobs
    are spread over workers: none of them is among what the phase simulator's entry imports."""
    imported = {p.relative_to(ROOT).as_posix() for p in imported_sources(ROOT, SIMULATOR)}
    assert "pegbt/sim2real/outcomes/phasesim.py" in imported and "pegbt/sim/world.py" in imported
    for diagnosis in ("diagnose", "fit", "gate", "predict", "likelihood", "workers"):
        assert f"pegbt/sim2real/outcomes/{diagnosis}.py" not in imported


def test_a_batch_is_kept_a_job_at_a_time_so_a_run_killed_inside_it_keeps_the_jobs_done(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    tasks = [((WORLDS[1],), "bilateral", "uncalibrated", seed) for seed in range(10)]  # a job each
    calls: list[int] = []

    def killed_on_the_third_job(
        part: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]], attempts: int, registered: bool
    ) -> list[list[TransferResult]]:
        calls.append(len(part))
        if len(calls) == 3:
            raise KeyboardInterrupt
        return fake_mapper(part)

    monkeypatch.setattr(workers, "run_job", killed_on_the_third_job)
    memo = StoredMemo(workers.LocalMapper(0), tmp_path, "aaa")
    with pytest.raises(KeyboardInterrupt):
        memo(tasks)
    assert calls == [1, 1, 1]
    assert StoredMemo(_never, tmp_path, "aaa").stored == 2
