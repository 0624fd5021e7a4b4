"""`pegbt bench startup`: how long a user waits for the commands run after each edit of a tree.

Wall time of a fresh `pegbt tree check trees/handover.yaml` and `pegbt log why` (on the tick log of
`trees/example.yaml`, run here first), beside the interpreter alone (`python -c pass`) and `import
pegbt`: the machine is shared, so the baselines say how much of a figure is the machine's. The four
commands take turns in every round, so a burst of load falls on all of them; medians of `ROUNDS`, of
wall time (what the user waits) and of CPU time (user + system, less sensitive to other processes),
and how many modules each command loads (all, and pegbt's own), which the load of the machine does not
change.
Modules are compiled once, in a warm-up round, into a cache of this run (`PYTHONPYCACHEPREFIX`), as
an installed pegbt's are, even where the environment asks Python not to write bytecode.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pegbt.bench import Figures

ROUNDS = 5
REPO = Path(__file__).resolve().parents[2]
TREE = REPO / "trees" / "handover.yaml"
EXAMPLE = REPO / "trees" / "example.yaml"
TIMEOUT = 120.0  # s: far beyond any start-up; a hung child fails the bench instead of hanging it


def _timed(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds of running `argv` to its exit; a failure is an error, not a figure."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, cwd=REPO, env=env, timeout=TIMEOUT)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} exited {done.returncode}: {done.stderr.strip()}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _modules(argv: list[str], env: dict[str, str]) -> tuple[int, int]:
    """How many modules `pegbt ARGV` has loaded when it returns (all, pegbt's own), in a fresh interpreter."""
    probe = (
        "import contextlib, io, json, sys\n"
        "from pegbt.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    status = main({argv!r})\n"
        "print(json.dumps([status, len(sys.modules), sum(m.split('.')[0] == 'pegbt' for m in sys.modules)]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, cwd=REPO, env=env, timeout=TIMEOUT
    )
    if done.returncode != 0:
        raise RuntimeError(f"pegbt {' '.join(argv)} crashed: {done.stderr.strip()}")
    status, loaded, own = json.loads(done.stdout.strip().splitlines()[-1])
    if status != 0:
        raise RuntimeError(f"pegbt {' '.join(argv)} exited {status}: {done.stderr.strip()}")
    return loaded, own


def run() -> Figures:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "example.jsonl"
        example = ["run", str(EXAMPLE), "--clock", "manual", "--period", "0.01", "--log", str(log), "--quiet"]
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        env["PYTHONPYCACHEPREFIX"] = str(Path(tmp) / "pycache")
        _timed([sys.executable, "-m", "pegbt", *example], env)
        commands = {
            "python_pass": [sys.executable, "-c", "pass"],
            "import_pegbt": [sys.executable, "-c", "import pegbt"],
            "tree_check": [sys.executable, "-m", "pegbt", "tree", "check", str(TREE)],
            "log_why": [sys.executable, "-m", "pegbt", "log", "why", str(log)],
        }
        for command in commands.values():
            _timed(command, env)
        times: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
        for _ in range(ROUNDS):
            for name, command in commands.items():
                times[name].append(_timed(command, env))
        figures: Figures = {}
        for name, argv in (
            ("tree_check", ["tree", "check", str(TREE)]),
            ("log_why", ["log", "why", str(log)]),
        ):
            figures[f"{name}_modules"], figures[f"{name}_pegbt_modules"] = _modules(argv, env)
    for name, pairs in times.items():
        figures[f"{name}_s"] = statistics.median(wall for wall, _ in pairs)
        figures[f"{name}_cpu_s"] = statistics.median(cpu for _, cpu in pairs)
    figures["rounds"] = ROUNDS
    return figures
