"""Locate every block in a capture: segment, register the block model by ICP, judge the fit.

Each segment is registered with Open3D's point-to-plane ICP against the block model, with
correspondence distances shrinking from a few millimetres to half a millimetre (the paper's
coarse-to-fine schedule). ICP starts from a guess made from the segment itself: the hole on the peg's
axis (or the top face's centre for a block off the pegs), the top face's height, and the yaw of the
top face's three-fold shape. The block is three-fold symmetric, so yaw is reported modulo 120°; the six
grasp candidates share that symmetry. A fit that explains too few points, or leaves the block tilted,
is reported as a failure with its reason, never passed on as a pose. A lone block's failed fit is tried
again from starts round the first: an instrument between the camera and the block hides part of its top
face and misleads the guess. A lone block off the pegs whose bottom is above the board, nothing under it,
is not at rest: held, or an instrument's jaw seen block-sized.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from pegbt.errors import PegbtError
from pegbt.frames import invert_rigid, yaw_of, yaw_pose
from pegbt.perception.board import BoardEstimate
from pegbt.perception.cloud import Points, to_open3d, transform_points
from pegbt.perception.models import block_model
from pegbt.perception.organised import OrganisedCloud, raised_points
from pegbt.perception.segment import block_segments, clusters, split_by_nearest_peg
from pegbt.perception.settings import BlockSettings, perception_settings
from pegbt.workcell import Workcell, workcell

SYMMETRY = 2 * math.pi / 3  # the block looks the same turned by 120°
RESTART_YAWS = tuple(math.radians(turn) for turn in (0.0, 30.0, 60.0, 90.0))  # within the 120° symmetry


@dataclass(frozen=True)
class BlockEstimate:
    """One block found in a capture, in the board frame.

    `position`: centre of the bottom face, on the hole's axis; `yaw` about board z, in [-60°, 60°);
    `peg`: the peg through its hole, or None for a block lying on the board. `ok` False (with a `reason`)
    means a block-sized object was seen but its pose is not trustworthy: re-capture, do not grasp.
    """

    position: NDArray[np.float64]
    yaw: float
    peg: int | None
    fitness: float
    rmse: float
    points: int
    ok: bool
    reason: str

    @property
    def pose(self) -> NDArray[np.float64]:
        """4×4 pose in the board frame, lying flat at `yaw`."""
        return yaw_pose(self.position, self.yaw)


class BlockLocator:
    """Finds blocks in captures; holds the sampled block model and its KD-tree, so both are built once
    (Open3D's evaluation rebuilds the tree at every call, the larger part of its cost)."""

    def __init__(self, cell: Workcell | None = None, settings: BlockSettings | None = None) -> None:
        self.cell = cell or workcell()
        self.settings = settings or perception_settings().block
        self._model = block_model(self.cell, self.settings.model_points)
        self._model_tree = cKDTree(np.asarray(self._model.points))

    def locate(self, cloud: ArrayLike | OrganisedCloud, board: BoardEstimate) -> list[BlockEstimate]:
        """Every block in a camera-frame capture (N, 3, metres), given the registered board; of an organised
        capture (a Zivid's), only the pixels near something raised, at full resolution (`raised_points`).

        `PegbtError` if the board's registration failed: positions from it would be guesses.
        """
        if not board.ok:
            raise PegbtError(
                f"the board registration failed ({board.reason}); register it again", field="board"
            )
        if isinstance(cloud, OrganisedCloud):
            segment, surface = self.settings.segment, self.cell.board.surface_z
            highest = segment.max_stack * self.cell.block.height + segment.plane_margin
            cloud = raised_points(
                cloud.grid, board.board_from_camera, surface - segment.plane_margin, surface - highest
            )
            if len(cloud) == 0:
                return []
        board_points = board.to_board(cloud)
        peg_xy = board.peg_tops[:, :2]
        segments = block_segments(board_points, peg_xy, self.cell, self.settings.segment)
        estimates = [estimate for segment in segments.blocks for estimate in self.unstack(segment, peg_xy)]
        for cluster in segments.touching:
            estimates += self.take_apart(cluster, peg_xy)
        return estimates

    def unstack(self, segment: Points, peg_xy: Points) -> list[BlockEstimate]:
        """The blocks of a segment: one, or, if it stands taller than `stack_height` blocks, a stack (a block
        dropped onto a peg that held one): the top block is fitted from its top face down, its points
        (those above its bottom face) registered as one block, the rest as the block under it."""
        model, settings = self.cell.block, self.settings
        low, high = np.percentile(segment[:, 2], [1.0, 99.0])
        if high - low < settings.stack_height * model.height:
            return [self.resting(self.register(segment, peg_xy, search=True))]
        bottom = self._fit(segment, self.initial_pose(segment, peg_xy))[2, 3]
        above = segment[:, 2] < bottom - settings.top_face_depth  # board z points down
        return [
            self.register(part, peg_xy)
            for part in (segment[above], segment[~above])
            if len(part) >= settings.segment.min_points
        ]

    def resting(self, block: BlockEstimate) -> BlockEstimate:
        """`block`, a segment's only one, doubtful if it is off the pegs and its bottom is above the board: with
        nothing seen under it, it is not at rest (a block a jaw holds, or an instrument's jaw seen as one)."""
        above = self._above_board(block.pose)
        if not block.ok or block.peg is not None or above <= self.settings.segment.plane_margin:
            return block
        return replace(
            block, ok=False, reason=f"nothing under it: its bottom {above * 1000:.1f} mm above the board"
        )

    def take_apart(self, cluster: Points, peg_xy: Points) -> list[BlockEstimate]:
        """The blocks of a cluster too wide for one. Blocks touching across neighbouring pegs are cut apart
        by nearest peg (the paper's per-peg crop), which holds if each part fits a block on its own peg.
        A part that fits doubtfully, or off that peg, means a block lies loose against another and the
        crop cut it (a piece of a block fits the model as well as a whole one: the pieces of one loose
        block were two blocks that were not there): then the block on each peg the cluster surrounds is
        fitted first, by ICP from that peg's axis, and its points taken out; what is left is registered
        as the blocks lying loose. With no peg surrounded, the crop's parts off their pegs are doubtful."""
        cropped = [
            (peg, self.register(part, peg_xy))
            for peg, part in split_by_nearest_peg(cluster, peg_xy)
            if len(part) >= self.settings.segment.min_points
        ]
        if all(estimate.ok and estimate.peg == peg for peg, estimate in cropped):
            return [estimate for _, estimate in cropped]
        estimates: list[BlockEstimate] = []
        rest = cluster
        for peg in self._surrounded_pegs(cluster, peg_xy):
            near = rest[np.linalg.norm(rest[:, :2] - peg_xy[peg], axis=1) < self.cell.block.corner_distance]
            if len(near) < self.settings.segment.min_points:
                continue
            mine = self._near_model(rest, self._fit_from_yaws(near, self.initial_pose(near, peg_xy)))
            estimates.append(self.register(rest[mine], peg_xy))
            rest = rest[~mine]
        if not estimates:
            return [self._cut(estimate, peg) for peg, estimate in cropped]
        return estimates + [self.register(part, peg_xy) for part in clusters(rest, self.settings.segment)]

    @staticmethod
    def _cut(estimate: BlockEstimate, peg: int) -> BlockEstimate:
        """`estimate`, fitted to the part of a touching cluster nearest `peg`, doubtful if it is not a block
        on that peg: the crop may have cut a loose block, and a piece fits as well as a whole block."""
        if not estimate.ok or estimate.peg == peg:
            return estimate
        return replace(estimate, ok=False, reason=f"a piece of a cluster cut at peg {peg}'s cell")

    def _fit_from_yaws(self, segment: Points, initial: NDArray[np.float64]) -> NDArray[np.float64]:
        """The best of ICP fits from `initial` turned by each of `RESTART_YAWS`: the other block's points
        spoil the yaw read off the top face, and ICP started 60° out settles on a wrong fit."""
        fits = [
            self._fit(segment, initial @ yaw_pose([0.0, 0.0, 0.0], turn), robust=True)
            for turn in RESTART_YAWS
        ]
        return fits[int(np.argmax([self._quality(segment, fit)[0] for fit in fits]))]

    def best_fit(
        self, segment: Points, starts: Sequence[NDArray[np.float64]]
    ) -> tuple[NDArray[np.float64], float]:
        """The block pose (board frame) of the best of the ICP fits of `segment` from each of `starts`, by
        its fitness (`_quality`), and that fitness."""
        fits = [self._fit(segment, start) for start in starts]
        fitness = [self._quality(segment, fit)[0] for fit in fits]
        best = int(np.argmax(fitness))
        return fits[best], fitness[best]

    def _surrounded_pegs(self, cluster: Points, peg_xy: Points) -> list[int]:
        """Pegs whose axis the cluster surrounds (points all round it, centred on it), most points first."""
        model = self.cell.block
        found = []
        for peg, xy in enumerate(peg_xy):
            ring = cluster[np.linalg.norm(cluster[:, :2] - xy, axis=1) < model.edge_distance]
            if (
                len(ring) >= self.settings.surrounded_points
                and np.linalg.norm(ring[:, :2].mean(axis=0) - xy) < model.hole_radius
            ):
                found.append((len(ring), peg))
        return [peg for _, peg in sorted(found, reverse=True)]

    def _near_model(self, points: Points, block_to_board: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which `points` (board frame) lie within `part_distance` of the block model placed at `block_to_board`."""
        return np.isfinite(self._distances(points, block_to_board, self.settings.part_distance))

    def _distances(
        self, points: Points, block_to_board: NDArray[np.float64], within: float
    ) -> NDArray[np.float64]:
        """Distance from each of `points` (board frame) to the nearest point of the block model placed at
        `block_to_board`, inf beyond `within`."""
        local = transform_points(invert_rigid(block_to_board), points)
        return np.asarray(self._model_tree.query(local, distance_upper_bound=within)[0])

    def _quality(self, segment: Points, block_to_board: NDArray[np.float64]) -> tuple[float, float]:
        """Open3D's `evaluate_registration` of the block model placed at `block_to_board` against `segment`:
        the share of its points within `quality_distance` of the model (fitness), and their RMSE."""
        distances = self._distances(segment, block_to_board, self.settings.quality_distance)
        inliers = distances[np.isfinite(distances)]
        rmse = math.sqrt(float(np.mean(inliers**2))) if len(inliers) else 0.0
        return len(inliers) / len(segment), rmse

    def _fit(
        self, segment: Points, initial: NDArray[np.float64], robust: bool = False
    ) -> NDArray[np.float64]:
        """The block pose (board frame) that ICP fits to `segment` from `initial`, coarse to fine; `robust`:
        with a Tukey loss, so points of another block touching this one do not pull the fit towards it."""
        import open3d as o3d

        registration = o3d.pipelines.registration
        source = to_open3d(segment)
        T = invert_rigid(initial)  # ICP moves the segment into the block frame
        for distance in self.settings.distances:
            loss = registration.TukeyLoss(k=distance / 2) if robust else registration.L2Loss()
            T = registration.registration_icp(
                source,
                self._model,
                distance,
                T,
                registration.TransformationEstimationPointToPlane(loss),
                registration.ICPConvergenceCriteria(max_iteration=self.settings.max_iterations),
            ).transformation
        return invert_rigid(T)

    def register(self, segment: Points, peg_xy: Points, search: bool = False) -> BlockEstimate:
        """The block whose visible surface is `segment` (board frame); `search`: a lone block's doubtful fit,
        its top face at a resting block's height, is sought again from starts round the first
        (`search_hidden`)."""
        settings = self.settings
        if len(segment) > settings.max_points:
            return self._failure(segment, peg_xy, f"{len(segment)} points are too many for one block")
        initial = self.initial_pose(segment, peg_xy)
        pose = self._fit(segment, initial)
        fitness, rmse = self._quality(segment, pose)
        reason = self._doubt(len(segment), pose, fitness, rmse)
        resting = self._above_board(initial) <= self.settings.segment.plane_margin  # not held, not a jaw
        found = self.search_hidden(segment, initial) if reason and search and resting else None
        if found is not None:
            pose, fitness, rmse, reason = found
        position, yaw = pose[:3, 3], wrap_symmetric(yaw_of(pose))
        return BlockEstimate(
            position=position,
            yaw=yaw,
            peg=self._peg_through_hole(position, peg_xy),
            fitness=fitness,
            rmse=rmse,
            points=len(segment),
            ok=not reason,
            reason=reason,
        )

    def search_hidden(
        self, segment: Points, initial: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, float, str] | None:
        """A block partly hidden (the other arm's instrument between it and the camera) shows part of its top
        face, so the start read off it is millimetres and tens of degrees out, and ICP settles on a wrong
        fit. Its pose, fitness, RMSE and doubt from the best of the fits from `initial` moved by each of
        `search_radii` in `search_directions` directions and turned by each of `RESTART_YAWS`; None if none
        passes and explains all but `search_slack` of the points, or if fewer than `search_min_points` are
        seen. Fits within `search_slack` of the best that disagree with it leave it doubtful: the part seen
        fits more than one pose."""
        settings = self.settings
        if len(segment) < settings.search_min_points:
            return None
        turns = np.linspace(0.0, 2 * math.pi, settings.search_directions, endpoint=False)
        offsets = [np.zeros(2)] + [
            radius * np.array([math.cos(turn), math.sin(turn)])
            for radius in settings.search_radii
            for turn in turns
        ]
        passed = []
        for offset in offsets:
            for yaw in RESTART_YAWS:
                start = initial @ yaw_pose([0.0, 0.0, 0.0], yaw)
                start[:2, 3] += offset
                pose = self._fit(segment, start)
                fitness, rmse = self._quality(segment, pose)
                if not self._doubt(len(segment), pose, fitness, rmse):
                    passed.append((fitness, -rmse, pose))
        fitness, negative_rmse, best = max(passed, key=lambda fit: fit[:2], default=(0.0, 0.0, initial))
        if fitness < 1.0 - settings.search_slack:
            return None
        rivals = [pose for share, _, pose in passed if share >= fitness - settings.search_slack]
        apart = max(self._outline_apart(best, pose) for pose in rivals)
        reason = (
            f"a partly hidden block: poses {apart * 1000:.1f} mm apart fit what is seen"
            if apart > settings.search_agreement
            else ""
        )
        return best, fitness, -negative_rmse, reason

    def _above_board(self, pose: NDArray[np.float64]) -> float:
        """How far (m) the bottom of a block at `pose` is above the board."""
        return self.cell.board.surface_z - float(pose[2, 3])  # board z points down

    def _outline_apart(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
        """How far (m) the outline of the block at pose `a` lies from that at `b`: the farthest of `a`'s
        corners from the nearest of `b`'s (the outline's three-fold symmetry leaves yaw modulo 120°)."""
        outline = np.column_stack([self.cell.block.outline, np.zeros(6), np.ones(6)])
        corners_a, corners_b = ((outline @ pose.T)[:, :2] for pose in (a, b))
        return float(np.linalg.norm(corners_a[:, None] - corners_b[None], axis=2).min(axis=1).max())

    def _doubt(self, points: int, pose: NDArray[np.float64], fitness: float, rmse: float) -> str:
        """Why a fit of `points` points at `pose` is not trustworthy, or "" if it is."""
        settings = self.settings
        tilt = math.acos(min(1.0, pose[2, 2]))
        if fitness < settings.min_fitness:
            return f"block model fits only {fitness:.0%} of {points} points"
        if rmse > settings.max_rmse:
            return f"block fit RMSE {rmse * 1000:.2f} mm"
        if tilt > settings.max_tilt:
            return f"block tilted {math.degrees(tilt):.0f}°"
        return ""

    def _failure(self, segment: Points, peg_xy: Points, reason: str) -> BlockEstimate:
        """A segment that cannot be a block seen clearly, reported where it lies."""
        centre = segment.mean(axis=0)
        peg = self._peg_through_hole(centre, peg_xy)
        return BlockEstimate(centre, 0.0, peg, 0.0, math.inf, len(segment), False, reason)

    def initial_pose(self, segment: Points, peg_xy: Points) -> NDArray[np.float64]:
        """ICP's starting block pose: centre, height and yaw read off the segment's top face."""
        model, settings = self.cell.block, self.settings
        top_z = segment[:, 2].min()
        top = segment[segment[:, 2] < top_z + settings.top_face_depth]
        centre = top[:, :2].mean(axis=0)
        nearest = int(np.argmin(np.linalg.norm(peg_xy - centre, axis=1)))
        if np.linalg.norm(peg_xy[nearest] - centre) < model.hole_radius:
            centre = peg_xy[nearest]  # a peg's shadow on the top face biases the centroid; the peg does not
        z = float(np.median(top[:, 2])) + model.height
        return yaw_pose(
            [centre[0], centre[1], z], three_fold_yaw(top[:, :2] - centre, model.edge_directions[0])
        )

    def _peg_through_hole(self, position: Points, peg_xy: Points) -> int | None:
        """The peg within the hole's clearance of the block's axis, if any."""
        clearance = self.cell.block.hole_radius - self.cell.pegs.radius + self.settings.on_peg_tolerance
        offsets = np.linalg.norm(peg_xy - position[:2], axis=1)
        nearest = int(np.argmin(offsets))
        return nearest if offsets[nearest] <= clearance else None


@lru_cache(maxsize=1)
def _default_locator() -> BlockLocator:
    return BlockLocator()


def locate_blocks(cloud: ArrayLike | OrganisedCloud, board: BoardEstimate) -> list[BlockEstimate]:
    """Every block in a camera-frame capture of the default work cell, given the board registered once
    per trial (a `BlockLocator` serves another work cell or other settings)."""
    return _default_locator().locate(cloud, board)


def block_on_peg(estimates: list[BlockEstimate], peg: int) -> BlockEstimate | None:
    """The block found on `peg` (a trustworthy one first; of a stack, the top one, the only one that can be
    lifted off), or None: the peg is empty as far as we see."""
    on_peg = [estimate for estimate in estimates if estimate.peg == peg]
    return max(
        on_peg, key=lambda estimate: (estimate.ok, -stack_level(estimate), estimate.fitness), default=None
    )


def stack_level(block: BlockEstimate, cell: Workcell | None = None) -> int:
    """How many blocks `block` rests on: 0 on the board, 1 on top of another block (a stack on a peg)."""
    cell = cell or workcell()
    return max(
        0, round((cell.board.surface_z - float(block.position[2])) / cell.block.height)
    )  # board z points down


def wrap_symmetric(yaw: float) -> float:
    """`yaw` modulo the block's 120° symmetry, in [-60°, 60°)."""
    return (yaw + SYMMETRY / 2) % SYMMETRY - SYMMETRY / 2


def three_fold_yaw(xy: Points, edge_direction: float) -> float:
    """Yaw (modulo 120°) of a three-fold shape's points about its centre, from their third harmonic.

    The shape's far points (its corners, weighted by r³) sit at edge_direction + 60° + k·120° turned
    by the yaw, so the phase of Σ r³·e^{3iθ} is 3·(edge_direction + 60° + yaw).
    """
    radius = np.linalg.norm(xy, axis=1)
    harmonic = np.sum(radius**3 * np.exp(3j * np.arctan2(xy[:, 1], xy[:, 0])))
    return wrap_symmetric(float(np.angle(harmonic)) / 3 - edge_direction - math.pi / 3)
