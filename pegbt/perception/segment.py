"""Cut a registered capture into one point set per block: off the board plane, off the pegs, clustered.

In the board frame the plane is known (z = surface), so removing it is a height threshold; the pegs'
shafts are removed inside a radius halfway between peg and hole wall (the paper's inner annulus). What
remains is blocks (and anything else above the board). Open3D's DBSCAN clusters it over the whole board,
so a block that fell off its peg is found as readily as one on a peg; a cluster too wide for one block
(blocks touching each other) is returned apart, for registration to separate block by block.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pegbt.perception.cloud import Points, to_open3d
from pegbt.perception.settings import SegmentSettings
from pegbt.workcell import Workcell


@dataclass(frozen=True)
class Segments:
    """A capture's raised points, clustered: `blocks` one block wide each; `touching` too wide for one
    block (blocks touching each other), left for registration to take apart (`BlockLocator`)."""

    blocks: list[Points]
    touching: list[Points]


def block_segments(
    board_points: Points, peg_xy: Points, cell: Workcell, settings: SegmentSettings
) -> Segments:
    """The raised points of a capture clustered into blocks, each list largest first.

    `board_points`: the capture in the board frame; `peg_xy` (12, 2): where the pegs stand.
    """
    surface, block = cell.board.surface_z, cell.block
    z = board_points[:, 2]
    highest = settings.max_stack * block.height + settings.plane_margin
    raised = board_points[(z < surface - settings.plane_margin) & (z > surface - highest)]
    shaft = (cell.pegs.radius + block.hole_radius) / 2
    off_pegs = squared_peg_distances(raised, peg_xy).min(axis=1) > shaft**2
    points = np.asarray(to_open3d(raised[off_pegs]).voxel_down_sample(settings.voxel).points)
    found = clusters(points, settings)
    wide = [xy_span(cluster) > 2 * block.corner_distance + settings.wide_margin for cluster in found]
    return Segments([c for c, w in zip(found, wide) if not w], [c for c, w in zip(found, wide) if w])


def clusters(points: Points, settings: SegmentSettings) -> list[Points]:
    """Open3D's DBSCAN clusters of `points` with at least `min_points` points, largest first."""
    if len(points) < settings.min_points:
        return []
    labels = np.asarray(
        to_open3d(points).cluster_dbscan(settings.cluster_distance, settings.cluster_min_points)
    )
    found = [points[labels == label] for label in range(labels.max() + 1)]
    return sorted(
        [cluster for cluster in found if len(cluster) >= settings.min_points], key=len, reverse=True
    )


def xy_span(points: Points) -> float:
    """Width of `points` in x, y: the distance from the point farthest from their centroid to the point
    farthest from it (the diameter, or close to it, in linear time)."""
    xy = points[:, :2]
    extreme = xy[np.argmax(np.linalg.norm(xy - xy.mean(axis=0), axis=1))]
    return float(np.linalg.norm(xy - extreme, axis=1).max())


def squared_peg_distances(points: Points, peg_xy: Points) -> Points:
    """(N, pegs) squared distances in x, y from each of `points` to each peg's axis: a column per
    coordinate, since `np.linalg.norm` over an (N, pegs, 2) array costs six times as much."""
    dx = points[:, 0, None] - peg_xy[None, :, 0]
    dy = points[:, 1, None] - peg_xy[None, :, 1]
    distances: Points = dx * dx + dy * dy
    return distances


def split_by_nearest_peg(cluster: Points, peg_xy: Points) -> list[tuple[int, Points]]:
    """`cluster` cut into the parts nearest to each peg (each peg's Voronoi cell), with that peg: the paper's
    per-peg crop, for touching blocks each on its own peg."""
    nearest = np.argmin(squared_peg_distances(cluster, peg_xy), axis=1)
    return [(int(peg), cluster[nearest == peg]) for peg in np.unique(nearest)]
