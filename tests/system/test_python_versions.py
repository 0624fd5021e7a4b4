"""pegbt admits Python 3.12 (Ubuntu 24.04's, which dVRK 2.4 on ROS 2 Jazzy runs on): the project says so, and
every pinned dependency resolves to a 3.12 wheel for this platform. Resolved by uv without installing anything
(pip's resolver took 84 s for the same answer, uv about 16 s), so it needs the package registry; it skips,
saying so, only when the registry cannot be reached."""

from __future__ import annotations

import os
import subprocess
import tomllib
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet
from uv import find_uv_bin

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


def test_the_whole_pinned_set_resolves_for_python_3_12() -> None:
    version = "3.12"
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert version in SpecifierSet(project["requires-python"]), project["requires-python"]
    unreachable = _registry_reachable()
    if unreachable:
        pytest.skip(unreachable)
    extras = [f"--extra={extra}" for extra in project["optional-dependencies"]]
    done = subprocess.run(
        [
            find_uv_bin(),
            "pip",
            "compile",
            str(REPO / "pyproject.toml"),
            *extras,
            f"--python-version={version}",
            "--only-binary=:all:",
            f"--index-url={INDEX}",
            "-c",
            str(REPO / "constraints.txt"),
            "--no-header",
            "--no-annotate",
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    resolved = dict(
        line.lower().split("==", 1)
        for line in done.stdout.splitlines()
        if "==" in line and not line.startswith("-")
    )
    pins = dict(
        line.split("==", 1)
        for line in (REPO / "constraints.txt").read_text().splitlines()
        if "==" in line and not line.startswith("#")
    )
    for name in ("torch", "open3d-cpu", "toppra", "ruckig", "osqp", "eclipse-zenoh", "numpy", "scipy"):
        assert resolved.get(name) == pins[name], (name, resolved.get(name), pins[name])
