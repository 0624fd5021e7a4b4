"""The work cell's frames and geometry, read once from `skills/workcell.yaml`.

One source of truth for the pegboard, the pegs, the FLS block (and where it is grasped), where the
arms and the camera sit relative to the board, and which pegs the handover meets over: the simulator
builds its world from it, perception its models, motion and behaviours their waypoints. How the arms
move (heights, jaw angles, clearances) is `skills/motion.yaml`'s (`pegbt.motion.settings`). Everything
is in metres and radians, in the board frame (origin in the board plane, z down into the board)
unless a name says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache, cached_property, lru_cache
from pathlib import Path

import numpy as np

from pegbt.frames import Matrix, apply_rigid, invert_rigid
from pegbt.pegboard import N_PEGS
from pegbt.psm import ARMS, known_arm
from pegbt.yamlfile import Located, read_settings_file

WORKCELL_FILE = Path(__file__).resolve().parents[1] / "skills" / "workcell.yaml"
ORDERS_FILE = Path(__file__).resolve().parents[1] / "trees" / "shared" / "orders.yaml"


@lru_cache(maxsize=4)
def transfer_list(name: str, path: Path = ORDERS_FILE) -> tuple[tuple[int, int], ...]:
    """(start peg, goal peg) of each transfer of list `name` of the trees' orders (`reference`,
    `bilateral_PSM1`, `bilateral_PSM2`), as the trees loop over it."""
    items = read_settings_file(path).section("lists")[name].sequence()
    return tuple(
        (item["pick"].integer(low=0, high=N_PEGS - 1), item["place"].integer(low=0, high=N_PEGS - 1))
        for item in items
    )


@lru_cache(maxsize=4)
def transfer_strays(name: str, path: Path = ORDERS_FILE) -> tuple[tuple[int, ...], ...]:
    """The `strays` of each transfer of list `name`: pegs a block dropped at the handover's meeting point may
    fall onto, which the trees' picks of that transfer look at once no loose block is seen."""
    items = read_settings_file(path).section("lists")[name].sequence()
    return tuple(
        tuple(stray.integer(low=0, high=N_PEGS - 1) for stray in strays.sequence())
        if (strays := item.get("strays")) is not None
        else ()
        for item in items
    )


def __getattr__(name: str) -> tuple[tuple[int, int], ...]:
    """`UNILATERAL_ORDER`: the reference's unilateral trial (one arm), (start peg, goal peg) of each of its
    12 transfers, read from `trees/shared/orders.yaml` (the list the trees loop over) when first asked for,
    so importing this module reads no tree file."""
    if name == "UNILATERAL_ORDER":
        return transfer_list("reference")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    left_group: tuple[int, ...]  # where the blocks start

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
        corners = np.array(vertices)
        return corners[np.argsort(np.arctan2(corners[:, 1], corners[:, 0]))]

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
class Workcell:
    """Everything in `skills/workcell.yaml`, typed."""

    source: Path
    board: Board
    pegs: Pegs
    block: BlockModel
    arm_from_board: dict[str, Matrix]  # arm name -> (4, 4): p_arm = T · p_board
    camera: CameraModel
    tool: ToolGeometry
    handover_pegs: tuple[int, ...]  # the handover meets over the mean of these pegs' tops

    @property
    def block_top_below_peg_top(self) -> float:
        """How far a resting block's top face lies below the peg tops (along the pegs)."""
        return (self.board.surface_z - self.block.height) - self.pegs.top_z

    def board_to_arm(self, arm: str) -> Matrix:
        """(4, 4) transform taking board coordinates into `arm`'s base frame."""
        return self.arm_from_board[known_arm(arm)].copy()

    def arm_to_board(self, arm: str) -> Matrix:
        """(4, 4) transform taking `arm`'s base-frame coordinates into the board frame."""
        return invert_rigid(self.arm_from_board[known_arm(arm)])

    def peg_tops_in(self, arm: str) -> Matrix:
        """(12, 3) peg top centres in `arm`'s base frame."""
        return apply_rigid(self.arm_from_board[known_arm(arm)], self.pegs.tops)

    def up_in(self, arm: str) -> Matrix:
        """(3,) the pegs' axis pointing away from the board ("up"), in `arm`'s base frame."""
        return self.arm_from_board[known_arm(arm)][:3, :3] @ np.array([0.0, 0.0, -1.0])

    def remote_centre(self, arm: str) -> Matrix:
        """(3,) the arm's remote centre of motion (its base-frame origin) in the board frame."""
        return self.arm_to_board(arm)[:3, 3]


SECTIONS = ("board", "pegs", "block", "arms", "camera", "tool", "handover")


def _pegs(value: Located) -> tuple[int, ...]:
    return tuple(item.integer(low=0, high=N_PEGS - 1) for item in value.sequence())


def _lengths(section: Located, names: tuple[str, ...]) -> dict[str, float]:
    """The named positive numbers of a section that holds nothing else."""
    section.mapping(names)
    return {name: section[name].number(positive=True) for name in names}


def _extent(board: Located, name: str) -> tuple[float, float]:
    low, high = board[name].array((2,))
    if low >= high:
        raise board[name].error("expected [low, high] with low < high")
    return float(low), float(high)


def load_workcell(path: Path | str = WORKCELL_FILE) -> Workcell:
    """Read and check a work-cell file; `PegbtError` (with its file, line, column and field) if anything is wrong."""
    path = Path(path)
    root = read_settings_file(path)
    root.mapping(SECTIONS)
    board, pegs_section, block_section = root["board"], root["pegs"], root["block"]
    board.mapping(("resting_block_top_z", "extent_x", "extent_y", "thickness"))
    pegs_section.mapping(("diameter", "top_z", "positions", "left_group"))
    pegs = Pegs(
        positions=pegs_section["positions"].array((N_PEGS, 2)),
        top_z=pegs_section["top_z"].number(),
        radius=pegs_section["diameter"].number(positive=True) / 2,
        left_group=_pegs(pegs_section["left_group"]),
    )
    block_section.mapping(
        (
            "edge_distance",
            "corner_distance",
            "height",
            "hole_radius",
            "edge_directions_deg",
            "grasp_radial",
            "grasp_along_edge",
            "grasp_depth",
        )
    )
    block = BlockModel(
        **{
            name: block_section[name].number(positive=True)
            for name in (
                "edge_distance",
                "corner_distance",
                "height",
                "hole_radius",
                "grasp_radial",
                "grasp_depth",
            )
        },
        grasp_along_edge=block_section["grasp_along_edge"].number(),
        edge_directions=np.radians(block_section["edge_directions_deg"].array((3,))),
    )
    if not block.hole_radius < block.edge_distance < block.corner_distance < 2 * block.edge_distance:
        raise block_section.error(
            "expected hole_radius < edge_distance < corner_distance < 2 · edge_distance"
        )
    if block.hole_radius <= pegs.radius:
        raise block_section["hole_radius"].error("the hole must be wider than a peg")
    if not 0 < block.grasp_depth < block.height:
        raise block_section["grasp_depth"].error(
            f"expected a depth below the top face within the block's height ({block.height:g} m)"
        )
    camera_section = root["camera"]
    camera_section.mapping(
        ("rotation", "translation", "width", "height", "fx", "fy", "cx", "cy", "depth_noise")
    )
    camera = CameraModel(
        board_from_camera=camera_section.rigid(),
        width=camera_section["width"].integer(low=1),
        height=camera_section["height"].integer(low=1),
        fx=camera_section["fx"].number(positive=True),
        fy=camera_section["fy"].number(positive=True),
        cx=camera_section["cx"].number(),
        cy=camera_section["cy"].number(),
        depth_noise=camera_section["depth_noise"].number(low=0.0),
    )
    arms = root["arms"]
    for arm in arms.mapping(ARMS).values():
        arm.mapping(("rotation", "translation"))
    handover = root["handover"]
    handover.mapping(("pegs",))
    return Workcell(
        source=path,
        board=Board(
            surface_z=board["resting_block_top_z"].number() + block.height,
            extent_x=_extent(board, "extent_x"),
            extent_y=_extent(board, "extent_y"),
            thickness=board["thickness"].number(positive=True),
        ),
        pegs=pegs,
        block=block,
        arm_from_board={arm: arms[arm].rigid() for arm in ARMS},
        camera=camera,
        tool=ToolGeometry(
            **_lengths(
                root["tool"], ("jaw_length", "wrist_length", "jaw_radius", "wrist_radius", "shaft_radius")
            )
        ),
        handover_pegs=_pegs(handover["pegs"]),
    )


@cache
def workcell(path: Path = WORKCELL_FILE) -> Workcell:
    """The work cell, loaded once per file (the default: `skills/workcell.yaml`)."""
    return load_workcell(path)
