"""pegbt admits Python 3.12 (Ubuntu 24.04's, which dVRK 2.4 on ROS 2 Jazzy runs on): the project says so, and
every pinned dependency resolves to a 3.12 wheel. Resolved by pip without installing anything, so it needs
the package registry; it skips, saying so, only when the registry cannot be reached."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
INDEX = os.environ.get("PIP_INDEX_URL", "https://pypi.org/simple/").rstrip("/") + "/"


def _registry_reachable() -> str | None:
    """None if pip's index answers; else why not."""
    try:
        with urllib.request.urlopen(INDEX + "pip/", timeout=20):
            return None
    except (urllib.error.URLError, OSError) as error:
        return f"the package registry {INDEX} is unreachable ({error}): cannot resolve for Python 3.12"


def test_the_whole_pinned_set_resolves_for_python_3_12(tmp_path: Path) -> None:
    version = "3.12"
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert version in SpecifierSet(project["requires-python"]), project["requires-python"]
    unreachable = _registry_reachable()
    if unreachable:
        pytest.skip(unreachable)
    report = tmp_path / "report.json"
    extras = ",".join(project["optional-dependencies"])
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--dry-run",
            "--quiet",
            "--ignore-installed",
            f"--python-version={version}",
            "--only-binary=:all:",
            "--target",
            str(tmp_path / "target"),
            "--report",
            str(report),
            "-c",
            str(REPO / "constraints.txt"),
            "-e",
            f"{REPO}[{extras}]",
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    resolved = {
        item["metadata"]["name"].lower(): item["metadata"]["version"]
        for item in json.loads(report.read_text())["install"]
    }
    pins = dict(
        line.split("==", 1)
        for line in (REPO / "constraints.txt").read_text().splitlines()
        if "==" in line and not line.startswith("#")
    )
    for name in ("torch", "open3d-cpu", "toppra", "ruckig", "osqp", "eclipse-zenoh", "numpy", "scipy"):
        assert resolved.get(name) == pins[name], (name, resolved.get(name), pins[name])
