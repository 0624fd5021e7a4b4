"""Short trees for trials on the embedded simulator that several test modules run: one transfer, one
handover. They live here so that no test module imports another."""

from __future__ import annotations

from pathlib import Path

from executive_helpers import with_shared_trees


def short_task(tmp_path: Path, regrasps: int = 1) -> Path:
    """Look, then move the block on peg 1 to peg 7 with PSM1, `regrasps` recoveries allowed, then check it
    arrived."""
    tree = tmp_path / "short.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        "include: [shared/one_transfer.yaml, shared/sense.yaml]\n"
        "blackboard: {/policy/skip_failed_blocks: true, /PSM1/may_carry: true, /PSM2/may_carry: true}\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        f"    - subtree: {{use: transfer_block, args: {{arm: PSM1, pick: 1, place: 7, regrasps: {regrasps}}}}}\n"
        "    - subtree: {use: clear_view, name: look at the result}\n"
        "    - check_placed: {name: block home, pegs: [7]}\n"
    )
    return tree


def one_handover(tmp_path: Path, regrasps: int = 0, pick: int = 1, place: int = 7) -> Path:
    """Look, then hand the block on peg `pick` from PSM2 to PSM1 for peg `place`, with `regrasps` recoveries
    of the pick."""
    tree = tmp_path / "one-handover.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        f"include: [shared/handover.yaml, shared/sense.yaml]\n"
        "tree:\n  sequence:\n"
        "    - subtree: {use: clear_view}\n"
        "    - parallel:\n        name: one handover\n        children:\n"
        f"          - force_success: {{name: g, child: {{subtree: {{use: give, args: {{giver: PSM2, receiver: PSM1, n: 1, pick: {pick}, place: {place}, regrasps: {regrasps}, strays: [6]}}}}}}}}\n"
        f"          - force_success: {{name: r, child: {{subtree: {{use: receive, args: {{receiver: PSM1, giver: PSM2, n: 1, place: {place}, strays: [6]}}}}}}}}\n"
    )
    return tree
