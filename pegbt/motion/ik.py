"""Closed-form inverse kinematics of the PSM (the reference paper's Pieper-style method).

Why it is closed form: q1, q2 and q4 rotate about axes through the remote centre of motion (RCM), so
the RCM seen from the tool tip depends only on q3, q5 and q6. Inverting the target pose gives that point
(`t_inv = −Rᵀt`) and, from it, q6, q5 and q3 directly; the rest of the rotation, `R₀⁴ = R·R₄⁸ᵀ`, is an
Euler decomposition in q1, q2, q4.

The same arithmetic runs on Python floats (`math`, about 10 µs for one pose) and on numpy arrays
(vectorised over any batch shape), so the single-pose path pays no numpy overhead.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.kinematics import L1, L2, L3, L4
from pegbt.motion.limits import ArmSettings

_SCALAR = SimpleNamespace(sqrt=math.sqrt, atan2=math.atan2, sin=math.sin, cos=math.cos)
_ARRAY = SimpleNamespace(sqrt=np.sqrt, atan2=np.arctan2, sin=np.sin, cos=np.cos)

ROTATION_TOLERANCE = 1e-6  # how far RᵀR may be from I before a pose is refused as not a rotation
SINGULAR_COS_Q2 = 1e-9  # |cos q2| below this: yaw and roll are not separable


_Num = float | NDArray[np.float64]  # one pose (floats) or a batch (arrays)


def _solve(r: Sequence[Sequence[_Num]], x: _Num, y: _Num, z: _Num, ops: SimpleNamespace) -> tuple:
    """Joint values (q1..q6) and the cos q2 used for the singularity test, for rotation rows `r`
    (r[i][j] = R[i, j]) and tip position (x, y, z); works on floats and on numpy arrays alike."""
    # The RCM (base origin) expressed in the tip frame: t_inv = -Rᵀ t.
    xi = -(r[0][0] * x + r[1][0] * y + r[2][0] * z)
    yi = -(r[0][1] * x + r[1][1] * y + r[2][1] * z)
    zi = -(r[0][2] * x + r[1][2] * y + r[2][2] * z)
    q6 = ops.atan2(xi, zi - L4)
    p = ops.sqrt(xi * xi + (zi - L4) * (zi - L4)) - L3
    depth = ops.sqrt(yi * yi + p * p)  # q3 − L1 + L2: distance from the RCM along the shaft
    q3 = depth + L1 - L2
    q5 = ops.atan2(-yi, p)
    s5, c5, s6, c6 = ops.sin(q5), ops.cos(q5), ops.sin(q6), ops.cos(q6)
    # Rows of R₄⁸ (wrist rotation), then the needed entries of R₀⁴ = R · R₄⁸ᵀ.
    w0 = (-s5 * s6, -c5, -s5 * c6)
    w1 = (-c6, 0.0, s6)
    w2 = (-s6 * c5, s5, -c5 * c6)

    def r04(i: int, w: tuple[_Num, _Num, _Num]) -> _Num:
        return r[i][0] * w[0] + r[i][1] * w[1] + r[i][2] * w[2]

    a02, a12, a22 = r04(0, w2), r04(1, w2), r04(2, w2)
    a10, a11 = r04(1, w0), r04(1, w1)
    cos_q2 = ops.sqrt(a02 * a02 + a22 * a22)
    q1 = ops.atan2(a02, -a22)
    q2 = ops.atan2(-a12, cos_q2)
    q4 = ops.atan2(a11, -a10)
    return (q1, q2, q3, q4, q5, q6), cos_q2, depth, p


@dataclass(frozen=True)
class IKSolution:
    """Joint solutions of a batch of poses, each with its flags.

    `reachable`: the pose is a finite rigid transform with a non-singular solution. `within_limits`: the
    solution also respects the arm's joint limits. `ok` is both. `problems(i)` says why pose `i` failed.
    """

    q: NDArray[np.float64]  # (..., 6)
    reachable: NDArray[np.bool_] | np.bool_  # (...)
    within_limits: NDArray[np.bool_] | np.bool_  # (...)
    settings: ArmSettings | None
    _reasons: tuple[str | None, ...]  # per flattened pose: why it is unreachable, None if reachable

    @property
    def ok(self) -> NDArray[np.bool_] | np.bool_:
        return self.reachable & self.within_limits

    def problems(self, index: int | tuple[int, ...] = ()) -> list[str]:
        """Human-readable reasons pose `index` has no acceptable solution; empty when it has one."""
        index = (index,) if isinstance(index, int) else tuple(index)
        flat = int(np.ravel_multi_index(index, self.reachable.shape)) if self.reachable.shape else 0
        reason = self._reasons[flat]
        if reason is not None:
            return [reason]
        if self.settings is None:
            return []
        return self.settings.joint_violations(self.q[index])


def _reachability(finite: NDArray, orthonormal: NDArray, cos_q2: NDArray, depth: NDArray, p: NDArray) -> list:
    reasons = np.full(finite.shape, None, dtype=object)
    reasons[cos_q2 < SINGULAR_COS_Q2] = "singular: pitch q2 at ±90°, yaw and roll not separable"
    reasons[p <= 0] = "wrist singular: the RCM lies within the wrist (q5 beyond ±90°)"
    reasons[depth <= 0] = "the tip coincides with the remote centre of motion"
    reasons[~orthonormal] = "the pose's rotation is not orthonormal"
    reasons[~finite] = "the pose has non-finite entries"
    return list(reasons.ravel())


def inverse_kinematics(pose: ArrayLike, settings: ArmSettings | None = None) -> IKSolution:
    """Closed-form IK of tip poses (..., 4, 4) in the arm's base frame; flags against `settings`' limits."""
    T = np.asarray(pose, dtype=float)
    if T.shape[-2:] != (4, 4):
        raise PegbtError(f"expected poses of shape (..., 4, 4), got {T.shape}", field="pose")
    if T.ndim == 2:
        return _inverse_kinematics_single(T, settings)
    R = T[..., :3, :3]
    with np.errstate(invalid="ignore", divide="ignore"):
        (q1, q2, q3, q4, q5, q6), cos_q2, depth, p = _solve(
            [[R[..., i, j] for j in range(3)] for i in range(3)],
            T[..., 0, 3],
            T[..., 1, 3],
            T[..., 2, 3],
            _ARRAY,
        )
        q = np.stack(np.broadcast_arrays(q1, q2, q3, q4, q5, q6), axis=-1)
        finite = np.all(np.isfinite(T), axis=(-2, -1))
        gram = np.einsum("...ki,...kj->...ij", R, R) - np.eye(3)
        orthonormal = finite & np.all(np.abs(gram) < ROTATION_TOLERANCE, axis=(-2, -1))
        reachable = orthonormal & (cos_q2 >= SINGULAR_COS_Q2) & (p > 0) & (depth > 0)
        if settings is None:
            within = np.ones(reachable.shape, dtype=bool)
        else:
            within = np.all((q >= settings.lower) & (q <= settings.upper), axis=-1)
    reasons = (
        (None,) * reachable.size
        if reachable.all()
        else tuple(_reachability(finite, orthonormal, cos_q2, depth, p))
    )
    return IKSolution(q, reachable, within & reachable, settings, reasons)


def _inverse_kinematics_single(T: NDArray[np.float64], settings: ArmSettings | None) -> IKSolution:
    rows = T.tolist()
    r = [row[:3] for row in rows[:3]]
    reason = None
    if not all(math.isfinite(v) for row in rows for v in row):
        reason = "the pose has non-finite entries"
    elif any(
        abs(sum(r[k][i] * r[k][j] for k in range(3)) - (i == j)) >= ROTATION_TOLERANCE
        for i in range(3)
        for j in range(3)
    ):
        reason = "the pose's rotation is not orthonormal"
    if reason is not None:
        q = np.full(6, np.nan)
    else:
        joints, cos_q2, depth, p = _solve(r, rows[0][3], rows[1][3], rows[2][3], _SCALAR)
        q = np.array(joints)
        if depth <= 0:
            reason = "the tip coincides with the remote centre of motion"
        elif p <= 0:
            reason = "wrist singular: the RCM lies within the wrist (q5 beyond ±90°)"
        elif cos_q2 < SINGULAR_COS_Q2:
            reason = "singular: pitch q2 at ±90°, yaw and roll not separable"
    within = reason is None and (
        settings is None
        or all(low <= v <= high for v, low, high in zip(q.tolist(), settings.lower, settings.upper))
    )
    return IKSolution(q, np.bool_(reason is None), np.bool_(within), settings, (reason,))


def solve_ik(pose: ArrayLike, settings: ArmSettings, *, what: str = "pose") -> NDArray[np.float64]:
    """Joints (6,) reaching one tip pose within `settings`' limits, or a `PegbtError` naming `what` and
    the violated limit."""
    solution = inverse_kinematics(pose, settings)
    if not solution.ok:
        raise PegbtError(f"not reachable by {settings.name}: " + "; ".join(solution.problems()), field=what)
    return solution.q
