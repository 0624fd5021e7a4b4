"""Do two diagnoses of the same arm agree? In kind (which physics on which joint), and where not in value."""

from __future__ import annotations

from pegbt.physics import Effect

RELATIVE_DIFFERENCE = 0.25  # parameters further apart than this (relative) are reported as differing


def kind_key(effect: Effect) -> tuple[str, str, str]:
    """Effect family, joint, source: full and partial play on a joint's own drive are the same kind."""
    source = str(effect.params.get("source", effect.joint))
    family = effect.kind.family_name()
    return (family, effect.joint, source)


def describe(key: tuple[str, str, str]) -> str:
    family, joint, source = key
    if source != joint:
        return f"{family} {source}→{joint}"
    return f"{family} on {joint}"


def compare(first: list[Effect], second: list[Effect], names: tuple[str, str]) -> dict[str, object]:
    """Shared and unshared kinds of effect, and the parameters that differ between two diagnoses."""
    a = {kind_key(e): e for e in first}
    b = {kind_key(e): e for e in second}
    shared = sorted(set(a) & set(b))
    differences = []
    for key in shared:
        for name, value in a[key].params.items():
            other = b[key].params.get(name)
            if name == "source" or other is None:
                continue
            scale = max(abs(value), abs(other), 1e-12)
            if abs(value - other) > RELATIVE_DIFFERENCE * scale:
                differences.append(
                    f"{describe(key)} {name}: {value:.4g} ({names[0]}) vs {other:.4g} ({names[1]})"
                )
    union = set(a) | set(b)
    return {
        "agreement": len(shared) / max(len(union), 1),
        "shared": [describe(k) for k in shared],
        f"only_{names[0]}": [describe(k) for k in sorted(set(a) - set(b))],
        f"only_{names[1]}": [describe(k) for k in sorted(set(b) - set(a))],
        "differences": differences,
    }
