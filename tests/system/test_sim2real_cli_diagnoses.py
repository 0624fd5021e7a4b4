"""The `pegbt sim2real` commands in this process (`main`): reports, closing the loop, bad input, the
generator."""

import contextlib
import io
import json

import pytest

from pegbt.cli import main
from pegbt.physics import ArmPhysics
from pegbt.physics.recording import load_recording
from pegbt.sim2real.diagnose import diagnose
from tests.sim2real_helpers import wrist_recording


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """10 s at 100 Hz of a wrist with `WRIST_EFFECTS`."""
    return wrist_recording(tmp_path_factory.mktemp("rec") / "wrist")


@pytest.fixture(scope="module")
def reported(recorded, tmp_path_factory):
    """`sim2real diagnose --out`: its folder and what it printed (10 resamples: the fewest that give intervals)."""
    out = tmp_path_factory.mktemp("out")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(["sim2real", "diagnose", str(recorded), "--out", str(out), "--bootstrap", "10"])
    assert status == 0
    return out, printed.getvalue()


def test_report_json_has_the_documented_keys_and_the_named_effects(reported):
    out, stdout = reported
    report = json.loads((out / "report.json").read_text())
    assert report["joints"] == ["q1", "q2", "q3", "q4", "q5", "q6"]
    assert {"joint", "rmse", "bias", "share", "windows", "regimes"} <= set(report["mismatch"][0])
    assert {"heldout_rmse_before", "heldout_rmse_after"} <= set(report["fit"])
    assert report["sampling"]["mode"] == "stream" and "stream" in stdout
    named = {(e["effect"], e["joint"], e["params"].get("source")) for e in report["effects"]}
    assert named == {("offset", "q4", None), ("coupling", "q5", "q6"), ("backlash", "q6", None)}
    for entry in report["effects"]:
        assert {"effect", "joint", "params", "ci", "explains", "text"} <= set(entry)
        assert set(entry["ci"]) == {name for name in entry["params"] if name != "source"}
        for name, (lo, hi) in entry["ci"].items():
            assert lo <= entry["params"][name] <= hi
    coupling = next(e for e in report["effects"] if e["effect"] == "coupling")
    assert "q5 follows the q6 command with k = 0.15" in coupling["text"]
    after, before = report["fit"]["heldout_rmse_after"], report["fit"]["heldout_rmse_before"]
    assert after["q5"] < 0.2 * before["q5"] and after["q6"] < 0.5 * before["q6"]
    for name in ("report.md", "residual_over_time.png", "error_vs_command.png", "heldout_fit.png"):
        assert (out / name).stat().st_size > 1000


def test_a_report_loads_as_the_simulator_physics_and_closes_the_loop(reported, recorded):
    out, _ = reported
    physics = ArmPhysics.load(out / "report.json", "PSM1")
    assert {(e.effect, e.joint) for e in physics.effects} == {
        ("offset", "q4"),
        ("coupling", "q5"),
        ("backlash", "q6"),
    }
    again = diagnose(load_recording(recorded), sim=str(out / "report.json"), n_bootstrap=0)
    assert again.effects == []
    before = again.rmse_before()
    assert (
        before["q5"] < 0.0025 and before["q6"] < 0.0025
    )  # the mismatch is gone: only the 2 mrad noise is left


def test_json_output_is_the_report(recorded, capsys):
    assert main(["sim2real", "diagnose", str(recorded), "--json", "--bootstrap", "0"]) == 0
    assert {"mismatch", "effects", "fit", "model"} <= set(json.loads(capsys.readouterr().out))


def test_synth_writes_a_recording_and_a_truth_that_diagnose_does_not_need(tmp_path, capsys):
    assert (
        main(
            [
                "sim2real",
                "synth",
                str(tmp_path / "s"),
                "--family",
                "coupled",
                "--seed",
                "4",
                "--seconds",
                "20",
            ]
        )
        == 0
    )
    truth = json.loads((tmp_path / "s" / "truth.json").read_text())
    assert truth["family"] == "coupled" and len(truth["effects"]) == 1
    assert sorted(p.name for p in (tmp_path / "s" / "recording").iterdir()) == [
        "q_cmd.npy",
        "q_phy.npy",
        "t_stamp.npy",
    ]
    capsys.readouterr()
    assert (
        main(["sim2real", "diagnose", str(tmp_path / "s" / "recording"), "--json", "--bootstrap", "0"]) == 0
    )
    report = json.loads(capsys.readouterr().out)
    true_effect = truth["effects"][0]
    assert [(e["effect"], e["joint"]) for e in report["effects"]] == [
        (true_effect["effect"], true_effect["joint"])
    ]
