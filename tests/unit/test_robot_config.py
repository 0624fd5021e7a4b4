"""Limits from a dVRK's share/ folder: the dVRK's own files are read as the dVRK writes them (JSON with
comments), skills/psm.yaml never allows more than they do, and a robot's narrower limit narrows the plan's."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.limits import arm_settings
from pegbt.motion.robot_config import read_robot_limits, robot_arm_settings

SHARE = Path(__file__).parents[1] / "data" / "dvrk-share"
DVRK_MIRROR = Path("/work/.mirror/jhu-dvrk+sawIntuitiveResearchKit/repo")


def test_the_dvrk_files_give_the_psm_and_large_needle_driver_limits() -> None:
    limits = read_robot_limits(SHARE)
    assert np.allclose(limits.lower, [-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
    assert np.allclose(limits.upper, [1.588, 0.925025, 0.24, 4.53786, 1.39626, 1.39626])
    assert (limits.jaw_lower, limits.jaw_upper) == (-0.698132, 1.39626)


@pytest.mark.parametrize("arm", ["PSM1", "PSM2"])
def test_skills_psm_yaml_never_allows_more_than_the_dvrk(arm: str) -> None:
    limits, settings = read_robot_limits(SHARE), arm_settings(arm)
    assert np.all(settings.lower >= limits.lower) and np.all(settings.upper <= limits.upper)
    assert limits.jaw_lower <= settings.jaw_lower < settings.jaw_upper <= limits.jaw_upper
    robot = robot_arm_settings(arm, SHARE)  # nothing left to narrow
    assert np.array_equal(robot.lower, settings.lower) and np.array_equal(robot.upper, settings.upper)
    assert (robot.jaw_lower, robot.jaw_upper) == (settings.jaw_lower, settings.jaw_upper)


def test_a_robot_narrower_than_the_skills_narrows_them_and_a_wider_one_never_widens(tmp_path: Path) -> None:
    share = tmp_path / "share"
    shutil.copytree(SHARE, share)
    tool = share / "tool" / "LARGE_NEEDLE_DRIVER_400006.json"
    tool.write_text(tool.read_text().replace('"qmax": 1.39626 },   // ±80°', '"qmax": 0.5 },'))
    kinematic = share / "kinematic" / "PSM.json"
    kinematic.write_text(kinematic.read_text().replace('"qmax": 0.24', '"qmax": 0.30'))
    settings = robot_arm_settings("PSM1", share)
    assert settings.upper[4] == 0.5  # wrist pitch: the robot's narrower limit
    assert settings.upper[2] == arm_settings("PSM1").upper[2] == 0.24  # insertion: never wider than psm.yaml


def test_a_missing_limit_names_the_file_and_field(tmp_path: Path) -> None:
    share = tmp_path / "share"
    shutil.copytree(SHARE, share)
    kinematic = share / "kinematic" / "PSM.json"
    kinematic.write_text(kinematic.read_text().replace('"qmin": -0.925025, ', ""))
    with pytest.raises(PegbtError, match="expected a finite number, got None") as caught:
        read_robot_limits(share)
    assert caught.value.file == str(kinematic) and caught.value.field == "DH.joints[1].qmin"
    with pytest.raises(PegbtError, match="not found"):
        read_robot_limits(SHARE, tool="NO_SUCH_TOOL")
    with pytest.raises(PegbtError, match="not a folder"):
        read_robot_limits(tmp_path / "nowhere")


def test_the_real_dvrk_share_folder_reads_as_the_test_copy(tmp_path: Path) -> None:
    """Against jhu-dvrk/sawIntuitiveResearchKit's own files (every field, comments and all), when a mirror is here."""
    if not DVRK_MIRROR.exists():
        pytest.skip(f"no dVRK source mirror at {DVRK_MIRROR}")
    for name in ("kinematic/PSM.json", "tool/LARGE_NEEDLE_DRIVER_400006.json"):
        target = tmp_path / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(
            subprocess.run(
                ["git", "-C", str(DVRK_MIRROR), "show", f"HEAD:share/{name}"], capture_output=True, check=True
            ).stdout
        )
    real, copy = read_robot_limits(tmp_path), read_robot_limits(SHARE)
    assert np.array_equal(real.lower, copy.lower) and np.array_equal(real.upper, copy.upper)
    assert (real.jaw_lower, real.jaw_upper) == (copy.jaw_lower, copy.jaw_upper)
