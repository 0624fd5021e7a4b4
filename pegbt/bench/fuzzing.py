"""The fuzz campaign's bookkeeping: each input read under a deadline, its outcome tallied per reader.

An outcome is one of: accepted, refused (a `PegbtError`), a traceback (any other exception), or a hang
(over `HANG_S`). An input made absurd or damaged on purpose that is accepted as if it were whole counts
as `absurd_accepted`; one accepted with the damage said (`reported`) does not.
"""

from __future__ import annotations

import json
import random
import re
import signal
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from pegbt.errors import PegbtError

HANG_S = 10.0
ABSURD_NUMBERS = (".nan", ".inf", "-.inf", "1.0e+300", "-1.0e+300", "0x" + "f" * 5000)
NUMERIC_PARAMS = ("seconds", "height", "keep_apart", "attempts", "times", "retries", "held_above", "settle")
REPORTED = "reported"  # what a reader returns for an input it accepted saying what was damaged
SILENT = "silent"  # what it returns for a damaged input it accepted as if whole


class Hang(Exception):
    """An input that took longer than `HANG_S` to read."""


@contextmanager
def _deadline(seconds: float) -> Iterator[None]:
    def expire(signum: int, frame: object) -> None:
        raise Hang()

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@dataclass
class Tally:
    """Counts of one reader's campaign."""

    inputs: int = 0
    parsed: int = 0
    accepted: int = 0
    refused: int = 0
    tracebacks: int = 0
    hangs: int = 0
    absurd_accepted: int = 0
    reported: int = 0
    good_refused: int = 0
    written_from_non_arm: int = 0
    examples: list[str] = field(default_factory=list)

    def record(
        self, read: Callable[[], Any], *, parsed: bool, absurd: bool, what: str, good: bool = False
    ) -> None:
        """Read one input: `read` raises, returns False (refused), `REPORTED`, `SILENT` or anything else
        (accepted). `good`: an input that must be accepted (whole, and an arm's)."""
        self.inputs += 1
        self.parsed += parsed
        try:
            with _deadline(HANG_S):
                accepted = read()
        except Hang:
            self.hangs += 1
            self._example(f"hang: {what}")
            return
        except PegbtError as error:
            self._refused(good, f"{what}: {error}")
            return
        except Exception as error:  # noqa: BLE001 - the campaign's finding: any other exception
            self.tracebacks += 1
            self._example(f"traceback {type(error).__name__}: {error!s:.120}: {what}")
            return
        if accepted is False:
            self._refused(good, what)
            return
        self.accepted += 1
        if accepted is REPORTED:
            self.reported += 1
        elif absurd or accepted is SILENT:
            self.absurd_accepted += 1
            self._example(f"absurd accepted: {what}")

    def _refused(self, good: bool, what: str) -> None:
        self.refused += 1
        if good:
            self.good_refused += 1
            self._example(f"good refused: {what}")

    def _example(self, text: str) -> None:
        if len(self.examples) < 5:
            self.examples.append(text[:300])

    def figures(self, name: str) -> dict[str, float | int | str]:
        out: dict[str, float | int | str] = {
            f"{name}_{key}": value
            for key, value in vars(self).items()
            if key != "examples" and not (key == "written_from_non_arm" and name != "recordings")
        }
        out[f"{name}_parsed_share"] = round(self.parsed / max(self.inputs, 1), 3)
        if self.examples:
            out[f"{name}_examples"] = " | ".join(self.examples)
        return out


def mutate_text(text: str, rng: random.Random) -> tuple[str, bool, str]:
    """(mutated text, whether it was made absurd on purpose, what was done)."""
    lines = text.splitlines(keepends=True)
    kind = rng.choice(
        [
            "number",
            "number",
            "number",
            "param",
            "param",
            "delete",
            "duplicate",
            "swap",
            "bytes",
            "deep",
            "truncate",
        ]
    )
    if kind in ("number", "param"):
        numbers = [(i, match) for i, line in enumerate(lines) for match in _numbers(line)]
        params = [
            (i, m)
            for i, m in numbers
            if lines[i][: m.start()].rstrip().endswith(tuple(f"{p}:" for p in NUMERIC_PARAMS))
        ]
        chosen = params if kind == "param" and params else numbers
        if chosen:
            index, match = rng.choice(chosen)
            absurd = rng.choice(ABSURD_NUMBERS)
            lines[index] = lines[index][: match.start()] + absurd + lines[index][match.end() :]
            made_absurd = (kind == "param" and bool(params)) or not absurd.startswith(("1", "-1", "0x"))
            return "".join(lines), made_absurd, f"{match.group()} -> {absurd[:12]} at line {index + 1}"
    if kind == "delete" and lines:
        index = rng.randrange(len(lines))
        return "".join(lines[:index] + lines[index + 1 :]), False, f"line {index + 1} deleted"
    if kind == "duplicate" and lines:
        index = rng.randrange(len(lines))
        return "".join(lines[: index + 1] + lines[index:]), False, f"line {index + 1} duplicated"
    if kind == "swap" and len(lines) > 1:
        a, b = rng.randrange(len(lines)), rng.randrange(len(lines))
        lines[a], lines[b] = lines[b], lines[a]
        return "".join(lines), False, f"lines {a + 1} and {b + 1} swapped"
    if kind == "deep":
        depth = rng.choice([50, 600, 30_000])
        return text + "extra: " + "[" * depth + "]" * depth + "\n", False, f"{depth}-deep nesting"
    if kind == "truncate":
        cut = rng.randrange(len(text) + 1)
        return text[:cut], False, f"cut at {cut}"
    raw = bytearray(text.encode())
    for _ in range(rng.randint(1, 8)):
        if raw:
            raw[rng.randrange(len(raw))] = rng.randrange(256)
    return raw.decode("utf-8", "replace"), False, "bytes flipped"


def _numbers(line: str) -> list[re.Match[str]]:
    """Numbers written as values (after `: `, `[` or `, `), not inside names, strings or comments."""
    code = line.split("#", 1)[0]
    return list(
        re.finditer(
            r"(?<=[:\[,] )-?\d+(?:\.\d+)?(?:e[-+]\d+)?(?=\s*[,}\]]|\s*$)|(?<=\[)-?\d+(?:\.\d+)?(?=[,\]])",
            code,
        )
    )


def mutate_records(records: list[Any], rng: random.Random) -> tuple[bool, str]:
    """One mutation of a tick log's records in place: whether it made a value absurd, and what it did."""
    index = rng.randrange(len(records))
    record = records[index]
    kind = rng.choice(["value", "value", "delete", "duplicate", "node", "deep", "huge", "nan t", "raw"])
    absurd_values: list[object] = [None, "x", [], {}, -1, 2**70, 1.5, True, float("nan"), "9" * 5000]
    if kind == "nan t" and index > 0:
        record["t"] = rng.choice([float("nan"), float("inf"), -1.0, 1e308])
        return True, f"line {index + 1}: t made absurd"
    if kind == "node":
        node = rng.choice(records[0]["nodes"])
        key = rng.choice(sorted(node))
        node[key] = rng.choice(absurd_values) if rng.random() < 0.7 else node.pop(key, None)
        return False, f"node {node.get('id')}.{key} changed"
    if kind == "duplicate":
        records.insert(index, json.loads(json.dumps(record)))
        return False, f"line {index + 1} duplicated"
    if kind == "deep":
        records.insert(index + 1, "[" * 100_000 + "]" * 100_000)
        return False, f"deep JSON after line {index + 1}"
    if kind == "huge":
        records.insert(index + 1, '{"type": "tick", "n": ' + "9" * 5000 + ', "t": 0.0, "changes": []}')
        return False, f"huge integer after line {index + 1}"
    if kind == "raw":
        records[index] = json.dumps(record)[: rng.randrange(1, 200)]
        return False, f"line {index + 1} cut"
    key = rng.choice(sorted(record))
    if kind == "delete":
        record.pop(key)
        return False, f"line {index + 1}: {key} deleted"
    record[key] = rng.choice(absurd_values)
    return False, f"line {index + 1}: {key} replaced"
