"""`pegbt sim2real diagnose` as a real process: bad input exits non-zero without a traceback."""

import numpy as np

from pegbt.physics.recording import write_recording
from tests.sim2real_helpers import recording_with


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


def test_the_process_exits_non_zero_without_a_traceback(tmp_path, pegbt_cli):
    path, problem = _bad_recordings(tmp_path)["nan"]
    done = pegbt_cli("sim2real", "diagnose", path)
    assert done.returncode == 2 and problem in done.stderr and "Traceback" not in done.stderr
