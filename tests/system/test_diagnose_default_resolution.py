"""`pegbt sim2real diagnose` on a real dVRK arm's recording that states no resolution diagnoses it at the
paper's fiducial tracker's, and says so on the console and in the report: a recording copied without its
metadata names no more effects than the paper's resolution allows, none on the arm joints q1-q3."""

from __future__ import annotations

import json
import shutil

import pytest

from pegbt.cli import main

pytestmark = [pytest.mark.system, pytest.mark.slow]


def test_a_copied_real_recording_is_diagnosed_at_the_papers_resolution(dvrk_data, tmp_path, capsys):
    copy = tmp_path / "held_out_PSM1"  # outside the shared folder, named for its arm, no meta.json
    copy.mkdir()
    for name in ("q_cmd.npy", "q_phy.npy", "t_stamp.npy"):
        shutil.copyfile(dvrk_data / "random_smooth_grey1_PSM1" / name, copy / name)
    out = tmp_path / "report"
    assert main(["sim2real", "diagnose", str(copy), "--bootstrap", "0", "--out", str(out)]) == 0
    console = capsys.readouterr()
    said = "diagnosed at the paper's fiducial tracker's 0.01,0.01,0.0005,0.01,0.01,0.01"
    assert said in console.err and "--resolution" in console.err
    report = json.loads((out / "report.json").read_text())
    named = [effect["joint"] for effect in report["effects"]]
    assert 0 < len(named) <= 8 and not {"q1", "q2", "q3"} & set(named), named
    assert report["resolution"]["q3"] == 0.0005 and said in report["resolution_note"]
    assert said in (out / "report.md").read_text()
