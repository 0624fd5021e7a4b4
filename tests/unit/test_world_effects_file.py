"""World files: the effects a simulated world runs with, read with every error located."""

import math

import pytest

from pegbt.errors import PegbtError
from pegbt.sim.world_effects import (
    WORLD_EFFECT_KINDS,
    WorldEffect,
    WorldEffects,
    read_world_file,
    write_world_file,
)

KINDS = (
    "peg_compliance",
    "chamfer_capture",
    "grip_compliance",
    "jaw_friction",
    "registration_offset",
    "depth_bias",
)


def test_the_issue_s_kinds_are_registered_with_units_ranges_and_inert_defaults_inside_them():
    assert set(KINDS) <= set(WORLD_EFFECT_KINDS)
    for kind in WORLD_EFFECT_KINDS.values():
        for name, (unit, low, high, default, source) in kind.parameters.items():
            assert unit and source, (kind.name, name)
            assert math.isfinite(low) and math.isfinite(high) and low <= default <= high


def test_a_world_file_lists_effects_and_absent_parameters_take_their_defaults(tmp_path):
    path = tmp_path / "world.yaml"
    path.write_text(
        "effects:\n"
        "  - {kind: peg_compliance, deflection: 0.001}\n"
        "  - kind: registration_offset\n"
        "    x: 0.0015\n"
        "    z: -0.0005\n"
    )
    effects = read_world_file(path)
    assert [effect.kind for effect in effects] == ["peg_compliance", "registration_offset"]
    assert effects.values("peg_compliance") == {"stiffness": 2900.0, "deflection": 0.001}
    assert effects.values("registration_offset") == {"x": 0.0015, "y": 0.0, "z": -0.0005}
    assert effects.values("jaw_friction") == WORLD_EFFECT_KINDS["jaw_friction"].defaults()  # not listed
    again = read_world_file(write_world_file(effects, tmp_path / "out" / "again.yaml"))
    assert again == effects


def test_an_empty_list_is_today_s_world(tmp_path):
    path = tmp_path / "world.yaml"
    path.write_text("effects: []\n")
    assert not read_world_file(path) and read_world_file(path) == WorldEffects()


@pytest.mark.parametrize(
    ("text", "where", "said"),
    [
        ("effects:\n  - {kind: peg_complianse}\n", ":2:12: effects[0].kind:", "unknown world effect kind"),
        (
            "effects:\n  - kind: jaw_friction\n    max_lode: 3\n",
            ":3:5: effects[0].max_lode:",
            "unknown field; expected one of kind, max_load, max_acceleration",
        ),
        (
            "effects:\n  - kind: chamfer_capture\n    capture_radius: 0.01\n",
            ":3:21: effects[0].capture_radius:",
            "expected a number in [0.002, 0.004], got 0.01",
        ),
        (
            "effects:\n  - {kind: depth_bias, bias: .nan}\n",
            ":2:30: effects[0].bias:",
            "expected a finite number",
        ),
        (
            "effects:\n  - {kind: depth_bias}\n  - {kind: depth_bias, bias: 0.001}\n",
            ":3:12: effects[1].kind:",
            "listed twice",
        ),
        ("effects:\n  - {bias: 0.001}\n", ":2:5: effects[0].kind:", "missing"),
        ("world: []\n", ":1:1: world:", "unknown field"),
    ],
)
def test_every_error_in_a_world_file_names_its_file_line_column_and_field(tmp_path, text, where, said):
    path = tmp_path / "world.yaml"
    path.write_text(text)
    with pytest.raises(PegbtError) as error:
        read_world_file(path)
    assert str(error.value).startswith(f"{path}{where}") and said in str(error.value)


def test_effects_built_in_code_are_checked_as_a_file_is():
    with pytest.raises(PegbtError, match="no parameter 'stiffnes'"):
        WorldEffects.of({"peg_compliance": {"stiffnes": 10.0}})
    with pytest.raises(PegbtError, match=r"peg_compliance.deflection: expected a number in \[0, 0.003\]"):
        WorldEffect("peg_compliance", {"deflection": 0.01})
    with pytest.raises(PegbtError, match="unknown world effect"):
        WorldEffects.of({"peg_bending": {}})
