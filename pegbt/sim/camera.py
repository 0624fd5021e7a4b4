"""A simulated depth camera at the work cell's camera pose: point clouds with noise and self-occlusion.

Each capture casts one ray per pixel (Open3D's `RaycastingScene`) into the board, pegs, blocks and,
optionally, the instruments, keeps the first hit, and adds Gaussian noise along the ray, so hidden
faces and the board behind blocks are missing exactly as for a real camera. Only the pixels that can
see the board are cast. Noise bursts can be injected (scheduled or at random); each is logged in the
world's event log.
"""

from __future__ import annotations

import numpy as np
import open3d as o3d

from pegbt.errors import PegbtError
from pegbt.frames import Matrix
from pegbt.sim.events import Event
from pegbt.sim.faults import CameraFaults, NoiseBurst
from pegbt.sim.meshes import Mesh, block_mesh, cylinder_mesh, merge, static_scene_mesh, transformed
from pegbt.sim.world import World
from pegbt.workcell import Workcell, workcell

ROI_MARGIN_PX = 8


class DepthCamera:
    """The work cell's depth camera. `capture(world)` returns an (N, 3) float32 cloud in the camera frame (m)."""

    def __init__(
        self,
        cell: Workcell | None = None,
        seed: int = 0,
        *,
        faults: CameraFaults = CameraFaults(),
        include_arms: bool = True,
        depth_noise: float | None = None,
    ) -> None:
        self.cell = cell or workcell()
        self.faults = faults
        self.include_arms = include_arms
        self.depth_noise = self.cell.camera.depth_noise if depth_noise is None else depth_noise
        self._rng = np.random.default_rng(np.random.SeedSequence([seed, 0xCA3E7A]))
        self._static = static_scene_mesh(self.cell)
        self._block = block_mesh(self.cell.block)
        self._directions = self._pixel_directions()  # (n, 3) camera frame, z = 1
        board_from_camera = self.cell.camera.board_from_camera
        origins = np.broadcast_to(board_from_camera[:3, 3], self._directions.shape)
        self._rays = o3d.core.Tensor(
            np.hstack([origins, self._directions @ board_from_camera[:3, :3].T]).astype(np.float32)
        )

    @property
    def ray_count(self) -> int:
        """How many pixels are cast per capture (those whose view can meet the board)."""
        return len(self._directions)

    def _pixel_directions(self) -> Matrix:
        """Ray directions (z = 1) of the pixels inside the board's image, padded by a margin."""
        camera = self.cell.camera
        board, top = self.cell.board, self.cell.pegs.top_z
        corners = np.array(
            [[x, y, z] for x in board.extent_x for y in board.extent_y for z in (board.surface_z, top)]
        )
        in_camera = corners @ camera.camera_from_board[:3, :3].T + camera.camera_from_board[:3, 3]
        if np.any(in_camera[:, 2] <= 0):
            raise PegbtError("the board is behind the camera", file=self.cell.source, field="camera")
        u = camera.fx * in_camera[:, 0] / in_camera[:, 2] + camera.cx
        v = camera.fy * in_camera[:, 1] / in_camera[:, 2] + camera.cy
        u_range = np.clip([u.min() - ROI_MARGIN_PX, u.max() + ROI_MARGIN_PX], 0, camera.width - 1).astype(int)
        v_range = np.clip([v.min() - ROI_MARGIN_PX, v.max() + ROI_MARGIN_PX], 0, camera.height - 1).astype(
            int
        )
        us, vs = np.meshgrid(np.arange(u_range[0], u_range[1] + 1), np.arange(v_range[0], v_range[1] + 1))
        return np.column_stack(
            [(us.ravel() - camera.cx) / camera.fx, (vs.ravel() - camera.cy) / camera.fy, np.ones(us.size)]
        )

    def scene_mesh(self, world: World) -> Mesh:
        """Everything the camera can see now, in the board frame."""
        meshes = [self._static] + [transformed(self._block, block.pose) for block in world.blocks]
        if self.include_arms:
            tool = self.cell.tool
            for state in world.tools.values():
                starts, ends, radii = state.segments(tool)
                meshes += [
                    cylinder_mesh(s, e, r)
                    for s, e, r in zip(starts, ends, radii)
                    if np.linalg.norm(e - s) > 1e-6
                ]
        return merge(meshes)

    def capture(self, world: World, time: float | None = None) -> np.ndarray:
        """A point cloud (N, 3) float32 in the camera frame (metres) of the world at `time` (default: now)."""
        time = world.time if time is None else time
        vertices, triangles = self.scene_mesh(world)
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(
            o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(triangles.astype(np.uint32))
        )
        depth = scene.cast_rays(self._rays)["t_hit"].numpy()
        seen = np.isfinite(depth)
        depth = depth[seen].astype(np.float64)
        if self.depth_noise > 0:
            depth += self._rng.normal(0.0, self.depth_noise, depth.shape)
        burst = self._burst(world, time)
        if burst is not None:
            depth += self._rng.normal(0.0, burst.sigma, depth.shape)
            wild = self._rng.random(depth.shape) < burst.outliers
            depth[wild] *= self._rng.uniform(0.8, 1.2, int(wild.sum()))
        return (self._directions[seen] * depth[:, None]).astype(np.float32)

    def _burst(self, world: World, time: float) -> NoiseBurst | None:
        """The noise burst affecting a capture at `time`, logged as a fault event in the world."""
        burst = next((burst for burst in self.faults.bursts if burst.active(time)), None)
        if (
            burst is None
            and self.faults.burst_probability > 0
            and self._rng.random() < self.faults.burst_probability
        ):
            burst = self.faults.random_burst
        if burst is not None:
            detail = f"depth noise burst: sigma {burst.sigma * 1000:.1f} mm, {burst.outliers:.0%} outliers"
            world.events.append(Event(time, "fault", detail=detail))
        return burst
