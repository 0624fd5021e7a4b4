"""`pegbt run`'s console, `pegbt log plot`, `pegbt eval`'s trial figures, and the monitor's world on the simulator."""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree

import matplotlib.image
import PIL.Image
import pytest

from pegbt.cli import main
from pegbt.evaluation.campaign import Cell
from pegbt.evaluation.figures import plot_trial_figures, trial_rows
from pegbt.evaluation.output import write_cell
from pegbt.evaluation.trial import TrialRecord
from pegbt.executive.analysis import node_stats
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.logplot import running_spans

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "trees" / "example.yaml"


def test_run_prints_failures_and_recoveries_and_every_leaf_only_when_verbose(tmp_path, capsys):
    log = tmp_path / "example.jsonl"
    assert main(["run", str(EXAMPLE), "--clock", "manual", "--log", str(log)]) == 0
    quiet = capsys.readouterr().out
    assert (
        "FAILURE  /example/both arms/transfer PSM1/transfer with PSM1/pick, re-sense on failure/pick" in quiet
    )
    assert "RECOVER  /example/both arms/transfer PSM1/transfer with PSM1/pick, re-sense on failure\n" in quiet
    assert "SUCCESS  /example/start" not in quiet
    assert main(["run", str(EXAMPLE), "--clock", "manual", "--log", str(log), "--verbose"]) == 0
    verbose = capsys.readouterr().out
    assert "SUCCESS  /example/start  (starting the example run)" in verbose
    assert "RECOVER  " in verbose and "FAILURE  " in verbose


def test_a_check_that_answers_no_is_not_printed_as_a_failure_but_a_leaf_that_fails_is(tmp_path, capsys):
    tree = tmp_path / "checks.yaml"
    tree.write_text(
        """tree:
  sequence:
    name: checks
    children:
      - selector:
          name: registered or register
          children:
            - check_blackboard: {name: already registered, key: registered, value: true}
            - set_blackboard: {name: register, key: registered, value: true}
      - selector:
          name: try then fall back
          children:
            - scripted: {name: first try, outcomes: [failure]}
            - log: {name: fall back, message: fell back}
"""
    )
    log = tmp_path / "checks.jsonl"
    assert main(["run", str(tree), "--clock", "manual", "--log", str(log)]) == 0
    quiet = capsys.readouterr().out
    assert "/already registered" not in quiet
    assert "FAILURE  /checks/try then fall back/first try" in quiet
    assert main(["run", str(tree), "--clock", "manual", "--log", str(log), "--verbose"]) == 0
    assert "FAILURE  /checks/registered or register/already registered" in capsys.readouterr().out


def test_log_plot_shows_each_leaf_for_as_long_as_log_summary_says_it_ran(tmp_path, capsys):
    log = tmp_path / "example.jsonl"
    main(["run", str(EXAMPLE), "--clock", "manual", "--period", "0.01", "--log", str(log), "--quiet"])
    parsed = read_tick_log(log)
    stats = node_stats(parsed)
    drawn: dict[int, float] = {}
    for node, start, end in running_spans(parsed):
        drawn[node] = drawn.get(node, 0.0) + end - start
    leaves = [node["id"] for node in parsed.nodes if not parsed.children(node["id"])]
    assert {node: pytest.approx(stats[node].running_time) for node in leaves if stats[node].running_time} == {
        node: time for node, time in drawn.items() if time
    }
    capsys.readouterr()
    assert main(["log", "plot", str(log)]) == 0
    assert capsys.readouterr().out == f"wrote {log.with_suffix('.png')}\n"
    image = matplotlib.image.imread(log.with_suffix(".png"))
    assert image.shape[0] > 200 and image.shape[1] > 1000


def test_log_plot_writes_the_format_out_names_and_refuses_one_it_cannot(tmp_path, capsys):
    log = tmp_path / "example.jsonl"
    main(["run", str(EXAMPLE), "--clock", "manual", "--log", str(log), "--quiet"])
    capsys.readouterr()
    assert main(["log", "plot", str(log), "--out", str(tmp_path / "timeline.foo")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pegbt: error: {tmp_path / 'timeline.foo'}") and "--out" in err and "png" in err
    assert not (tmp_path / "timeline.foo").exists()
    bare = tmp_path / "timeline"
    assert main(["log", "plot", str(log), "--out", str(bare)]) == 0
    assert capsys.readouterr().out == f"wrote {bare}\n"
    with PIL.Image.open(bare) as image:  # written where it says, not at timeline.png
        assert image.format == "PNG"
    assert main(["log", "plot", str(log), "--out", str(tmp_path / "timeline.svg")]) == 0
    assert ElementTree.parse(tmp_path / "timeline.svg").getroot().tag == "{http://www.w3.org/2000/svg}svg"


def test_eval_trial_figures_read_every_cell_written(tmp_path):
    cell = Cell("unilateral", "optimized", 3)
    records = [
        TrialRecord(
            "unilateral",
            "optimized",
            seed,
            "success" if done == 12 else "failure",
            transfers_attempted=12,
            transfers_succeeded=done,
            trial_time_s=50.0 + seed,
            arm_arm_collisions=seed,
            tip_path_m=2.5 + 0.1 * seed,
        )
        for seed, done in enumerate((12, 9, 12))
    ]
    write_cell(tmp_path, cell, records, {})
    rows = trial_rows(tmp_path)
    assert list(rows) == [("unilateral", "optimized")]
    assert [row["success"] for row in rows[("unilateral", "optimized")]] == [100.0, 75.0, 100.0]
    assert [row["arm_arm_collisions"] for row in rows[("unilateral", "optimized")]] == [0.0, 1.0, 2.0]
    image = matplotlib.image.imread(plot_trial_figures(tmp_path))
    assert image.shape[0] > 800


def test_a_failing_world_view_stops_itself_not_the_run(caplog):
    from pegbt.monitor.world import WorldSampler

    class BrokenArm:
        @property
        def measured_js(self):
            raise RuntimeError("no joints here")

    class Robot:
        arms = {"PSM1": BrokenArm()}
        truth = None
        link = None

    samples = []
    sampler = WorldSampler(Robot(), [samples.append])
    tick = {"type": "tick", "n": 1, "t": 0.0, "changes": []}
    sampler(tick)
    sampler({**tick, "n": 2, "t": 1.0})
    assert sampler.broken and samples == []
    assert "RuntimeError: no joints here" in caplog.text
