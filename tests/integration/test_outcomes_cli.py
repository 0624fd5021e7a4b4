"""`pegbt sim2real outcomes` end to end: a tiny campaign's tick logs (and nothing else) read into cells,
diagnosed against the phase simulator, and the report written; bad tables refused in one located line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def pegbt(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
    }
    return subprocess.run(
        [sys.executable, "-m", "pegbt", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=900
    )


def test_tick_logs_of_a_campaign_are_diagnosed_from_the_logs_alone(tmp_path: Path):
    ran = pegbt(
        "eval",
        "--variant",
        "unilateral",
        "--condition",
        "uncalibrated",
        "--trials",
        "1",
        "--seed",
        "5",
        "--workers",
        "1",
        "--keep-logs",
        "--quiet",
        "--json",
        "--out",
        str(tmp_path / "eval"),
        cwd=tmp_path,
    )
    assert ran.returncode == 0, ran.stderr
    real = tmp_path / "real"
    real.mkdir()
    logs = [p for p in (tmp_path / "eval").rglob("*.jsonl") if not p.name.endswith(".truth.jsonl")]
    assert logs
    for log in logs:
        shutil.copy(log, real / log.name)
    out = tmp_path / "report"
    diagnosed = pegbt(
        "sim2real",
        "outcomes",
        str(real),
        "--transfers",
        "2",
        "--located",
        "2",
        "--points",
        "2",
        "--workers",
        "0",
        "--out",
        str(out),
        "--json",
        cwd=tmp_path,
    )
    assert diagnosed.returncode == 0, diagnosed.stderr
    report = json.loads((out / "report.json").read_text())
    (cell,) = report["cells"]
    assert (cell["variant"], cell["condition"]) == ("unilateral", "uncalibrated")
    assert cell["real"]["attempted"] == 12
    failed = cell["real"]["attempted"] - cell["real"]["succeeded"]
    assert sum(cell["real"].get("failures", {}).values()) == failed
    assert 0.0 <= cell["simulated_before"] <= 1.0 and cell["held_out"] is False
    assert (out / "report.md").exists() and (out / "outcomes.png").stat().st_size > 0
    assert json.loads(diagnosed.stdout)["cells"] == report["cells"]


def test_a_bad_table_is_one_located_line(tmp_path: Path):
    table = tmp_path / "real.csv"
    table.write_text("variant,condition,attempted,succeeded\nunilateral,uncalibrated,10,11\n")
    ran = pegbt("sim2real", "outcomes", str(table), cwd=tmp_path)
    assert ran.returncode == 2
    assert ran.stderr.strip().count("\n") == 0 and f"{table}:2" in ran.stderr and "succeeded" in ran.stderr
