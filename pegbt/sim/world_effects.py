"""World effects: the physics of contact the simulated world leaves out by default, as a registry of kinds.

The default world (`pegbt.sim.world`) is rigid: a peg never bends, a hole must come within the 2.0 mm
clearance to go over a peg, closing jaws grip a block on a peg only as far off its wall's centre as the
block can slide and the wrist's cable play (the arm's, `ToolState.give`) yields, a gripped block never
moves in the jaws and never slips out, the arms stand where the work cell says, and the camera measures
every surface true and shows each block where it is. Each kind here relaxes one of those, with parameters
in physical units, their range, the value that leaves the world as it is (the default) and where a value
comes from. The world (`World(effects=...)`) and its camera (`acts_on`) apply them;
`WorldEffects()` (none) is today's world.

A world file lists them (YAML, read with `pegbt.yamlfile`, so every error names file, line and field):

    effects:
      - {kind: peg_compliance, stiffness: 2900, deflection: 0.001}
      - {kind: registration_offset, x: 0.001, y: -0.0005, z: 0.0}
      - {kind: grasp_capture, width: 0.0015}

A new kind is one class (`register_world_effect(MyKind())`): the listing, the world file and the fitting of
`pegbt sim2real outcomes` know it from then on; the world or camera has to apply it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar, NamedTuple

import yaml

from pegbt.errors import PegbtError
from pegbt.yamlfile import Located, read_settings_file

GRAVITY = 9.81  # m/s²
# An FLS block: a truncated triangular prism (flat edges 5.6 mm from the centre, corners cut at 9.0 mm,
# 14.7 mm high) around a 3.6 mm hole is about 1.6 cm³; printed in PLA (1.24 g/cm³) it weighs about 2 g.
BLOCK_MASS = 0.002  # kg
HOLE_RADIUS = 0.0036  # m: the hole's walls (skills/workcell.yaml)
CLEARANCE = HOLE_RADIUS - 0.0016  # m: less the peg's radius 1.6 mm (skills/workcell.yaml)


class Parameter(NamedTuple):
    """One parameter of a world effect: unit, range [low, high], the inert default, and its source."""

    unit: str
    low: float
    high: float
    default: float
    source: str


class WorldEffectKind:
    """One kind of world effect. Subclasses set `name`, `acts_on` (what applies it: "world" or
    "camera"), `summary` (what it does, one sentence) and `parameters`."""

    name: ClassVar[str]
    acts_on: ClassVar[str]
    summary: ClassVar[str]
    parameters: ClassVar[Mapping[str, Parameter]]

    def defaults(self) -> dict[str, float]:
        """Every parameter at its inert default."""
        return {name: parameter.default for name, parameter in self.parameters.items()}

    def sentence(self, values: Mapping[str, float]) -> str:
        """The effect with its values, in one line."""
        shown = ", ".join(
            f"{name} = {values[name]:.4g} {self.parameters[name].unit}" for name in self.parameters
        )
        return f"{self.name} ({shown})"


class PegCompliance(WorldEffectKind):
    name = "peg_compliance"
    acts_on = "world"
    summary = (
        "a peg bends: a block threaded on it and dragged sideways past the clearance, beyond what the wrist "
        "and the grip yield, bends the peg up to `deflection` before the block is knocked loose; the bent "
        "peg pushes on the grip with stiffness × bend (a load `jaw_friction` may not hold)"
    )
    parameters = {
        "stiffness": Parameter(
            "N/m",
            100.0,
            100_000.0,
            2900.0,
            "a cantilever's 3EI/L³: a 3.2 mm peg (peg-transfer-geometry.md) standing 22.8 mm "
            "(skills/workcell.yaml: board surface to peg top), ABS plastic E ≈ 2.2 GPa",
        ),
        "deflection": Parameter(
            "m",
            0.0,
            0.003,
            0.0,
            "how far a peg's top bends sideways before the block catches on it; 0: a rigid peg",
        ),
    }


class ChamferCapture(WorldEffectKind):
    name = "chamfer_capture"
    acts_on = "world"
    summary = (
        "lowered or dropped onto a peg, a block whose hole comes within `capture_radius` of the peg's axis "
        "(the chamfers widen the peg's room in the hole by what they add to the clearance, lobes and all) "
        "is caught by the chamfers of the hole and the peg and guided onto it (turning in the jaws if held)"
    )
    parameters = {
        "capture_radius": Parameter(
            "m",
            CLEARANCE,
            0.004,
            CLEARANCE,
            "the 2.0 mm clearance (hole radius 3.6 mm less peg radius 1.6 mm, skills/workcell.yaml) plus "
            "the chamfers of hole and peg top, up to 1 mm each",
        ),
    }


class HoleLobes(WorldEffectKind):
    name = "hole_lobes"
    acts_on = "world"
    summary = (
        "the block's hole is no circle: between its walls it reaches out to `lobe_radius` towards the "
        "corners, so a peg off the hole's axis towards a corner stands clear of it further than towards a wall"
    )
    parameters = {
        "lobe_radius": Parameter(
            "m",
            HOLE_RADIUS,
            0.0045,
            HOLE_RADIUS,
            "the paper's block model (img/block.pcd, BerkeleyAutomation/FLSpegtransferHO): a 4.5 mm circle (the "
            "paper's '4.5 mm opening') cut by three flats along the edge normals; the flats stay at the walls "
            "pegbt grips (3.6 mm, skills/workcell.yaml; the model's are at 3.4 mm)",
        ),
    }


class GripCompliance(WorldEffectKind):
    name = "grip_compliance"
    acts_on = "world"
    summary = (
        "a block pushed sideways by its peg slides along the jaws (up to `displacement`) and turns about "
        "their closing axis (up to `angle`, its travel where the peg presses) before the peg catches it; "
        "it springs back when the push is gone"
    )
    parameters = {
        "angle": Parameter(
            "rad",
            0.0,
            0.5,
            0.0,
            "how far a 2 mm wall turns between the jaws' serrations before they hold it (0: rigid)",
        ),
        "displacement": Parameter(
            "m",
            0.0,
            0.003,
            0.0,
            "how far the wall slides along the jaws (jaw length 9.5 mm, skills/workcell.yaml; 0: rigid)",
        ),
    }


class GraspCapture(WorldEffectKind):
    name = "grasp_capture"
    acts_on = "world"
    summary = (
        "jaws closing off the centre of a wall further than the block can slide on its peg and the wrist's "
        "cable play yields still grip it when the rest is within `width`: the first jaw to touch is pushed "
        "aside against the wrist's cable compliance and the grip closes on the wall off the tip's centre"
    )
    parameters = {
        "width": Parameter(
            "m",
            0.0,
            0.003,
            0.0,
            "the wrist joints' deflection from their commands under cable load, 0.13–0.21 rad RMSE on q5 "
            "and q6 (the paper's Table I, shared/data/dvrk/README.md), on the 9.5 mm jaw: 1.2–2.0 mm; up "
            "to 0.3 rad, 3 mm (0: beyond the wrist's play the peg stops the block and the jaws miss)",
        ),
    }


class JawTipSlide(WorldEffectKind):
    name = "jaw_tip_slide"
    acts_on = "world"
    summary = (
        "an open jaw's tip that comes down on a wall's top within `width` of the edge it reached over "
        "slides back off the rounded edge beside the wall, so the jaws straddle it and close on it"
    )
    parameters = {
        "width": Parameter(
            "m",
            0.0,
            0.001,
            0.0,
            "the rounding of a jaw's tip (about 0.5 mm radius on the dVRK's 8 mm instruments' jaws, "
            "estimated) and of a printed wall's top edge (0.2–0.4 mm of FDM layers, estimated) (0: a tip "
            "on the wall's top stays there and the jaws miss)",
        ),
    }


class JawFriction(WorldEffectKind):
    name = "jaw_friction"
    acts_on = "world"
    summary = (
        "a gripped block slips out of the jaws when the load on the grip (its weight as the tip accelerates, "
        "and a bent peg's push) exceeds `max_load`, or the tip accelerates beyond `max_acceleration`"
    )
    parameters = {
        "max_load": Parameter(
            "N",
            0.001,
            100.0,
            100.0,
            f"the jaws' friction; a held block weighs {BLOCK_MASS * GRAVITY:.3f} N ({BLOCK_MASS * 1000:g} g: "
            "an FLS block's 1.6 cm³ of PLA)",
        ),
        "max_acceleration": Parameter(
            "m/s²",
            0.1,
            1000.0,
            1000.0,
            "the tip's acceleration (over 20 ms) the grip survives; the paper's planner limits (π rad/s² on "
            "q1, q2 at about 0.15 m) give about 0.5 m/s²",
        ),
    }


class RegistrationOffset(WorldEffectKind):
    name = "registration_offset"
    acts_on = "world"
    summary = (
        "camera-to-robot registration is off by (x, y, z) in the board frame: every target perception "
        "hands the robot is reached that far off it (the arms' bases stand off the work cell's figures; "
        "perception registers the board each trial, so an offset in the camera's view alone would cancel)"
    )
    parameters = {
        axis: Parameter(
            "m",
            -0.005,
            0.005,
            0.0,
            "a hand-eye registration error of a few millimetres (the reference geometry's figures are "
            "estimated to ±3 mm)",
        )
        for axis in ("x", "y", "z")
    }


class DepthBias(WorldEffectKind):
    name = "depth_bias"
    acts_on = "camera"
    summary = (
        "the camera measures the blocks and instruments `bias` farther along each ray than they are (light "
        "entering the printed plastic); the pegboard, which perception registers, is measured true"
    )
    parameters = {
        "bias": Parameter(
            "m",
            -0.003,
            0.003,
            0.0,
            "structured-light depth on translucent plastic: about 1 mm at 0.55 m; the camera's noise is "
            "0.3 mm (skills/workcell.yaml)",
        ),
    }


class PerceptionNoise(WorldEffectKind):
    name = "perception_noise"
    acts_on = "camera"
    summary = (
        "each view of a block finds it `sd` off in each of the board's x and y (a fresh draw for each place "
        "it stands, the same for a block that has not moved): the error of registering the block model to "
        "a real, partial cloud, which the simulated camera's independent depth noise averages away"
    )
    parameters = {
        "sd": Parameter(
            "m",
            0.0,
            0.001,
            0.0,
            "pegbt's own perception on the simulated camera errs 0.03-0.05 mm a look (whole trials' looks "
            "against the truth log); the paper never measured its robot's: ICP on the faces a Zivid cloud "
            "shows of a translucent block, 0.3 mm of depth noise a point (skills/workcell.yaml)",
        ),
    }


WORLD_EFFECT_KINDS: dict[str, WorldEffectKind] = {}


def register_world_effect(kind: WorldEffectKind) -> WorldEffectKind:
    """Add a kind (replacing one of the same name); its defaults must lie in its ranges."""
    for name, parameter in kind.parameters.items():
        if not parameter.low <= parameter.default <= parameter.high:
            raise PegbtError(f"{kind.name}.{name}: default {parameter.default} outside its range", field=name)
    WORLD_EFFECT_KINDS[kind.name] = kind
    return kind


for _kind in (
    PegCompliance(),
    ChamferCapture(),
    HoleLobes(),
    GripCompliance(),
    GraspCapture(),
    JawTipSlide(),
    JawFriction(),
    RegistrationOffset(),
    DepthBias(),
    PerceptionNoise(),
):
    register_world_effect(_kind)


def world_effect_kind(name: str) -> WorldEffectKind:
    """The registered kind called `name`."""
    try:
        return WORLD_EFFECT_KINDS[name]
    except KeyError:
        raise PegbtError(
            f"unknown world effect {name!r}; expected one of {', '.join(WORLD_EFFECT_KINDS)}", field="kind"
        ) from None


@dataclass(frozen=True)
class WorldEffect:
    """One configured effect: its kind and every parameter's value (defaults filled in)."""

    kind: str
    values: Mapping[str, float]

    def __post_init__(self) -> None:
        kind = world_effect_kind(self.kind)
        unknown = sorted(set(self.values) - set(kind.parameters))
        if unknown:
            raise PegbtError(
                f"{self.kind} has no parameter {unknown[0]!r}; expected {', '.join(kind.parameters)}",
                field=f"{self.kind}.{unknown[0]}",
            )
        values = {**kind.defaults(), **self.values}
        for name, value in values.items():
            low, high = kind.parameters[name].low, kind.parameters[name].high
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise PegbtError(f"expected a finite number, got {value!r}", field=f"{self.kind}.{name}")
            if not low <= value <= high:
                raise PegbtError(
                    f"expected a number in [{low:g}, {high:g}], got {value!r}", field=f"{self.kind}.{name}"
                )
        object.__setattr__(self, "values", {name: float(value) for name, value in values.items()})

    def __hash__(self) -> int:
        return hash((self.kind, tuple(self.values.items())))

    def sentence(self) -> str:
        return world_effect_kind(self.kind).sentence(self.values)

    def to_dict(self) -> dict[str, object]:
        """`{kind: NAME, PARAMETER: VALUE, ...}`, as a world file lists it."""
        return {"kind": self.kind, **self.values}


@dataclass(frozen=True)
class WorldEffects:
    """The effects a world runs with, at most one of each kind; empty: today's rigid world."""

    effects: tuple[WorldEffect, ...] = ()
    source: str = field(default="", compare=False)  # the world file read, for messages

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for effect in self.effects:
            if effect.kind in seen:
                raise PegbtError(f"{effect.kind} is listed twice", field="effects")
            seen.add(effect.kind)

    @classmethod
    def of(cls, effects: Mapping[str, Mapping[str, float]]) -> WorldEffects:
        """Effects from `{kind: {parameter: value}}` (missing parameters at their defaults)."""
        return cls(tuple(WorldEffect(kind, dict(values)) for kind, values in effects.items()))

    def __bool__(self) -> bool:
        return bool(self.effects)

    def __iter__(self) -> Iterator[WorldEffect]:
        return iter(self.effects)

    def has(self, kind: str) -> bool:
        return any(effect.kind == kind for effect in self.effects)

    def values(self, kind: str) -> dict[str, float]:
        """The parameters of `kind` as configured, or its inert defaults when it is not."""
        for effect in self.effects:
            if effect.kind == kind:
                return dict(effect.values)
        return world_effect_kind(kind).defaults()

    def to_dict(self) -> dict[str, object]:
        return {"effects": [effect.to_dict() for effect in self.effects]}


def read_world_file(path: Path) -> WorldEffects:
    """The effects a YAML world file lists (`effects:`, a list of `{kind: NAME, PARAMETER: VALUE}`); any
    error names the file, line, column and field."""
    document = read_settings_file(path)
    document.mapping(("effects",))
    entries = document["effects"]
    if entries.value is None:
        return WorldEffects(source=str(path))
    effects: list[WorldEffect] = []
    for entry in entries.sequence():
        effect = _read_effect(entry)
        if any(other.kind == effect.kind for other in effects):
            raise entry["kind"].error(f"{effect.kind} is listed twice; give each kind once")
        effects.append(effect)
    return WorldEffects(tuple(effects), source=str(path))


def _read_effect(entry: Located) -> WorldEffect:
    fields = entry.mapping()
    kind = world_effect_kind_at(entry["kind"])
    parameters = WORLD_EFFECT_KINDS[kind].parameters
    entry.mapping(("kind", *parameters))
    values = {
        name: value.number(low=parameters[name].low, high=parameters[name].high)
        for name, value in fields.items()
        if name != "kind"
    }
    return WorldEffect(kind, values)


def world_effect_kind_at(value: Located) -> str:
    """The kind named at `value` (a located error naming the known kinds if there is none)."""
    if value.value not in WORLD_EFFECT_KINDS:
        raise value.error(
            f"unknown world effect kind; expected one of {', '.join(WORLD_EFFECT_KINDS)}, got {value.value!r}"
        )
    return str(value.value)


def write_world_file(effects: WorldEffects, path: Path) -> Path:
    """Write `effects` as a world file `read_world_file` reads back; returns `path`."""
    header = "# pegbt world effects (pegbt sim --world-effects, pegbt eval --world-effects)\n"
    body = yaml.safe_dump(effects.to_dict(), sort_keys=False, default_flow_style=None)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(header + body)
    return path


def effects_listing() -> list[dict[str, object]]:
    """Every registered kind with its parameters' units, ranges and defaults (`pegbt sim2real outcomes
    --effects --json`)."""
    return [
        {
            "kind": kind.name,
            "acts_on": kind.acts_on,
            "summary": kind.summary,
            "parameters": {
                name: {
                    "unit": p.unit,
                    "low": p.low,
                    "high": p.high,
                    "default": p.default,
                    "source": p.source,
                }
                for name, p in kind.parameters.items()
            },
        }
        for kind in WORLD_EFFECT_KINDS.values()
    ]
