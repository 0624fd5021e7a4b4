"""World effects on the command line: a bad world file given to `pegbt sim`, `pegbt eval` or `pegbt run` is
one located line and exit 2, before any simulator starts; `pegbt sim2real outcomes --effects` lists them."""

import json
import subprocess
import sys

import pytest

from pegbt.sim.world_effects import WORLD_EFFECT_KINDS


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


def test_the_listing_gives_every_kind_with_its_parameters_units_and_ranges():
    listed = subprocess.run(
        [sys.executable, "-m", "pegbt", "sim2real", "outcomes", "--effects", "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    kinds = {entry["kind"]: entry["parameters"] for entry in json.loads(listed.stdout)}
    assert list(kinds) == list(WORLD_EFFECT_KINDS)
    assert kinds["peg_compliance"]["stiffness"] | {"source": ""} == {
        "unit": "N/m",
        "low": 100.0,
        "high": 100000.0,
        "default": 2900.0,
        "source": "",
    }
    assert set(kinds["registration_offset"]) == {"x", "y", "z"}
