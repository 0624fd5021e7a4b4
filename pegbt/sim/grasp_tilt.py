"""Whether a tool standing off a block's axis can still close its jaws on the block's wall.

A jaw is a blade pivoting on the wrist's yaw axis (the hinge, `jaw_length` above the tip along the tool's
z; workcell.yaml's `tool`: L4 = 9.5 mm), its gripping face a line from the hinge to the tip in the plane
the jaws close in (the tool's x and z). The wall is the block between the hole and one flat edge
(workcell.yaml's `block`: the hole's radius 3.6 mm, the flat edge 5.6 mm from the axis, so 2 mm thick;
14.7 mm high; its ends where the corner cuts begin), the hole's far side the block beyond the hole's other
side; the hole's face is taken as the plane tangent to it across the wall's normal, as the world's wall is.

The world slides a free block (or the wrist yields) until the wall is centred under the closed tip before
this is asked (`World._grip_problem`); what is left is the tilt. The plane the jaws close in cuts the
wall and the far side in two convex polygons. A blade pointing at angle β from the tool's -z towards its
x touches a polygon where the polygon meets the disc of radius `jaw_length` about the hinge, so the
polygon's points in that disc span an angle [lo, hi] (its vertices inside the disc and its edges' crossings
with the circle bound it). The jaws open to ±opened/2 and each closes towards the other, on its own blade
(the yaw yields to the first blade that touches, as `World._grip_problem` says the wrist does). They grip
when:

1. neither blade starts inside [lo, hi] and the wall lies between them (−opened/2 < lo, hi < opened/2):
   otherwise a blade would have had to come down through the wall;
2. no blade sweeps through the far side's span on its way from its start to the wall: otherwise its tip
   would have had to pass through the hole's far side;
3. each blade meets the wall's face (or its top edge) between its ends, where the corner cuts begin (the
   closed tip itself keeps the world's `grasp_edge_margin` inside them), and with its tip, at that angle, at least
   `min_bite` below the top face and above the bottom one: a blade meeting the wall's top edge with its
   tip barely under it (a tool leaning across the jaws' plane makes one blade steeper, and the other must
   still reach past the edge when it gets there) or a blade whose face meets the wall beyond its end (a
   tool leaning along the wall turns the blades' plane across the wall's face) holds nothing.

Nothing here is fitted: every figure is the work cell's, or the world's grasp tolerances.
"""

from __future__ import annotations

import math

import numpy as np

from pegbt.frames import Matrix
from pegbt.workcell import BlockModel

_Planes = list[tuple[Matrix, float]]  # half-spaces g·p <= k in the block frame


def tilt_problem(
    local: Matrix,
    opened: float,
    normal: Matrix,
    block: BlockModel,
    jaw_length: float,
    min_bite: float,
) -> str | None:
    """Why jaws opened to `opened` (rad), the closed tip at `local` (pose in the block frame), would not
    close on the wall whose outward normal is `normal` (block x, y), once the wall is centred under the
    tip; None when they grip it."""
    rotation, tip = local[:3, :3], local[:3, 3]
    n3, t3 = np.array([normal[0], normal[1], 0.0]), np.array([-normal[1], normal[0], 0.0])
    centre = (block.hole_radius + block.edge_distance) / 2
    x, z = rotation[:, 0], rotation[:, 2]
    hinge = tip - (float(tip @ n3) - centre) * n3 + jaw_length * z
    closing = math.degrees(math.atan2(float(z @ n3), -float(z[2])))
    along = math.degrees(math.atan2(float(z @ t3), -float(z[2])))
    tilted = f"tool tilted {closing:.0f}° across the wall, {along:.0f}° along it: "
    outline = _outline(block)
    wall = _span(_section(outline + [(-n3, -block.hole_radius)], hinge, x, z), jaw_length)
    far = _span(_section(outline + [(n3, -block.hole_radius)], hinge, x, z), jaw_length)
    half = max(opened, 0.0) / 2
    if wall is None:
        return tilted + "the jaws close without meeting the wall"
    (lo, low_point), (hi, high_point) = wall
    if not -half < lo <= hi < half:
        return tilted + "a jaw would come down through the wall"
    for start, meet, point in ((-half, lo, low_point), (half, hi, high_point)):
        if far is not None and min(start, meet) <= far[1][0] and far[0][0] <= max(start, meet):
            return tilted + "a jaw would pass through the hole's far side"
        if abs(float((hinge + point[0] * x + point[1] * z) @ t3)) > block.edge_half_length:
            return tilted + "a jaw meets the wall beyond its end"
        depth = float(hinge[2] + jaw_length * (math.sin(meet) * x[2] - math.cos(meet) * z[2])) + block.height
        if not min_bite <= depth <= block.height:
            return tilted + f"a jaw tip meets the wall {depth * 1000:.1f} mm below its top"
    return None


def _outline(block: BlockModel) -> _Planes:
    """The block's prism: its six sides and its top and bottom faces (block z down, top at -height)."""
    normals, offsets = block.outline_planes
    sides = [(np.array([nx, ny, 0.0]), float(k)) for (nx, ny), k in zip(normals, offsets)]
    return sides + [(np.array([0.0, 0.0, 1.0]), 0.0), (np.array([0.0, 0.0, -1.0]), block.height)]


def _section(planes: _Planes, origin: Matrix, x: Matrix, z: Matrix) -> Matrix:
    """(k, 2) convex polygon cut from the half-spaces' intersection by the plane origin + a·x + b·z, in
    (a, b); empty when they do not meet it."""
    size = 1.0  # m: far beyond a block
    polygon = np.array([[-size, -size], [size, -size], [size, size], [-size, size]])
    for g, k in planes:
        coefficients, limit = np.array([g @ x, g @ z]), k - float(g @ origin)
        values = polygon @ coefficients - limit
        clipped = []
        for i in range(len(polygon)):
            a, b, va, vb = (
                polygon[i],
                polygon[(i + 1) % len(polygon)],
                values[i],
                values[(i + 1) % len(polygon)],
            )
            if va <= 0:
                clipped.append(a)
            if (va <= 0) != (vb <= 0):
                clipped.append(a + (b - a) * va / (va - vb))
        polygon = np.array(clipped).reshape(-1, 2)
        if len(polygon) == 0:
            break
    return polygon


def _span(polygon: Matrix, radius: float) -> tuple[tuple[float, Matrix], tuple[float, Matrix]] | None:
    """The least and greatest blade angles (from -z towards x) at which a blade of `radius` from the
    origin touches `polygon`, each with the point it touches; None when it cannot reach it."""
    if len(polygon) < 3:
        return None
    points = [p for p in polygon if p @ p <= radius**2]
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0)):
        d = b - a
        qa, qb, qc = d @ d, 2 * (a @ d), a @ a - radius**2
        root = qb**2 - 4 * qa * qc
        if qa > 0 and root >= 0:
            for s in ((-qb - math.sqrt(root)) / (2 * qa), (-qb + math.sqrt(root)) / (2 * qa)):
                if 0.0 <= s <= 1.0:
                    points.append(a + s * d)
    if not points:
        return None
    angles = [math.atan2(p[0], -p[1]) for p in points]
    low, high = int(np.argmin(angles)), int(np.argmax(angles))
    return (angles[low], points[low]), (angles[high], points[high])
