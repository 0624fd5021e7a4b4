"""`pegbt sim2real outcomes` end to end: a tiny campaign's tick logs (and nothing else) read into cells,
diagnosed against the phase simulator, and the report written."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

pytestmark = [pytest.mark.system, pytest.mark.slow]


def test_tick_logs_of_a_campaign_are_diagnosed_from_the_logs_alone(tmp_path: Path, pegbt_cli):
    ran = pegbt_cli(
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
        timeout=900,
    )
    assert ran.returncode == 0, ran.stderr
    real = tmp_path / "real"
    real.mkdir()
    logs = [p for p in (tmp_path / "eval").rglob("*.jsonl") if not p.name.endswith(".truth.jsonl")]
    assert logs
    for log in logs:
        shutil.copy(log, real / log.name)
    out = tmp_path / "report"
    diagnosed = pegbt_cli(
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
        timeout=900,
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
