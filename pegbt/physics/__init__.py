"""The one arm-physics (cable) model: how a PSM's physical joints follow its commanded joints.

The simulator endpoint runs it to move the tool, the sim-to-real tool replays recordings through it
and names the effects it lacks, and calibration inverts it. One implementation, shared.
"""

from pegbt.physics.effects import EFFECT_KINDS, Effect, joint_index
from pegbt.physics.model import ArmPhysics

__all__ = ["EFFECT_KINDS", "Effect", "joint_index", "ArmPhysics"]
