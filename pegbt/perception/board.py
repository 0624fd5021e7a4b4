"""Pegboard registration, once per trial: refine the camera's extrinsics by ICP and find the pegs.

The camera's pose relative to the board is known only roughly (a few millimetres, a few degrees).
Open3D's point-to-plane ICP aligns the captured cloud to the board-and-pegs model, starting from the
nominal `board_from_camera`: coarse correspondence distances on a sparse cloud pull the board's plane
and outline into place, fine ones on a denser cloud let the pegs set the last fraction of a millimetre.
Blocks are not in the model; a robust (Tukey) kernel keeps them from dragging the fit. The pegs are then
found in the height band between the resting blocks' tops and the pegs' tops, where only pegs stand.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.perception.cloud import Points, checked_points, to_open3d, transform_points
from pegbt.perception.models import board_model
from pegbt.perception.settings import BoardSettings, perception_settings
from pegbt.workcell import Workcell, workcell

if TYPE_CHECKING:
    import open3d as o3d


@dataclass(frozen=True)
class BoardEstimate:
    """The registered board: corrected extrinsics, the pegs found, and how well the model fits.

    `peg_tops` (12, 3): each peg's top centre in the board frame, x, y measured from its points
    (the registered model's position where a peg was not seen). `ok` is False, with a `reason`, when
    the fit or a peg is not trustworthy; the caller should capture again rather than use it.
    """

    board_from_camera: NDArray[np.float64]
    peg_tops: NDArray[np.float64]
    peg_points: NDArray[np.int64]
    fitness: float
    rmse: float
    ok: bool
    reason: str

    def to_board(self, cloud: ArrayLike) -> Points:
        """A camera-frame cloud (N, 3) in the board frame, checked."""
        return transform_points(self.board_from_camera, checked_points(cloud))


class PegboardRegistration:
    """Registers the board model to a capture, starting from nominal extrinsics (default: the work cell's)."""

    def __init__(
        self,
        cell: Workcell | None = None,
        nominal_board_from_camera: ArrayLike | None = None,
        settings: BoardSettings | None = None,
    ) -> None:
        self.cell = cell or workcell()
        self.settings = settings or perception_settings().board
        nominal = (
            self.cell.camera.board_from_camera
            if nominal_board_from_camera is None
            else nominal_board_from_camera
        )
        self.nominal_board_from_camera = np.array(nominal, dtype=np.float64)
        import open3d as o3d

        self._model = o3d.t.geometry.PointCloud.from_legacy(
            board_model(self.cell, self.settings.model_points)
        )

    def fit(self, cloud: ArrayLike) -> BoardEstimate:
        """Register the board in a camera-frame capture (N, 3, metres) and find its pegs."""
        import open3d as o3d

        registration = o3d.t.pipelines.registration
        points = checked_points(cloud)
        settings = self.settings
        thinned = to_open3d(points).voxel_down_sample(settings.voxels[-1])  # the legacy grid is ~4× faster
        # wild points each fill a voxel of their own: unremoved, a few percent of them would outnumber the board
        thinned, _ = thinned.remove_radius_outlier(settings.outlier_neighbours, settings.outlier_radius)
        if len(thinned.points) < settings.min_points:
            return self._unregistered(
                f"only {len(thinned.points)} points left after thinning: not a view of the board"
            )
        source = o3d.t.geometry.PointCloud.from_legacy(thinned)
        result = registration.multi_scale_icp(
            source,
            self._model,
            o3d.utility.DoubleVector(settings.voxels),
            [registration.ICPConvergenceCriteria(max_iteration=settings.max_iterations)]
            * len(settings.voxels),
            o3d.utility.DoubleVector(settings.distances),
            o3d.core.Tensor.from_numpy(self.nominal_board_from_camera.copy()),
            registration.TransformationEstimationPointToPlane(
                registration.robust_kernel.RobustKernel(
                    registration.robust_kernel.RobustKernelMethod.TukeyLoss, settings.tukey_k
                )
            ),
        )
        quality = registration.evaluate_registration(
            source, self._model, settings.quality_distance, result.transformation
        )
        T = result.transformation.numpy().astype(np.float64)
        peg_tops, counts = self._find_pegs(transform_points(T, points))
        reason = self._doubt(quality, peg_tops, counts)
        return BoardEstimate(
            board_from_camera=np.array(T),
            peg_tops=peg_tops,
            peg_points=counts,
            fitness=float(quality.fitness),
            rmse=float(quality.inlier_rmse),
            ok=not reason,
            reason=reason,
        )

    def _unregistered(self, reason: str) -> BoardEstimate:
        """A failed registration: the nominal extrinsics and modelled pegs, marked untrustworthy."""
        pegs = self.cell.pegs.tops
        return BoardEstimate(
            self.nominal_board_from_camera.copy(),
            pegs.copy(),
            np.zeros(len(pegs), np.int64),
            0.0,
            math.inf,
            False,
            reason,
        )

    def _find_pegs(self, board_points: Points) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Each peg's top from the points in the pegs-only height band near its modelled axis."""
        pegs, settings = self.cell.pegs, self.settings
        block_top = self.cell.board.surface_z - self.cell.block.height
        z = board_points[:, 2]
        band = board_points[
            (z > pegs.top_z + settings.peg_band_margin) & (z < block_top - settings.peg_band_margin)
        ]
        tops = pegs.tops.copy()
        counts = np.zeros(len(tops), dtype=np.int64)
        for peg, modelled in enumerate(pegs.positions):
            near = band[np.linalg.norm(band[:, :2] - modelled, axis=1) < settings.peg_search_radius, :2]
            counts[peg] = len(near)
            if len(near) >= settings.min_peg_points:
                tops[peg, :2] = circle_centre(near, pegs.radius, modelled)
        return tops, counts

    def _doubt(
        self,
        quality: o3d.t.pipelines.registration.RegistrationResult,
        peg_tops: Points,
        counts: NDArray[np.int64],
    ) -> str:
        """Why this registration should not be trusted ("" if it should)."""
        settings = self.settings
        if quality.fitness < settings.min_fitness:
            return f"board model fits only {quality.fitness:.0%} of the points"
        unseen = np.flatnonzero(counts < settings.min_peg_points)
        if len(unseen):
            return f"peg(s) {', '.join(map(str, unseen))} not seen"
        offsets = np.linalg.norm(peg_tops[:, :2] - self.cell.pegs.positions, axis=1)
        worst = int(np.argmax(offsets))
        if offsets[worst] > settings.max_peg_offset:
            return f"peg {worst} found {offsets[worst] * 1000:.1f} mm from the registered model"
        return ""


def circle_centre(
    points: Points, radius: float, start: ArrayLike, iterations: int = 8
) -> NDArray[np.float64]:
    """Centre of the circle of known `radius` through 2-D `points` (a peg seen from one side).

    The visible half of a peg biases a plain centroid towards the camera by about 2r/π; a least-squares
    fit of the known radius (Gauss-Newton from `start`) does not.
    """
    centre = np.array(start, dtype=np.float64)
    for _ in range(iterations):
        offsets = points - centre
        distances = np.maximum(np.linalg.norm(offsets, axis=1), 1e-9)
        residuals = distances - radius
        jacobian = -offsets / distances[:, None]
        step, *_ = np.linalg.lstsq(jacobian, -residuals, rcond=None)
        centre += step
    return centre
