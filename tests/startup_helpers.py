"""What a fresh interpreter has imported after running some code: the probe behind the start-up tests, which
keep the libraries that take seconds to import out of commands that do not need them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def modules_loaded_after(code: str, modules: Sequence[str], cwd: Path = REPO) -> list[str]:
    """Runs `code` in a new interpreter (this checkout on its path, in `cwd`); which of `modules` (dotted
    names, as in `sys.modules`) it then holds, sorted. The code must end without an error."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(m for m in {list(modules)!r} if m in sys.modules)))\n"
    done = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
        env=dict(os.environ, PYTHONPATH=str(REPO)),
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])
