"""The world-file campaign: a valid world file (every registered kind, values inside their ranges) with one
part mutated (a parameter's value made non-finite, huge, 5,000 digits long or just past its range; an unknown
kind or parameter; lines deleted, repeated, swapped or cut; bytes flipped; deep nesting), read as `pegbt sim
--world-effects` reads it (`read_world_file`). An accepted file holding a value outside its kind's declared
range, or not finite, counts as `absurd_accepted`; so does an accepted unknown kind or parameter."""

from __future__ import annotations

import math
import random
import re
from pathlib import Path

from pegbt.bench.fuzzing import SILENT, Tally, mutate_text

VALID = """\
# a world with every effect
effects:
  - {kind: peg_compliance, stiffness: 2900, deflection: 0.001}
  - {kind: chamfer_capture, capture_radius: 0.003}
  - kind: grip_compliance
    angle: 0.2
    displacement: 0.001
  - {kind: jaw_friction, max_load: 0.5, max_acceleration: 20}
  - {kind: registration_offset, x: 0.001, y: -0.0005, z: 0.0}
  - {kind: depth_bias, bias: 0.001}
"""
_VALUE = re.compile(r"(?<=: )-?\d+(?:\.\d+)?(?=[,}\n])")
OUT_OF_RANGE = (
    ".nan",
    ".inf",
    "-.inf",
    "1.0e+300",
    "-1.0e+300",
    "1" + "0" * 5000,
    "0x" + "f" * 5000,
    "1e999",
)
ODD = ("'0.001'", "true", "null", "[]", "{}", "0.0001")  # wrong types, or in range: refused or accepted


def _mutate(text: str, rng: random.Random) -> tuple[str, bool, str]:
    """(text, whether it was made absurd on purpose, what was done)."""
    from pegbt.sim.world_effects import WORLD_EFFECT_KINDS

    choice = rng.random()
    if choice < 0.4:
        match = rng.choice(list(_VALUE.finditer(text)))
        line = text[: match.start()].rsplit("\n", 1)[-1]
        name = re.findall(r"(\w+): $", line)[0]
        parameter = next(k.parameters[name] for k in WORLD_EFFECT_KINDS.values() if name in k.parameters)
        past = rng.choice([parameter.high * 1.01 + 1e-9, parameter.low - abs(parameter.low) * 0.01 - 1e-9])
        value = rng.choice((*OUT_OF_RANGE, *ODD, repr(past)))
        absurd = value in OUT_OF_RANGE or value == repr(past)
        return text[: match.start()] + value + text[match.end() :], absurd, f"{name}: {value[:14]}"
    if choice < 0.5:
        unknown = rng.choice(
            ["  - {kind: magnetism, strength: 1}\n", "  - {kind: depth_bias, bias: 0, gain: 2}\n"]
        )
        lines = text.splitlines(keepends=True)
        at = rng.randrange(2, len(lines) + 1)
        return "".join(lines[:at] + [unknown] + lines[at:]), True, f"{unknown.strip()} at line {at + 1}"
    return mutate_text(text, rng)


def _out_of_range(effects: object) -> bool:
    """Whether an accepted `WorldEffects` holds a value outside its declared range, or not finite."""
    from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects

    assert isinstance(effects, WorldEffects)
    for effect in effects:
        parameters = WORLD_EFFECT_KINDS[effect.kind].parameters
        for name, value in effect.values.items():
            low, high = parameters[name].low, parameters[name].high
            if not (math.isfinite(value) and low <= value <= high):
                return True
    return False


def fuzz_world_files(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.sim.world_effects import read_world_file

    tally = Tally()
    for n in range(count):
        good = n % 50 == 0
        text, absurd, what = (VALID, False, "unchanged") if good else _mutate(VALID, rng)
        path = work / f"world-{n}.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogateescape")

        def read(path: Path = path) -> object:
            return SILENT if _out_of_range(read_world_file(path)) else True

        tally.record(read, parsed=_parses(text), absurd=absurd, what=what, good=good)
        path.unlink()
    return tally


def _parses(text: str) -> bool:
    from pegbt.errors import PegbtError
    from pegbt.yamlfile import parse_yaml

    try:
        parse_yaml(text, "<fuzz>")
    except PegbtError:
        return False
    return True
