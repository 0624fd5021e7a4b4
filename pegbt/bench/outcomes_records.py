"""What `pegbt bench sim2real-outcomes --out DIR` keeps as it goes, so a run longer than a session resumes.

`DIR/records.jsonl` holds JSON lines, each appended and flushed as soon as it is known: first the pilot's
plan (per family: size, detectable_at, read_from, too_large), then one score per family and seed. A rerun
with the same DIR reads them back and simulates only what is missing. Every record carries the code's
identity: a SHA-256 of the files a run reads (the `pegbt` package's Python sources, `trees/` and `skills/`
beside it), not a git commit, since a commit says nothing of uncommitted edits and "dirty" cannot tell two
edited trees apart, and the hash holds outside a checkout too. A rerun whose code differs is refused: the
figures never mix two versions. A last line torn by a killed run is dropped with a message.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pegbt
from pegbt.errors import PegbtError

RECORDS = "records.jsonl"
FIELDS = {"plan": ("families", "plans", "pilot_transfers"), "score": ("family", "seed", "score", "simulated")}
ROOT = Path(pegbt.__file__).resolve().parents[1]


def code_identity(root: Path = ROOT) -> str:
    """SHA-256 of the package's `.py` files and of every file under `trees/` and `skills/`, by path."""
    digest = hashlib.sha256()
    files = [p for p in (root / "pegbt").rglob("*.py") if "__pycache__" not in p.parts]
    for folder in ("trees", "skills"):
        files += [p for p in (root / folder).rglob("*") if p.is_file()]
    for path in sorted(files):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


class Records:
    """The records of one run in `folder` (created if missing) for `families`, under code `code`."""

    def __init__(self, folder: Path, families: Sequence[str], code: str) -> None:
        self.path = folder / RECORDS
        self.code = code
        self.families = list(families)
        folder.mkdir(parents=True, exist_ok=True)
        self.plan: dict[str, Any] | None = None
        self.scores: dict[tuple[str, int], dict[str, Any]] = {}
        for record in self._read():
            if record.get("code") != code:
                raise PegbtError(
                    f"{folder} holds a run of other code ({record.get('code')}; this code is {code}): "
                    "use another --out, or rerun that code",
                    file=self.path,
                    field="--out",
                )
            if record["kind"] == "plan":
                if record["families"] != self.families:
                    raise PegbtError(
                        f"{folder} holds a run of families {','.join(record['families'])}, not "
                        f"{','.join(self.families)}: the pilot's plan depends on them",
                        file=self.path,
                        field="--families",
                    )
                self.plan = record
            else:
                self.scores[(record["family"], record["seed"])] = record

    def _read(self) -> list[dict[str, Any]]:
        """The complete records; a torn last line is cut off the file (so the next record starts a line)."""
        if not self.path.exists():
            return []
        data = self.path.read_bytes()
        lines = data.split(b"\n")
        records, offset = [], 0
        for number, line in enumerate(lines, 1):
            last = number == len(lines) or (number == len(lines) - 1 and not lines[-1])
            try:
                record = json.loads(line) if line.strip() else None
                if record is not None and not (
                    isinstance(record, dict)
                    and record.get("kind") in FIELDS
                    and all(name in record for name in FIELDS[record["kind"]])
                ):
                    raise ValueError("not a plan or a score with all its fields")
            except ValueError as error:
                if not last:
                    raise PegbtError(f"not a record ({error})", file=self.path, line=number) from None
                print(
                    f"{self.path}:{number}: a torn last line (a run stopped while writing it), ignored",
                    file=sys.stderr,
                )
                with self.path.open("r+b") as file:
                    file.truncate(offset)
                break
            if record is not None:
                records.append(record)
            offset += len(line) + 1
        return records

    def _append(self, record: dict[str, Any]) -> None:
        with self.path.open("a", encoding="utf-8") as file:
            file.write(json.dumps({**record, "code": self.code}) + "\n")
            file.flush()
            os.fsync(file.fileno())

    def save_plan(self, plans: dict[str, dict[str, Any]], pilot_transfers: int) -> None:
        """The pilot's plan, per family, and the transfers the pilot simulated."""
        self.plan = {
            "kind": "plan",
            "families": self.families,
            "plans": plans,
            "pilot_transfers": pilot_transfers,
        }
        self._append(self.plan)

    def save_score(self, family: str, seed: int, score: dict[str, float], simulated: int) -> None:
        """One diagnosis's score and the transfers it needed."""
        record = {"kind": "score", "family": family, "seed": seed, "score": score, "simulated": simulated}
        self.scores[(family, seed)] = record
        self._append(record)
