"""The work cell's frames and geometry, read once from `skills/workcell.yaml`.

One source of truth for the pegboard, the pegs, the FLS block, where the arms and the camera sit
relative to the board, and the heights motions use: the simulator builds its world from it,
perception its models, behaviours their waypoints. Everything is in metres and radians, in the
board frame (origin in the board plane, z down into the board) unless a name says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from pegbt.errors import PegbtError

WORKCELL_FILE = Path(__file__).resolve().parents[1] / "skills" / "workcell.yaml"
ARMS = ("PSM1", "PSM2")
N_PEGS = 12
# The reference's unilateral trial (one arm): (start peg, goal peg) of each of the 12 transfers.
UNILATERAL_ORDER = ((1, 7), (0, 6), (3, 8), (2, 9), (5, 11), (4, 10), (7, 1), (6, 0), (8, 3), (9, 2), (11, 5), (10, 4))

Matrix = NDArray[np.float64]


@dataclass(frozen=True)
class Board:
    """The board's top surface and the area beyond which a dropped block is lost."""

    surface_z: float
    extent_x: tuple[float, float]
    extent_y: tuple[float, float]
    thickness: float

    def contains_xy(self, x: float, y: float) -> bool:
        """Whether the point (x, y) lies over the board."""
        return self.extent_x[0] <= x <= self.extent_x[1] and self.extent_y[0] <= y <= self.extent_y[1]


@dataclass(frozen=True)
class Pegs:
    """Twelve vertical pegs standing on the board surface."""

    positions: Matrix  # (12, 2) top centres x, y
    top_z: float
    radius: float
    left_group: tuple[int, ...]
    right_group: tuple[int, ...]

    @cached_property
    def tops(self) -> Matrix:
        """(12, 3) top centres."""
        return np.column_stack([self.positions, np.full(len(self.positions), self.top_z)])

    def top(self, peg: int) -> Matrix:
        """(3,) top centre of one peg."""
        return self.tops[peg].copy()


@dataclass(frozen=True)
class GraspCandidates:
    """The six grasp points of a block, in the block frame."""

    positions: Matrix  # (6, 3) jaw-tip positions
    jaw_yaw: Matrix  # (6,) angle of the jaw-closing axis about block z (the edge normal's angle)
    edge: tuple[int, ...]  # which edge (0..2) each candidate grips


@dataclass(frozen=True)
class BlockModel:
    """The FLS block: a triangular prism with truncated corners around a central through-hole.

    Block frame: origin at the centre of the bottom face, on the hole axis; z down like the board's,
    so the top face lies at z = -height.
    """

    edge_distance: float
    corner_distance: float
    height: float
    hole_radius: float
    edge_directions: Matrix  # (3,) outward normal angles of the flat edges
    grasp_radial: float
    grasp_along_edge: float
    grasp_depth: float

    @cached_property
    def edge_normals(self) -> Matrix:
        """(3, 2) outward unit normals of the three flat edges."""
        return np.column_stack([np.cos(self.edge_directions), np.sin(self.edge_directions)])

    @cached_property
    def edge_half_length(self) -> float:
        """Half the length of each flat edge, between its two corner cuts."""
        cos60, sin60 = 0.5, math.sqrt(3) / 2
        return (self.corner_distance - self.edge_distance * cos60) / sin60

    @cached_property
    def outline(self) -> Matrix:
        """(6, 2) corners of the hexagonal outline, counter-clockwise about block z."""
        vertices = []
        for normal in self.edge_normals:
            tangent = np.array([-normal[1], normal[0]])
            for sign in (-1.0, 1.0):
                vertices.append(self.edge_distance * normal + sign * self.edge_half_length * tangent)
        vertices = np.array(vertices)
        return vertices[np.argsort(np.arctan2(vertices[:, 1], vertices[:, 0]))]

    @cached_property
    def outline_planes(self) -> tuple[Matrix, Matrix]:
        """Outward normals (6, 2) and offsets (6,) of the outline: inside where normals·p <= offsets."""
        edges = np.roll(self.outline, -1, axis=0) - self.outline
        normals = np.column_stack([edges[:, 1], -edges[:, 0]])
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        return normals, np.einsum("ij,ij->i", normals, self.outline)

    @cached_property
    def grasp_candidates(self) -> GraspCandidates:
        """Two candidates per edge, on the wall between hole and edge, `grasp_depth` below the top."""
        z = -self.height + self.grasp_depth
        positions, yaws, edges = [], [], []
        for index, (normal, angle) in enumerate(zip(self.edge_normals, self.edge_directions)):
            tangent = np.array([-normal[1], normal[0]])
            for sign in (-1.0, 1.0):
                xy = self.grasp_radial * normal + sign * self.grasp_along_edge * tangent
                positions.append([xy[0], xy[1], z])
                yaws.append(angle)
                edges.append(index)
        return GraspCandidates(np.array(positions), np.array(yaws), tuple(edges))


@dataclass(frozen=True)
class CameraModel:
    """A pinhole depth camera; its frame is OpenCV's (x right, y down, z along the optical axis)."""

    board_from_camera: Matrix  # (4, 4): p_board = T · p_camera
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_noise: float

    @cached_property
    def camera_from_board(self) -> Matrix:
        return invert_rigid(self.board_from_camera)

    @cached_property
    def intrinsic_matrix(self) -> Matrix:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class ToolGeometry:
    """Sizes of the instrument's end, for collisions and for rendering.

    Tool-tip frame (as `pegbt.motion.kinematics` computes it): z points back up the tool, so the tool
    approaches along -z; x is the direction in which the jaws close; y is the jaw hinge axis.
    """

    jaw_length: float
    wrist_length: float
    jaw_radius: float
    wrist_radius: float
    shaft_radius: float


@dataclass(frozen=True)
class MotionHeights:
    """Waypoint heights (z in each arm's base frame, z up) and jaw angles."""

    transfer_height: float
    drop_height: float
    approach_above_block: float
    jaw_open: float
    jaw_closed: float


@dataclass(frozen=True)
class Handover:
    """Where and how a block passes from one arm to the other."""

    pegs: tuple[int, ...]
    offset: Matrix  # (2,) board x, y
    above_transfer: float
    receiver_wait_above: float
    giver_rise: float


@dataclass(frozen=True)
class Workcell:
    """Everything in `skills/workcell.yaml`, typed."""

    source: Path
    board: Board
    pegs: Pegs
    block: BlockModel
    arm_from_board: dict[str, Matrix]  # arm name -> (4, 4): p_arm = T · p_board
    camera: CameraModel
    tool: ToolGeometry
    motion: MotionHeights
    handover: Handover

    def board_to_arm(self, arm: str) -> Matrix:
        """(4, 4) transform taking board coordinates into `arm`'s base frame."""
        return self.arm_from_board[_known_arm(arm)].copy()

    def arm_to_board(self, arm: str) -> Matrix:
        """(4, 4) transform taking `arm`'s base-frame coordinates into the board frame."""
        return invert_rigid(self.arm_from_board[_known_arm(arm)])

    def peg_tops_in(self, arm: str) -> Matrix:
        """(12, 3) peg top centres in `arm`'s base frame."""
        to_arm = self.arm_from_board[_known_arm(arm)]
        return self.pegs.tops @ to_arm[:3, :3].T + to_arm[:3, 3]

    def up_in(self, arm: str) -> Matrix:
        """(3,) the pegs' axis pointing away from the board ("up"), in `arm`'s base frame."""
        return self.arm_from_board[_known_arm(arm)][:3, :3] @ np.array([0.0, 0.0, -1.0])

    def remote_centre(self, arm: str) -> Matrix:
        """(3,) the arm's remote centre of motion (its base-frame origin) in the board frame."""
        return self.arm_to_board(arm)[:3, 3]

    def handover_point_xy(self) -> Matrix:
        """(2,) board x, y of the handover meeting point."""
        return self.pegs.positions[list(self.handover.pegs)].mean(axis=0) + self.handover.offset


def invert_rigid(T: Matrix) -> Matrix:
    """Inverse of a rigid 4×4 transform."""
    inverse = np.eye(4)
    inverse[:3, :3] = T[:3, :3].T
    inverse[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return inverse


def _known_arm(arm: str) -> str:
    if arm not in ARMS:
        raise PegbtError(f"unknown arm {arm!r}; known: {', '.join(ARMS)}", field="arm")
    return arm


class _Reader:
    """Typed reads of the YAML document; errors name the file, line, column and dotted field."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        try:
            self.data = yaml.safe_load(text)
            self.root = yaml.compose(text)
        except yaml.YAMLError as error:
            mark = getattr(error, "problem_mark", None)
            raise PegbtError(
                f"not valid YAML: {getattr(error, 'problem', error)}",
                file=path,
                line=None if mark is None else mark.line + 1,
                column=None if mark is None else mark.column + 1,
            ) from None
        if not isinstance(self.data, dict):
            raise PegbtError("expected a mapping of sections", file=path, line=1, column=1)

    def error(self, field: str, message: str) -> PegbtError:
        node, line, column = self.root, None, None
        for key in field.split("."):
            if not isinstance(node, yaml.MappingNode):
                break
            match = [(k, v) for k, v in node.value if k.value == key]
            if not match:
                break
            node = match[0][1]
            line, column = node.start_mark.line + 1, node.start_mark.column + 1
        return PegbtError(message, file=self.path, line=line, column=column, field=field)

    def raw(self, field: str) -> Any:
        value: Any = self.data
        for key in field.split("."):
            if not isinstance(value, dict) or key not in value:
                raise self.error(field, "missing")
            value = value[key]
        return value

    def number(self, field: str, *, positive: bool = False) -> float:
        value = self.raw(field)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(field, f"expected a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(field, f"expected a positive number, got {value!r}")
        return float(value)

    def array(self, field: str, shape: tuple[int, ...]) -> Matrix:
        value = self.raw(field)
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            array = None
        if array is None or array.shape != shape or not np.all(np.isfinite(array)):
            raise self.error(field, f"expected {' x '.join(map(str, shape))} finite numbers, got {value!r}")
        return array

    def pegs(self, field: str) -> tuple[int, ...]:
        value = self.raw(field)
        if not isinstance(value, list) or not all(isinstance(v, int) and 0 <= v < N_PEGS for v in value):
            raise self.error(field, f"expected a list of peg numbers 0..{N_PEGS - 1}, got {value!r}")
        return tuple(value)

    def rigid(self, field: str, scale: float = 1.0) -> Matrix:
        """A 4×4 transform from `field.rotation` (projected onto SO(3)) and `field.translation`."""
        rotation = self.array(f"{field}.rotation", (3, 3))
        u, _, vt = np.linalg.svd(rotation)
        exact = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        if np.abs(exact - rotation).max() > 0.01:
            raise self.error(f"{field}.rotation", "not a rotation matrix (off by more than 0.01)")
        T = np.eye(4)
        T[:3, :3] = exact
        T[:3, 3] = self.array(f"{field}.translation", (3,)) * scale
        return T


def load_workcell(path: Path | str = WORKCELL_FILE) -> Workcell:
    """Read and check a work-cell file; `PegbtError` (with its location) if anything is wrong."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise PegbtError(f"cannot read the work cell: {error.strerror}", file=path) from None
    read = _Reader(path, text)
    extent_x, extent_y = read.array("board.extent_x", (2,)), read.array("board.extent_y", (2,))
    for field, extent in (("board.extent_x", extent_x), ("board.extent_y", extent_y)):
        if extent[0] >= extent[1]:
            raise read.error(field, "expected [low, high] with low < high")
    pegs = Pegs(
        positions=read.array("pegs.positions", (N_PEGS, 2)),
        top_z=read.number("pegs.top_z"),
        radius=read.number("pegs.diameter", positive=True) / 2,
        left_group=read.pegs("pegs.left_group"),
        right_group=read.pegs("pegs.right_group"),
    )
    block = BlockModel(
        edge_distance=read.number("block.edge_distance", positive=True),
        corner_distance=read.number("block.corner_distance", positive=True),
        height=read.number("block.height", positive=True),
        hole_radius=read.number("block.hole_radius", positive=True),
        edge_directions=np.radians(read.array("block.edge_directions_deg", (3,))),
        grasp_radial=read.number("block.grasp_radial", positive=True),
        grasp_along_edge=read.number("block.grasp_along_edge"),
        grasp_depth=read.number("block.grasp_depth", positive=True),
    )
    if not block.hole_radius < block.edge_distance < block.corner_distance < 2 * block.edge_distance:
        raise read.error("block", "expected hole_radius < edge_distance < corner_distance < 2 · edge_distance")
    if block.hole_radius <= pegs.radius:
        raise read.error("block.hole_radius", "the hole must be wider than a peg")
    camera = CameraModel(
        board_from_camera=read.rigid("camera"),
        width=int(read.number("camera.width", positive=True)),
        height=int(read.number("camera.height", positive=True)),
        fx=read.number("camera.fx", positive=True),
        fy=read.number("camera.fy", positive=True),
        cx=read.number("camera.cx"),
        cy=read.number("camera.cy"),
        depth_noise=read.number("camera.depth_noise"),
    )
    return Workcell(
        source=path,
        board=Board(
            surface_z=read.number("board.surface_z"),
            extent_x=(float(extent_x[0]), float(extent_x[1])),
            extent_y=(float(extent_y[0]), float(extent_y[1])),
            thickness=read.number("board.thickness", positive=True),
        ),
        pegs=pegs,
        block=block,
        arm_from_board={arm: read.rigid(f"arms.{arm}") for arm in ARMS},
        camera=camera,
        tool=ToolGeometry(
            jaw_length=read.number("tool.jaw_length", positive=True),
            wrist_length=read.number("tool.wrist_length", positive=True),
            jaw_radius=read.number("tool.jaw_radius", positive=True),
            wrist_radius=read.number("tool.wrist_radius", positive=True),
            shaft_radius=read.number("tool.shaft_radius", positive=True),
        ),
        motion=MotionHeights(
            transfer_height=read.number("motion.transfer_height"),
            drop_height=read.number("motion.drop_height"),
            approach_above_block=read.number("motion.approach_above_block"),
            jaw_open=read.number("motion.jaw_open"),
            jaw_closed=read.number("motion.jaw_closed"),
        ),
        handover=Handover(
            pegs=read.pegs("handover.pegs"),
            offset=read.array("handover.offset", (2,)),
            above_transfer=read.number("handover.above_transfer"),
            receiver_wait_above=read.number("handover.receiver_wait_above"),
            giver_rise=read.number("handover.giver_rise"),
        ),
    )


@lru_cache(maxsize=None)
def workcell(path: Path = WORKCELL_FILE) -> Workcell:
    """The work cell, loaded once per file (the default: `skills/workcell.yaml`)."""
    return load_workcell(path)
