"""Inputs the fuzz campaign found mishandled: a `--robot-config` limit written as a huge integer or in
degrees, a ROS 2 namespace that zenoh would read as a wildcard or refuse, and an rmw_zenoh attachment whose
GID length claims terabytes (zenoh's deserializer aborted the process)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.motion.robot_config import read_robot_limits
from pegbt.transport.rmw_zenoh import decode_attachment, encode_attachment
from pegbt.transport.wires import check_names

SHARE = Path(__file__).parents[1] / "data" / "dvrk-share"


@pytest.mark.parametrize(
    ("written", "words"),
    [
        ("0x" + "f" * 5000, "an integer of 20000 bits is beyond"),
        ("-260", "-260 is beyond"),
        ("NaN", "finite"),
    ],
)
def test_a_roll_limit_no_arm_has_is_refused_naming_the_field(
    tmp_path: Path, written: str, words: str
) -> None:
    share = tmp_path / "share"
    shutil.copytree(SHARE, share)
    tool = share / "tool" / "LARGE_NEEDLE_DRIVER_400006.json"
    tool.write_text(tool.read_text().replace('"qmin": -4.53786', f'"qmin": {written}'))
    with pytest.raises(PegbtError, match=words) as raised:
        read_robot_limits(share)
    assert raised.value.file == str(tool) and raised.value.field == "DH.joints[0].qmin"


def test_a_tool_name_is_a_file_name_not_a_path() -> None:
    with pytest.raises(PegbtError, match="a tool is named by its file") as raised:
        read_robot_limits(SHARE, tool="../kinematic/PSM")
    assert raised.value.field == "--robot-tool"


@pytest.mark.parametrize("namespace", ["", "/", "lab2", "/lab2/dvrk/"])
def test_ros2_namespaces_pass(namespace: str) -> None:
    check_names(namespace, "pegbt")


@pytest.mark.parametrize("namespace", ["*", "lab/**", "$*", "a#b", "a?b", "a//b", "1lab", "lab-2", "a" * 300])
def test_names_zenoh_would_read_as_wildcards_or_refuse_are_refused_by_every_wire(namespace: str) -> None:
    with pytest.raises(PegbtError, match="is not a key prefix|at most 255") as raised:
        check_names(namespace, "pegbt")
    assert raised.value.field == "--namespace"


def test_an_attachment_claiming_a_huge_gid_is_dropped_not_fatal() -> None:
    valid = encode_attachment(3, 4, bytes(range(16)))
    huge = valid[:16] + bytes([0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x5F]) + valid[17:]  # a LEB128 length of ~3 TB
    code = (
        "from pegbt.transport.rmw_zenoh import decode_attachment; "
        f"print(decode_attachment({huge!r}), decode_attachment({valid[:-1]!r}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0 and done.stdout.split() == ["None", "None"], done.stderr[-300:]
    assert decode_attachment(valid) is not None
