"""Cable effects between a commanded joint and the physical joint: `Effect` (plain data) and the
registry of effect kinds.

An `Effect` names one physical phenomenon on one joint with its parameters, in the same form as the
sim-to-real report (`{"effect": "coupling", "joint": "q5", "params": {"source": "q6", "k": 0.21}}`).
What an effect *does* belongs to its kind: a subclass of `EffectKind`, registered by name, that declares
its parameters, how it enters the arm's physics (its step and sequence kernels, its inverse for
compensation), the regressors sim-to-real searches for it, how a synthetic recording conceals it and
the sentence that explains it. The simulator, calibration and sim-to-real iterate the registry, so a new
effect is one class (`register(MyKind())`). The built-in kinds are in `pegbt.physics.kinds`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.psm import JOINT_NAMES

Array = NDArray[np.float64]

# Where a kind acts in the arm's chain, in order: the command as each joint sees it (delay), the linear
# static map (scale, coupling, offset), play in a drive added to the target (hysteresis), then per-joint
# transforms of the target: stateless ones ("target"), play that settled set-points keep ("play"), and
# dynamics that settle out between set-points ("output").
STAGES = ("delay", "linear", "drive", "target", "play", "output")
TRANSFORM_STAGES = ("target", "play", "output")
UNITS = {"q3": "m"}


class ArmParameters(Protocol):
    """What an effect kind may read and write on an arm's physics (`pegbt.physics.model.ArmPhysics`): the
    parameters of the structured stages, which `EffectKind.install` writes and `to_effect` reads back from
    the model sim-to-real searches against (its `base`), and the list of per-joint transforms a kind of a
    transform stage joins. Per joint, in `pegbt.psm.JOINT_NAMES` order; neutral values change nothing."""

    scale: Array  # (6,) static gain of each joint's command; neutral 1
    offset: Array  # (6,) added to each joint's target; rad (m for q3)
    coupling: Array  # (6, 6) coupling[j, s]: gain of source s's command into joint j
    half_width: Array  # (6,) half the backlash of each joint's own drive
    tau: Array  # (6,) first-order lag of each joint, s
    delay: Array  # (6,) transport delay of each joint's command, s
    hysteresis: list[tuple[int, int, float, float]]  # play in a drive: (joint, source, half_width, k)

    def add_transform(self, kind: EffectKind, effect: Effect) -> None:
        """Run `effect` as a per-joint transform of its kind's stage."""
        ...


def joint_unit(joint: str) -> str:
    """The unit a joint's values are in: metres for insertion, radians for the rest."""
    return UNITS.get(joint, "rad")


def joint_index(name: str | int) -> int:
    """0-based index of a joint given as `q1`..`q6` or as an index."""
    if isinstance(name, int) and 0 <= name < len(JOINT_NAMES):
        return name
    if isinstance(name, str) and name in JOINT_NAMES:
        return JOINT_NAMES.index(name)
    raise PegbtError(f"unknown joint {name!r}; expected one of {', '.join(JOINT_NAMES)}", field="joint")


class EffectKind:
    """One kind of cable effect. Subclasses set the class attributes and override what they need.

    Physics: a kind in a transform stage maps its joint's signal (`sequence` over a whole recording,
    `start`/`step` sample by sample, `inverse` for compensation on settled set-points); the kinds of
    the structured stages (delay, linear, drive) write their parameters into the arm in `install`.

    Sim-to-real: a candidate is a coefficient times a regressor column built from `signal` ("constant",
    "command": a joint's command, one per source for kinds that take one, or "driver": the joint's static
    target); kinds with a `width` parameter search it on a grid (`grid`: "play" widths scaled to the
    motion, or "time" widths) and compute the column in `column`; `gains` says whether it enters with a
    free coefficient (False), at unit gain (True) or either.
    """

    name: ClassVar[str]
    params: ClassVar[tuple[str, ...]]
    non_negative: ClassVar[frozenset[str]] = frozenset()
    stage: ClassVar[str] = "target"
    signal: ClassVar[str] = "driver"
    width: ClassVar[str | None] = None
    grid: ClassVar[str] = "play"
    gains: ClassVar[tuple[bool, ...]] = (True,)
    streams_only: ClassVar[bool] = False  # not identifiable on settled set-points (lag, delay)
    needs_reversals: ClassVar[bool] = False  # only a command that reverses can show it (play)
    family: ClassVar[str] = ""  # effects of one family describe the same physics (compare); default: name
    neutral: ClassVar[float] = 0.0  # the parameter value that changes nothing (scale: 1)

    @property
    def takes_source(self) -> bool:
        return "source" in self.params

    @property
    def is_intercept(self) -> bool:
        return self.signal == "constant"

    @property
    def is_linear(self) -> bool:
        """A coefficient on a command: it changes the joint's static target (its driver)."""
        return self.signal == "command" and self.width is None

    def family_name(self) -> str:
        return self.family or self.name

    # ------------------------------------------------------------------ data
    def check(self, effect: Effect) -> None:
        """Refuse parameter values the physics cannot take (beyond finite numbers and `non_negative`)."""

    def slot(self, effect: Effect) -> tuple[str, str, str, float]:
        """What the effect occupies in a model: one of each kind per joint (and per source, if it has one)."""
        return (effect.effect, effect.joint, str(effect.params.get("source", "")), 0.0)

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        """What the effect means physically, with its parameters, in one sentence (`before`: the same
        slot in the model it was found against)."""
        values = ", ".join(f"{k} = {v:.4g}" for k, v in effect.params.items() if k != "source")
        return f"{effect.joint} shows {self.name} ({values})"

    # ------------------------------------------------------------------ physics
    def install(self, arm: ArmParameters, effect: Effect) -> None:
        """Enter the effect into `arm`; transform stages are applied by `sequence` and `step`."""
        arm.add_transform(self, effect)

    def sequence(self, effect: Effect, x: Array, t: Array | None) -> Array:
        """The transformed signal (N,) of one joint; `t=None`: settled set-points."""
        raise NotImplementedError(f"{self.name} gives no sequence kernel")

    def sequence_from(
        self, effect: Effect, x: Array, t: Array | None, start: int, state: Any
    ) -> tuple[Array, Any]:
        """Rows start:start+len(x) of `sequence` over a whole recording (`t` its whole times), from the
        `state` the rows before left (None at row 0), and the state they leave: a replay a chunk at a
        time. This default suits a stateless kind (the target stage); a kind with state carries it."""
        return self.sequence(effect, x, None if t is None else t[start : start + len(x)]), state

    def start(self, effect: Effect, x: float) -> Any:
        """The kernel's state with the joint settled at input `x` (None for a stateless kind)."""
        return None

    def step(self, effect: Effect, state: Any, x: float, dt: float) -> tuple[float, Any]:
        """(output, next state) after `dt` seconds with the input at `x`."""
        return float(self.sequence(effect, np.array([x]), None)[0]), state

    def inverse(self, effect: Effect, y: float, state: Any, previous: float) -> float:
        """The input after which a settled `step` outputs `y` (`previous`: the last input)."""
        raise NotImplementedError(f"{self.name} cannot be inverted")

    # ------------------------------------------------------------------ sim-to-real
    def column(self, signal: Array, t: Array | None, width: float) -> Array:
        """The regressor column of a width candidate: what the effect adds to the signal at this width."""
        raise NotImplementedError(f"{self.name} has no width column")

    def columns(self, signal: Array, t: Array | None, widths: Array) -> Array:
        """The columns (N, G) of a grid of widths."""
        return np.column_stack([self.column(signal, t, float(w)) for w in widths])

    def column_blocks(
        self, signal: Array, t: Array | None, widths: Array, edges: Sequence[int]
    ) -> Iterator[Array]:
        """`columns` block by block (rows edges[k]:edges[k+1]), in order, so that a long recording's bank
        is never held whole. A kind whose kernel keeps state carries it across each boundary (the
        built-ins do); this default computes the columns whole and slices them."""
        whole = self.columns(signal, t, widths)
        for a, b in zip(edges[:-1], edges[1:]):
            yield whole[a:b]

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        """The effect a fitted candidate stands for, merged with the base model's effect in its slot."""
        params: dict[str, Any] = {}
        if self.takes_source:
            params["source"] = JOINT_NAMES[source]
        if self.width is not None:
            params[self.width] = float(width)
        for name in self.params:
            if name not in params:
                params[name] = float(coef)
        return Effect(self.name, JOINT_NAMES[joint], params)

    def term(self, effect: Effect) -> tuple[str, int, float, bool]:
        """(candidate kind, source index, width, fixed) of the fit structure that names this effect."""
        source = joint_index(effect.params["source"]) if self.takes_source else effect.index
        width = float(effect.params[self.width]) if self.width else float("nan")
        return self.name, source, width, self.width is not None and self.signal == "driver"

    def candidate_key(self, effect: Effect) -> tuple[str, int, int]:
        """The candidate this effect of a base model occupies (so it is not searched again)."""
        return self.term(effect)[0], effect.index, self.term(effect)[1]

    # ------------------------------------------------------------------ synthetic recordings
    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        """An effect of this kind with parameters in the range a cable-driven arm shows."""
        raise NotImplementedError(f"{self.name} cannot be synthesised")

    def resized(self, effect: Effect, ratio: float) -> Effect | None:
        """The effect with its contribution scaled by `ratio`, if that is linear in a parameter; else
        None and its `width` is searched instead, up to `largest`."""
        return None

    def largest(self, q_cmd: Array, joint: int) -> float:
        """The largest width a synthetic recording may give it."""
        return 0.5


_REGISTRY: dict[str, EffectKind] = {}


def register(kind: EffectKind) -> EffectKind:
    """Add a kind to the registry (replacing one of the same name); the simulator, calibration and
    sim-to-real know it from then on."""
    if kind.stage not in STAGES:
        raise PegbtError(f"effect kind {kind.name!r} has unknown stage {kind.stage!r}", field="stage")
    _REGISTRY[kind.name] = kind
    return kind


def unregister(name: str) -> None:
    _REGISTRY.pop(name, None)


@contextmanager
def registered(kind: EffectKind) -> Iterator[EffectKind]:
    """The kind registered for the duration of a block (tests, experiments)."""
    previous = _REGISTRY.get(kind.name)
    register(kind)
    try:
        yield kind
    finally:
        if previous is None:
            unregister(kind.name)
        else:
            register(previous)


def kind_of(name: str) -> EffectKind:
    """The registered kind called `name`."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise PegbtError(
            f"unknown effect {name!r}; expected one of {', '.join(_REGISTRY)}", field="effect"
        ) from None


def effect_kinds() -> tuple[EffectKind, ...]:
    """Every registered kind, in registration order."""
    return tuple(_REGISTRY.values())


@dataclass(frozen=True)
class Effect:
    """One cable effect on one joint."""

    effect: str
    joint: str
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        kind = kind_of(self.effect)
        joint_index(self.joint)
        expected = set(kind.params)
        if set(self.params) != expected:
            raise PegbtError(
                f"{self.effect} on {self.joint} takes parameters {sorted(expected)}, got {sorted(self.params)}",
                field="params",
            )
        for name, value in self.params.items():
            if name == "source":
                joint_index(value)
                continue
            if not isinstance(value, (int, float)) or value != value or abs(value) == float("inf"):
                raise PegbtError(f"{self.effect}.{name} on {self.joint} must be a finite number", field=name)
            if name in kind.non_negative and value < 0:
                raise PegbtError(
                    f"{self.effect}.{name} on {self.joint} must be >= 0, got {value}", field=name
                )
        kind.check(self)

    @property
    def kind(self) -> EffectKind:
        return kind_of(self.effect)

    @property
    def index(self) -> int:
        return joint_index(self.joint)

    @property
    def slot(self) -> tuple[str, str, str, float]:
        return self.kind.slot(self)

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "joint": self.joint, "params": dict(self.params)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Effect:
        """Read an effect from its report / preset form; extra keys (ci, text, ...) are ignored."""
        if not isinstance(data, Mapping):
            raise PegbtError(f"an effect entry is an object with effect, joint and params; got {data!r}")
        params = data.get("params", {})
        if not isinstance(params, Mapping):
            raise PegbtError(f"params is an object of parameter values; got {params!r}", field="params")
        try:
            return cls(str(data["effect"]), str(data["joint"]), dict(params))
        except KeyError as missing:
            raise PegbtError(f"effect entry lacks {missing.args[0]!r}", field=str(missing.args[0])) from None
