"""The built-in cable effects, one class each, registered on import.

- `offset` {value}: physical = command + value (rad or m).
- `scale` {value}: physical = value × command.
- `coupling` {source, k}: physical += k × the source joint's command (cables routed past each other).
- `hysteresis` {source, half_width, k}: physical += k × (play(x, half_width) − x), x the source's
  command: play in one joint's drive that shows, scaled by k, in this joint. With source = the joint
  itself, x is the joint's static target (the input its backlash sees) and k ≠ 1 is play of which only
  part reaches the joint (k = 1 is backlash). Found on the real dVRK wrist, where q6's cable play moves
  q5 about as much as q6.
- `backlash` {half_width}: play; the output stays until the input has moved half_width past it.
- `lag` {tau}: first-order response with time constant tau (s).
- `delay` {seconds}: pure transport delay of the command.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from pegbt.errors import PegbtError
from pegbt.physics.effects import ArmParameters, Array, Effect, EffectKind, joint_index, joint_unit, register
from pegbt.physics.kernels import (
    delay_blocks,
    delay_series,
    lag_blocks,
    lag_chunk,
    lag_series,
    play_blocks,
    play_grid,
)
from pegbt.psm import JOINT_NAMES

EXACT = 1e-12  # rad or m: below this a joint counts as not moving
MAX_BACKLASH_FRACTION = 0.15  # of the joint's range: more play than this and the joint hardly moves


def unit_ratio(joint: int, source: int) -> float:
    """How a rad-sized coefficient scales between joints of different units (q3 is in metres)."""
    return (0.01 if joint == 2 else 1.0) / (0.01 if source == 2 else 1.0)


def _size(joint: int) -> float:
    return 0.01 if joint == 2 else 1.0  # q3 moves in metres


def _sign(rng: np.random.Generator) -> float:
    return float(rng.choice([-1.0, 1.0]))


class PlayKind(EffectKind):
    """Kinds whose regressor is play on a signal minus the signal (they share columns on one signal)."""

    def column(self, signal: Array, t: Array | None, width: float) -> Array:
        return play_grid(signal, width)[:, 0] - signal

    def columns(self, signal: Array, t: Array | None, widths: Array) -> Array:
        return play_grid(signal, widths) - signal[:, None]

    def column_blocks(
        self, signal: Array, t: Array | None, widths: Array, edges: Sequence[int]
    ) -> Iterator[Array]:
        for (a, b), play in zip(zip(edges[:-1], edges[1:]), play_blocks(signal, widths, edges)):
            yield play - signal[a:b, None]


class Offset(EffectKind):
    name = "offset"
    params = ("value",)
    stage = "linear"
    signal = "constant"
    gains = (False,)

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        arm.offset[effect.index] = effect.params["value"]

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        return Effect("offset", JOINT_NAMES[joint], {"value": float(base.offset[joint] + coef)})

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        j, u, value = effect.joint, joint_unit(effect.joint), effect.params["value"]
        base_value = float(before.params["value"]) if before else 0.0
        change = (
            ""
            if not base_value
            else f" ({value - base_value:+.4g} {u} from the simulator's {base_value:.4g})"
        )
        return (
            f"{j} sits {value:+.4g} {u} from its command wherever it goes{change}: a constant offset "
            "(the joint was homed or zeroed elsewhere)"
        )

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        return Effect(
            "offset", JOINT_NAMES[joint], {"value": _sign(rng) * _size(joint) * rng.uniform(0.01, 0.2)}
        )

    def resized(self, effect: Effect, ratio: float) -> Effect:
        return Effect("offset", effect.joint, {"value": effect.params["value"] * ratio})


class Scale(EffectKind):
    name = "scale"
    params = ("value",)
    neutral = 1.0
    stage = "linear"
    signal = "command"
    gains = (False,)

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        arm.scale[effect.index] = effect.params["value"]

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        return Effect("scale", JOINT_NAMES[joint], {"value": float(base.scale[joint] + coef)})

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        return (
            f"{effect.joint} moves {effect.params['value']:.3f}× as far as commanded: a scale error (cable "
            "stretch or a wrong transmission ratio)"
        )

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        return Effect("scale", JOINT_NAMES[joint], {"value": 1.0 + _sign(rng) * rng.uniform(0.02, 0.2)})

    def resized(self, effect: Effect, ratio: float) -> Effect:
        return Effect("scale", effect.joint, {"value": 1.0 + (effect.params["value"] - 1.0) * ratio})


class Coupling(EffectKind):
    name = "coupling"
    params = ("source", "k")
    stage = "linear"
    signal = "command"
    gains = (False,)

    def check(self, effect: Effect) -> None:
        if joint_index(effect.params["source"]) == effect.index:
            raise PegbtError(f"coupling on {effect.joint} cannot take itself as source", field="source")

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        arm.coupling[effect.index, joint_index(effect.params["source"])] = effect.params["k"]

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        return Effect(
            "coupling",
            JOINT_NAMES[joint],
            {"source": JOINT_NAMES[source], "k": float(base.coupling[joint, source] + coef)},
        )

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        j, s, k = effect.joint, effect.params["source"], effect.params["k"]
        return (
            f"{j} follows the {s} command with k = {k:.3g}: the {j} and {s} cables are coupled, so "
            f"commanding {s} alone also moves {j}"
        )

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        k = _sign(rng) * unit_ratio(joint, source) * rng.uniform(0.02, 0.3)
        return Effect("coupling", JOINT_NAMES[joint], {"source": JOINT_NAMES[source], "k": k})

    def resized(self, effect: Effect, ratio: float) -> Effect:
        return Effect("coupling", effect.joint, {**effect.params, "k": effect.params["k"] * ratio})


class Backlash(PlayKind):
    name = "backlash"
    params = ("half_width",)
    non_negative = frozenset({"half_width"})
    stage = "play"
    width = "half_width"
    gains = (False, True)  # full play, or play of which only part reaches the joint
    needs_reversals = True
    family = "play"

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        arm.half_width[effect.index] = effect.params["half_width"]
        arm.add_transform(self, effect)

    def sequence(self, effect: Effect, x: Array, t: Array | None) -> Array:
        return play_grid(x, effect.params["half_width"], x[0])[:, 0]

    def sequence_from(
        self, effect: Effect, x: Array, t: Array | None, start: int, state: Any
    ) -> tuple[Array, Any]:
        y = play_grid(x, effect.params["half_width"], x[0] if state is None else state)[:, 0]
        return y, y[-1]

    def start(self, effect: Effect, x: float) -> float:
        return x

    def step(self, effect: Effect, state: Any, x: float, dt: float) -> tuple[float, Any]:
        h = effect.params["half_width"]
        y = min(max(state, x - h), x + h)
        return y, y

    def inverse(self, effect: Effect, y: float, state: Any, previous: float) -> float:
        h = effect.params["half_width"]
        if y > state + EXACT:
            return y + h
        if y < state - EXACT:
            return y - h
        return min(max(previous, y - h), y + h)

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        name = JOINT_NAMES[joint]
        if fixed:
            return Effect("backlash", name, {"half_width": float(width)})
        return Effect("hysteresis", name, {"source": name, "half_width": float(width), "k": float(coef)})

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        j, u = effect.joint, joint_unit(effect.joint)
        return (
            f"after a reversal {j} stays put until its command has moved {effect.params['half_width']:.3g} "
            f"{u} past it: backlash (play) in its drive"
        )

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        _sign(rng)
        return Effect("backlash", JOINT_NAMES[joint], {"half_width": _size(joint) * rng.uniform(0.005, 0.05)})

    def largest(self, q_cmd: Array, joint: int) -> float:
        return MAX_BACKLASH_FRACTION * float(np.ptp(q_cmd[:, joint]))


class Hysteresis(PlayKind):
    name = "hysteresis"
    params = ("source", "half_width", "k")
    non_negative = frozenset({"half_width"})
    stage = "drive"
    signal = "command"
    width = "half_width"
    gains = (False,)
    needs_reversals = True
    family = "play"

    def slot(self, effect: Effect) -> tuple[str, str, str, float]:
        """One per source and play width: several widths from the same drive add up to a hysteresis loop
        of any shape, as in a Prandtl–Ishlinskii operator."""
        return (self.name, effect.joint, str(effect.params["source"]), float(effect.params["half_width"]))

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        p = effect.params
        arm.hysteresis.append((effect.index, joint_index(p["source"]), float(p["half_width"]), float(p["k"])))

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        params = {"source": JOINT_NAMES[source], "half_width": float(width), "k": float(coef)}
        return Effect("hysteresis", JOINT_NAMES[joint], params)

    def term(self, effect: Effect) -> tuple[str, int, float, bool]:
        source = joint_index(effect.params["source"])
        own = source == effect.index
        return ("backlash" if own else "hysteresis"), source, float(effect.params["half_width"]), False

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        j, p, u = effect.joint, effect.params, joint_unit(effect.joint)
        s = p["source"]
        shift = abs(p["k"]) * p["half_width"]
        if s == j:
            return (
                f"{j} lags its own reversals by up to ±{shift:.3g} {u}: play of half-width "
                f"{p['half_width']:.3g} {u} in its drive of which only k = {p['k']:.2f} reaches the joint "
                "(hysteresis)"
            )
        return (
            f"{j} shifts by up to ±{shift:.3g} {u} depending on which way {s} last moved: play of "
            f"half-width {p['half_width']:.3g} {joint_unit(s)} in the {s} drive shows in {j} with "
            f"k = {p['k']:.3g} (hysteresis through coupled cables)"
        )

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        sign = _sign(rng)
        half_width = float(rng.uniform(0.03, 0.1) * np.ptp(q_cmd[:, source]))
        k = sign * unit_ratio(joint, source) * rng.uniform(0.1, 0.8)
        return Effect(
            "hysteresis",
            JOINT_NAMES[joint],
            {"source": JOINT_NAMES[source], "half_width": half_width, "k": k},
        )

    def resized(self, effect: Effect, ratio: float) -> Effect:
        return Effect("hysteresis", effect.joint, {**effect.params, "k": effect.params["k"] * ratio})


class Lag(EffectKind):
    name = "lag"
    params = ("tau",)
    non_negative = frozenset({"tau"})
    stage = "output"
    width = "tau"
    grid = "time"
    streams_only = True

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        arm.tau[effect.index] = effect.params["tau"]
        arm.add_transform(self, effect)

    def sequence(self, effect: Effect, x: Array, t: Array | None) -> Array:
        return x.copy() if t is None else lag_series(x, t, float(effect.params["tau"]))

    def sequence_from(
        self, effect: Effect, x: Array, t: Array | None, start: int, state: Any
    ) -> tuple[Array, Any]:
        return (x.copy(), state) if t is None else lag_chunk(x, t, start, float(effect.params["tau"]), state)

    def start(self, effect: Effect, x: float) -> float:
        return x

    def step(self, effect: Effect, state: Any, x: float, dt: float) -> tuple[float, Any]:
        tau = effect.params["tau"]
        alpha = 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0
        y = state + alpha * (x - state)
        return y, y

    def inverse(self, effect: Effect, y: float, state: Any, previous: float) -> float:
        return y  # settled: the lag has died out

    def column(self, signal: Array, t: Array | None, width: float) -> Array:
        assert t is not None, "lag needs sample times"
        return lag_series(signal, t, width) - signal

    def column_blocks(
        self, signal: Array, t: Array | None, widths: Array, edges: Sequence[int]
    ) -> Iterator[Array]:
        assert t is not None, "lag needs sample times"
        lagged = [lag_blocks(signal, t, float(w), edges) for w in widths]
        for a, b in zip(edges[:-1], edges[1:]):
            yield np.column_stack([next(each) for each in lagged]) - signal[a:b, None]

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        return (
            f"{effect.joint} trails its command like a first-order system with time constant "
            f"{effect.params['tau'] * 1e3:.0f} ms: lag"
        )

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        _sign(rng)
        return Effect("lag", JOINT_NAMES[joint], {"tau": rng.uniform(0.02, 0.1)})


class Delay(EffectKind):
    name = "delay"
    params = ("seconds",)
    non_negative = frozenset({"seconds"})
    stage = "delay"
    width = "seconds"
    grid = "time"
    streams_only = True

    def install(self, arm: ArmParameters, effect: Effect) -> None:
        arm.delay[effect.index] = effect.params["seconds"]

    def column(self, signal: Array, t: Array | None, width: float) -> Array:
        assert t is not None, "delay needs sample times"
        return delay_series(signal, t, width) - signal

    def column_blocks(
        self, signal: Array, t: Array | None, widths: Array, edges: Sequence[int]
    ) -> Iterator[Array]:
        assert t is not None, "delay needs sample times"
        delayed = [delay_blocks(signal, t, float(w), edges) for w in widths]
        for a, b in zip(edges[:-1], edges[1:]):
            yield np.column_stack([next(each) for each in delayed]) - signal[a:b, None]

    def to_effect(
        self, joint: int, source: int, width: float, coef: float, fixed: bool, base: ArmParameters
    ) -> Effect:
        return Effect("delay", JOINT_NAMES[joint], {"seconds": float(base.delay[joint] + width)})

    def sentence(self, effect: Effect, before: Effect | None = None) -> str:
        return f"{effect.joint} repeats its command {effect.params['seconds'] * 1e3:.0f} ms late: a transport delay"

    def plausible(self, joint: int, source: int, q_cmd: Array, rng: np.random.Generator) -> Effect:
        _sign(rng)
        return Effect("delay", JOINT_NAMES[joint], {"seconds": rng.uniform(0.01, 0.05)})


for _kind in (Offset(), Scale(), Coupling(), Backlash(), Hysteresis(), Lag(), Delay()):
    register(_kind)
