"""Bad input to any command is one line naming the file and field, and a non-zero exit; never a traceback.
Each case calls `pegbt.cli.main` in this process (an exception escaping it would fail the test, as a
traceback would); `tests/integration/test_cli_bad_input_process.py` runs the real command."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from pegbt.cli import main
from pegbt.sim.process import free_port

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "trees" / "example.yaml"
MODEL = REPO / "skills" / "calibration" / "PSM1-physics.json"


def _model_with(tmp_path: Path, **changes: object) -> str:
    """The committed PSM1 physics model with some top-level fields replaced."""
    document = {**json.loads(MODEL.read_text()), **changes}
    path = tmp_path / "model.json"
    path.write_text(json.dumps(document))
    return str(path)


def _physics_file(tmp_path: Path, document: object) -> str:
    path = tmp_path / "physics.json"
    path.write_text(json.dumps(document))
    return str(path)


@pytest.fixture(scope="module")
def tick_log(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A tick log of the example tree (7 ticks)."""
    path = tmp_path_factory.mktemp("log") / "example.jsonl"
    assert main(["run", str(EXAMPLE), "--clock", "manual", "--log", str(path), "--quiet"]) == 0
    return str(path)


def _sim(*args: str) -> list[str]:
    """`pegbt sim` on a free loopback port, arms only (each case is refused before it would serve)."""
    return ["sim", "--no-world", "--listen", f"tcp/127.0.0.1:{free_port()}", *args]


CASES = {
    "dot into a missing folder": (
        lambda tmp, log: ["tree", "show", str(EXAMPLE), "--dot", str(tmp / "no" / "o.dot")],
        "--dot: cannot write the dot file",
    ),
    "sim log into a missing folder": (
        lambda tmp, log: _sim("--log", str(tmp / "no" / "sim.jsonl")),
        "--log: cannot write the simulator's log",
    ),
    "physics effect not an object": (
        lambda tmp, log: _sim("--physics", _physics_file(tmp, {"effects": [1]})),
        "physics.json: effects[0]: an effect entry is an object",
    ),
    "physics effects not a list": (
        lambda tmp, log: _sim("--physics", _physics_file(tmp, {"effects": {"q1": 1}})),
        "physics.json: effects: effects is a list",
    ),
    "physics params not an object": (
        lambda tmp, log: _sim(
            "--physics", _physics_file(tmp, {"effects": [{"effect": "offset", "joint": "q1", "params": 3}]})
        ),
        "physics.json: effects[0].params:",
    ),
    "model joints not a list": (
        lambda tmp, log: ["calibrate", "eval", _model_with(tmp, joints=5), str(tmp)],
        "model.json: joints: expected a list of joint names",
    ),
    "model outputs not a list": (
        lambda tmp, log: ["calibrate", "eval", _model_with(tmp, outputs=5), str(tmp)],
        "model.json: outputs: expected a list of joint names",
    ),
    "model training not an object": (
        lambda tmp, log: ["calibrate", "eval", _model_with(tmp, training=5), str(tmp)],
        "model.json: training: expected an object",
    ),
    "model for an unknown arm": (
        lambda tmp, log: ["calibrate", "eval", _model_with(tmp, arm="PSM9"), str(tmp)],
        "model.json: arm: unknown arm 'PSM9'",
    ),
    "model effect not an object": (
        lambda tmp, log: ["calibrate", "eval", _model_with(tmp, effects=[1]), str(tmp)],
        "model.json: effects[0]: an effect entry is an object",
    ),
    "period nan": (
        lambda tmp, log: ["run", str(EXAMPLE), "--period", "nan"],
        "--period: must be a finite number > 0, got nan",
    ),
    "period zero": (
        lambda tmp, log: ["run", str(EXAMPLE), "--period", "0"],
        "--period: must be a finite number > 0",
    ),
    "timeout infinite": (
        lambda tmp, log: ["run", str(EXAMPLE), "--timeout", "inf"],
        "--timeout: must be a finite number",
    ),
    "replay a negative tick": (
        lambda tmp, log: ["log", "replay", log, "--tick", "-3"],
        "--tick: the log has ticks 0 to 7, not -3",
    ),
    "replay a tick after the end": (
        lambda tmp, log: ["log", "replay", log, "--tick", "99999"],
        "--tick: the log has ticks 0 to 7",
    ),
    "replay a time of nan": (
        lambda tmp, log: ["log", "replay", log, "--time", "nan"],
        "--time: must be a finite number >= 0",
    ),
    "from-fraction below 0": (
        lambda tmp, log: ["calibrate", "eval", str(MODEL), str(tmp), "--from-fraction", "-1"],
        "--from-fraction: must be a finite number >= 0 and < 1, got -1",
    ),
    "from-fraction above 1": (
        lambda tmp, log: ["calibrate", "eval", str(MODEL), str(tmp), "--from-fraction", "2"],
        "--from-fraction: must be a finite number >= 0 and < 1, got 2",
    ),
    "train-fraction zero": (
        lambda tmp, log: [
            "calibrate",
            "train",
            str(tmp),
            "--arm",
            "PSM1",
            "--model",
            "physics",
            "--train-fraction",
            "0",
        ],
        "--train-fraction: must be a finite number > 0",
    ),
    "crash-at nan": (
        lambda tmp, log: _sim("--crash-at", "nan"),
        "--crash-at: must be a finite number >= 0, got nan",
    ),
    "loss above 1": (lambda tmp, log: _sim("--loss", "2"), "--loss: must be a finite number >= 0 and <= 1"),
    "negative seed": (lambda tmp, log: _sim("--seed", "-1"), "--seed: must be a finite number >= 0"),
    "eval under an unknown condition": (
        lambda tmp, log: ["eval", "--variant", "unilateral", "--trials", "1", "--condition", "compensated"],
        "--condition: unknown condition 'compensated'; known: uncalibrated, calibrated, optimized",
    ),
    "namespace with a wildcard": (
        lambda tmp, log: _sim("--namespace", "lab/*"),
        "--namespace: 'lab/*' is not a key prefix",
    ),
    "namespace with a space": (
        lambda tmp, log: _sim("--namespace", "a b"),
        "--namespace: 'a b' is not a key prefix",
    ),
    "listen on port 0": (
        lambda tmp, log: ["sim", "--listen", "tcp/127.0.0.1:0"],
        "listen: listen endpoint 'tcp/127.0.0.1:0' asks for any free port",
    ),
    "listen on every interface": (
        lambda tmp, log: ["sim", "--listen", "tcp/0.0.0.0:7447"],
        "is not on loopback",
    ),
    "synth seconds nan": (
        lambda tmp, log: ["sim2real", "synth", str(tmp / "s"), "--seconds", "nan"],
        "--seconds: must be a finite number > 0",
    ),
    "collect minutes zero": (
        lambda tmp, log: ["calibrate", "collect", "--arm", "PSM1", "--minutes", "0"],
        "--minutes: must be a finite number > 0",
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_bad_input_is_one_line_naming_the_field(case, tmp_path, tick_log, capsys):
    argv, expected = CASES[case]
    policy = os.sched_getscheduler(0)
    assert main(argv(tmp_path, tick_log)) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pegbt: error: ") and expected in err, err
    assert len(err.splitlines()) == 1
    # a refused `pegbt sim` gives back the real-time priority it took: the caller goes on as it was
    assert os.sched_getscheduler(0) == policy
