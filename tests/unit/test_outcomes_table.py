"""Outcome tables: the paper's built in, YAML and CSV read, every error located by file, line and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.sim2real.outcomes.table import paper_table, read_table


def test_the_paper_table_holds_the_reference_counts_and_times():
    table = paper_table()
    assert table.attempts_end_at_lost_block
    assert len(table.cells) == 9
    uni = table.cell("unilateral", "uncalibrated")
    assert uni is not None and (uni.succeeded, uni.attempted, uni.mean_transfer_s) == (26, 75, 5.6)
    assert [(c.succeeded, c.attempted) for c in table.cells if c.condition == "uncalibrated"] == [
        (26, 75),
        (37, 68),
        (14, 79),
    ]
    assert all((c.succeeded, c.attempted) == (120, 120) for c in table.cells if c.condition != "uncalibrated")


def test_a_yaml_table_with_phases_reads(tmp_path: Path):
    path = tmp_path / "t.yaml"
    path.write_text(
        "counting: until_lost\ncells:\n"
        "  - {variant: unilateral, condition: uncalibrated, attempted: 20, succeeded: 8, mean_transfer_s: 5.1,\n"
        "     failures: {lift: 10, lower: 2}}\n"
    )
    table = read_table(path)
    cell = table.cells[0]
    assert table.attempts_end_at_lost_block
    assert cell.failures == {"lift": 10, "lower": 2} and cell.rate == 0.4


def test_a_csv_table_reads(tmp_path: Path):
    path = tmp_path / "t.csv"
    path.write_text("variant,condition,attempted,succeeded,failures_lift\nbilateral,uncalibrated,68,37,31\n")
    cell = read_table(path).cells[0]
    assert (cell.variant, cell.attempted, cell.succeeded, dict(cell.failures)) == (
        "bilateral",
        68,
        37,
        {"lift": 31},
    )


@pytest.mark.parametrize(
    ("text", "line", "field"),
    [
        (
            "cells:\n  - {variant: sideways, condition: uncalibrated, attempted: 3, succeeded: 1}\n",
            2,
            "cells[0].variant",
        ),
        (
            "cells:\n  - {variant: bilateral, condition: uncalibrated, attempted: 3, succeeded: 4}\n",
            2,
            "succeeded",
        ),
        (
            "cells:\n  - {variant: bilateral, condition: uncalibrated, attempted: 3, succeeded: 1,\n     failures: {wobble: 1}}\n",
            3,
            "cells[0].failures.wobble",
        ),
        (
            "cells:\n  - {variant: bilateral, condition: uncalibrated, attempted: 3, succeeded: 1}\n"
            "  - {variant: bilateral, condition: uncalibrated, attempted: 3, succeeded: 1}\n",
            3,
            "variant",
        ),
        (
            "cells:\n  - {variant: bilateral, condition: uncalibrated, attempted: -3, succeeded: 1}\n",
            2,
            "cells[0].attempted",
        ),
    ],
)
def test_yaml_errors_name_line_and_field(tmp_path: Path, text: str, line: int, field: str):
    path = tmp_path / "t.yaml"
    path.write_text(text)
    with pytest.raises(PegbtError) as caught:
        read_table(path)
    assert caught.value.file == str(path) and caught.value.line == line and caught.value.field == field


@pytest.mark.parametrize(
    ("text", "line", "field"),
    [
        ("variant,condition,attempted,succeeded\nbilateral,uncalibrated,x,1\n", 2, "attempted"),
        ("variant,condition,attempted,succeeded,colour\nbilateral,uncalibrated,3,1,red\n", 1, "colour"),
        ("variant,condition,attempted\nbilateral,uncalibrated,3\n", 1, "succeeded"),
        (
            "variant,condition,attempted,succeeded,mean_transfer_s\nbilateral,uncalibrated,3,1,nan\n",
            2,
            "mean_transfer_s",
        ),
        (
            "variant,condition,attempted,succeeded\nbilateral,uncalibrated,3,1\nbilateral,wobbly,3,1\n",
            3,
            "condition",
        ),
        (
            "variant,condition,attempted,succeeded\nbilateral,uncalibrated," + "9" * 5000 + ",1\n",
            2,
            "attempted",
        ),
        ("variant,condition,attempted,succeeded\nbilateral,uncalibrated,3,\u00b2\n", 2, "succeeded"),
        ("variant,condition,attempted,succeeded\nbilateral,uncali\rbrated,3,1\n", 2, None),
    ],
)
def test_csv_errors_name_line_and_field(tmp_path: Path, text: str, line: int, field: str):
    path = tmp_path / "t.csv"
    path.write_text(text)
    with pytest.raises(PegbtError) as caught:
        read_table(path)
    assert caught.value.line == line and caught.value.field == field
