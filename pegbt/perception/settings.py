"""Perception's tunables, read from `skills/perception.yaml`: what each value means is written there, once.

What follows from the work cell (the block's size, the board surface, the peg count) is derived from
`skills/workcell.yaml` where it is used, not repeated here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import cache
from pathlib import Path
from typing import Any

from pegbt.motion.limits import SKILLS_DIR
from pegbt.yamlfile import Located, read_settings_file

PERCEPTION_SETTINGS = SKILLS_DIR / "perception.yaml"


@dataclass(frozen=True)
class SegmentSettings:
    """Tunables of the segmentation (metres)."""

    plane_margin: float
    max_stack: int
    voxel: float
    cluster_distance: float
    cluster_min_points: int
    min_points: int
    wide_margin: float


@dataclass(frozen=True)
class BlockSettings:
    """Tunables of block registration (metres; max_tilt in radians)."""

    model_points: int
    distances: tuple[float, ...]
    max_iterations: int
    quality_distance: float
    min_fitness: float
    max_points: int
    max_rmse: float
    max_tilt: float
    top_face_depth: float
    on_peg_tolerance: float
    surrounded_points: int
    part_distance: float
    stack_height: float
    search_radii: tuple[float, ...]
    search_directions: int
    search_min_points: int
    search_slack: float
    search_agreement: float
    segment: SegmentSettings


@dataclass(frozen=True)
class BoardSettings:
    """Tunables of the board registration (metres)."""

    model_points: int
    voxels: tuple[float, ...]
    distances: tuple[float, ...]
    outlier_radius: float
    outlier_neighbours: int
    min_points: int
    tukey_k: float
    max_iterations: int
    quality_distance: float
    min_fitness: float
    peg_band_margin: float
    peg_search_radius: float
    min_peg_points: int
    max_peg_offset: float


@dataclass(frozen=True)
class PerceptionSettings:
    board: BoardSettings
    block: BlockSettings


def _value(value: Located, kind: str) -> Any:
    if kind == "int":
        return value.integer(low=1)
    if kind == "tuple[float, ...]":
        return tuple(float(item.number(positive=True)) for item in value.sequence())
    return value.number(positive=True)


def _section(
    document: Located, name: str, kind: type, renamed: dict[str, str] | None = None
) -> dict[str, Any]:
    """The fields of `kind` read from section `name`; `renamed` maps a field to its key in the file."""
    renamed = renamed or {}
    wanted = [f for f in fields(kind) if f.name != "segment"]
    section = document.section(name, tuple(renamed.get(f.name, f.name) for f in wanted))
    return {f.name: _value(section[renamed.get(f.name, f.name)], str(f.type)) for f in wanted}


@cache
def perception_settings(path: Path = PERCEPTION_SETTINGS) -> PerceptionSettings:
    """The settings of `path` (default `skills/perception.yaml`); a `PegbtError` naming file, line and field."""
    document = read_settings_file(path)
    document.mapping(("board", "segment", "block"))
    block = _section(document, "block", BlockSettings, {"max_tilt": "max_tilt_deg"})
    block["max_tilt"] = math.radians(block["max_tilt"])
    return PerceptionSettings(
        board=BoardSettings(**_section(document, "board", BoardSettings)),
        block=BlockSettings(
            **block, segment=SegmentSettings(**_section(document, "segment", SegmentSettings))
        ),
    )
