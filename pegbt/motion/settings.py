"""Motion settings from `skills/motion.yaml`: waypoint heights, the peg channel, SQP and handover knobs.

Joint limits are per arm and live in `skills/psm.yaml` (`pegbt.motion.limits`); this file holds what
both arms share.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import lru_cache
from pathlib import Path

import yaml

from pegbt.errors import PegbtError
from pegbt.motion.limits import SKILLS_DIR

MOTION_SETTINGS = SKILLS_DIR / "motion.yaml"
SIGNED = {"meeting_offset_board_y", "jaw_closed"}  # settings that may be zero or negative


@dataclass(frozen=True)
class TransferSettings:
    """Where the tip goes relative to the pegs, along the peg axis (m), and the jaw angles (rad)."""

    block_top_below_peg_top: float
    grasp_depth: float
    approach_above_block: float
    transfer_height_above_peg_top: float
    drop_height_above_peg_top: float
    channel_clear_above_peg_top: float
    channel_tolerance: float
    upright_tilt: float
    jaw_open: float
    jaw_closed: float


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


@dataclass(frozen=True)
class HandoverSettings:
    """The handover's meeting point and clearances (m)."""

    meeting_offset_board_y: float
    meeting_above_transfer: float
    receiver_wait_above: float
    giver_retreat: float
    min_tool_distance: float


@dataclass(frozen=True)
class MotionSettings:
    transfer: TransferSettings
    sqp: SqpSettings
    handover: HandoverSettings


def _number(value: object, wanted: type, signed: bool, path: Path, field: str) -> float | int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (wanted is int and not isinstance(value, int)):
        raise PegbtError(f"expected a number ({wanted.__name__}), got {value!r}", file=path, field=field)
    if not value > 0 and not signed:
        raise PegbtError(f"must be positive, got {value!r}", file=path, field=field)
    return wanted(value)


def _section(document: dict, name: str, kind: type, path: Path) -> object:
    data = document.get(name) if isinstance(document, dict) else None
    if not isinstance(data, dict):
        raise PegbtError("missing section", file=path, field=name)
    values = {}
    for field in fields(kind):
        if field.name not in data:
            raise PegbtError("missing setting", file=path, field=f"{name}.{field.name}")
        value, where, signed = data[field.name], f"{name}.{field.name}", field.name in SIGNED
        if field.type == "tuple[float, ...]":  # one value per joint
            if not isinstance(value, list) or len(value) != 6:
                raise PegbtError(f"expected 6 numbers (one per joint), got {value!r}", file=path, field=where)
            values[field.name] = tuple(_number(v, float, signed, path, f"{where}[{i}]") for i, v in enumerate(value))
        else:
            values[field.name] = _number(value, int if field.type == "int" else float, signed, path, where)
    return kind(**values)


@lru_cache(maxsize=None)
def motion_settings(path: Path = MOTION_SETTINGS) -> MotionSettings:
    """The motion settings of `path` (default `skills/motion.yaml`)."""
    try:
        document = yaml.safe_load(path.read_text())
    except OSError as error:
        raise PegbtError(f"cannot read motion settings: {error}", file=path) from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        raise PegbtError(
            f"not valid YAML: {getattr(error, 'problem', error)}",
            file=path,
            line=None if mark is None else mark.line + 1,
            column=None if mark is None else mark.column + 1,
        ) from None
    return MotionSettings(
        transfer=_section(document, "transfer", TransferSettings, path),
        sqp=_section(document, "sqp", SqpSettings, path),
        handover=_section(document, "handover", HandoverSettings, path),
    )
