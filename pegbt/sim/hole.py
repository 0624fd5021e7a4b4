"""Where a peg's axis may stand in a block's hole without touching it.

The paper's block (`img/block.pcd` and `3D_modeling/peg_transfer_kit/block.SLDPRT`,
BerkeleyAutomation/FLSpegtransferHO) has no round hole: a 4.5 mm circle (the paper's "4.5 mm opening")
cut by three flats 3.4 mm out along the edge normals, where the walls the jaws grip are. A peg of radius r
stands clear of it while its axis keeps within the circle less r and `flat` less r of each flat: a
triangle with rounded corners, convex, 1.8 mm from the centre towards a wall and 2.9 mm towards a corner.
The world keeps its walls at 3.6 mm (2.0 mm towards a wall) and takes the lobes as the world effect
`hole_lobes`; at its default the room is the round hole's disc.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Matrix = NDArray[np.float64]
_BISECTIONS = 40  # halvings of a slide of a few millimetres: well under a nanometre


@dataclass(frozen=True)
class HoleRoom:
    """The room a peg's axis has in a hole (block x, y, m): within `lobe` of the centre and `flat` along
    each of `normals` (unit, (k, 2)); both already less the peg's radius."""

    lobe: float
    flat: float
    normals: Matrix

    def outside(self, points: Matrix) -> Matrix:
        """How far (m, 0 within) each of `points` (n, 2) lies beyond the room."""
        points = np.atleast_2d(points)
        return np.linalg.norm(points - self.nearest(points), axis=1)

    def nearest(self, points: Matrix) -> Matrix:
        """The room's point nearest each of `points` (n, 2): itself within, else on the room's border (on
        the circle, on a flat, or where the two meet; the room is convex, so the nearest of those within)."""
        points = np.atleast_2d(np.asarray(points, dtype=float))
        inside = self._inside(points)
        if inside.all():  # a threaded block's peg, tick after tick
            return points
        norms = np.maximum(np.linalg.norm(points, axis=1), 1e-300)[:, None]
        on_flats = points[:, None, :] - (points @ self.normals.T - self.flat)[:, :, None] * self.normals[None]
        candidates = np.concatenate(
            [
                (points * self.lobe / norms)[:, None, :],
                on_flats,
                np.broadcast_to(self._corners, (len(points), *self._corners.shape)),
            ],
            axis=1,
        )
        distances = np.linalg.norm(candidates - points[:, None, :], axis=2)
        distances[~self._inside(candidates, 1e-12)] = np.inf
        nearest = candidates[np.arange(len(points)), np.argmin(distances, axis=1)]
        return np.where(inside[:, None], points, nearest)

    @property
    def _corners(self) -> Matrix:
        """(2k, 2) where the flats meet the circle."""
        half_chord = math.sqrt(max(self.lobe**2 - self.flat**2, 0.0))
        along = self.normals @ np.array([[0.0, 1.0], [-1.0, 0.0]])  # each normal turned a quarter
        return np.concatenate(
            [self.flat * self.normals + half_chord * along, self.flat * self.normals - half_chord * along]
        )

    def shrunk(self, by: float) -> HoleRoom:
        """The room `by` narrower all round."""
        return HoleRoom(self.lobe - by, self.flat - by, self.normals)

    def within(self, points: Matrix, margin: float = 0.0) -> NDArray[np.bool_]:
        """Which of `points` (n, 2) lie within the room widened by `margin` all round."""
        return self.outside(points) <= margin + 1e-12

    def _inside(self, points: Matrix, slack: float = 0.0) -> NDArray[np.bool_]:
        """Which of `points` (..., 2) lie within the room, `slack` wider."""
        return (np.linalg.norm(points, axis=-1) <= self.lobe + slack) & (
            (points @ self.normals.T <= self.flat + slack).all(axis=-1)
        )

    def slide(self, start: Matrix, direction: Matrix, wanted: float, inside: float) -> float:
        """How far (m, signed as `wanted`, at most it) a block whose peg stands at `start` in its hole
        slides along `direction` before the hole comes within `inside` of the peg (the peg's place in
        the hole moves by the opposite)."""
        room = self.shrunk(inside)
        if not room._inside(start):
            return 0.0
        if room._inside(start - wanted * direction):
            return wanted
        low, high = 0.0, 1.0  # fractions of `wanted`: the room is convex, so one crossing
        for _ in range(_BISECTIONS):
            middle = (low + high) / 2
            low, high = (middle, high) if room._inside(start - middle * wanted * direction) else (low, middle)
        return low * wanted
