"""Segment distances (collision checks) and the meshes the camera sees, against hand-worked cases."""

import numpy as np
import pytest

from pegbt.frames import segment_distances
from pegbt.sim.meshes import block_mesh, box_mesh, cylinder_mesh
from pegbt.workcell import workcell


@pytest.mark.parametrize(
    ("p0", "p1", "q0", "q1", "expected"),
    [
        ([0, 0, 0], [1, 0, 0], [0.5, -1, 1], [0.5, 1, 1], 1.0),  # crossing at a distance
        ([0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], 1.0),  # collinear, end to end
        ([0, 0, 0], [1, 0, 0], [0, 2, 0], [1, 2, 0], 2.0),  # parallel
        ([0, 0, 0], [1, 0, 0], [0.3, 0.4, 0], [0.3, 0.4, 0], 0.4),  # q is a point above the segment
        ([0, 0, 0], [0, 0, 0], [-1, 1, 0], [1, 1, 0], 1.0),  # p is a point
        ([0, 0, 0], [1, 1, 0], [0, 1, 0], [1, 0, 0], 0.0),  # intersecting
    ],
)
def test_segment_distances(p0, p1, q0, q1, expected):
    p0, p1, q0, q1 = (np.asarray(v, dtype=float) for v in (p0, p1, q0, q1))
    assert segment_distances(p0, p1, q0, q1) == pytest.approx(expected)
    assert segment_distances(q0, q1, p0, p1) == pytest.approx(expected)


def test_segment_distances_broadcast_over_many_pairs():
    rng = np.random.default_rng(0)
    p0, p1 = rng.normal(size=(2, 5, 1, 3))
    q0, q1 = rng.normal(size=(2, 1, 7, 3))
    batch = segment_distances(p0, p1, q0, q1)
    assert batch.shape == (5, 7)
    # brute force: the minimum over dense samples of both segments can only be at or above the answer
    s = np.linspace(0, 1, 201)[:, None]
    for i, j in [(0, 0), (2, 5), (4, 6)]:
        a = p0[i, 0] + s * (p1[i, 0] - p0[i, 0])
        b = q0[0, j] + s * (q1[0, j] - q0[0, j])
        brute = np.linalg.norm(a[:, None] - b[None], axis=-1).min()
        assert batch[i, j] <= brute + 1e-12 and batch[i, j] == pytest.approx(brute, abs=0.01)


def _signed_volume(mesh):
    vertices, triangles = mesh
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def test_meshes_are_closed_outward_solids_of_the_right_volume():
    model = workcell().block
    x, y = model.outline[:, 0], model.outline[:, 1]
    outline_area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    expected = (outline_area - np.pi * model.hole_radius**2) * model.height
    assert _signed_volume(block_mesh(model)) == pytest.approx(expected, rel=0.01)
    assert _signed_volume(box_mesh(np.zeros(3), np.array([1.0, 2.0, 3.0]))) == pytest.approx(6.0)
    assert _signed_volume(cylinder_mesh(np.zeros(3), np.array([0.0, 0.0, 2.0]), 0.5)) == pytest.approx(
        np.pi / 2, rel=0.03
    )
