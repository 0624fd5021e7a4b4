"""A simulated depth camera at the work cell's camera pose: point clouds with noise and self-occlusion.

Each capture casts one ray per pixel (Open3D's `RaycastingScene`) into the board, pegs, blocks and,
optionally, the instruments, keeps the first hit, and adds Gaussian noise along the ray, so hidden
faces and the board behind blocks are missing exactly as for a real camera. Only the pixels that can
see the board are cast (`image_shape`: that region of the image, rows by columns), or, for a camera that
sends its whole image (a Zivid's organised cloud), every pixel (`full_frame`). Noise bursts can be
injected (scheduled or at random); each is logged in the world's event log.

A world's `depth_bias` (`pegbt.sim.world_effects`) acts on what the camera sees, never on the world: it
lengthens the rays that meet the blocks and the instruments (not the pegboard, which perception registers
and measures the pegs on). Its `perception_noise` shows each block off where it stands by a draw fixed by
the camera's seed and the block's pose (`view_error`): all of a block's points move together, as a real
cloud's registration error moves the block model, and a block that has not moved is seen as before.

Each point has the colour of what its ray met (`Exposure.colours`, `capture_coloured`), as a Zivid's cloud
has: the reference set-up's blocks and pegs are red (FLSpegtransferHO `vision/BlockDetection3D.py` keeps the
red points, `lower_red`/`upper_red`, to find both), the pegboard light grey, the instruments dark grey. A
colour is a rgba word as zivid-ros packs it (`PointXYZColorBGRA`: `0xAARRGGBB`, little-endian bytes B, G, R,
A); a pixel that saw nothing is 0.

A capture is taken whole (`capture`) or in parts (`expose`, then `Exposure.cast` a few rays at a time, then
`Exposure.points`): the streaming camera of the simulator's dVRK interface renders a frame over several
control periods, so that a frame never stalls the arms' control loop. Both give the same points.
"""

from __future__ import annotations

import hashlib

import numpy as np
import open3d as o3d
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.frames import Matrix
from pegbt.sim.events import Event
from pegbt.sim.faults import CameraFaults, NoiseBurst
from pegbt.sim.interfaces import SimWorld
from pegbt.sim.meshes import Mesh, block_mesh, box_mesh, cylinder_mesh, merge, static_scene_mesh, transformed
from pegbt.sim.world import World
from pegbt.workcell import CameraModel, Workcell, workcell

ROI_MARGIN_PX = 8


def view_error(seed: int, pose: NDArray[np.float64], sd: float) -> NDArray[np.float64]:
    """Where a view of a block standing at `pose` shows it off its place (board x, y, m; z 0): `sd` a
    coordinate, drawn from the camera's `seed` and the pose, so an unmoved block is shown where it was."""
    key = np.frombuffer(hashlib.sha256(np.ascontiguousarray(pose).tobytes()).digest()[:16], dtype=np.uint32)
    draw = np.random.default_rng(np.random.SeedSequence([seed, *map(int, key)])).normal(0.0, sd, 2)
    return np.array([draw[0], draw[1], 0.0])


def rgba_word(red: int, green: int, blue: int) -> int:
    """An opaque colour as one rgba word, `0xAARRGGBB` (zivid-ros's `rgba` field)."""
    return 0xFF000000 | red << 16 | green << 8 | blue


RED = rgba_word(200, 40, 30)  # the blocks and the pegs: a hue of 4°, inside the paper's mask (0–40°)
BOARD_GREY = rgba_word(185, 185, 180)
TOOL_GREY = rgba_word(60, 60, 64)
NO_HIT = np.iinfo(np.uint32).max  # Open3D's primitive id where a ray met nothing
SLAB_TRIANGLES = len(box_mesh(np.zeros(3), np.ones(3))[1])  # the static scene mesh's first part, the board


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
        model: CameraModel | None = None,
        full_frame: bool = False,
    ) -> None:
        self.cell = cell or workcell()
        self.model = model or self.cell.camera  # the work cell's camera, or another sensor at its pose
        self.faults = faults
        self.include_arms = include_arms
        self.depth_noise = self.model.depth_noise if depth_noise is None else depth_noise
        self.seed = seed
        self._rng = np.random.default_rng(np.random.SeedSequence([seed, 0xCA3E7A]))
        self._static = static_scene_mesh(self.cell)
        self._block = block_mesh(self.cell.block)
        self._directions, self.image_shape = (  # (n, 3) camera frame, z = 1
            self._all_pixel_directions() if full_frame else self._pixel_directions()
        )
        board_from_camera = self.model.board_from_camera
        rays = np.empty((len(self._directions), 6), dtype=np.float32)
        rays[:, :3] = board_from_camera[:3, 3]
        # einsum, not `@`: a busy machine's multi-threaded BLAS takes seconds over a full frame's 2.3 M rays
        rays[:, 3:] = np.einsum("ij,kj->ik", self._directions, board_from_camera[:3, :3])
        self._rays = o3d.core.Tensor.from_numpy(rays)

    @property
    def ray_count(self) -> int:
        """How many pixels are cast per capture (those whose view can meet the board)."""
        return len(self._directions)

    def _pixel_directions(self) -> tuple[Matrix, tuple[int, int]]:
        """Ray directions (z = 1) of the pixels inside the board's image, padded by a margin, row by row; and
        that region's rows and columns."""
        camera = self.model
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
        return self.directions_of(
            np.arange(u_range[0], u_range[1] + 1), np.arange(v_range[0], v_range[1] + 1)
        )

    def _all_pixel_directions(self) -> tuple[Matrix, tuple[int, int]]:
        """Ray directions (z = 1) of every pixel of the image, row by row; and its rows and columns."""
        return self.directions_of(np.arange(self.model.width), np.arange(self.model.height))

    def directions_of(self, columns: np.ndarray, rows: np.ndarray) -> tuple[Matrix, tuple[int, int]]:
        """Ray directions (z = 1, camera frame) of the pixels at `columns` × `rows`, row by row; and the
        region's rows and columns."""
        camera = self.model
        us, vs = np.meshgrid(columns, rows)
        directions = np.column_stack(
            [(us.ravel() - camera.cx) / camera.fx, (vs.ravel() - camera.cy) / camera.fy, np.ones(us.size)]
        )
        return directions, (int(us.shape[0]), int(us.shape[1]))

    def scene_mesh(self, world: World) -> Mesh:
        """Everything the camera can see now, in the board frame: the pegboard first (`board_triangles`
        triangles), then the blocks and the instruments."""
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

    def triangle_colours(self, world: World) -> NDArray[np.uint32]:
        """The rgba word of each triangle of `scene_mesh(world)`: the slab grey, its pegs and the blocks red,
        the instruments dark grey."""
        blocks = self.board_triangles + len(world.blocks) * self.block_triangles
        colours = np.full(blocks, RED, dtype=np.uint32)
        colours[:SLAB_TRIANGLES] = BOARD_GREY
        return colours

    @property
    def board_triangles(self) -> int:
        """How many triangles of a scene mesh are the pegboard's (board and pegs)."""
        return len(self._static[1])

    @property
    def block_triangles(self) -> int:
        """How many triangles of a scene mesh each block has (the blocks follow the pegboard, in order)."""
        return len(self._block[1])

    def shown_off(self, world: World) -> NDArray[np.float64] | None:
        """How far (camera frame, m; a row per block) a capture shows each of `world`'s blocks off where it
        stands (its `perception_noise`), None where the world has none."""
        sd = world.effects.values("perception_noise")["sd"]
        if not sd:
            return None
        in_board = np.array([view_error(self.seed, block.pose, sd) for block in world.blocks])
        return in_board @ self.model.board_from_camera[:3, :3]  # each row turned into the camera frame

    def capture(self, world: SimWorld, time: float | None = None) -> np.ndarray:
        """A point cloud (N, 3) float32 in the camera frame (metres) of the world at `time` (default: now)."""
        points = self.capture_organised(world, time)
        return points[np.isfinite(points[:, 0])]

    def capture_coloured(
        self, world: SimWorld, time: float | None = None
    ) -> tuple[np.ndarray, NDArray[np.uint32]]:
        """`capture`'s points and the rgba word of each (the colour of what its ray met)."""
        exposure = self._exposed(world, time)
        points = exposure.points()
        seen = np.isfinite(points[:, 0])
        return points[seen], exposure.colours()[seen]

    def capture_organised(self, world: SimWorld, time: float | None = None) -> np.ndarray:
        """Every pixel's point (n, 3) float32, row by row over `image_shape`, NaN where nothing is seen."""
        return self._exposed(world, time).points()

    def _exposed(self, world: SimWorld, time: float | None) -> Exposure:
        """A capture of the world at `time`, every ray cast."""
        exposure = self.expose(world, time)
        exposure.cast(self.ray_count)
        return exposure

    def expose(self, world: SimWorld, time: float | None = None) -> Exposure:
        """A capture of the world as it is now, stamped `time` (default: the world's); no ray cast yet."""
        assert isinstance(world, World)  # the camera renders pegbt's world, its blocks where they are
        return Exposure(self, world, world.time if time is None else time)

    def _develop(
        self, depth: np.ndarray, world: World, time: float, biased: np.ndarray | None = None
    ) -> np.ndarray:
        """Every pixel's point (n, 3) float32 from its ray's hit distance, noisy (and biased where `biased`
        says a ray met a surface a depth bias lengthens); NaN where nothing is hit."""
        seen = np.isfinite(depth)
        hits = depth[seen].astype(np.float64)
        bias = world.effects.values("depth_bias")["bias"]
        if bias and biased is not None:
            hits += bias * biased[seen]
        if self.depth_noise > 0:
            hits += self._rng.normal(0.0, self.depth_noise, hits.shape)
        burst = self._burst(world, time)
        if burst is not None:
            hits += self._rng.normal(0.0, burst.sigma, hits.shape)
            wild = self._rng.random(hits.shape) < burst.outliers
            hits[wild] *= self._rng.uniform(0.8, 1.2, int(wild.sum()))
        points = np.full(self._directions.shape, np.nan, dtype=np.float32)
        points[seen] = (self._directions[seen] * hits[:, None]).astype(np.float32)
        return points

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


class Exposure:
    """One capture under way: the scene frozen as it was when exposed, its rays cast a part at a time."""

    def __init__(self, camera: DepthCamera, world: World, time: float) -> None:
        self.time = time
        self._camera = camera
        self._world = world
        vertices, triangles = camera.scene_mesh(world)
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(
            o3d.core.Tensor.from_numpy(vertices.astype(np.float32)),
            o3d.core.Tensor.from_numpy(triangles.astype(np.uint32)),
        )
        self._depth = np.empty(camera.ray_count, dtype=np.float32)
        self._hit = np.empty(camera.ray_count, dtype=np.uint32)  # the triangle each ray met
        self._triangle_colours = camera.triangle_colours(world)
        self._shown_off = camera.shown_off(world)
        self._cast = 0

    @property
    def done(self) -> bool:
        """Whether every ray has been cast."""
        return self._cast >= len(self._depth)

    def cast(self, count: int) -> None:
        """Cast the next `count` rays (the first call also builds the scene's search structure)."""
        start, stop = self._cast, min(self._cast + count, len(self._depth))
        rays = self._camera._rays[start:stop]
        hits = self._scene.cast_rays(rays)
        self._depth[start:stop] = hits["t_hit"].numpy()
        self._hit[start:stop] = hits["primitive_ids"].numpy()
        self._cast = stop

    def points(self) -> np.ndarray:
        """Every pixel's point (n, 3) float32, camera frame, row by row over `image_shape`; NaN where no
        surface was hit (as a depth camera's organised cloud marks invalid pixels)."""
        self._check_done()
        camera, biased = self._camera, None
        if self._world.effects.values("depth_bias")["bias"]:  # rays that met a block or an instrument
            biased = self._hit >= camera.board_triangles
        points = camera._develop(self._depth, self._world, self.time, biased)
        if self._shown_off is not None:
            met = self._hit.astype(np.int64) - camera.board_triangles
            block = np.where(met >= 0, met // camera.block_triangles, len(self._shown_off))
            on_block = block < len(self._shown_off)
            points[on_block] += self._shown_off[block[on_block]].astype(np.float32)
        return points

    def colours(self) -> NDArray[np.uint32]:
        """Every pixel's rgba word, as `points` orders them: the colour of what its ray met, 0 where none."""
        self._check_done()
        colours = np.full(len(self._hit), TOOL_GREY, dtype=np.uint32)
        scenery = self._hit < len(self._triangle_colours)
        colours[scenery] = self._triangle_colours[self._hit[scenery]]
        colours[self._hit == NO_HIT] = 0
        return colours

    def _check_done(self) -> None:
        if not self.done:
            raise PegbtError("the exposure's rays are not all cast yet", field="camera")
