"""Outcome tables: a YAML or CSV file of cells, and the reference paper's Tables II–IV built in.

YAML: `counting: until_lost` (a trial's attempts end at a block lost for good, as the paper counts) or
`every_attempt` (the default), and `cells:` a list of `{variant, condition, attempted, succeeded,
mean_transfer_s?, failures?: {PHASE: COUNT}}`. CSV: a header with `variant, condition, attempted,
succeeded` and optionally `mean_transfer_s`, `failures_PHASE` columns and `counting`. Every error names
file, line and field.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from pegbt.boundedio import read_bytes
from pegbt.errors import PegbtError
from pegbt.evaluation.paper import PAPER
from pegbt.runconditions import CONDITIONS, VARIANTS
from pegbt.sim2real.outcomes.cells import PHASES, Cell, Outcomes
from pegbt.yamlfile import Located, read_settings_file

MAX_TABLE_BYTES = 1 << 20
COUNTINGS = ("every_attempt", "until_lost")
_CELL_FIELDS = ("variant", "condition", "attempted", "succeeded", "mean_transfer_s", "failures")
_MAX_COUNT = 10**9

# The paper's counts (success / attempts, `../shared/reference/peg-transfer-geometry.md`): uncalibrated
# attempts stop at a block lost for good; calibrated and optimised placed 120 of 120 in every variant.
PAPER_COUNTS: dict[tuple[str, str], tuple[int, int]] = {
    ("unilateral", "uncalibrated"): (26, 75),
    ("bilateral", "uncalibrated"): (37, 68),
    ("handover", "uncalibrated"): (14, 79),
    **{(v, c): (120, 120) for v in VARIANTS for c in ("calibrated", "optimized")},
}


def paper_table() -> Outcomes:
    """Tables II–IV of Hwang et al. (T-ASE 2022): counts and mean transfer times, no phases."""
    cells = tuple(
        Cell(v, c, attempted, succeeded, PAPER[(v, c)].mean_transfer_time_s)
        for (v, c), (succeeded, attempted) in sorted(PAPER_COUNTS.items(), key=lambda item: _order(item[0]))
    )
    return Outcomes(cells, "the reference paper's Tables II-IV", attempts_end_at_lost_block=True)


def _order(key: tuple[str, str]) -> tuple[int, int]:
    return VARIANTS.index(key[0]), CONDITIONS.index(key[1])


def read_table(path: Path) -> Outcomes:
    """The outcome table at `path` (`.csv`, else YAML)."""
    return _read_csv(path) if path.suffix.lower() == ".csv" else _read_yaml(path)


def _check_cell(cell: Cell, file: str, line: int | None, seen: set[tuple[str, str]]) -> None:
    def fail(message: str, field: str) -> PegbtError:
        return PegbtError(message, file=file, line=line, field=field)

    if cell.succeeded > cell.attempted:
        raise fail(f"{cell.succeeded} succeeded of {cell.attempted} attempted", "succeeded")
    failed = sum(cell.failures.values())
    if failed > cell.attempted - cell.succeeded:
        raise fail(
            f"{failed} failures per phase, but only {cell.attempted - cell.succeeded} failed", "failures"
        )
    if cell.key in seen:
        raise fail(f"a second {cell.variant} {cell.condition} cell", "variant")
    seen.add(cell.key)


def _read_yaml(path: Path) -> Outcomes:
    document = read_settings_file(path)
    document.mapping(("counting", "cells"))
    counting = document["counting"].choice(COUNTINGS) if document.get("counting") else COUNTINGS[0]
    entries = document["cells"].sequence()
    if not entries:
        raise document["cells"].error("no cells")
    cells: list[Cell] = []
    seen: set[tuple[str, str]] = set()
    for entry in entries:
        entry.mapping(_CELL_FIELDS)
        attempted = entry["attempted"].integer(low=0, high=_MAX_COUNT)
        time = entry.get("mean_transfer_s")
        cell = Cell(
            entry["variant"].choice(VARIANTS),
            entry["condition"].choice(CONDITIONS),
            attempted,
            entry["succeeded"].integer(low=0, high=_MAX_COUNT),
            None if time is None else time.number(positive=True),
            _yaml_failures(entry.section("failures", PHASES)),
        )
        _check_cell(cell, entry.mark.file, entry.mark.line, seen)
        cells.append(cell)
    return Outcomes(tuple(cells), str(path), attempts_end_at_lost_block=counting == "until_lost")


def _yaml_failures(section: Located) -> dict[str, int]:
    return {phase: value.integer(low=0, high=_MAX_COUNT) for phase, value in section.mapping().items()}


def _read_csv(path: Path) -> Outcomes:
    name = str(path)
    try:
        content = read_bytes(path, MAX_TABLE_BYTES).decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise PegbtError(f"not UTF-8 text ({error.reason})", file=name) from None
    reader = csv.DictReader(io.StringIO(content))
    try:
        header = [column.strip() for column in reader.fieldnames or []]
    except csv.Error as error:
        raise PegbtError(f"not CSV ({error})", file=name, line=reader.line_num + 1) from None
    known = {"variant", "condition", "attempted", "succeeded", "mean_transfer_s", "counting"}
    known |= {f"failures_{phase}" for phase in PHASES}
    for column in header:
        if column not in known:
            raise PegbtError(
                f"unknown column; expected some of {', '.join(sorted(known))}",
                file=name,
                line=1,
                field=column,
            )
    for column in ("variant", "condition", "attempted", "succeeded"):
        if column not in header:
            raise PegbtError("missing column", file=name, line=1, field=column)
    reader.fieldnames = header
    cells: list[Cell] = []
    countings: set[str] = set()
    seen: set[tuple[str, str]] = set()
    try:
        rows = [(reader.line_num, row) for row in reader]
    except csv.Error as error:
        raise PegbtError(f"not CSV ({error})", file=name, line=reader.line_num + 1) from None
    for line, row in rows:
        values = {key: (value or "").strip() for key, value in row.items() if key is not None}
        if None in row:
            raise PegbtError("more values than columns", file=name, line=line)

        def text(column: str, options: tuple[str, ...]) -> str:
            value = values.get(column, "")
            if value not in options:
                raise PegbtError(
                    f"expected one of {', '.join(options)}, got {value!r}", file=name, line=line, field=column
                )
            return value

        def count(column: str) -> int:
            value = values.get(column, "")
            digits = value.isascii() and value.isdigit() and len(value) <= len(str(_MAX_COUNT))
            if not digits or int(value) > _MAX_COUNT:
                raise PegbtError(
                    f"expected a whole number ≥ 0, got {value!r}", file=name, line=line, field=column
                )
            return int(value)

        time = None
        if values.get("mean_transfer_s"):
            try:
                time = float(values["mean_transfer_s"])
            except ValueError:
                time = float("nan")
            if not time > 0 or time == float("inf"):
                raise PegbtError(
                    f"expected a positive number, got {values['mean_transfer_s']!r}",
                    file=name,
                    line=line,
                    field="mean_transfer_s",
                )
        if values.get("counting"):
            countings.add(text("counting", COUNTINGS))
        failures = {phase: count(f"failures_{phase}") for phase in PHASES if values.get(f"failures_{phase}")}
        cell = Cell(
            text("variant", VARIANTS),
            text("condition", CONDITIONS),
            count("attempted"),
            count("succeeded"),
            time,
            failures,
        )
        _check_cell(cell, name, line, seen)
        cells.append(cell)
    if not cells:
        raise PegbtError("no cells", file=name, line=1)
    if len(countings) > 1:
        raise PegbtError("rows disagree on how attempts are counted", file=name, field="counting")
    return Outcomes(tuple(cells), name, attempts_end_at_lost_block=countings == {"until_lost"})
