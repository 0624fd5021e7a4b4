"""Physics presets identified from recordings: one diagnosis per arm, its whole model written out."""

from __future__ import annotations

import json
from pathlib import Path

from pegbt.errors import PegbtError
from pegbt.physics.recording import load_recording
from pegbt.psm import ARMS
from pegbt.sim2real.diagnose import diagnose


def _rounded(value: object) -> object:
    return float(f"{value:.5g}") if isinstance(value, float) else value


def identify_preset(sources: dict[str, Path]) -> dict[str, list[dict]]:
    """Each arm's identified effects (diagnosed against the ideal arm) from its recording."""
    arms = {}
    for arm, path in sources.items():
        diagnosis = diagnose(load_recording(path), "ideal", arm, n_bootstrap=0)
        arms[arm] = [
            {**e.to_dict(), "params": {k: _rounded(v) for k, v in e.params.items()}}
            for e in diagnosis.physics.effects
        ]
    return arms


def parse_sources(pairs: list[str]) -> dict[str, Path]:
    """`ARM=RECORDING` pairs, as given on the command line."""
    sources = {}
    for pair in pairs:
        arm, sep, path = pair.partition("=")
        if not sep or arm not in ARMS:
            raise PegbtError(
                f"expected ARM=RECORDING with ARM one of {', '.join(ARMS)}, got {pair!r}", field="--from"
            )
        sources[arm] = Path(path)
    return sources


def write_preset(out: str | Path, sources: dict[str, Path], command: str) -> Path:
    """Identify each arm's effects from its recording and write them as a preset (`command` is quoted in its
    description, so the file says how to make it again); one effect per line, for readable diffs."""
    arms = identify_preset(sources)
    described = ", ".join(f"{arm} from {path.name}" for arm, path in sources.items())
    preset = {
        "description": f"Cable effects identified by `{command}` ({described}): every effect the diagnosis named "
        "against the ideal arm, with its fitted parameters. The recordings are settled set-points, so lag and "
        "delay are not identifiable from them and none is included.",
        "arms": arms,
    }
    out = Path(out)
    arm_lines = [
        f'    "{arm}": [\n' + ",\n".join(f"      {json.dumps(effect)}" for effect in effects) + "\n    ]"
        for arm, effects in arms.items()
    ]
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(
            '{\n  "description": '
            + json.dumps(preset["description"])
            + ',\n  "arms": {\n'
            + ",\n".join(arm_lines)
            + "\n  }\n}\n"
        )
    except OSError as error:
        raise PegbtError(f"cannot write the preset: {error.strerror}", file=out, field="--out") from None
    return out
