"""The `physics` model: named cable effects (`ArmPhysics`), inverted analytically where they can be.

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

# (physical joints y, target m, play of each hysteresis drive, hysteresis terms of the last command)
PhysicsState = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


class ArmInverse:
    """Forward and inverse of an `ArmPhysics` on set-points, one command at a time.

    Static map and backlash invert exactly. Hysteresis terms (a drive's play: they depend on which way
    the drive last moved) are taken as they stand after the last command; Alg. 1's iterations correct
    what moving changes of them."""

    def __init__(self, physics: ArmPhysics) -> None:
        self.physics = physics
        self.matrix = np.diag(physics.scale) + physics.coupling
        if abs(np.linalg.det(self.matrix)) < 1e-6:
            raise PegbtError("the effects' scale and coupling cannot be inverted (singular map)", field="effects")
        self.matrix_inverse = np.linalg.inv(self.matrix)
        self.half_width = physics.half_width
        table = np.array(physics.hysteresis, dtype=float).reshape(-1, 4)  # (joint, source, half_width, k) per drive
        self._joints, self._sources = table[:, 0].astype(int), table[:, 1].astype(int)
        self._own = self._joints == self._sources  # a joint's own hysteresis is driven by its static target
        self._widths, self._gains = table[:, 2], table[:, 3]

    def _seen(self, q_c: NDArray[np.float64], static: NDArray[np.float64]) -> NDArray[np.float64]:
        """What each hysteresis drive sees: its source's command, or its joint's static target."""
        return np.where(self._own, static[self._joints], q_c[self._sources])

    def _target(self, q_c: NDArray[np.float64], plays: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """(target, new drive plays, hysteresis terms) of command `q_c`, as `ArmPhysics.step` computes them."""
        static = self.physics.static_map(q_c)
        seen = self._seen(q_c, static)
        plays = np.minimum(np.maximum(plays, seen - self._widths), seen + self._widths)
        terms = np.bincount(self._joints, weights=self._gains * (plays - seen), minlength=len(static))
        return static + terms, plays, terms

    def settle(self, q: NDArray[np.float64]) -> PhysicsState:
        static = self.physics.static_map(q)
        return static.copy(), static, self._seen(q, static), np.zeros_like(static)

    def forward(self, q_c: NDArray[np.float64], state: PhysicsState) -> NDArray[np.float64]:
        played, _, plays, _ = state
        target, _, _ = self._target(q_c, plays)
        return np.clip(played, target - self.half_width, target + self.half_width)

    def advance(self, state: PhysicsState, q_issued: NDArray[np.float64]) -> PhysicsState:
        played, _, plays, _ = state
        target, plays, terms = self._target(q_issued, plays)
        return np.clip(played, target - self.half_width, target + self.half_width), target, plays, terms

    def inverse(self, q_d: NDArray[np.float64], state: PhysicsState) -> NDArray[np.float64]:
        played, previous_target, _, terms = state
        target = np.where(
            q_d > played, q_d + self.half_width, np.where(q_d < played, q_d - self.half_width, previous_target)
        )
        return self.matrix_inverse @ (target - terms - self.physics.offset)


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
