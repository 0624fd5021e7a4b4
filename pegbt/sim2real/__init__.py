"""Sim to real: locate where a simulator and real recordings disagree, name the physics it left out,
fit it with uncertainty, and show the held-out fit improve; proven on synthetic data with concealed
effects (`synth`) that the diagnosis never sees the truth of.

Entry points: `load_recording(path)`, `diagnose(recording, sim="ideal") -> Diagnosis`,
`write_report(diagnosis, out_dir)`, and for calibration `identify(q_cmd, q_phy, t=None) -> list[Effect]`
(the whole fitted arm-physics model, ready for `pegbt.physics.ArmPhysics`).
"""

from pegbt.sim2real.diagnose import Diagnosis, diagnose, identify
from pegbt.physics.recording import Recording, load_recording

__all__ = ["Diagnosis", "Recording", "diagnose", "identify", "load_recording"]
