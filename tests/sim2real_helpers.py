"""Shared builders for the sim2real tests: commands and recordings with known physics."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording, write_recording
from pegbt.sim2real.synth import smooth_commands

SIGMA = 0.002


def commands(seed: int, seconds: float = 20.0, rate_hz: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    return t, smooth_commands(rng, t, rng.uniform(0.8, 1.6, 6))


def recording_with(
    effects: list[Effect], seed: int = 0, noise: str = "white", sigma: float = SIGMA, seconds: float = 20.0
) -> Recording:
    """A 100 Hz stream whose physical joints follow `effects`, plus white or AR(1) (ρ = 0.9) noise."""
    t, q_cmd = commands(seed, seconds)
    rng = np.random.default_rng(seed + 1000)
    e = rng.standard_normal(q_cmd.shape)
    if noise == "ar1":
        for n in range(1, len(e)):
            e[n] = 0.9 * e[n - 1] + np.sqrt(1 - 0.81) * e[n]
    q_phy = ArmPhysics(effects).simulate(q_cmd, t) + sigma * e
    return Recording(Path(f"<test {seed}>"), q_cmd, q_phy, t)


def bad_recordings(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Recordings each broken in one way, written under `tmp_path`, with the words the refusal names."""
    rec = recording_with([], seed=1, seconds=2.0)
    cases = {}
    folder = write_recording(tmp_path / "lengths", rec.q_cmd, rec.q_phy[:-3], rec.t)
    cases["lengths"] = (folder, "different lengths")
    q_phy = rec.q_phy.copy()
    q_phy[17, 2] = np.nan
    cases["nan"] = (
        write_recording(tmp_path / "nan", rec.q_cmd, q_phy, rec.t),
        "NaN or infinite value in sample 17",
    )
    t = rec.t.copy()
    t[40] = t[39]
    cases["time"] = (
        write_recording(tmp_path / "time", rec.q_cmd, rec.q_phy, t),
        "timestamps not increasing at sample 40",
    )
    constant = np.zeros_like(rec.q_cmd)
    cases["constant"] = (
        write_recording(tmp_path / "constant", constant, rec.q_phy, rec.t),
        "constant commands",
    )
    cases["single"] = (
        write_recording(tmp_path / "single", rec.q_cmd[:1], rec.q_phy[:1], rec.t[:1]),
        "only 1 sample",
    )
    text = tmp_path / "notes.txt"
    text.write_text("not a recording\n")
    cases["text"] = (text, "not a recording")
    (tmp_path / "empty").mkdir()
    cases["folder"] = (tmp_path / "empty", "lacks q_cmd.npy and q_phy.npy")
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "q_cmd.npy").write_text("garbage")
    (junk / "q_phy.npy").write_text("garbage")
    cases["junk"] = (junk, "cannot read it as a NumPy array")
    csv = tmp_path / "bad.csv"
    header = (
        "t," + ",".join(f"q{i}_cmd" for i in range(1, 7)) + "," + ",".join(f"q{i}_meas" for i in range(1, 7))
    )
    csv.write_text(
        header + "\n" + "\n".join(",".join(["0.1"] * 13) for _ in range(3)) + "\n0.2,x" + ",0" * 11 + "\n"
    )
    cases["csv"] = (csv, ":5:2: q1_cmd: not a number")
    return cases


# a wrist with three effects the diagnosis names
WRIST_EFFECTS = [
    Effect("offset", "q4", {"value": 0.1}),
    Effect("coupling", "q5", {"source": "q6", "k": 0.15}),
    Effect("backlash", "q6", {"half_width": 0.03}),
]


def wrist_recording(folder: Path) -> Path:
    """10 s at 100 Hz of a wrist with `WRIST_EFFECTS`, written to `folder`."""
    rec = recording_with(WRIST_EFFECTS, seed=9, seconds=10.0)
    return write_recording(folder, rec.q_cmd, rec.q_phy, rec.t)
