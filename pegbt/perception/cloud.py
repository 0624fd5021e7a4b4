"""Checked conversions between numpy point arrays and Open3D point clouds."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError

if TYPE_CHECKING:
    import open3d as o3d

Points = NDArray[np.float64]


def checked_points(cloud: ArrayLike, field: str = "cloud") -> Points:
    """`cloud` as an (N, 3) float64 array; `PegbtError` if it is empty, mis-shaped or not finite.

    A depth camera's invalid pixels must be dropped before perception sees them: a NaN here means the
    caller passed raw data, and silently skipping it would hide that.
    """
    try:
        points = np.asarray(cloud, dtype=np.float64)
    except (TypeError, ValueError):
        raise PegbtError("expected an (N, 3) array of numbers", field=field) from None
    if points.ndim != 2 or points.shape[1] != 3:
        raise PegbtError(f"expected an (N, 3) array of points, got shape {points.shape}", field=field)
    if len(points) == 0:
        raise PegbtError("the point cloud is empty", field=field)
    if not np.isfinite(points).all():
        finite = np.isfinite(points).all(axis=1)
        first = int(np.flatnonzero(~finite)[0])
        raise PegbtError(
            f"{int((~finite).sum())} point(s) are not finite (first at row {first})",
            field=f"{field}[{first}]",
        )
    return points


def to_open3d(points: Points) -> o3d.geometry.PointCloud:
    """An Open3D point cloud holding `points`."""
    import open3d as o3d

    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))


@contextmanager
def open3d_threads(count: int | None) -> Iterator[None]:
    """Open3D on at most `count` threads inside (None: as it is), its previous limit back after. The limit
    is the process's: while one thread holds it, no other may run Open3D. One thread makes Open3D's
    parallel sums (ICP's normal equations) add up in one order, so the same cloud gives the same pose bit
    for bit in any process; on two threads the board's pose moves by ~3e-8 from run to run."""
    if count is None:
        yield
        return
    import open3d as o3d

    previous = o3d.utility.get_max_threads()
    o3d.utility.set_max_threads(count)
    try:
        yield
    finally:
        o3d.utility.set_max_threads(previous)


def transform_points(T: Points, points: Points) -> Points:
    """`points` (N, 3) moved by the 4×4 rigid transform `T`.

    Done by Open3D: numpy's matrix product hands this shape to a multi-threaded BLAS, which on a
    busy two-core machine is 20–40× slower.
    """
    cloud = to_open3d(points)
    cloud.transform(T)
    return np.asarray(cloud.points)
