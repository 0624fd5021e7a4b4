"""Whether a tool standing off a block's axis can still close its jaws on the block's wall.

Dimensions (all `skills/workcell.yaml`'s, from shared/reference/peg-transfer-geometry.md): a jaw reaches
`tool.jaw_length` (L4, 9.5 mm) from the wrist's yaw axis, its hinge, to its tip; the block's wall lies between
its hole (`block.hole_radius`, 3.6 mm) and a flat edge (`block.edge_distance`, 5.6 mm), 2 mm thick, 14.7 mm
high (`block.height`), and ends where the corner cuts begin (`BlockModel.edge_half_length`); beyond the hole
lies the block's far side. The hole's face is taken as the plane at its radius across the wall's normal, as
the world's wall is everywhere else (`World._grip_problem`'s reach and centring).

A jaw is a blade from the hinge to the tip, its gripping face through the hinge, turning in the plane the
jaws close in (the tool's x and z; the hinge `jaw_length` up the tool's z from the closed tip). By the time
this is asked the world has centred the wall under the closed tip (a free block slides, the wrist gives);
what is left is the tilt. That plane cuts the wall, and the far side, in a convex polygon each. A blade at
angle β from the tool's -z towards its x touches a polygon at a point of it within `jaw_length` of the
hinge, so the angles at which it does form an interval [lo, hi], bounded by the polygon's vertices inside
that disc and its edges' crossings with the circle. The jaws open to ±opened/2 and each closes towards the
other until it meets the wall (the first to touch stops and the other goes on, the yaw taking the difference,
as the wrist takes a wall off the tip's centre). They grip when:

1. the wall lies between the open blades, −opened/2 < lo <= hi < opened/2: otherwise a blade would have
   had to come down through the wall to be where it is;
2. neither blade's sweep, from its start to the wall, crosses the far side's interval: otherwise its tip
   would have had to pass through the hole's far side;
3. each blade meets the wall's face, or its top edge, between the edge's ends (the closed tip itself keeps
   the world's `grasp_edge_margin` inside them), its tip at that angle at least `min_bite` below the top face
   and above the bottom one. Leaning in the closing plane makes one blade steeper and the other shallower, so
   one meets the wall high on its edge with its tip barely under it; leaning along the wall turns the blades'
   plane across the wall's face, and the contact runs along it towards an end.

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
        for a, b, va, vb in zip(polygon, np.roll(polygon, -1, axis=0), values, np.roll(values, -1)):
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
