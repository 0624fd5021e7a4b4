"""A tool standing off a block's axis grips the block's wall when its jaws' geometry lets it, not below a
fixed angle: scripted closes on a block resting on its peg, the tip where the planner grips (the wall's
centre, `grasp_depth` below the top face), the jaws opened as the planner opens them; and the criterion
itself (`grasp_tilt.tilt_problem`) on cases worked by hand."""

import math

import numpy as np

from pegbt.frames import rigid_transform
from pegbt.motion.settings import motion_settings
from pegbt.sim.grasp_tilt import tilt_problem
from pegbt.sim.tools import ToolState
from pegbt.sim.world import World
from pegbt.workcell import load_workcell

BLOCK = 0


def _turn(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by `angle` (rad) about the unit `axis` (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def _close_tilted(across_deg: float, along_deg: float) -> list[str]:
    """Open, then close, PSM1's jaws with the tip on the wall of edge 0's centre, the tool leaning
    `across_deg` in the jaws' closing plane (its top out over the flat edge) and `along_deg` along the
    wall (about the closing axis); what the world logged about block 0's grasp."""
    world = World(0)
    model = world.cell.block
    normal = np.array([*model.edge_normals[0], 0.0])
    tangent = np.array([-normal[1], normal[0], 0.0])
    up = np.array([0.0, 0.0, -1.0])  # block z points down
    upright = np.column_stack([normal, np.cross(up, normal), up])  # x closes across the wall
    tilt = _turn(tangent, -math.radians(across_deg)) @ _turn(normal, math.radians(along_deg))
    rotation = tilt @ upright
    centre = (model.hole_radius + model.edge_distance) / 2
    local = rigid_transform(rotation, centre * normal + [0.0, 0.0, -model.height + model.grasp_depth])
    tip = world.blocks[BLOCK].pose @ local
    shaft = np.array([tip[:3, 3] + 0.3 * tip[:3, 2], tip[:3, 3] + 0.0186 * tip[:3, 2]])
    jaw = motion_settings().transfer
    world.update(0.0, {"PSM1": ToolState(tip, jaw.jaw_open, shaft)})
    world.update(0.1, {"PSM1": ToolState(tip, jaw.jaw_closed, shaft)})
    return [f"{e.kind}: {e.detail}" for e in world.events if e.kind.startswith("grasp") and e.block == BLOCK]


def _tilt(across_deg: float, along_deg: float) -> float:
    """Degrees between the tool's axis and the block's for `_close_tilted`'s two leans."""
    across, along = math.radians(across_deg), math.radians(along_deg)
    return math.degrees(math.acos(math.cos(across) * math.cos(along)))


def test_a_tool_leaning_along_the_wall_beyond_30_degrees_grips_it():
    # 10° across and 33° along: 34.5° off the block's axis, which a fixed 30° limit refused. Leaning along
    # the wall turns the plane the jaws close in about the wall's normal; each jaw still starts on its own
    # side of the wall (one in the hole, one beyond the flat edge) and closes onto it, the one in the hole
    # on the hole's rim with its tip 3.3 mm under the top face, the other with its tip on the flat face
    # 4.6 mm under it: more than the world's 1 mm bite, between the wall's ends.
    assert _tilt(10, 33) > 34
    assert _close_tilted(10, 33) == ["grasp: edge 0"]


def test_a_tool_leaning_27_degrees_across_the_wall_cannot_grip_it():
    # 27° in the closing plane, under the old limit. The wrist's hinge, 9.5 mm up the tool, stands 3.3 mm
    # out beyond the flat edge and 4 mm over the top face; seen from it the wall fills the jaw angles from
    # 26° on the hole's side of the tool's axis to 7° on the other. The jaws open 25° either side of the
    # axis, so the jaw on the hole's side would already lie inside the wall: it could only have got there
    # through the wall.
    assert _tilt(27, 0) < 30
    (event,) = _close_tilted(27, 0)
    assert event.startswith("grasp_miss") and "a jaw would come down through the wall" in event


def test_an_upright_tool_grips_as_it_did():
    assert _close_tilted(0, 0) == ["grasp: edge 0"]


def _ask(along_deg: float, along_wall: float, depth: float) -> str | None:
    """`tilt_problem` for the planner's jaws (50°) closed on edge 0's wall, the tip `along_wall` (m) from
    the wall's middle and `depth` under the top face, the tool upright across the wall and leaning
    `along_deg` along it (about the closing axis, its top towards +`along_wall`)."""
    cell = load_workcell()
    model = cell.block
    normal = np.array([*model.edge_normals[0], 0.0])
    tangent = np.array([-normal[1], normal[0], 0.0])
    up = np.array([0.0, 0.0, -1.0])
    rotation = _turn(normal, math.radians(along_deg)) @ np.column_stack([normal, np.cross(up, normal), up])
    centre = (model.hole_radius + model.edge_distance) / 2
    tip = centre * normal + along_wall * tangent + [0.0, 0.0, -model.height + depth]
    opened = motion_settings().transfer.jaw_open
    return tilt_problem(
        rigid_transform(rotation, tip), opened, normal[:2], model, cell.tool.jaw_length, 0.001
    )


def test_leaning_along_the_wall_carries_the_contact_towards_the_wall_s_end():
    # The tip 6 mm from the middle of a wall whose edge runs 7.16 mm either side, 4.5 mm deep, the tool
    # leaning 20° along the wall: each blade meets the wall's top edge, 4.5 / cos 20° - 9.5 mm down the
    # tool from the hinge, which stands 9.5 sin 20° mm along the wall from the tip, so the contact lies
    # 6 + 4.5 tan 20° = 7.64 mm along: beyond the end. Leaning the other way it lies at 4.36 mm and grips.
    assert _ask(20, 0.006, 0.0045) == (
        "tool tilted 0° across the wall, 20° along it: a jaw meets the wall beyond its end"
    )
    assert _ask(-20, 0.006, 0.0045) is None


def test_a_tip_just_under_the_top_face_bites_too_little():
    # Upright, the tip 0.5 mm under the top face: the hinge stands 9.0 mm over it and 1 mm from either face
    # of the wall, so each blade meets the wall's top corner at atan(1 / 9.0) = 6.3°, its tip
    # 9.5 cos 6.3° - 9.0 = 0.44 mm under the top face: less than the world's 1 mm bite. At 4.5 mm it is 4.3 mm.
    assert _ask(0, 0.0, 0.0005) == (
        "tool tilted 0° across the wall, 0° along it: a jaw tip meets the wall 0.4 mm below its top"
    )
    assert _ask(0, 0.0, 0.0045) is None
