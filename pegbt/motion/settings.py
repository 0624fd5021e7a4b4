"""Motion settings from `skills/motion.yaml`: waypoint heights, the peg channel, jaw angles, SQP, the
handover and how far apart the two arms keep.

Joint limits are per arm and live in `skills/psm.yaml` (`pegbt.motion.limits`); the block and where it
is gripped are the work cell's (`skills/workcell.yaml`), so the two heights the waypoints take from the
block are derived from it here, not written twice.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import cache
from pathlib import Path
from typing import Any

from pegbt.motion.limits import SKILLS_DIR
from pegbt.workcell import WORKCELL_FILE, workcell
from pegbt.yamlfile import Located, read_settings_file

MOTION_SETTINGS = SKILLS_DIR / "motion.yaml"
SIGNED = {
    "meeting_offset_board_y",
    "meeting_above_transfer",
    "jaw_closed",
}  # settings that may be zero or negative


@dataclass(frozen=True)
class TransferSettings:
    """Where the tip goes relative to the pegs, along the peg axis (m), and the jaw angles (rad).

    `block_top_below_peg_top`, `grasp_depth` and `block_below_tip` come from the work cell's block."""

    block_top_below_peg_top: float
    grasp_depth: float
    block_below_tip: float
    approach_above_block: float
    transfer_height_above_peg_top: float
    drop_height_above_peg_top: float
    channel_margin: float
    channel_tolerance: float
    upright_tilt: float
    jaw_open: float
    jaw_at_grasp: float
    jaw_release: float
    jaw_closed: float
    grip_confirmed_below: float

    @property
    def channel_clear_above_peg_top(self) -> float:
        """The block is on the peg while the tip is lower than this above the peg top (its bottom hangs
        `block_below_tip` under the tip), and the tip must then stay on the peg axis."""
        return self.block_below_tip + self.channel_margin


@dataclass(frozen=True)
class SqpSettings:
    """Discretisation and solver knobs of the SQP refinement."""

    segments: int
    max_iterations: int
    step_limit: tuple[float, ...]
    jerk_weight: float
    eps: float
    rho: float
    max_solver_iterations: int
    warm_above_clear: float  # m: the warm start passes over the pegs this far above the clearing height
    approach_above_clear: float  # m: the same for an approach (the empty tool passes the other arm's)
    lone_approach_above_clear: float  # m: the same for an approach with the other arm parked


@dataclass(frozen=True)
class HandoverSettings:
    """The handover's meeting point and clearances (m)."""

    meeting_offset_board_y: float
    meeting_above_transfer: float
    receiver_wait_above: float
    giver_retreat: float
    min_tool_distance: float
    grasp_clearance: (
        float  # the receiver's tool keeps this clear of the giver's, waiting above its grasp and down onto it
    )


@dataclass(frozen=True)
class TwoArmSettings:
    """How the two arms share the work cell (m)."""

    keep_apart: float  # an arm motion waits until it keeps the tools' axes this far apart


@dataclass(frozen=True)
class MotionSettings:
    transfer: TransferSettings
    sqp: SqpSettings
    handover: HandoverSettings
    two_arms: TwoArmSettings


def _setting(value: Located, kind: str, signed: bool) -> Any:
    if kind == "int":
        return value.integer(low=1)
    if kind == "tuple[float, ...]":  # one value per joint
        return tuple(value.array((6,), positive=not signed).tolist())
    return value.number(positive=not signed)


def _section(document: Located, name: str, kind: type, derived: dict[str, float] | None = None) -> Any:
    """Section `name` as dataclass `kind`: every field it reads, and nothing else."""
    section = document[name]
    read = [f for f in fields(kind) if f.name not in (derived or {})]
    section.mapping(tuple(f.name for f in read))
    values = {f.name: _setting(section[f.name], str(f.type), f.name in SIGNED) for f in read}
    return kind(**values, **(derived or {}))


@cache
def motion_settings(path: Path = MOTION_SETTINGS, workcell_file: Path = WORKCELL_FILE) -> MotionSettings:
    """The motion settings of `path` (default `skills/motion.yaml`), with the block's heights from
    `workcell_file` (default `skills/workcell.yaml`)."""
    document = read_settings_file(path)
    document.mapping(("transfer", "sqp", "handover", "two_arms"))
    cell = workcell(workcell_file)
    block = {
        "block_top_below_peg_top": cell.block_top_below_peg_top,
        "grasp_depth": cell.block.grasp_depth,
        "block_below_tip": cell.block.height - cell.block.grasp_depth,
    }
    return MotionSettings(
        transfer=_section(document, "transfer", TransferSettings, block),
        sqp=_section(document, "sqp", SqpSettings),
        handover=_section(document, "handover", HandoverSettings),
        two_arms=_section(document, "two_arms", TwoArmSettings),
    )
