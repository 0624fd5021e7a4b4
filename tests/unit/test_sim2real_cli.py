"""The `pegbt sim2real` commands in this process (`main`): reports, closing the loop, bad input, the
generator."""

import contextlib
import io
import json

import numpy as np
import pytest

from pegbt.cli import main
from pegbt.physics import ArmPhysics, Effect
from pegbt.sim2real.diagnose import diagnose
from pegbt.physics.recording import load_recording, write_recording
from tests.sim2real_helpers import recording_with

EFFECTS = [
    Effect("offset", "q4", {"value": 0.1}),
    Effect("coupling", "q5", {"source": "q6", "k": 0.15}),
    Effect("backlash", "q6", {"half_width": 0.03}),
]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """10 s at 100 Hz of a wrist with EFFECTS."""
    folder = tmp_path_factory.mktemp("rec") / "wrist"
    rec = recording_with(EFFECTS, seed=9, seconds=10.0)
    return write_recording(folder, rec.q_cmd, rec.q_phy, rec.t)


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


def _bad_recordings(tmp_path):
    rec = recording_with([], seed=1, seconds=2.0)
    cases = {}
    folder = write_recording(tmp_path / "lengths", rec.q_cmd, rec.q_phy[:-3], rec.t)
    cases["lengths"] = (folder, "different lengths")
    q_phy = rec.q_phy.copy()
    q_phy[17, 2] = np.nan
    cases["nan"] = (
        write_recording(tmp_path / "nan", rec.q_cmd, q_phy, rec.t),
        "NaN or infinite value in sample 17",
    )
    t = rec.t.copy()
    t[40] = t[39]
    cases["time"] = (
        write_recording(tmp_path / "time", rec.q_cmd, rec.q_phy, t),
        "timestamps not increasing at sample 40",
    )
    constant = np.zeros_like(rec.q_cmd)
    cases["constant"] = (
        write_recording(tmp_path / "constant", constant, rec.q_phy, rec.t),
        "constant commands",
    )
    cases["single"] = (
        write_recording(tmp_path / "single", rec.q_cmd[:1], rec.q_phy[:1], rec.t[:1]),
        "only 1 sample",
    )
    text = tmp_path / "notes.txt"
    text.write_text("not a recording\n")
    cases["text"] = (text, "not a recording")
    (tmp_path / "empty").mkdir()
    cases["folder"] = (tmp_path / "empty", "lacks q_cmd.npy and q_phy.npy")
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "q_cmd.npy").write_text("garbage")
    (junk / "q_phy.npy").write_text("garbage")
    cases["junk"] = (junk, "cannot read it as a NumPy array")
    csv = tmp_path / "bad.csv"
    header = (
        "t," + ",".join(f"q{i}_cmd" for i in range(1, 7)) + "," + ",".join(f"q{i}_meas" for i in range(1, 7))
    )
    csv.write_text(
        header + "\n" + "\n".join(",".join(["0.1"] * 13) for _ in range(3)) + "\n0.2,x" + ",0" * 11 + "\n"
    )
    cases["csv"] = (csv, ":5:2: q1_cmd: not a number")
    return cases


def test_bad_input_is_refused_by_name_with_nothing_written(tmp_path, capsys):
    for name, (path, problem) in _bad_recordings(tmp_path).items():
        out = tmp_path / f"out-{name}"
        status = main(["sim2real", "diagnose", str(path), "--out", str(out)])
        stderr = capsys.readouterr().err
        assert status == 2, (name, stderr)
        assert problem in stderr and str(path) in stderr and len(stderr.splitlines()) == 1, (name, stderr)
        assert not out.exists(), name


def test_a_csv_recording_is_read_like_a_folder(tmp_path):
    rec = recording_with([Effect("offset", "q2", {"value": 0.02})], seed=2, seconds=5.0)
    rows = np.column_stack([rec.t, rec.q_cmd, rec.q_phy])
    header = (
        "t," + ",".join(f"q{i}_cmd" for i in range(1, 7)) + "," + ",".join(f"q{i}_meas" for i in range(1, 7))
    )
    path = tmp_path / "rec.csv"
    np.savetxt(path, rows, delimiter=",", header=header, comments="")
    loaded = load_recording(path)
    assert np.allclose(loaded.q_phy, rec.q_phy) and loaded.sampling.mode == "stream"


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


def test_unknown_family_and_physics_are_refused(tmp_path, recorded, capsys):
    assert main(["sim2real", "synth", str(tmp_path / "x"), "--family", "nope"]) == 2
    assert "unknown family 'nope'" in capsys.readouterr().err
    assert main(["sim2real", "diagnose", str(recorded), "--sim", "no-such-physics"]) == 2
    assert "unknown physics preset" in capsys.readouterr().err
