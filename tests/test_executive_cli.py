"""The executive's commands end to end: `pegbt tree ...`, `pegbt run`, `pegbt log ...`; bad input never shows a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.cli import main

REPO = Path(__file__).resolve().parents[1]
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


def bad_inputs(tmp_path: Path) -> dict[str, Path]:
    files = {
        "empty": "",
        "huge": "tree:\n" + "  # padding\n" * 250_000,
        "wrong types": "tree: {wait: {seconds: [1, 2]}}\nblackboard: 5\n",
        "unknown keys": "tree: {wait: {seconds: 1, speed: 2}}\nextra: 1\n",
        "binary": b"\xff\xfe\x00tree",
        "deep flow nesting": "tree: " + "[" * 50_000,
        "deep block nesting": "tree:\n" + "".join(" " * i + "a:\n" for i in range(1, 400)),
        "tabs": "tree:\n\twait: {seconds: 1}\n",
        "alias bomb": "a: &a [x, x, x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
        "c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c, *c]\n"
        "e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d, *d]\ntree: [*e, *e, *e, *e, *e, *e, *e, *e, *e, *e]\n",
    }
    paths = {}
    for name, content in files.items():
        path = tmp_path / (name.replace(" ", "_") + ".yaml")
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        paths[name] = path
    paths["missing"] = tmp_path / "missing.yaml"
    paths["directory"] = tmp_path
    return paths


def test_bad_tree_files_give_located_errors_never_tracebacks(tmp_path, pegbt_cli):
    paths = bad_inputs(tmp_path)
    result = pegbt_cli("tree", "check", *paths.values())
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and "Traceback" not in result.stdout
    for name, path in paths.items():
        assert f"{path}: " in result.stderr, name
    expectations = {
        "empty": ":1:1: the file is empty",
        "huge": ": file is 3000006 bytes; the limit is 2000000 bytes",
        "wrong types": ":1:15: seconds: /wait: parameter 'seconds' should be a float",
        "unknown keys": ":1:27: speed: /wait: wait has no field 'speed'",
        "binary": ":1:1: not UTF-8 text",
        "deep flow nesting": "nested more than 100 levels deep",
        "deep block nesting": "nested more than 100 levels deep",
        "tabs": ":2:1: YAML syntax",
        "alias bomb": "more than 200000 YAML values",
    }
    for name, expected in expectations.items():
        assert any(
            line.startswith(str(paths[name])) and expected in line for line in result.stderr.splitlines()
        ), (name, result.stderr)
    assert f"{paths['missing']}: file not found" in result.stderr


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


def test_ctrl_c_halts_a_running_tree_and_the_log_records_it(tmp_path, pegbt_cli):
    import json
    import signal
    import time

    tree = tmp_path / "long.yaml"
    tree.write_text("tree: {sequence: [{log: {message: started}}, {wait: {name: long wait, seconds: 60}}]}\n")
    log = tmp_path / "long.jsonl"
    process = pegbt_cli.start("run", tree, "--log", log)
    try:
        deadline = time.monotonic() + 60
        while not (log.exists() and len(log.read_text().splitlines()) >= 2) and time.monotonic() < deadline:
            time.sleep(0.05)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 130, err
    assert "Traceback" not in err and "pegbt: interrupted by SIGINT" in err
    assert "HALTED   /sequence/long wait  (waiting 60 s)" in out
    records = [json.loads(line) for line in log.read_text().splitlines()]
    assert records[-2]["type"] == "halt" and records[-2]["reason"] == "interrupt"
    assert [2, "RUNNING", "INVALID", "waiting 60 s"] in records[-2]["changes"]
    assert records[-1]["outcome"] == "interrupted"


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
