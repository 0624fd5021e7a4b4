"""Whether the arm joints' errors are one geometric displacement rather than cable physics.

A fiducial tracker reports joints through the arm's kinematics: if its registration to the arm is off by
a fixed translation (or the arm's own kinematic calibration is), every tool point it sees is displaced by
the same vector d, and the joints change by Δq = J(q)⁻¹ (d, 0), J the tool pose's Jacobian
(`pegbt.motion.kinematics`): q1–q3 carry the displacement, by amounts that depend on where the arm is,
and the wrist turns back the tilt their change gives the tool. Per-joint cable effects cannot express
that one cause. After a first choice of effects, this check fits joint offsets plus one displacement to
q1–q3 in the diagnosis's held-out folds; when that predicts them clearly better than the cable effects,
the diagnosis takes the displacement out before choosing the effects again (and adds it back to their
prediction), and the report names it as geometry, not a cable effect: the tracker's registration or the
arm's kinematic calibration, which a tracker alone cannot tell apart.

A constant offset on q1–q3 is geometry too: where the arm was homed, or where the tracker's registration
puts its zero (an insertion offset is the tool's length as the tracker models it). The diagnosis fits it like
any offset, and the physics model keeps it, but reports it apart from the cable effects (`is_arm_zero`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.motion.kinematics import forward_kinematics
from pegbt.physics import Effect
from pegbt.scratch import scratch, scratch_where

Array = NDArray[np.float64]

ARM_JOINTS = 3  # q1–q3: the joints a displacement is fitted on (the wrist's cable errors are far larger)
GUARD = 0.8  # the displacement's held-out squared error over the named physics', at most, on q1–q3
STEP = 1e-6  # rad or m: finite-difference step of the Jacobian
CHUNK_ROWS = 8192


def is_arm_zero(effect: Effect) -> bool:
    """Whether `effect` is a constant offset on q1–q3: a zero of the arm or of the tracker, not cable physics."""
    return effect.kind.is_intercept and effect.index < ARM_JOINTS


def displacement_columns(q_cmd: Array) -> Array:
    """(N, 6, 3): how each joint (rows) changes per metre of tool displacement along x, y, z (columns),
    the tool's orientation unchanged: J(q)⁻¹ of the tip pose's Jacobian (position and rotation rows) on
    a displacement with no rotation. q1–q3 carry it; the wrist turns back what their change tilts.
    Computed `CHUNK_ROWS` samples at a time: each sample's Jacobian and its transients (130 numbers) would
    otherwise be held for the whole recording at once."""
    q_cmd = np.asarray(q_cmd, dtype=float)
    columns = np.empty((len(q_cmd), q_cmd.shape[1], 3))
    for a in range(0, len(q_cmd), CHUNK_ROWS):
        columns[a : a + CHUNK_ROWS] = _displacement_columns(q_cmd[a : a + CHUNK_ROWS])
    return columns


def _displacement_columns(q: Array) -> Array:
    pose = forward_kinematics(q)
    jacobian = np.empty((len(q), 6, q.shape[1]))
    for j in range(q.shape[1]):
        nudged = q.copy()
        nudged[:, j] += STEP
        moved = forward_kinematics(nudged)
        jacobian[:, :3, j] = (moved[:, :3, 3] - pose[:, :3, 3]) / STEP
        turn = moved[:, :3, :3] @ np.swapaxes(pose[:, :3, :3], 1, 2)  # ≈ I + [ω]× STEP
        jacobian[:, 3:, j] = np.stack([turn[:, 2, 1], turn[:, 0, 2], turn[:, 1, 0]], axis=1) / STEP
    return np.asarray(np.linalg.inv(jacobian)[:, :, :3], dtype=float)


@dataclass(frozen=True)
class GeometryCheck:
    """A displacement that explains q1–q3: its vector, and q1–q3's held-out RMSE with it and with the
    named physics (both over the error before either)."""

    displacement_m: tuple[float, float, float]
    heldout_ratio: tuple[float, float, float]
    physics_ratio: tuple[float, float, float]

    def sentence(self) -> str:
        mm = ", ".join(f"{1000 * v:+.1f}" for v in self.displacement_m)
        ratios = " / ".join(f"{r:.2f}" for r in self.heldout_ratio)
        physics = " / ".join(f"{r:.2f}" for r in self.physics_ratio)
        return (
            f"q1–q3 move together as if the tool were displaced by ({mm}) mm in the arm's base frame: with "
            f"joint offsets, that one displacement predicts q1 / q2 / q3 held out to {ratios} of their error, "
            f"cable effects alone to {physics}; it is taken out before naming them. A geometric error (the tracker's registration, or the arm's "
            "kinematic calibration), not a cable effect"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "displacement_m": list(self.displacement_m),
            "heldout_ratio": list(self.heldout_ratio),
            "physics_ratio": list(self.physics_ratio),
            "text": self.sentence(),
        }


def _design(columns: Array) -> Array:
    """(k, 3, 6): per q1–q3 row, its own offset and the displacement's three columns."""
    offsets = np.broadcast_to(np.eye(ARM_JOINTS), (len(columns), ARM_JOINTS, ARM_JOINTS))
    return np.concatenate([offsets, columns[:, :ARM_JOINTS]], axis=2)


def _pieces(segments: list[tuple[int, int]]) -> Iterator[tuple[int, int]]:
    """The rows of `segments` as pieces of at most `CHUNK_ROWS`."""
    for a, b in segments:
        for start in range(a, b, CHUNK_ROWS):
            yield start, min(b, start + CHUNK_ROWS)


def _fit(q_cmd: Array, error: Array, weights: Array, segments: list[tuple[int, int]]) -> Array:
    """Weighted least squares of q1–q3's `error` on their offsets and one displacement, over the rows of
    `segments`. The design (144 bytes a sample) is built a piece at a time from the commands and folded
    into a QR factor (`numpy.linalg.qr` of the factor so far stacked on the piece), so no more than a
    piece of it is ever held; the small triangular system left is solved by `numpy.linalg.lstsq` with
    the cut-off it would have applied to the whole design."""
    factor, projected, rows = np.zeros((0, 2 * ARM_JOINTS)), np.zeros(0), 0
    for a, b in _pieces(segments):
        design = _design(_displacement_columns(q_cmd[a:b])) / weights[None, :, None]
        x = np.vstack([factor, design.reshape(-1, design.shape[2])])
        q, factor = np.linalg.qr(x)
        projected = q.T @ np.concatenate([projected, (error[a:b] / weights).reshape(-1)])
        rows += design.shape[0] * design.shape[1]
    rcond = np.finfo(float).eps * max(rows, factor.shape[1])
    return np.asarray(np.linalg.lstsq(factor, projected, rcond=rcond)[0], dtype=float)


def _moved(q_cmd: Array, coefficients: Array, joints: int) -> Array:
    """(N, joints): what the displacement in `coefficients` moves each joint by, piece by piece."""
    moved = scratch((len(q_cmd), joints))
    for a, b in _pieces([(0, len(q_cmd))]):
        moved[a:b] = _displacement_columns(q_cmd[a:b])[:, :joints] @ coefficients[ARM_JOINTS:]
    return moved


def _without(n: int, segment: tuple[int, int]) -> list[tuple[int, int]]:
    """The rows outside `segment`, as the segments before and after it."""
    return [(0, segment[0]), (segment[1], n)]


def check_geometry(
    q_cmd: Array,
    error: Array,
    physics_error: Array,
    folds: list[tuple[int, int]],
    resolution: tuple[float, ...] | None,
) -> GeometryCheck | None:
    """The displacement q1–q3's `error` (N, 3: measured minus simulated for the commands `q_cmd`) shows,
    if offsets plus one displacement, refitted without each of `folds` in turn, predict q1–q3 held out
    with at most `GUARD` of the squared error the named physics leaves (`physics_error`, N, 3, held out
    the same way), and the displacement moves some joint by its resolution or more; else None. Joints
    are weighed by their resolution (else by their error), so metres and radians add up."""
    error = np.asarray(error, dtype=float)[:, :ARM_JOINTS]
    physics_error = np.asarray(physics_error, dtype=float)[:, :ARM_JOINTS]
    scale = _rms(error)
    weights = _weights(error, resolution)
    if np.any(weights <= 0) or np.any(scale <= 0):
        return None
    left = scratch(error.shape)
    for a, b in folds:
        coefficients = _fit(q_cmd, error, weights, _without(len(error), (a, b)))
        for c, d in _pieces([(a, b)]):
            left[c:d] = error[c:d] - _design(_displacement_columns(q_cmd[c:d])) @ coefficients
    if _weighted(left, weights) > GUARD * _weighted(physics_error, weights):
        return None
    coefficients = _fit(q_cmd, error, weights, [(0, len(error))])
    moved = _moved(q_cmd, coefficients, ARM_JOINTS)
    moved -= moved.mean(axis=0)  # the part an offset cannot take up
    if resolution and not np.any(_largest(moved) >= weights):
        return None
    ratio = _rms(left) / scale
    physics = _rms(physics_error) / scale
    return GeometryCheck(_triple(coefficients[ARM_JOINTS:]), _triple(ratio), _triple(physics))


def displacement_removal(
    q_cmd: Array, error: Array, resolution: tuple[float, ...] | None
) -> Callable[[NDArray[np.bool_]], Array]:
    """A function of samples `rows` (all of them, or all but one contiguous segment): the displacement
    fitted on them alone (with the joints' offsets, as for `check_geometry`), as it shows in every joint
    of every sample (N, 6; its mean over `rows` left to the joints' offsets). The diagnosis takes it out
    of the error before choosing the cable effects and adds it back to their prediction, fold by fold in
    nested cross-validation."""
    error = np.asarray(error, dtype=float)[:, :ARM_JOINTS]
    weights = _weights(error, resolution)

    def removal(rows: NDArray[np.bool_]) -> Array:
        shift = _moved(q_cmd, _fit(q_cmd, error, weights, _segments(rows)), q_cmd.shape[1])
        return np.subtract(shift, scratch_where(shift, rows).mean(axis=0), out=shift)

    return removal


def _segments(rows: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """The runs of true values in `rows`, as [start, stop) pairs."""
    edges = np.flatnonzero(np.diff(np.r_[0, rows.astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def _weights(error: Array, resolution: tuple[float, ...] | None) -> Array:
    """How q1–q3 are weighed against one another: by resolution, else by their error."""
    if resolution:
        return np.asarray(resolution[:ARM_JOINTS], dtype=float)
    return _rms(error)


def _rms(error: Array) -> Array:
    """Each column's root mean square, its squares in scratch (`pegbt.scratch`), not memory."""
    return np.asarray(np.sqrt(np.square(error, out=scratch(error.shape)).mean(axis=0)), dtype=float)


def _largest(values: Array) -> Array:
    """Each column's largest absolute value, a chunk of rows at a time."""
    return np.max(
        [np.abs(values[a : a + CHUNK_ROWS]).max(axis=0) for a in range(0, len(values), CHUNK_ROWS)], axis=0
    )


def _weighted(error: Array, weights: Array) -> float:
    """The sum of squares of `error` over `weights`, computed in scratch."""
    scaled = np.divide(error, weights, out=scratch(error.shape))
    return float(np.square(scaled, out=scaled).sum())


def _triple(values: Array) -> tuple[float, float, float]:
    return float(values[0]), float(values[1]), float(values[2])
