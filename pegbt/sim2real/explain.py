"""Sentences a person understands, for named effects, regimes and what remains."""

from __future__ import annotations

from pegbt.physics import Effect
from pegbt.sim2real.locate import JointMismatch

UNITS = {"q3": "m"}


def unit(joint: str) -> str:
    return UNITS.get(joint, "rad")


def effect_sentence(effect: Effect, base_value: float | None = None) -> str:
    """What the effect means physically, with its parameters, in one sentence."""
    j, p, u = effect.joint, effect.params, unit(effect.joint)
    kind = effect.effect
    if kind == "offset":
        change = (
            ""
            if not base_value
            else f" ({p['value'] - base_value:+.4g} {u} from the simulator's {base_value:.4g})"
        )
        return (
            f"{j} sits {p['value']:+.4g} {u} from its command wherever it goes{change}: a constant offset "
            "(the joint was homed or zeroed elsewhere)"
        )
    if kind == "scale":
        return (
            f"{j} moves {p['value']:.3f}× as far as commanded: a scale error (cable stretch or a wrong "
            "transmission ratio)"
        )
    if kind == "coupling":
        s = p["source"]
        return (
            f"{j} follows the {s} command with k = {p['k']:.3g}: the {j} and {s} cables are coupled, so "
            f"commanding {s} alone also moves {j}"
        )
    if kind == "backlash":
        return (
            f"after a reversal {j} stays put until its command has moved {p['half_width']:.3g} {u} past it: "
            "backlash (play) in its drive"
        )
    if kind == "hysteresis":
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
            f"half-width {p['half_width']:.3g} {unit(s)} in the {s} drive shows in {j} with k = {p['k']:.3g} "
            "(hysteresis through coupled cables)"
        )
    if kind == "lag":
        return f"{j} trails its command like a first-order system with time constant {p['tau'] * 1e3:.0f} ms: lag"
    return f"{j} repeats its command {p['seconds'] * 1e3:.0f} ms late: a transport delay"


def rival_sentence(label: str, rival: str) -> str:
    return (
        f"{label} or {rival}: not separable with these data (they explain nearly as much and neither wins in "
        f"every held-out segment); the model keeps {label}"
    )


NOTABLE_WINDOW = 0.1  # a window holding this share of what remains is worth naming


def remaining_sentence(left: JointMismatch, rmse_after: float, rmse_before: float, time_unit: str) -> str:
    """What the model leaves unexplained on one joint, and where it concentrates."""
    joint = left.joint
    share = 100 * (rmse_after / rmse_before) ** 2 if rmse_before > 0 else 0.0
    text = f"{joint}: {rmse_after:.3g} {unit(joint)} RMSE remains held out ({share:.0f} % of the squared error before)"
    where = []
    if left.windows and left.windows[0][2] >= NOTABLE_WINDOW:
        t0, t1, part = left.windows[0]
        where.append(f"{100 * part:.0f} % of it in {t0:.4g}–{t1:.4g} {time_unit}")
    larger = [regime for regime in left.regimes if regime.rmse_in > regime.rmse_out]
    if larger:
        regime = larger[0]
        where.append(
            f"it is largest {regime.regime} (RMSE {regime.rmse_in:.3g} there against {regime.rmse_out:.3g})"
        )
    return "; ".join([text] + where)
