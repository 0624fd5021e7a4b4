"""`pegbt eval` run as a real process: bad input, and a fault plan that is not valid, are one line (naming its
line and field) and a non-zero exit."""

from __future__ import annotations

import pytest


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--variant", "trilateral", "--trials", "3"], "unknown variant 'trilateral'"),
        (["--variant", "unilateral", "--trials", "0"], "--trials: must be at least 1"),
        (["--variant", "unilateral", "--trials", "-2"], "--trials: must be at least 1"),
        (["--variant", "unilateral", "--trials", "2", "--condition", "fast"], "unknown condition 'fast'"),
        (
            ["--variant", "unilateral", "--trials", "2", "--faults", "no/such/plan.yaml"],
            "no/such/plan.yaml: file not found",
        ),
        (
            ["--variant", "unilateral", "--trials", "2", "--cluster", "127.0.0.1:8786"],
            "expected a scheduler address tls://HOST:PORT or tcp://HOST:PORT",
        ),
    ],
)
def test_bad_input_is_one_line_and_a_non_zero_exit(tmp_path, pegbt_cli, args, words):
    run = pegbt_cli("eval", *args, "--out", str(tmp_path))
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and words in run.stderr and "Traceback" not in run.stderr
    assert run.stdout == "" and not list(tmp_path.iterdir())  # nothing ran, nothing written


def test_a_fault_plan_that_is_not_valid_names_its_line_and_field(tmp_path, pegbt_cli):
    plan = tmp_path / "plan.yaml"
    plan.write_text("seed: 1\nworld:\n  miss_probability: 2.5\n")
    run = pegbt_cli(
        "eval",
        "--variant",
        "handover",
        "--trials",
        "1",
        "--faults",
        str(plan),
        "--out",
        str(tmp_path / "out"),
    )
    assert run.returncode == 2 and run.stderr.count("\n") == 1
    assert f"{plan}:3:" in run.stderr and "miss_probability" in run.stderr
