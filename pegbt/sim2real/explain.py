"""Sentences a person understands, for named effects, regimes and what remains."""

from __future__ import annotations

from pegbt.physics import Effect
from pegbt.physics.effects import joint_unit
from pegbt.sim2real.locate import JointMismatch


def unit(joint: str) -> str:
    return joint_unit(joint)


def effect_sentence(effect: Effect, before: Effect | None = None) -> str:
    """What the effect means physically, with its parameters, in one sentence (its kind's sentence;
    `before`: the same slot in the model it was found against)."""
    return effect.kind.sentence(effect, before)


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
