"""Which cable effects an arm has, and how strong: the physics model's source of effects.

`identify_effects` is the single place the physics and hybrid models get their effects from. Until the
sim-to-real tool's identification (`pegbt.sim2real`) is merged, it fits a fixed structure; replacing its
body with a call to that identification changes nothing else.

The fixed structure is the one the dVRK is known to have: per wrist joint (q4, q5, q6) an offset, a
scale and backlash, and the q5↔q6 cable coupling, fitted by least squares over `ArmPhysics.simulate`
(the same code the simulator runs) on settled set-points (no lag or delay); and per arm joint (q1–q3)
an offset and a scale, a straight-line fit: millirad calibration errors of the arm joints move the tip
by as much as the remaining wrist error once that is compensated.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from pegbt.physics import ArmPhysics, Effect

_ARM = ("q1", "q2", "q3")
_WRIST = ("q4", "q5", "q6")
_COUPLINGS = (("q5", "q6"), ("q6", "q5"))  # (joint, source)
_START_HALF_WIDTHS = (0.01, 0.05)  # backlash makes the cost non-smooth: start from a narrow and a wide play


def identify_effects(q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> list[Effect]:
    """Cable effects explaining q_phy from q_cmd (both N×6, settled set-points)."""
    return fit_arm_joint_calibration(q_cmd, q_phy) + fit_fixed_wrist_structure(q_cmd, q_phy)


def fit_arm_joint_calibration(q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> list[Effect]:
    """Offset and scale of each arm joint (q1–q3): q_phy = scale × q_cmd + offset, least squares."""
    effects = []
    for j, name in enumerate(_ARM):
        scale, offset = np.polyfit(q_cmd[:, j], q_phy[:, j], 1)
        effects.append(Effect("offset", name, {"value": float(offset)}))
        effects.append(Effect("scale", name, {"value": float(scale)}))
    return effects


def _effects(x: NDArray[np.float64]) -> list[Effect]:
    offsets, scales, couplings, half_widths = x[0:3], x[3:6], x[6:8], x[8:11]
    effects = []
    for j, name in enumerate(_WRIST):
        effects.append(Effect("offset", name, {"value": float(offsets[j])}))
        effects.append(Effect("scale", name, {"value": float(scales[j])}))
        effects.append(Effect("backlash", name, {"half_width": float(half_widths[j])}))
    for (joint, source), k in zip(_COUPLINGS, couplings):
        effects.append(Effect("coupling", joint, {"source": source, "k": float(k)}))
    return effects


def fit_fixed_wrist_structure(q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> list[Effect]:
    """Least-squares fit of wrist offsets, scales, backlash and q5↔q6 coupling to set-point data."""
    wrist = slice(3, 6)

    def residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return (ArmPhysics(_effects(x)).simulate(q_cmd)[:, wrist] - q_phy[:, wrist]).ravel()

    lower = np.r_[[-np.pi] * 3, [0.5] * 3, [-0.5] * 2, [0.0] * 3]
    upper = np.r_[[np.pi] * 3, [1.5] * 3, [0.5] * 2, [0.3] * 3]
    offsets = np.mean(q_phy[:, wrist] - q_cmd[:, wrist], axis=0)
    best = None
    for half_width in _START_HALF_WIDTHS:
        x0 = np.r_[offsets, [1.0] * 3, [0.0] * 2, [half_width] * 3]
        result = least_squares(residual, x0, bounds=(lower, upper), diff_step=1e-3, x_scale=0.1)
        if best is None or result.cost < best.cost:
            best = result
    assert best is not None
    return _effects(best.x)
