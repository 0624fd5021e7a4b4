"""What `pegbt bench sim2real-outcomes --out DIR` keeps as it goes, so a run longer than a session resumes.

Two kinds of JSON lines, each appended and flushed as soon as it is known, in files named by the identity
of the code they depend on:
- `DIR/records-CODE.jsonl`: the pilot's plan (per family: size, detectable_at, read_from, too_large), then
  one score per family and seed. CODE is a SHA-256 of the files a run reads (`code_identity`: the `pegbt`
  package's sources and data, `trees/` and `skills/`), not a git commit, since a commit says nothing of
  uncommitted edits and "dirty" cannot tell two edited trees apart. Records of other code lie beside them
  and are never read: the figures never mix two versions.
- `DIR/transfers-SIM.jsonl`: every transfer the run simulated (`StoredMemo`), one line a batch. SIM is the
  identity of the simulator alone (`simulator_identity`: the sources the phase simulator's entry imports,
  directly or not, anywhere in them, with the package's data, `trees/` and `skills/`). A run stopped in the
  middle of a seed loses nothing it simulated; the fit's candidate worlds, which every seed's diagnoses
  simulate on the same seeds, are simulated once for the whole run; and a change to the diagnosis (its
  fit, gate or predictions) scores every seed again from the transfers already simulated.
A rerun with the same DIR reads back what its code kept and simulates only what is missing. A last line
torn by a killed run is dropped with a message.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import sys
from collections.abc import Sequence
from dataclasses import astuple
from pathlib import Path
from typing import Any

import pegbt
from pegbt.errors import PegbtError
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cache import Known, MemoMapper
from pegbt.sim2real.outcomes.simulate import Mapper
from pegbt.sim2real.outcomes.transfer_result import TransferResult

RECORDS = "records-{}.jsonl"  # of a code identity's first 16 hex digits
TRANSFERS = "transfers-{}.jsonl"  # of a simulator identity's first 16 hex digits
SIMULATOR = "pegbt.sim2real.outcomes.simulate"  # the entry the benchmark's worker processes run
FIELDS = {
    "plan": ("families", "plans", "pilot_transfers"),
    "score": ("family", "seed", "score", "simulated"),
    "transfers": ("worlds", "rows"),
}
ROOT = Path(pegbt.__file__).resolve().parents[1]


def code_identity(root: Path = ROOT) -> str:
    """SHA-256 of the package's sources and data and of every file under `trees/` and `skills/`, by path."""
    return _digest(root, [*_package_files(root), *_data_files(root)])


def simulator_identity(root: Path = ROOT, entry: str = SIMULATOR) -> str:
    """SHA-256 of what a simulated transfer depends on: the sources `entry` imports, directly or through
    others, at module level or inside a function (whether a branch runs or not), with their packages'
    `__init__`s, the package's data, `trees/` and `skills/`."""
    return _digest(root, [*imported_sources(root, entry), *_data_files(root)])


def _package_files(root: Path) -> list[Path]:
    return [p for p in (root / "pegbt").rglob("*.py") if "__pycache__" not in p.parts]


def _data_files(root: Path) -> list[Path]:
    """The package's data (arm physics presets and the like; not the monitor's web build) and the trees and
    skills beside it."""
    data = [
        p
        for p in (root / "pegbt").rglob("*")
        if p.is_file() and p.suffix != ".py" and "__pycache__" not in p.parts and "web" not in p.parts
    ]
    for folder in ("trees", "skills"):
        data += [p for p in (root / folder).rglob("*") if p.is_file()]
    return data


def imported_sources(root: Path, entry: str) -> set[Path]:
    """The source files of `entry` and of every `pegbt` module it imports, transitively."""
    found: set[Path] = set()
    todo = [entry]
    while todo:
        name = todo.pop()
        parts = name.split(".")
        for depth in range(1, len(parts) + 1):
            path = _source(root, parts[:depth])
            if path is None or path in found:
                continue
            found.add(path)
            package = parts[:depth] if path.name == "__init__.py" else parts[: depth - 1]
            todo += _imports(path, package)
    return found


def _source(root: Path, parts: Sequence[str]) -> Path | None:
    """The file of module `parts`, if it is one of the package's."""
    base = root.joinpath(*parts)
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _imports(path: Path, package: Sequence[str]) -> list[str]:
    """The `pegbt` modules `path` names in any import statement (a `from X import y` names X and X.y)."""
    names: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = list(package[: len(package) - node.level + 1]) if node.level else []
            module = ".".join([*base, *(node.module.split(".") if node.module else [])])
            names += [module, *(f"{module}.{alias.name}" for alias in node.names)]
    return [n for n in names if n == "pegbt" or n.startswith("pegbt.")]


def _digest(root: Path, files: Sequence[Path]) -> str:
    digest = hashlib.sha256()
    for path in sorted(set(files)):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


class Records:
    """The records of one run in `folder` (created if missing) for `families`, under code `code`."""

    def __init__(self, folder: Path, families: Sequence[str], code: str) -> None:
        self.path = folder / RECORDS.format(code[:16])
        self.code = code
        self.families = list(families)
        folder.mkdir(parents=True, exist_ok=True)
        self.plan: dict[str, Any] | None = None
        self.scores: dict[tuple[str, int], dict[str, Any]] = {}
        for record in read_records(self.path, code, ("plan", "score")):
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

    def _append(self, record: dict[str, Any]) -> None:
        append_record(self.path, record, self.code)

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


def read_records(path: Path, code: str, kinds: Sequence[str]) -> list[dict[str, Any]]:
    """The complete records of `path` (none if it is missing), each of one of `kinds` with all its fields
    and of code `code`; a torn last line is cut off the file (so the next record starts a line)."""
    if not path.exists():
        return []
    lines = path.read_bytes().split(b"\n")
    records, offset = [], 0
    for number, line in enumerate(lines, 1):
        last = number == len(lines) or (number == len(lines) - 1 and not lines[-1])
        try:
            record = json.loads(line) if line.strip() else None
            if record is not None and not (
                isinstance(record, dict)
                and record.get("kind") in kinds
                and all(name in record for name in FIELDS[record["kind"]])
            ):
                raise ValueError(f"not a record of kind {' or '.join(kinds)} with all its fields")
        except ValueError as error:
            if not last:
                raise PegbtError(f"not a record ({error})", file=path, line=number) from None
            print(
                f"{path}:{number}: a torn last line (a run stopped while writing it), ignored",
                file=sys.stderr,
            )
            with path.open("r+b") as file:
                file.truncate(offset)
            break
        if record is not None:
            if record.get("code") != code:
                raise PegbtError(
                    f"{path.parent} holds a run of other code ({record.get('code')}; this code is {code}): "
                    "use another --out, or rerun that code",
                    file=path,
                    line=number,
                    field="--out",
                )
            records.append(record)
        offset += len(line) + 1
    return records


def append_record(path: Path, record: dict[str, Any], code: str) -> None:
    """`record` as one more line of `path`, on disk before this returns."""
    with path.open("a", encoding="utf-8") as file:
        file.write(json.dumps({**record, "code": code}) + "\n")
        file.flush()
        os.fsync(file.fileno())


class StoredMemo(MemoMapper):
    """A `MemoMapper` whose transfers are also kept in `folder`, in the file of simulator identity `code`
    (`simulator_identity`), and read back from it: what an earlier run of the same simulator simulated is
    known from the start. `mapper` must be the benchmark's (its attempts are in no key). Each of its jobs
    is kept as it is done (`workers.PartedMapper`), so a run killed in a large batch (the pilot's reach
    6,000 transfers a cell) loses only the jobs under way, a few minutes each at most (`workers.LARGEST_JOB`)."""

    def __init__(self, mapper: Mapper, folder: Path, code: str) -> None:
        super().__init__(mapper)
        folder.mkdir(parents=True, exist_ok=True)
        self.path, self.code = folder / TRANSFERS.format(code[:16]), code
        for record in read_records(self.path, code, ("transfers",)):
            worlds = [WorldEffects.of(w) for w in record["worlds"]]
            for w, variant, condition, seed, *result in record["rows"]:
                self.known[(worlds[w], variant, condition, seed)] = TransferResult(*result)
        self.stored = len(self.known)

    def keep(self, learnt: Sequence[tuple[Known, TransferResult]]) -> None:
        super().keep(learnt)
        if not learnt:
            return
        worlds = list(dict.fromkeys(world for (world, *_), _ in learnt))
        index = {world: i for i, world in enumerate(worlds)}
        rows = [
            [index[world], variant, condition, seed, *astuple(result)]
            for (world, variant, condition, seed), result in learnt
        ]
        append_record(
            self.path,
            {
                "kind": "transfers",
                "worlds": [{e.kind: dict(e.values) for e in w} for w in worlds],
                "rows": rows,
            },
            self.code,
        )
