"""`pegbt sim2real outcomes` as a command: a bad table is refused in one located line, no traceback."""

from __future__ import annotations

from pathlib import Path


def test_a_bad_table_is_one_located_line(tmp_path: Path, pegbt_cli):
    table = tmp_path / "real.csv"
    table.write_text("variant,condition,attempted,succeeded\nunilateral,uncalibrated,10,11\n")
    ran = pegbt_cli("sim2real", "outcomes", table)
    assert ran.returncode == 2
    assert ran.stderr.strip().count("\n") == 0 and f"{table}:2" in ran.stderr and "succeeded" in ran.stderr


def test_neither_real_outcomes_nor_a_table_is_said(pegbt_cli):
    ran = pegbt_cli("sim2real", "outcomes")
    assert ran.returncode == 2 and "--table paper" in ran.stderr and "Traceback" not in ran.stderr
