"""The `physics` model: named cable effects (`ArmPhysics`), inverted analytically.

On settled set-points an arm's physics is a static map m = A·q + o (scale, coupling, offset), then
backlash: the physical joint stays at y until m has moved half_width h past it. Both invert exactly:
to reach q_d from the current output y, the map must land at q_d + h when moving up, q_d − h when
moving down, and stay where it was when q_d = y; then q_c = A⁻¹(m − o). Backlash does not depend on
rate, so the state advances on every issued command, 10 ms step or set-point alike. Lag and delay
(if the effects name them) have died out at a set-point and are not modelled here.
"""

from __future__ import annotations

from collections.abc import Iterable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.identify import identify_effects
from pegbt.calibration.modelfile import ModelMetadata
from pegbt.errors import PegbtError
from pegbt.physics import JOINT_NAMES, ArmPhysics, Effect

PhysicsState = tuple[NDArray[np.float64], NDArray[np.float64]]  # (physical joints y, static-map target m)


class ArmInverse:
    """Forward and exact inverse of an `ArmPhysics` on set-points, one command at a time."""

    def __init__(self, physics: ArmPhysics) -> None:
        self.physics = physics
        self.matrix = np.diag(physics.scale) + physics.coupling
        if abs(np.linalg.det(self.matrix)) < 1e-6:
            raise PegbtError("the effects' scale and coupling cannot be inverted (singular map)", field="effects")
        self.matrix_inverse = np.linalg.inv(self.matrix)
        self.half_width = physics.half_width

    def settle(self, q: NDArray[np.float64]) -> PhysicsState:
        target = self.physics.static_map(q)
        return target.copy(), target

    def forward(self, q_c: NDArray[np.float64], state: PhysicsState) -> NDArray[np.float64]:
        played, _ = state
        target = self.physics.static_map(q_c)
        return np.clip(played, target - self.half_width, target + self.half_width)

    def advance(self, state: PhysicsState, q_issued: NDArray[np.float64]) -> PhysicsState:
        return self.forward(q_issued, state), self.physics.static_map(q_issued)

    def inverse(self, q_d: NDArray[np.float64], state: PhysicsState) -> NDArray[np.float64]:
        played, previous_target = state
        target = np.where(
            q_d > played, q_d + self.half_width, np.where(q_d < played, q_d - self.half_width, previous_target)
        )
        return self.matrix_inverse @ (target - self.physics.offset)


class PhysicsModel(CalibrationModel):
    """Explicit cable effects: offset, scale, coupling and backlash per joint."""

    kind = "physics"
    outputs = tuple(range(len(JOINT_NAMES)))  # effects may act on any joint; none means identity

    def __init__(self, arm: str) -> None:
        super().__init__(arm)
        self.effects: tuple[Effect, ...] = ()
        self.arm_inverse = ArmInverse(ArmPhysics())

    @classmethod
    def from_effects(cls, arm: str, effects: Iterable[Effect], source: str) -> "PhysicsModel":
        """A model from effects identified elsewhere (a sim-to-real report, a preset); `source` names them."""
        model = cls(arm)
        model._set_effects(effects)
        model.metadata = ModelMetadata(
            kind=cls.kind, arm=arm, outputs=JOINT_NAMES,
            training={"effects_from": source, "created": datetime.now(timezone.utc).isoformat(timespec="seconds")},
        )
        return model

    def _set_effects(self, effects: Iterable[Effect]) -> None:
        self.effects = tuple(effects)
        self.arm_inverse = ArmInverse(ArmPhysics(self.effects))

    def _fit(self, q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> None:
        self._set_effects(identify_effects(q_cmd, q_phy))

    def _predict(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.arm_inverse.physics.simulate(q_cmd)

    def initial_state(self, q: NDArray[np.float64]) -> PhysicsState:
        return self.arm_inverse.settle(q)

    def forward(self, q_c: NDArray[np.float64], state: PhysicsState) -> NDArray[np.float64]:
        return self.arm_inverse.forward(q_c, state)

    def advance(self, state: PhysicsState, q_issued: NDArray[np.float64]) -> PhysicsState:
        return self.arm_inverse.advance(state, q_issued)

    def command_for(self, target: NDArray[np.float64], state: PhysicsState) -> NDArray[np.float64]:
        return self.arm_inverse.inverse(target, state)

    def _body(self) -> dict[str, Any]:
        return {"settings": {}, "effects": [effect.to_dict() for effect in self.effects]}

    def _restore(self, document: dict[str, Any], path: Path) -> None:
        try:
            self._set_effects(Effect.from_dict(entry) for entry in document["effects"])
        except PegbtError as error:
            raise PegbtError(error.message, file=path, field=error.field) from None
