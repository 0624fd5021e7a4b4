"""The one arm-physics (cable) model: how a PSM's physical joints follow its commanded joints.

The simulator endpoint runs it to move the tool, the sim-to-real tool replays recordings through it
and names the effects it lacks, and calibration inverts it. One implementation, shared.
"""

from pegbt.physics import kinds as _kinds  # noqa: F401  (registers the built-in effect kinds)
from pegbt.physics.effects import (
    ArmParameters,
    Effect,
    EffectKind,
    effect_kinds,
    joint_index,
    kind_of,
    register,
    registered,
)
from pegbt.physics.model import ArmPhysics

__all__ = [
    "ArmParameters",
    "Effect",
    "EffectKind",
    "effect_kinds",
    "joint_index",
    "kind_of",
    "register",
    "registered",
    "ArmPhysics",
]
