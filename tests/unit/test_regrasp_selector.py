"""The grasp selector avoids a candidate that missed while another is feasible, and picks the same again when
nothing else is."""

from __future__ import annotations

from grasp_helpers import everywhere, off_peg

from pegbt.perception.grasp import GraspSelector


def test_the_selector_avoids_a_candidate_while_another_is_feasible():
    block = off_peg(2, 75.0)
    selector = GraspSelector("PSM1", everywhere)
    first = selector.pick(block)
    again = selector.pick(block, avoid=(first.candidate,))
    assert again is not None and again.candidate != first.candidate
    everything = tuple(range(6))
    assert selector.pick(block, avoid=everything).candidate == first.candidate  # nothing else: the same again
