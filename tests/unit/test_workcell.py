"""The work-cell file against the reference geometry, and its errors for bad input."""

from pathlib import Path

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.settings import motion_settings
from pegbt.workcell import N_PEGS, WORKCELL_FILE, load_workcell, workcell


def test_peg_tops_sit_about_148_mm_below_psm1():
    cell = workcell()
    tops = np.column_stack([cell.pegs.tops, np.ones(N_PEGS)]) @ cell.board_to_arm("PSM1").T
    assert np.allclose(tops[:, 2], -0.148, atol=0.003)


def test_arm_transforms_are_exact_inverses_and_turn_the_board_over():
    cell = workcell()
    for arm in ("PSM1", "PSM2"):
        assert np.allclose(cell.board_to_arm(arm) @ cell.arm_to_board(arm), np.eye(4), atol=1e-12)
        # about 180° about y: board x and z point the other way in the arm frame
        assert cell.board_to_arm(arm)[0, 0] < -0.99 and cell.board_to_arm(arm)[2, 2] < -0.99
    # the arms stand on either side of the board, above it (negative board z)
    assert cell.remote_centre("PSM1")[0] > 0.15 and cell.remote_centre("PSM2")[0] < -0.05
    assert cell.remote_centre("PSM1")[2] < -0.1


def test_block_outline_is_the_truncated_triangle():
    block = workcell().block
    normals, offsets = block.outline_planes
    # three long edges at 5.6 mm, three corner cuts at 9.0 mm
    assert np.allclose(sorted(offsets), [0.0056] * 3 + [0.0090] * 3, atol=1e-9)
    full_side = 2 * np.sqrt(3) * block.edge_distance
    assert full_side == pytest.approx(0.0194, abs=1e-4)


def test_grasp_candidates_lie_on_the_wall_at_grasp_depth():
    block = workcell().block
    candidates = block.grasp_candidates
    radial = np.linalg.norm(candidates.positions[:, :2], axis=1)
    assert np.all((radial > block.hole_radius) & (radial < block.edge_distance))
    assert np.allclose(candidates.positions[:, 2], -block.height + block.grasp_depth)
    # each pair grips one edge, 2 × 1.25 mm apart, jaw closing across the wall (along the edge normal)
    for edge in range(3):
        pair = candidates.positions[[i for i, e in enumerate(candidates.edge) if e == edge]]
        assert np.linalg.norm(pair[0] - pair[1]) == pytest.approx(0.0025)
        normal = block.edge_normals[edge]
        assert np.allclose(pair[:, :2] @ normal, block.grasp_radial)


def test_camera_looks_at_the_board_from_about_half_a_metre():
    camera = workcell().camera
    T = camera.board_from_camera
    axis, origin = T[:3, 2], T[:3, 3]
    hit = origin + axis * (-origin[2] / axis[2])  # where the optical axis meets the board plane
    assert 0.0 < hit[0] < 0.12 and 0.0 < hit[1] < 0.07
    assert 0.45 < np.linalg.norm(hit - origin) < 0.6
    assert np.allclose(camera.camera_from_board @ T, np.eye(4), atol=1e-12)


def test_handover_point_is_between_the_groups_offset_from_its_pegs():
    cell = workcell()
    x, y, _ = handover_meeting_point(cell)
    left, right = (
        cell.pegs.positions[list(cell.pegs.left_group)],
        np.delete(cell.pegs.positions, list(cell.pegs.left_group), axis=0),
    )
    assert left[:, 0].max() < x < right[:, 0].min()
    centre = cell.pegs.positions[list(cell.handover_pegs)].mean(axis=0)
    assert y == pytest.approx(centre[1] + motion_settings().handover.meeting_offset_board_y)


def _broken(tmp_path: Path, old: str, new: str) -> Path:
    text = WORKCELL_FILE.read_text()
    assert old in text
    path = tmp_path / "workcell.yaml"
    path.write_text(text.replace(old, new))
    return path


def test_a_bad_value_is_located_by_file_line_column_and_field(tmp_path):
    path = _broken(tmp_path, "height: 0.0147", "height: tall")
    with pytest.raises(PegbtError) as caught:
        load_workcell(path)
    error = caught.value
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if "height: tall" in text)
    assert (error.file, error.line, error.field) == (str(path), line, "block.height")
    assert error.column == 11


def test_a_matrix_that_is_not_a_rotation_is_refused(tmp_path):
    path = _broken(tmp_path, "- [-0.9996, -0.0172, -0.0226]", "- [-0.5, -0.0172, -0.0226]")
    with pytest.raises(PegbtError, match="not a rotation") as caught:
        load_workcell(path)
    assert caught.value.field == "arms.PSM1.rotation"


def test_eleven_pegs_are_refused(tmp_path):
    path = _broken(tmp_path, "    - [0.0948, 0.0429]      # 11\n", "")
    with pytest.raises(PegbtError, match="12 x 2") as caught:
        load_workcell(path)
    assert caught.value.field == "pegs.positions"


def test_unknown_arm_is_an_error():
    with pytest.raises(PegbtError, match="PSM3"):
        workcell().board_to_arm("PSM3")
