"""The outcome-table campaign: a valid YAML and a valid CSV outcome table (the paper's nine cells, some with
failures per phase) with one part mutated, read as `pegbt sim2real outcomes` reads them (`read_table`).
Besides the generic mutations, a count is made negative, huge or larger than the attempts, and a variant or
condition unknown; such a table accepted, or any accepted table whose cells break those rules, counts as
`absurd_accepted`."""

from __future__ import annotations

import csv
import io
import math
import random
import re
from pathlib import Path

from pegbt.bench.fuzzing import SILENT, Tally, mutate_text

_FAILURES = {
    ("unilateral", "uncalibrated"): {"grasp": 20, "carry": 9},
    ("handover", "uncalibrated"): {"handover": 40},
}
_SEMANTIC = ("succeeded > attempted", "negative", "huge", "unknown variant", "unknown condition")


def _valid_yaml() -> str:
    from pegbt.sim2real.outcomes.table import PAPER_COUNTS

    lines = ["# the paper's tables\n", "counting: until_lost\n", "cells:\n"]
    for (variant, condition), (succeeded, attempted) in PAPER_COUNTS.items():
        failures = _FAILURES.get((variant, condition))
        extra = (
            ", failures: {" + ", ".join(f"{p}: {c}" for p, c in failures.items()) + "}" if failures else ""
        )
        lines.append(
            f"  - {{variant: {variant}, condition: {condition}, attempted: {attempted}, "
            f"succeeded: {succeeded}, mean_transfer_s: 10.5{extra}}}\n"
        )
    return "".join(lines)


def _valid_csv() -> str:
    from pegbt.sim2real.outcomes.table import PAPER_COUNTS

    lines = ["variant,condition,attempted,succeeded,mean_transfer_s,failures_grasp,failures_carry,counting\n"]
    for (variant, condition), (succeeded, attempted) in PAPER_COUNTS.items():
        failures = _FAILURES.get((variant, condition), {})
        lines.append(
            f"{variant},{condition},{attempted},{succeeded},10.5,"
            f"{failures.get('grasp', '')},{failures.get('carry', '')},until_lost\n"
        )
    return "".join(lines)


def _semantic(text: str, csv: bool, rng: random.Random) -> tuple[str, str]:
    """A table made absurd on purpose, and what was done."""
    kind = rng.choice(_SEMANTIC)
    lines = text.splitlines(keepends=True)
    at = rng.randrange(1 if csv else 3, len(lines))
    line = lines[at]
    if kind.startswith("unknown"):
        word = "variant" if kind == "unknown variant" else "condition"
        from pegbt.runconditions import CONDITIONS, VARIANTS

        names = VARIANTS if word == "variant" else CONDITIONS
        name = next(n for n in names if n in line)
        line = line.replace(name, rng.choice(["trilateral", "Calibrated", "", "nan"]), 1)
    else:
        field = rng.choice(["attempted", "succeeded"]) if kind != "succeeded > attempted" else "succeeded"
        if csv:
            cells = line.rstrip("\n").split(",")
            index = 2 if field == "attempted" else 3
            attempted = int(cells[2])
            cells[index] = _absurd_count(kind, attempted, rng)
            line = ",".join(cells) + "\n"
        else:
            attempted = int(re.search(r"attempted: (\d+)", line).group(1))  # type: ignore[union-attr]
            line = re.sub(rf"{field}: \d+", f"{field}: {_absurd_count(kind, attempted, rng)}", line)
    lines[at] = line
    return "".join(lines), f"{kind} at line {at + 1}"


def _absurd_count(kind: str, attempted: int, rng: random.Random) -> str:
    if kind == "succeeded > attempted":
        return str(attempted + rng.choice([1, 7, 10**6]))
    if kind == "negative":
        return rng.choice(["-1", "-120", "-0.5"])
    return rng.choice(["1" + "0" * 10, "9" * 5000, "1e300", ".inf", "1.0e+30"])


def _broken(outcomes: object) -> bool:
    """Whether an accepted table holds a cell no trial could give."""
    from pegbt.runconditions import CONDITIONS, VARIANTS
    from pegbt.sim2real.outcomes.cells import PHASES, Outcomes

    assert isinstance(outcomes, Outcomes)
    for cell in outcomes.cells:
        time = cell.mean_transfer_s
        if (
            cell.variant not in VARIANTS
            or cell.condition not in CONDITIONS
            or not 0 <= cell.succeeded <= cell.attempted <= 10**9
            or any(phase not in PHASES or count < 0 for phase, count in cell.failures.items())
            or sum(cell.failures.values()) > cell.attempted - cell.succeeded
            or (time is not None and not (math.isfinite(time) and time > 0))
        ):
            return True
    return False


def fuzz_outcome_tables(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.sim2real.outcomes.table import read_table

    valid = {".yaml": _valid_yaml(), ".csv": _valid_csv()}
    tally = Tally()
    for n in range(count):
        suffix = rng.choice(sorted(valid))
        good = n % 50 < 2
        if good:
            text, absurd, what = valid[suffix], False, "unchanged"
        elif rng.random() < 0.4:
            (text, what), absurd = _semantic(valid[suffix], suffix == ".csv", rng), True
        else:
            text, absurd, what = mutate_text(valid[suffix], rng)
        path = work / f"table-{n}{suffix}"
        path.write_text(text, encoding="utf-8", errors="surrogateescape")

        def read(path: Path = path) -> object:
            return SILENT if _broken(read_table(path)) else True

        tally.record(read, parsed=_parses(text, suffix), absurd=absurd, what=f"{suffix}: {what}", good=good)
        path.unlink()
    return tally


def _parses(text: str, suffix: str) -> bool:
    """Whether the text gets past the YAML or CSV parser to the table's checks."""
    from pegbt.errors import PegbtError
    from pegbt.yamlfile import parse_yaml

    try:
        if suffix == ".csv":
            list(csv.reader(io.StringIO(text)))
        else:
            parse_yaml(text, "<fuzz>")
    except (PegbtError, csv.Error):
        return False
    return True
