"""A bad world file given to `pegbt sim`, `pegbt eval` or `pegbt run` is one located line and exit 2,
before any simulator starts."""

import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    "command",
    [
        ["sim", "--lockstep"],
        ["eval", "--variant", "unilateral", "--trials", "1"],
        ["run", "trees/unilateral.yaml"],
    ],
    ids=["sim", "eval", "run"],
)
def test_a_bad_world_file_is_one_located_line(tmp_path, command):
    world = tmp_path / "world.yaml"
    world.write_text("effects:\n  - kind: jaw_friction\n    max_load: .inf\n")
    done = subprocess.run(
        [sys.executable, "-m", "pegbt", *command, "--world-effects", str(world)]
        + (["--out", str(tmp_path / "out")] if command[0] == "eval" else [])
        + (["--log", str(tmp_path / "run.jsonl")] if command[0] == "run" else []),
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert f"{world}:3:15: effects[0].max_load: expected a finite number" in lines[0]


def test_world_effects_need_a_world():
    done = subprocess.run(
        [sys.executable, "-m", "pegbt", "sim", "--no-world", "--world-effects", "w.yaml"],
        capture_output=True,
        text=True,
        timeout=60,
        stdin=subprocess.DEVNULL,
    )
    assert done.returncode == 2 and "--world-effects: --world-effects act on the world" in done.stderr
