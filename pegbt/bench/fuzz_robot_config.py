"""The `--robot-config` reader's campaign: a dVRK `share/` folder (its `kinematic/PSM.json` and the large
needle driver's tool file, JSON with comments) with one file mutated, read as `pegbt run --robot-config` and
`pegbt sim2real diagnose --robot-config` read it. A joint limit made non-finite or beyond any arm's (1e300,
a limit in degrees or millimetres) that is accepted counts as `absurd_accepted`."""

from __future__ import annotations

import random
import re
import shutil
from pathlib import Path

from pegbt.bench.fuzzing import Tally, mutate_text

SHARE = Path(__file__).resolve().parents[2] / "tests" / "data" / "dvrk-share"
FILES = ("kinematic/PSM.json", "tool/LARGE_NEEDLE_DRIVER_400006.json")
_LIMIT = re.compile(r'(?<="q(?:min|max)": )-?\d+(?:\.\d+)?')
ABSURD = ("NaN", "Infinity", "-Infinity", "1e300", "-1e999", "57.3", "-260", "240")
ODD = ('"0.5"', "true", "null", "[]", "{}", "0x" + "f" * 5000, "1e-300")


def _mutate(text: str, rng: random.Random) -> tuple[str, bool, str]:
    """(text, whether a joint limit was made absurd, what was done)."""
    limits = list(_LIMIT.finditer(text))
    if limits and rng.random() < 0.5:
        match = rng.choice(limits)
        value = rng.choice(ABSURD + ODD)
        return (
            text[: match.start()] + value + text[match.end() :],
            value in ABSURD,
            f"{match.group()} -> {value[:12]}",
        )
    return mutate_text(text, rng)


def fuzz_robot_config(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.motion.robot_config import robot_arm_settings, robot_limits

    texts = {name: (SHARE / name).read_text() for name in FILES}
    tally = Tally()
    for n in range(count):
        share = work / f"share-{n}"
        shutil.copytree(SHARE, share)
        name = rng.choice(FILES)
        text, absurd, what = _mutate(texts[name], rng)
        (share / name).write_text(text, encoding="utf-8", errors="surrogateescape")

        def read(share: Path = share) -> bool:
            robot_limits(share)
            robot_arm_settings("PSM1", share)
            return True

        tally.record(read, parsed=_parses(text), absurd=absurd, what=f"{name}: {what}")
        shutil.rmtree(share)
    return tally


def _parses(text: str) -> bool:
    import json5

    try:
        json5.loads(text)
    except (ValueError, RecursionError):
        return False
    return True
