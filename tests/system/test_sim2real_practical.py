"""Practical significance on recordings whose truth is known: an effect below the measurement's
resolution is listed, not named, and still predicts; a joint whose error is mostly bias gets its offset first, and the
shares add up; the report opens with the named effects in order of what they explain."""

import contextlib
import io
import json

import numpy as np
import pytest

from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.physics import Effect
from pegbt.physics.recording import load_recording, parse_resolution, write_recording
from pegbt.sim2real.diagnose import diagnose
from tests.sim2real_helpers import recording_with

RESOLUTION = (0.01, 0.01, 0.0005, 0.01, 0.01, 0.01)
SMALL_ON_Q4 = Effect("offset", "q4", {"value": 0.004})  # clear in 0.0005 rad noise, under 0.01 rad
LARGE_ON_Q5 = Effect("coupling", "q5", {"source": "q6", "k": 0.2})


def _named(diagnosis):
    return {(e.effect.effect, e.effect.joint) for e in diagnosis.effects}


@pytest.fixture(scope="module")
def small_and_large():
    return recording_with([SMALL_ON_Q4, LARGE_ON_Q5], seed=4, sigma=0.0005)


def test_an_effect_below_resolution_is_listed_not_named(small_and_large):
    unresolved = diagnose(small_and_large, n_bootstrap=0)
    assert ("offset", "q4") in _named(unresolved)  # the test alone finds it
    resolved = diagnose(small_and_large, n_bootstrap=0, resolution=RESOLUTION)
    assert _named(resolved) == {("coupling", "q5")}
    (below,) = [b for b in resolved.below_resolution if b.label == "offset on q4"]
    assert below.size == pytest.approx(0.004, rel=0.2)
    assert "below the resolution 0.01 rad" in below.reason
    # it held up in every fold, so the model still predicts with it: named or not, the same fit
    assert resolved.physics.offset[3] == pytest.approx(unresolved.physics.offset[3], rel=1e-6)
    assert resolved.physics.offset[3] == pytest.approx(0.004, rel=0.2)
    assert resolved.rmse_after()["q4"] == pytest.approx(unresolved.rmse_after()["q4"], rel=1e-6)


def test_a_bias_dominated_joint_gets_its_offset_first_and_the_shares_add_up():
    effects = [
        Effect("offset", "q4", {"value": 0.14}),
        Effect("coupling", "q4", {"source": "q6", "k": 0.08}),
    ]
    diagnosis = diagnose(recording_with(effects, seed=6), n_bootstrap=0, resolution=RESOLUTION)
    on_q4 = [e for e in diagnosis.effects if e.effect.joint == "q4"]
    assert [e.effect.effect for e in on_q4] == ["offset", "coupling"]
    assert on_q4[0].explains > 0.9 > on_q4[1].explains > 0.0
    before, after = diagnosis.rmse_before()["q4"], diagnosis.rmse_after()["q4"]
    explained = 1 - (after / before) ** 2
    assert sum(e.explains for e in on_q4) == pytest.approx(explained, abs=0.01)


def test_the_report_opens_with_the_named_effects_and_lists_what_is_below_resolution(
    small_and_large, tmp_path
):
    folder = write_recording(
        tmp_path / "rec",
        small_and_large.q_cmd,
        small_and_large.q_phy,
        small_and_large.t,
        resolution=RESOLUTION,
    )
    assert load_recording(folder).resolution == RESOLUTION
    out = tmp_path / "out"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["sim2real", "diagnose", str(folder), "--out", str(out), "--bootstrap", "0"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert [e["effect"] for e in report["effects"]] == ["coupling"]
    assert report["resolution"]["q3"] == 0.0005
    assert [b["effect"] for b in report["below_resolution"]] == ["offset on q4"]
    lines = (out / "report.md").read_text().splitlines()
    assert lines[2] == "In order of what they explain:"
    assert lines[4].startswith("1. q5 follows the q6 command")
    assert "## Below resolution (in the model, not named)" in lines


def test_resolution_from_the_command_line_overrides_and_bad_values_are_refused(small_and_large, tmp_path):
    folder = write_recording(
        tmp_path / "rec", small_and_large.q_cmd, small_and_large.q_phy, small_and_large.t
    )
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(
            [
                "sim2real",
                "diagnose",
                str(folder),
                "--json",
                "--bootstrap",
                "0",
                "--resolution",
                "0,0,0,0,0.5,0",
            ]
        )
    assert status == 0
    report = json.loads(printed.getvalue())
    named = [(e["effect"], e["joint"]) for e in report["effects"]]
    assert named == [("offset", "q4")]  # resolved at 0; the coupling moves q5 by less than 0.5 rad
    with pytest.raises(PegbtError, match="6 non-negative numbers"):
        parse_resolution("0.01,0.01")
    assert np.isfinite(parse_resolution([1, 2, 3, 4, 5, 6])).all()
