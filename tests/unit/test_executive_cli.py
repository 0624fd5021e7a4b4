"""The executive's commands end to end: `pegbt tree ...`, `pegbt run`, `pegbt log ...`; bad input never shows a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.cli import main

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "trees" / "example.yaml"


def test_run_example_writes_a_log_that_the_log_commands_read(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # the default log goes to runs/ under the working directory
    assert main(["run", str(EXAMPLE), "--clock", "manual", "--period", "0.01"]) == 0
    out = capsys.readouterr().out
    assert (
        "FAILURE  /example/both arms/transfer PSM1/transfer with PSM1/pick, re-sense on failure/pick  (jaw of PSM1 closed on nothing)"
        in out
    )
    assert "outcome: success in 0.210 s, 7 ticks" in out  # waits need no ticks of their own
    logs = list((tmp_path / "runs").glob("example-*.jsonl"))
    assert len(logs) == 1
    assert f"tick log: runs/{logs[0].name}" in out
    assert main(["log", "why", str(logs[0])]) == 0 and "it helped" in capsys.readouterr().out
    assert main(["log", "replay", str(logs[0]), "--tick", "2"]) == 0
    assert "[F] pick  -- jaw of PSM1 closed on nothing" in capsys.readouterr().out


def test_tree_check_reports_every_error_and_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "tree:\n  sequence:\n    - wait: {seconds: x}\n    - lgo: {message: hi}\n    - retry: {child: wait}\n"
    )
    assert main(["tree", "check", str(EXAMPLE), str(bad)]) == 2
    out, err = capsys.readouterr()
    assert f"{EXAMPLE}: ok" in out
    lines = err.strip().splitlines()
    assert [line.split(":")[1] for line in lines[:-1]] == ["3", "4", "5", "5"]
    assert "did you mean 'log'" in lines[1]
    assert lines[-1] == f"{bad}: 4 error(s)"


def test_run_refuses_bad_input_in_one_line(tmp_path, capsys):
    failing = tmp_path / "fail.yaml"
    failing.write_text("tree: {scripted: {outcomes: [failure], message: no luck}}\n")
    assert (
        main(["run", str(failing), "--clock", "manual", "--log", str(tmp_path / "fail.jsonl"), "--quiet"])
        == 1
    )
    assert "outcome: failure" in capsys.readouterr().out
    assert main(["run", str(failing), "--period", "0"]) == 2
    assert capsys.readouterr().err.strip() == "pegbt: error: --period: must be a finite number > 0, got 0"
    assert main(["run", str(tmp_path / "nothing.yaml")]) == 2
    assert "file not found" in capsys.readouterr().err
    corrupt = tmp_path / "corrupt.jsonl"
    text = (tmp_path / "fail.jsonl").read_text()
    corrupt.write_text(text[:-20])
    for command in ("summary", "why"):
        assert main(["log", command, str(corrupt)]) == 0
        assert (
            capsys.readouterr()
            .err.strip()
            .startswith(f"pegbt: warning: {corrupt}: line {text.count(chr(10))} was cut short")
        )
    corrupt.write_text(text[:-20] + "\n")  # a complete line that is not a record is still refused
    assert main(["log", "summary", str(corrupt)]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"pegbt: error: {corrupt}:{text.count(chr(10))}:") and "corrupt record" in error


def test_tree_show_schema_and_dot(tmp_path, capsys):
    assert main(["tree", "show", str(EXAMPLE)]) == 0
    out = capsys.readouterr().out
    assert "{-} example" in out and "-^- transfer PSM2" in out
    dot = tmp_path / "example.dot"
    assert main(["tree", "show", str(EXAMPLE), "--dot", str(dot)]) == 0
    assert dot.read_text().startswith("digraph") and '"transfer PSM1"' in dot.read_text()
    assert main(["tree", "schema"]) == 0
    schema = capsys.readouterr().out
    for word in (
        "recover [main, recovery]",
        "guard [child]",
        "scripted --",
        "seconds: float, required, >= 0, <= 86400, $key allowed",
    ):
        assert word in schema


@pytest.mark.parametrize("argv", [["log", "replay", "x.jsonl"], ["tree"], ["run"]])
def test_usage_errors_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as raised:
        main(argv)
    assert raised.value.code == 2


def test_run_provides_declared_resources_and_closes_them(tmp_path, monkeypatch, capsys):
    from executive_helpers import Counter

    from pegbt.executive import providers

    tree = tmp_path / "uses.yaml"
    tree.write_text("tree:\n  sequence: [{test_counting: {name: count}}]\nblackboard: {step: 41}\n")
    argv = [
        "run",
        str(tree),
        "--clock",
        "manual",
        "--quiet",
        "--log",
        str(tmp_path / "uses.jsonl"),
        "--seed",
        "7",
    ]
    assert main(argv) == 2
    assert (
        f"no provider for resource 'counter' (needed by /sequence/count at {tree}:2:14)"
        in capsys.readouterr().err
    )
    monkeypatch.setitem(providers.RESOURCE_PROVIDERS, "counter", "executive_helpers:Counter")
    Counter.instances.clear()
    assert main(argv) == 0
    (counter,) = Counter.instances
    assert counter.uses == 1 and counter.closed and counter.clock.__class__.__name__ == "ManualClock"
    assert (
        counter.options["seed"] == 7 and counter.options["condition"] == "optimized"
    )  # every run option, defaults filled
    assert '"bb":{"/step":41,"/uses":42}' in (tmp_path / "uses.jsonl").read_text()
    assert main(["run", str(tree), "--clock", "sundial"]) == 2
    assert "unknown clock 'sundial'; known: wall, manual" in capsys.readouterr().err
