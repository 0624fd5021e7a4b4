"""The `physics` model: the cable effects the sim-to-real identification names, inverted analytically.

Effects come from `pegbt.sim2real.identify` (against the ideal arm, samples taken as settled set-points):
the same identification that produced the simulator's `dvrk-real` preset, so a model file is a physics
file the simulator can load. On settled set-points every effect it can name is rate-independent:

- a static map s = A·q + o (scale, coupling, offset);
- hysteresis: a play of half width h on a drive x (another joint's command, or the joint's own static
  target s_j) adds k·(play(x) − x) = k·clip(p − x, −h, h) to joint j, p the drive's play state;
- then the joint's transforms that set-points keep, each its kind's kernel: backlash of half width w
  on the target m (the joint stays at y until m is w past it), and any stateless map a kind adds.

The inverse is exact. The transforms are undone last to first by their kinds' `inverse` (backlash: to
move y to q_d the target must be m = q_d + w when rising, q_d − w when falling, and stays where it was
within the band when q_d = y). The target is piecewise linear in q (each
hysteresis is in its band or saturated at ±h), so m(q) = m* is solved by Newton's method over those
pieces: guess each hysteresis's piece, solve the 6×6 linear system, re-read the pieces at the solution,
repeat until they agree (a few iterations); should that ever cycle, every combination of pieces is
tried at once, and where none reaches the target (effects whose map folds over) the closest command is
returned, which compensation then rejects for the raw one. Lag and delay cannot be identified from set-points and are never named here; for a model
built from effects that do name them (`from_effects`), they are ignored: they only delay when the settled
joints are reached, and the inverse commands the settled joints (pre-empting them would need a lead filter
that amplifies noise and breaks the velocity limits). The state advances on every issued command, 10 ms
step or set-point alike, because nothing in it depends on rate.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.modelfile import ModelMetadata
from pegbt.errors import PegbtError
from pegbt.physics import ArmPhysics, Effect
from pegbt.psm import JOINT_NAMES

Array = NDArray[np.float64]
REACHED = 1e-9  # rad or m: a command whose target is this close solves the inverse
NEWTON_ITERATIONS = 20
LAST_STEPS = 2  # compensation steps from one state with the command and with the raw desired joints
MAX_ENUMERATED = 10  # hysteresis terms whose 3^n pieces may be tried at once (59049 small solves)


@dataclass(frozen=True)
class PhysicsState:
    """The arm's memory after a command: physical joints, each hysteresis's play, each transform's last
    input and kernel state."""

    played: Array  # (6,) the physical joints
    drives: Array  # (H,) play state of each hysteresis
    target: Array  # (6,) the static map plus hysteresis, before the transforms
    inputs: tuple[float, ...]  # what each settled transform saw last
    kernels: tuple[object, ...]  # each settled transform's kernel state


class SettledArm:
    """Forward and exact inverse of an `ArmPhysics` on settled set-points, one command at a time."""

    def __init__(self, physics: ArmPhysics) -> None:
        self.physics = physics
        self.matrix = np.diag(physics.scale) + physics.coupling
        if abs(np.linalg.det(self.matrix)) < 1e-6:
            raise PegbtError(
                "the effects' scale and coupling cannot be inverted (singular map)", field="effects"
            )
        self.transforms = physics.settled_transforms()
        n = len(physics.hysteresis)
        joints = np.array([h[0] for h in physics.hysteresis], dtype=int)
        sources = np.array([h[1] for h in physics.hysteresis], dtype=int)
        self.play = np.array([h[2] for h in physics.hysteresis], dtype=float)
        self.gain = np.array([h[3] for h in physics.hysteresis], dtype=float)
        self.into = np.zeros((len(JOINT_NAMES), n))  # into[j, n] = 1: hysteresis n acts on joint j
        self.into[joints, np.arange(n)] = 1.0
        # Each drive is x = G·q + c: the source's command, or the joint's own static target.
        own = sources == joints
        self.drive_rows = np.where(own[:, None], self.matrix[joints], np.eye(len(JOINT_NAMES))[sources])
        self.drive_offsets = np.where(own, physics.offset[joints], 0.0)
        # Compensation asks for the same few pieces and steps again and again (100 commands a second):
        # the linear system of each set of pieces, the last steps, and the last target (the inverse checks
        # the command it found, then compensation steps the arm with it) are kept (the same values).
        self._systems: dict[tuple[tuple[int, ...], bytes], tuple[Array, NDArray[np.bool_], Array, Array]] = {}
        self._last_steps: list[tuple[bytes, PhysicsState, PhysicsState]] = []
        self._last_target: tuple[bytes, Array, tuple[Array, Array]] | None = None

    # ------------------------------------------------------------------ forward
    def settle(self, q: Array) -> PhysicsState:
        target = self.physics.static_map(q)
        signal = target.copy()
        inputs, kernels = [], []
        for j, kind, effect in self.transforms:
            inputs.append(float(signal[j]))
            kernels.append(kind.start(effect, float(signal[j])))
            signal[j], kernels[-1] = kind.step(effect, kernels[-1], float(signal[j]), 0.0)
        drives = self.drive_rows @ q + self.drive_offsets
        return PhysicsState(signal, drives, target, tuple(inputs), tuple(kernels))

    def step(self, q_c: Array, state: PhysicsState) -> PhysicsState:
        """The state after issuing `q_c`."""
        q_c = np.asarray(q_c, dtype=float)
        key = q_c.tobytes()
        for known, before, after in self._last_steps:
            if before is state and known == key:
                return after
        after = self._step(q_c, state)
        self._last_steps = [(key, state, after), *self._last_steps[: LAST_STEPS - 1]]
        return after

    def _step(self, q_c: Array, state: PhysicsState) -> PhysicsState:
        target, drives = self._target(q_c, state.drives)
        signal = target.copy()
        inputs, kernels = [], []
        for (j, kind, effect), kernel in zip(self.transforms, state.kernels):
            inputs.append(float(signal[j]))
            signal[j], kernel = kind.step(effect, kernel, float(signal[j]), 0.0)
            kernels.append(kernel)
        return PhysicsState(signal, drives, target, tuple(inputs), tuple(kernels))

    def _target(self, q: Array, drives: Array) -> tuple[Array, Array]:
        """The target of command `q` and the plays' state after it (neither to be written to)."""
        key = q.tobytes()
        last = self._last_target
        if last is not None and last[1] is drives and last[0] == key:
            return last[2]
        x = self.drive_rows @ q + self.drive_offsets
        moved = np.minimum(np.maximum(drives, x - self.play), x + self.play)  # np.clip's values, sooner
        found = self.physics.static_map(q) + self.into @ (self.gain * (moved - x)), moved
        self._last_target = (key, drives, found)
        return found

    # ------------------------------------------------------------------ inverse
    def inverse(self, q_d: Array, state: PhysicsState) -> Array:
        """The command after which the physical joints are exactly `q_d`."""
        target = np.array(q_d, dtype=float)
        for n in reversed(range(len(self.transforms))):
            j, kind, effect = self.transforms[n]
            target[j] = kind.inverse(effect, float(target[j]), state.kernels[n], state.inputs[n])
        return self.command_for_target(target, state.drives)

    def command_for_target(self, target: Array, drives: Array) -> Array:
        """The command whose target (static map plus hysteresis) is `target`, given the plays' state.

        Where no command reaches it (effects whose map folds over), the closest one found is returned;
        compensation then sees that it does not land and falls back to the raw command."""
        free = target - self.physics.offset  # what the static map and the hysteresis terms must add up to
        pieces = self._pieces(np.linalg.solve(self.matrix, free), drives)
        relative = drives - self.drive_offsets
        candidates, seen = [], set()
        for _ in range(NEWTON_ITERATIONS):
            q = self._solve_one(pieces, free, relative)
            if self._miss(q, target, drives) < REACHED:
                return q
            candidates.append(q)
            seen.add(pieces.tobytes())
            pieces = self._pieces(q, drives)
            if pieces.tobytes() in seen:
                break
        if len(self.play) <= MAX_ENUMERATED:
            combos = np.array(list(itertools.product((-1, 0, 1), repeat=len(self.play))), dtype=np.int8)
            candidates.extend(self._solve_pieces(combos, target, drives))
        return min(candidates, key=lambda q: self._miss(q, target, drives))

    def _pieces(self, q: NDArray[np.floating], drives: Array) -> NDArray[np.int8]:
        """Which piece each hysteresis is on at command q: +1 saturated high, −1 low, 0 in its band."""
        gap = drives - (self.drive_rows @ q + self.drive_offsets)
        return np.where(gap >= self.play, 1, np.where(gap <= -self.play, -1, 0)).astype(np.int8)

    def _solve_one(self, pieces: NDArray[np.int8], free: Array, relative: Array) -> Array:
        """`_solve_pieces` of one row of pieces (H,), the same arithmetic on the same shapes, without
        masking a batch of one; `free` is the target less the offsets, `relative` the drives less theirs
        (the same for every Newton step of one target)."""
        matrices, regular, in_band, saturated = self._system(pieces[None])
        if not regular[0]:
            return np.full(len(free), np.nan)
        constant = in_band * relative + saturated
        rhs = free - (constant * self.gain) @ self.into.T
        return np.linalg.solve(matrices, rhs[..., None])[0, :, 0]

    def _solve_pieces(self, pieces: NDArray[np.int8], target: Array, drives: Array) -> Array:
        """Commands (K, 6) solving the linear target equation of each row of pieces (K, H); NaN if singular."""
        matrices, regular, in_band, saturated = self._system(pieces)
        constant = in_band * (drives - self.drive_offsets) + saturated
        rhs = target - self.physics.offset - (constant * self.gain) @ self.into.T
        solved = np.full(rhs.shape, np.nan)
        solved[regular] = np.linalg.solve(matrices, rhs[regular][..., None])[..., 0]
        return solved

    def _system(self, pieces: NDArray[np.int8]) -> tuple[Array, NDArray[np.bool_], Array, Array]:
        """The regular matrices of `pieces`' linear systems, which rows are regular, which hysteresis
        terms are in their band, and the saturated terms' ±h (kept per set of pieces)."""
        key = (pieces.shape, pieces.tobytes())
        system = self._systems.get(key)
        if system is None:
            in_band = (pieces == 0).astype(float)
            # In its band hysteresis n adds k (p − G q − c); saturated it adds k · (±h).
            matrices = self.matrix[None] - np.einsum(
                "jn,kn,ni->kji", self.into, in_band * self.gain, self.drive_rows
            )
            regular = np.abs(np.linalg.det(matrices)) > 1e-12
            saturated = (1.0 - in_band) * pieces * self.play
            system = self._systems[key] = (matrices[regular], regular, in_band, saturated)
        return system

    def _miss(self, q: Array, target: Array, drives: Array) -> float:
        """How far command q's target is from `target` (inf for a command that is not finite)."""
        if not np.isfinite(q).all():
            return np.inf
        return float(np.abs(self._target(q, drives)[0] - target).max())


class PhysicsModel(CalibrationModel):
    """Explicit cable effects, as `pegbt.physics` names them, with their exact inverse."""

    kind = "physics"
    outputs = tuple(range(len(JOINT_NAMES)))  # effects may act on any joint; none means identity

    def __init__(self, arm: str) -> None:
        super().__init__(arm)
        self.effects: tuple[Effect, ...] = ()
        self.settled = SettledArm(ArmPhysics())

    @classmethod
    def from_effects(cls, arm: str, effects: Iterable[Effect], source: str) -> PhysicsModel:
        """A model from effects identified elsewhere (a sim-to-real report, a preset); `source` names them."""
        model = cls(arm)
        model._set_effects(effects)
        model.metadata = ModelMetadata(
            kind=cls.kind,
            arm=arm,
            outputs=JOINT_NAMES,
            training={
                "effects_from": source,
                "created": datetime.now(UTC).isoformat(timespec="seconds"),
            },
        )
        return model

    def _set_effects(self, effects: Iterable[Effect]) -> None:
        self.effects = tuple(effects)
        self.settled = SettledArm(ArmPhysics(self.effects))

    def _fit(self, q_cmd: Array, q_phy: Array) -> None:
        from pegbt.sim2real import identify  # only fitting needs it; compensation at run time does not

        self._set_effects(identify(q_cmd, q_phy, t=None, base="ideal", arm=self.arm))

    def _predict(self, q_cmd: Array) -> Array:
        return self.settled.physics.simulate(q_cmd)

    def initial_state(self, q: Array) -> PhysicsState:
        return self.settled.settle(q)

    def forward(self, q_c: Array, state: PhysicsState) -> Array:
        return self.settled.step(q_c, state).played

    def advance(self, state: PhysicsState, q_issued: Array) -> PhysicsState:
        return self.settled.step(q_issued, state)

    def command_for(self, target: Array, state: PhysicsState) -> Array:
        return self.settled.inverse(target, state)

    def _body(self) -> dict[str, Any]:
        return {"settings": {}, "effects": [effect.to_dict() for effect in self.effects]}

    def _restore(self, document: dict[str, Any], path: Path) -> None:
        try:
            self._set_effects(ArmPhysics.from_dicts(document["effects"]).effects)
        except PegbtError as error:
            raise PegbtError(error.message, file=path, field=error.field) from None
