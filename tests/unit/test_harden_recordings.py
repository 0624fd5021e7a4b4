"""Recordings: only an arm's joints, in rad and m, read within bounds, reach a fit or a report."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

from pegbt.cli import main
from pegbt.physics.recording import RecordingError, load_recording, write_recording
from pegbt.psm import JOINT_NAMES


def arm_like(n: int = 200, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth commands within PSM1's limits and physical joints that follow them (rad, m, s)."""
    rng = np.random.default_rng(seed)
    phase = np.linspace(0, 6 * np.pi, n)[:, None] + rng.uniform(0, np.pi, 6)
    q_cmd = np.array([0.0, 0.0, 0.15, 0.0, 0.0, 0.0]) + np.array([0.4, 0.4, 0.05, 0.6, 0.6, 0.6]) * np.sin(
        phase
    )
    q_phy = q_cmd + np.array([0.002, 0.002, 0.0005, 0.1, 0.05, 0.05]) * rng.standard_normal((n, 6))
    return q_cmd, q_phy, 0.5 * np.arange(n)


def _csv(path, t, q_cmd, q_phy, field: str | None = None):
    header = (
        "t," + ",".join(f"{q}_cmd" for q in JOINT_NAMES) + "," + ",".join(f"{q}_meas" for q in JOINT_NAMES)
    )
    rows = [",".join(f"{v:.9g}" for v in row) for row in np.column_stack([t, q_cmd, q_phy])]
    if field is not None:
        rows[3] = field + rows[3][rows[3].index(",") :]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_an_arm_like_recording_loads(tmp_path):
    assert load_recording(write_recording(tmp_path / "ok_PSM1", *arm_like())).n == 200


def _bad_units(tmp_path):
    q_cmd, q_phy, t = arm_like()
    degrees = write_recording(tmp_path / "degrees", np.degrees(q_cmd), np.degrees(q_phy), t)
    millimetres = q_cmd.copy(), q_phy.copy()
    millimetres[0][:, 2] *= 1000
    millimetres[1][:, 2] *= 1000
    return {
        "degrees": (degrees, "q_cmd.npy", "q_cmd.q1", "at sample "),
        "millimetres": (
            write_recording(tmp_path / "mm", *millimetres, t),
            "q_cmd.npy",
            "q_cmd.q3",
            "at sample 0",
        ),
        "x100": (
            write_recording(tmp_path / "x100", 100 * q_cmd, 100 * q_phy, t),
            "q_cmd.npy",
            "q_cmd.q1",
            "sample",
        ),
        "noise": (
            write_recording(
                tmp_path / "noise",
                q_cmd,
                np.random.default_rng(1).uniform(-1, 1, q_phy.shape) * [1, 1, 0, 1, 1, 1]
                + [0, 0, 0.15, 0, 0, 0],
                t,
            ),
            "q_phy.npy",
            "q_phy.q1",
            "does not follow its commands",
        ),
        "phy_far_out": (
            write_recording(tmp_path / "phy", q_cmd, q_phy + [0, 0, 0, 0, 0, 2.0], t),
            "q_phy.npy",
            "q_phy.q6",
            "physical tolerance",
        ),
        "denormal_t": (
            write_recording(tmp_path / "denormal", q_cmd, q_phy, np.arange(len(t)) * 5e-324),
            "t_stamp.npy",
            "t",
            "apart",
        ),
    }


@pytest.mark.parametrize("case", ["degrees", "millimetres", "x100", "noise", "phy_far_out", "denormal_t"])
def test_wrong_units_and_noise_are_refused_naming_joint_and_sample_and_nothing_is_written(
    tmp_path, capsys, case
):
    path, file, field, words = _bad_units(tmp_path)[case]
    with pytest.raises(RecordingError) as raised:
        load_recording(path)
    assert (
        raised.value.file == str(path / file)
        and raised.value.field == field
        and words in raised.value.message
    )
    out, model = tmp_path / "report", tmp_path / "model.json"
    assert main(["sim2real", "diagnose", str(path), "--out", str(out)]) == 2
    assert (
        main(["calibrate", "train", str(path), "--arm", "PSM1", "--model", "physics", "--out", str(model)])
        == 2
    )
    assert not out.exists() and not model.exists()
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize("dtype", ["int8", "uint8", "complex128", "timedelta64[s]", "int64"])
def test_arrays_that_are_not_floating_point_are_refused_not_cast(tmp_path, dtype):
    q_cmd, q_phy, t = arm_like()
    folder = write_recording(tmp_path / "rec", q_cmd, q_phy, t)
    np.save(folder / "q_cmd.npy", (q_cmd * 10).astype(dtype))
    with pytest.raises(RecordingError, match="floating point") as raised:
        load_recording(folder)
    assert raised.value.file == str(folder / "q_cmd.npy")


def test_an_npz_named_npy_and_a_header_claiming_44_gib_are_refused(tmp_path):
    q_cmd, q_phy, t = arm_like()
    folder = write_recording(tmp_path / "rec", q_cmd, q_phy, t)
    with open(folder / "q_cmd.npy", "wb") as handle:
        np.savez(handle, q_cmd=q_cmd)
    with pytest.raises(RecordingError, match="no .npy header"):
        load_recording(folder)
    header = {"descr": "<f8", "fortran_order": False, "shape": (983_040_000, 6)}  # 44 GiB
    with open(folder / "q_cmd.npy", "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, header)
        handle.write(b"\0" * 4800)
    with pytest.raises(RecordingError, match="header claims 47185920000 bytes"):
        load_recording(folder)


def test_bad_metadata_and_a_long_name_are_refused_by_name(tmp_path):
    folder = write_recording(tmp_path / "rec", *arm_like())
    (folder / "meta.json").write_bytes(b'{"arm": "PSM1\xff"}')
    with pytest.raises(RecordingError, match="metadata") as raised:
        load_recording(folder)
    assert raised.value.file == str(folder / "meta.json")
    (folder / "meta.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(RecordingError, match="metadata"):
        load_recording(folder)
    with pytest.raises(RecordingError, match="too long"):
        load_recording(tmp_path / ("x" * 300) / "rec.csv")


def test_a_huge_csv_field_and_files_that_are_not_regular_are_refused(tmp_path):
    q_cmd, q_phy, t = arm_like()
    with pytest.raises(RecordingError, match="CSV"):
        load_recording(_csv(tmp_path / "wide.csv", t, q_cmd, q_phy, field="1" * 131_073))
    (tmp_path / "zero.csv").symlink_to("/dev/zero")
    with pytest.raises(RecordingError, match="regular"):
        load_recording(tmp_path / "zero.csv")
    os.mkfifo(tmp_path / "fifo.csv")
    done: list[BaseException] = []

    def load() -> None:
        try:
            load_recording(tmp_path / "fifo.csv")
        except RecordingError as error:
            done.append(error)

    reader = threading.Thread(target=load, daemon=True)
    reader.start()
    reader.join(10.0)
    if reader.is_alive():  # unblock the reader so the test process can end
        with open(tmp_path / "fifo.csv", "w"):
            pass
    assert done and "regular" in str(done[0])
