"""`pegbt sim2real outcomes --effects`: the registered world effects, their parameters, units and ranges."""

from __future__ import annotations

import json

from pegbt.sim.world_effects import effects_listing


def listing_json() -> str:
    """The listing as JSON: a list of `{kind, parameters: {name: {unit, low, high, default, ...}}, ...}`."""
    return json.dumps(effects_listing(), indent=2)


def listing_text() -> str:
    """The listing for a person: each kind, what it does, and a line per parameter."""
    lines = []
    for kind in effects_listing():
        lines.append(f"{kind['kind']} ({kind['acts_on']}): {kind['summary']}")
        parameters = kind["parameters"]
        assert isinstance(parameters, dict)  # effects_listing builds it so
        for name, p in parameters.items():
            lines.append(
                f"  {name}: {p['unit']} in [{p['low']:g}, {p['high']:g}], default {p['default']:g} "
                f"(inert); source: {p['source']}"
            )
    return "\n".join(lines)
