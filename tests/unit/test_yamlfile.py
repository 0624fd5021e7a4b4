"""The one YAML reader: typed accessors, and every settings loader's errors naming file, line, column, field."""

from pathlib import Path

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.limits import PSM_SETTINGS, arm_settings
from pegbt.motion.settings import MOTION_SETTINGS, motion_settings
from pegbt.sim.fault_plan import FaultPlan
from pegbt.workcell import WORKCELL_FILE, load_workcell
from pegbt.yamlfile import parse_yaml, read_settings_file


def _located(error: PegbtError) -> tuple:
    return error.file, error.line, error.column, error.field


def _line_of(text: str, fragment: str) -> int:
    return next(number for number, line in enumerate(text.splitlines(), 1) if fragment in line)


def _edited(tmp_path: Path, source: Path, old: str, new: str) -> tuple[Path, str]:
    text = source.read_text()
    assert old in text
    path = tmp_path / source.name
    path.write_text(text.replace(old, new, 1))
    return path, path.read_text()


def test_numbers_are_checked_and_located():
    doc = parse_yaml("a: 1.5\nb: yes\nc: -2\nd: .nan\n", "s.yaml")
    assert doc["a"].number(positive=True) == 1.5
    with pytest.raises(PegbtError, match="expected a finite number, got True") as caught:
        doc["b"].number()
    assert _located(caught.value) == ("s.yaml", 2, 4, "b")
    with pytest.raises(PegbtError, match="expected a positive number"):
        doc["c"].number(positive=True)
    with pytest.raises(PegbtError, match=r"in \[0, 1\]"):
        doc["c"].number(low=0.0, high=1.0)
    with pytest.raises(PegbtError, match="finite"):
        doc["d"].number()
    assert doc.number_or("missing", 7.0) == 7.0


def test_arrays_name_the_bad_element_and_want_their_shape():
    doc = parse_yaml("m:\n  - [1, 2]\n  - [3, x]\nv: [1, 2, 3]\n", "s.yaml")
    with pytest.raises(PegbtError) as caught:
        doc["m"].array((2, 2))
    assert _located(caught.value) == ("s.yaml", 3, 9, "m[1][1]")
    assert np.array_equal(doc["v"].array((3,)), [1.0, 2.0, 3.0])
    with pytest.raises(PegbtError, match="expected 2 finite numbers") as caught:
        doc["v"].array((2,))
    assert caught.value.field == "v"


def test_mappings_refuse_unknown_fields_and_name_missing_ones():
    doc = parse_yaml("outer:\n  known: 1\n  typo: 2\n", "s.yaml")
    with pytest.raises(PegbtError, match="unknown field; expected one of known, other") as caught:
        doc["outer"].mapping(("known", "other"))
    assert _located(caught.value) == ("s.yaml", 3, 3, "outer.typo")
    with pytest.raises(PegbtError, match="missing") as caught:
        doc["outer"]["other"]
    assert _located(caught.value) == ("s.yaml", 2, 3, "outer.other")
    assert doc.section("absent", ("x",)).number_or("x", 3.0) == 3.0
    with pytest.raises(PegbtError, match="one of PSM1, PSM2"):
        parse_yaml("arm: PSM3", "s.yaml")["arm"].choice(("PSM1", "PSM2"))


def test_rigid_transforms_are_projected_onto_rotations():
    doc = parse_yaml(
        "T:\n  rotation: [[0, -1, 0], [1, 0, 0], [0, 0, 1]]\n  translation: [1, 2, 3]\n", "s.yaml"
    )
    T = doc["T"].rigid()
    assert np.allclose(T[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]]) and np.allclose(T[:3, 3], [1, 2, 3])
    bad = parse_yaml(
        "T:\n  rotation: [[2, 0, 0], [0, 1, 0], [0, 0, 1]]\n  translation: [0, 0, 0]\n", "s.yaml"
    )
    with pytest.raises(PegbtError, match="not a rotation matrix") as caught:
        bad["T"].rigid()
    assert caught.value.field == "T.rotation"


def test_settings_files_may_merge_anchors_and_override_them(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("base: &b {x: 1, y: 2}\nuse:\n  <<: *b\n  y: 5\n")
    doc = read_settings_file(path)
    assert doc["use"].plain() == {"x": 1, "y": 5}
    assert doc["use"]["x"].path == "use.x"
    path.write_text("base: &b {x: 1}\nuse:\n  <<: *b\n  y: 5\n  y: 6\n")
    with pytest.raises(PegbtError, match="duplicate key 'y'") as caught:
        read_settings_file(path)
    assert caught.value.line == 5
    with pytest.raises(PegbtError, match="merge key"):
        parse_yaml("base: &b {x: 1}\nuse:\n  <<: *b\n", "tree.yaml")


def test_a_broken_psm_file_is_a_located_error_not_a_parser_traceback(tmp_path):
    path, text = _edited(tmp_path, PSM_SETTINGS, "lower: -0.3491", "lower: [-0.3491")
    with pytest.raises(PegbtError, match="YAML syntax") as caught:
        arm_settings("PSM1", path)
    assert (
        caught.value.file == str(path)
        and caught.value.line is not None
        and caught.value.line >= _line_of(text, "lower: [-0.3491")
    )


def test_a_non_number_joint_limit_names_its_line_and_field(tmp_path):
    path, text = _edited(
        tmp_path, PSM_SETTINGS, "upper: [1.3963, 0.925025, 0.24,", "upper: [1.3963, 0.925025, deep,"
    )
    with pytest.raises(PegbtError, match="expected a finite number, got 'deep'") as caught:
        arm_settings("PSM2", path)
    line = _line_of(text, "deep")
    # The limits are written once, under `defaults`, and merged into each arm: the error points there.
    assert _located(caught.value) == (
        str(path),
        line,
        text.splitlines()[line - 1].index("deep") + 1,
        "arms.PSM2.joint_limits.upper[2]",
    )


def test_a_bad_slips_entry_in_a_fault_plan_is_located(tmp_path):
    plan = tmp_path / "faults.yaml"
    plan.write_text("seed: 1\nworld: {slips: 5}\n")
    with pytest.raises(PegbtError, match="expected a list") as caught:
        FaultPlan.load(plan)
    assert _located(caught.value) == (str(plan), 2, 16, "world.slips")
    plan.write_text("world:\n  slips:\n    - {time: soon}\n")
    with pytest.raises(PegbtError, match="expected a finite number") as caught:
        FaultPlan.load(plan)
    assert _located(caught.value) == (str(plan), 3, 14, "world.slips[0].time")
    plan.write_text("camera: {bursts: 5}\n")
    with pytest.raises(PegbtError, match="expected a list") as caught:
        FaultPlan.load(plan)
    assert caught.value.field == "camera.bursts"


def test_a_wrong_typed_workcell_field_names_its_line_and_field(tmp_path):
    path, text = _edited(tmp_path, WORKCELL_FILE, "  extent_y: [-0.015, 0.080]", "  extent_y: {low: -0.015}")
    with pytest.raises(PegbtError, match="expected 2 finite numbers, got a mapping") as caught:
        load_workcell(path)
    assert _located(caught.value) == (str(path), _line_of(text, "extent_y"), 13, "board.extent_y")


def test_an_unknown_settings_field_is_refused_where_it_is_written(tmp_path):
    path, text = _edited(tmp_path, MOTION_SETTINGS, "  jaw_open: 0.8727", "  jaw_opn: 0.8727")
    with pytest.raises(PegbtError, match="unknown field") as caught:
        motion_settings(path)
    assert _located(caught.value) == (str(path), _line_of(text, "jaw_opn"), 3, "transfer.jaw_opn")
    path, text = _edited(tmp_path, WORKCELL_FILE, "handover:\n", "motion:\n  jaw_open: 0.8\nhandover:\n")
    with pytest.raises(PegbtError, match="unknown field") as caught:
        load_workcell(path)
    assert _located(caught.value) == (str(path), _line_of(text, "motion:"), 1, "motion")
