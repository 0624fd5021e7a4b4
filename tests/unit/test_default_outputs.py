"""Commands that write models or presets write under `runs/` unless `--out` says otherwise: never over the
committed skills/calibration models or the shipped physics presets by default."""

from __future__ import annotations

import hashlib
from pathlib import Path

from calibration_helpers import synthetic, write

from pegbt.calibration.base import CalibrationModel
from pegbt.cli import main
from pegbt.physics import ArmPhysics

REPO = Path(__file__).resolve().parents[2]
SHIPPED = sorted((REPO / "skills" / "calibration").rglob("*.json")) + sorted(
    (REPO / "pegbt" / "physics" / "presets").glob("*.json")
)


def _digests() -> dict[Path, str]:
    return {path: hashlib.sha256(path.read_bytes()).hexdigest() for path in SHIPPED}


def test_train_and_preset_write_under_runs_by_default(tmp_path, monkeypatch, capsys):
    before = _digests()
    folder = write(synthetic(300, noise=0.001), tmp_path / "rec_PSM1")
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", "train", str(folder), "--arm", "PSM1", "--model", "physics"]) == 0
    model = CalibrationModel.load(tmp_path / "runs" / "calibration" / "PSM1-physics.json", arm="PSM1")
    assert model.metadata.training["recording"] == "rec_PSM1"  # the recording's name, not a machine path
    assert main(["sim2real", "preset", "--from", f"PSM1={folder}"]) == 0
    assert "preset: runs/sim2real/preset.json" in capsys.readouterr().out
    preset = ArmPhysics.load(tmp_path / "runs" / "sim2real" / "preset.json", "PSM1")
    assert {effect.effect for effect in preset.effects} >= {"offset", "backlash"}
    assert _digests() == before
