"""The executive's commands as real processes: bad tree files give located errors, never tracebacks; Ctrl-C
halts a running tree and the log records it."""

from __future__ import annotations

from pathlib import Path


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
