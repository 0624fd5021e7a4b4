"""The peg channel: while the block's hole is on a peg, the tip must move along the peg's axis; and the
upright limit: while the tool carries the block, it stays close to the pegs' axis so the block hangs
straight.

A channel is the line through `point` (the tip's position when the block sits on the peg) along the
unit `axis` (the peg's "up"), for heights below `clear` (m above `point` along the axis, where the block
leaves the peg); `tolerance` is how far off the line the tip may be. The tip grips the block's wall `lever`
from the hole's axis: turning the tool about the axis by ψ carries the hole lever·ψ round the tip, so on the
peg the tool turns at most `max_twist` (the hole moved by no more than the tip's own tolerance; a simulated
block whose hole came 2 mm off its peg caught on it, `pegbt.sim.world`). A peg's channel is a `floor` too: the
block hangs below the tip, so the transit after it stays above its clearing height; a jaw's way out of a
block another arm holds is not (the block stays behind: the transit's own clearance applies once the jaw
is out), nor is the handover's meeting point, a channel pointing down that the block comes up onto (its
heights count down from there, and the tip on it stays at or below the point; the transit keeps above
the start peg's clearing height alone). Such a way out may widen, a funnel: from `widens_from` up the tip may leave the line by `widening`
for each metre it rises (the jaw's tips then clear the block's top, `pegbt.behaviours.poses.approach_for`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError


def perpendiculars(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """Two unit vectors (2, 3) perpendicular to the unit `axis` and to each other."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    first = np.cross(axis, helper)
    first /= np.linalg.norm(first)
    return np.stack([first, np.cross(axis, first)])


@dataclass(frozen=True)
class Channel:
    point: NDArray[np.float64]
    axis: NDArray[np.float64]
    clear: float
    tolerance: float
    floor: bool = True
    lever: float = 0.0  # m; 0: the tool may turn about the axis (nothing held off the tip's line)
    widens_from: float = np.inf  # m above `point`: the channel is a cylinder below, a funnel above
    widening: float = 0.0  # m off the line allowed per m risen above `widens_from`

    def __post_init__(self) -> None:
        point, axis = np.asarray(self.point, dtype=float), np.asarray(self.axis, dtype=float)
        if (
            point.shape != (3,)
            or axis.shape != (3,)
            or not np.all(np.isfinite(point))
            or not np.isfinite(axis).all()
        ):
            raise PegbtError("a channel needs a finite point and axis of 3 values", field="channel")
        norm = np.linalg.norm(axis)
        if norm == 0:
            raise PegbtError("the channel axis is zero", field="channel.axis")
        object.__setattr__(self, "point", point)
        object.__setattr__(self, "axis", axis / norm)

    @cached_property
    def normals(self) -> NDArray[np.float64]:
        """Two unit vectors (2, 3) perpendicular to the axis and to each other."""
        return perpendiculars(self.axis)

    @property
    def in_the_air(self) -> bool:
        """Whether, as a goal, it sets no clearing height for the transit before it: none above its point,
        or a channel that is no floor (the handover's meeting point, which the block comes up onto)."""
        return self.clear <= 0.0 or not self.floor

    @property
    def max_twist(self) -> float:
        """How far (rad) the tool may turn about the axis while the block is on the peg."""
        return self.tolerance / self.lever if self.lever > 0 else np.inf

    def twist(self, tool_x: ArrayLike, reference_x: ArrayLike) -> NDArray[np.float64]:
        """The turn (...) about the axis from the tool x axis `reference_x` (3,) to each of `tool_x` (..., 3)."""
        tool_x, reference_x = np.asarray(tool_x), np.asarray(reference_x)
        return np.arctan2(np.cross(reference_x, tool_x) @ self.axis, tool_x @ reference_x)

    def height(self, tip: ArrayLike) -> NDArray[np.float64]:
        """Height (...) of tip positions (..., 3) above `point` along the axis."""
        return (np.asarray(tip) - self.point) @ self.axis

    def allowed(self, height: ArrayLike) -> NDArray[np.float64]:
        """How far (...) off the line the tip may be at `height` (...) above `point`."""
        risen = np.maximum(np.asarray(height, dtype=float) - self.widens_from, 0.0)
        return self.tolerance + self.widening * np.where(np.isfinite(risen), risen, 0.0)

    def distance(self, tip: ArrayLike) -> NDArray[np.float64]:
        """Distance (...) of tip positions (..., 3) from the channel's line."""
        offset = np.asarray(tip) - self.point
        return np.linalg.norm(offset - np.multiply.outer(offset @ self.axis, self.axis), axis=-1)


@dataclass(frozen=True)
class Upright:
    """The tool's axis may lean at most `max_tilt` (rad) away from the unit `axis` (the pegs' "up")."""

    axis: NDArray[np.float64]
    max_tilt: float

    def __post_init__(self) -> None:
        axis = np.asarray(self.axis, dtype=float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0:
            raise PegbtError("the upright axis needs 3 finite values, not all zero", field="upright.axis")
        if not 0 < self.max_tilt < np.pi / 2:
            raise PegbtError(
                f"the upright tilt limit must lie in (0, π/2) rad, got {self.max_tilt!r}",
                field="upright.max_tilt",
            )
        object.__setattr__(self, "axis", axis / np.linalg.norm(axis))

    @cached_property
    def normals(self) -> NDArray[np.float64]:
        """Two unit vectors (2, 3) perpendicular to the axis and to each other."""
        return perpendiculars(self.axis)

    def tilt(self, tool_axes: ArrayLike) -> NDArray[np.float64]:
        """Angle (...) between tool axes (..., 3), unit vectors pointing back up the tool, and `axis`."""
        return np.arccos(np.clip(np.asarray(tool_axes) @ self.axis, -1.0, 1.0))
