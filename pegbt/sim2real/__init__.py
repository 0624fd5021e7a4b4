"""Sim to real: locate where a simulator and real recordings disagree, name the physics it left out,
fit it with uncertainty, and show the held-out fit improve; proven on synthetic data with concealed
effects (`synth`) that the diagnosis never sees the truth of.

Entry points: `load_recording(path)`, `diagnose(recording, sim="ideal") -> Diagnosis`,
`write_report(diagnosis, out_dir)`, and for calibration `identify(q_cmd, q_phy, t=None) -> list[Effect]`
(the whole fitted arm-physics model, ready for `pegbt.physics.ArmPhysics`).

The names load on first use (PEP 562): `pegbt --help` imports this package's command module, and the
diagnosis pulls in scipy.signal, which alone takes most of a second.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "Diagnosis": "pegbt.sim2real.diagnose",
    "diagnose": "pegbt.sim2real.diagnose",
    "identify": "pegbt.sim2real.diagnose",
    "Recording": "pegbt.physics.recording",
    "load_recording": "pegbt.physics.recording",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
