"""`pegbt calibrate` run as a real process: bad input is one line and exit status 2, never a traceback."""

import numpy as np
from calibration_helpers import synthetic, write

from pegbt.cli import main


def test_bad_input_is_one_line_and_status_2(tmp_path, pegbt_cli, capsys):
    folder = write(synthetic(300, arm="PSM2"), tmp_path / "rec")
    wrong_arm = pegbt_cli(
        "calibrate", "train", folder, "--arm", "PSM1", "--model", "physics", "--out", tmp_path / "m.json"
    )
    assert wrong_arm.returncode == 2 and "recording is of PSM2" in wrong_arm.stderr
    assert len(wrong_arm.stderr.strip().splitlines()) == 1 and not (tmp_path / "m.json").exists()
    q_phy = np.load(folder / "q_phy.npy")
    q_phy[17, 4] = np.nan
    np.save(folder / "q_phy.npy", q_phy)
    assert (
        main(
            [
                "calibrate",
                "train",
                str(folder),
                "--arm",
                "PSM2",
                "--model",
                "hybrid",
                "--out",
                str(tmp_path / "m.json"),
            ]
        )
        == 2
    )
    assert "q_phy.npy: q_phy: NaN or infinite value in sample 17" in capsys.readouterr().err
    assert main(["calibrate", "eval", str(tmp_path / "nothing.json"), str(folder)]) == 2
    assert "cannot read model file" in capsys.readouterr().err
