"""The `pegbt sim2real` commands in this process (`main`): reports, closing the loop, bad input, the
generator."""

import numpy as np
import pytest

from pegbt.cli import main
from pegbt.physics import Effect
from pegbt.physics.recording import load_recording
from tests.sim2real_helpers import bad_recordings, recording_with, wrist_recording


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """10 s at 100 Hz of a wrist with `WRIST_EFFECTS`."""
    return wrist_recording(tmp_path_factory.mktemp("rec") / "wrist")


def test_bad_input_is_refused_by_name_with_nothing_written(tmp_path, capsys):
    for name, (path, problem) in bad_recordings(tmp_path).items():
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


def test_unknown_family_and_physics_are_refused(tmp_path, recorded, capsys):
    assert main(["sim2real", "synth", str(tmp_path / "x"), "--family", "nope"]) == 2
    assert "unknown family 'nope'" in capsys.readouterr().err
    assert main(["sim2real", "diagnose", str(recorded), "--sim", "no-such-physics"]) == 2
    assert "unknown physics preset" in capsys.readouterr().err
