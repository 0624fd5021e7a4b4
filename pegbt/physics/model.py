"""`ArmPhysics`: the physical joints of one PSM as a function of its command history.

Per joint, in this order: delay the command, map it statically (scale, coupling from other joints'
commands, offset), add hysteresis (play in a drive: another joint's command, or for a joint's own
hysteresis its static target, the same input its backlash sees), pass it through backlash (play),
then through a first-order lag. The static map is vectorised; play and lag carry state, so `step()` runs
them sample by sample while `simulate()` uses the run-wise kernels of `pegbt.physics.kernels`.

Two ways to run it: `step()` at the control period (the simulator endpoint), and `simulate()` over a
whole recording, either as a time stream or as settled set-points (`t=None`: lag and delay have died
out before each sample, as in the dVRK recordings).
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.physics.effects import Effect, joint_index
from pegbt.physics.kernels import apply_lag, apply_play, delay_series, play_grid
from pegbt.psm import JOINT_NAMES, N_JOINTS

PRESET_DIR = Path(__file__).parent / "presets"


class ArmPhysics:
    """Cable physics of one arm, built from a list of `Effect`s (none: the ideal arm)."""

    def __init__(self, effects: Iterable[Effect] = ()) -> None:
        self.effects: tuple[Effect, ...] = tuple(effects)
        self.scale = np.ones(N_JOINTS)
        self.offset = np.zeros(N_JOINTS)
        self.coupling = np.zeros((N_JOINTS, N_JOINTS))  # coupling[j, s]: k of source s into joint j
        self.half_width = np.zeros(N_JOINTS)
        self.tau = np.zeros(N_JOINTS)
        self.delay = np.zeros(N_JOINTS)
        self.hysteresis: list[tuple[int, int, float, float]] = []  # (joint, source, half_width, k)
        seen: set[tuple[str, str, str, float]] = set()
        for effect in self.effects:
            if effect.slot in seen:
                raise PegbtError(f"{effect.effect} on {effect.joint} given twice", field=effect.joint)
            seen.add(effect.slot)
            self._apply(effect)
        self._state: NDArray[np.float64] | None = None  # backlash output
        self._target: NDArray[np.float64] = np.zeros(N_JOINTS)  # backlash input (static map plus hysteresis)
        self._drive_seen: NDArray[np.float64] = np.zeros(len(self.hysteresis))  # input of each hysteresis
        self._drive_play: NDArray[np.float64] = np.zeros(
            len(self.hysteresis)
        )  # play state of each hysteresis
        self._output: NDArray[np.float64] | None = None  # lag output
        self._history: deque[tuple[float, NDArray[np.float64]]] = deque()
        self._time = 0.0

    def _apply(self, effect: Effect) -> None:
        j, p = effect.index, effect.params
        if effect.effect == "offset":
            self.offset[j] = p["value"]
        elif effect.effect == "scale":
            self.scale[j] = p["value"]
        elif effect.effect == "coupling":
            self.coupling[j, joint_index(p["source"])] = p["k"]
        elif effect.effect == "backlash":
            self.half_width[j] = p["half_width"]
        elif effect.effect == "lag":
            self.tau[j] = p["tau"]
        elif effect.effect == "delay":
            self.delay[j] = p["seconds"]
        elif effect.effect == "hysteresis":
            self.hysteresis.append((j, joint_index(p["source"]), float(p["half_width"]), float(p["k"])))

    # ----------------------------------------------------------------- construction helpers
    @classmethod
    def from_dicts(cls, entries: object) -> "ArmPhysics":
        """The model of effect entries in report / preset form (a list of objects), as files store them."""
        if not isinstance(entries, list):
            raise PegbtError(f"effects is a list of effect entries; got {entries!r}", field="effects")
        effects = []
        for index, entry in enumerate(entries):
            try:
                effects.append(Effect.from_dict(entry))
            except PegbtError as error:
                raise PegbtError(
                    error.message,
                    field=f"effects[{index}].{error.field}" if error.field else f"effects[{index}]",
                ) from None
        return cls(effects)

    @classmethod
    def load(cls, source: str | Path, arm: str = "PSM1") -> "ArmPhysics":
        """Effects for `arm` from a preset name (`ideal`, `dvrk-real`) or a JSON file.

        A file may be a preset (`{"arms": {"PSM1": [effects...]}}`) or a sim-to-real report, which
        applies to whichever arm it is loaded for: its `model.effects` (the whole identified model,
        including the physics it was diagnosed against) or else its `effects`.
        """
        path = Path(source)
        if not path.suffix and not path.exists():
            path = PRESET_DIR / f"{source}.json"
            if not path.exists():
                known = ", ".join(sorted(p.stem for p in PRESET_DIR.glob("*.json")))
                raise PegbtError(f"unknown physics preset {str(source)!r}; known: {known}", field="physics")
        try:
            data = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as error:
            raise PegbtError(f"cannot read physics file: {error}", file=path) from None
        if isinstance(data, dict) and "arms" in data:
            arms = data["arms"]
            if not isinstance(arms, dict):
                raise PegbtError(
                    f"arms is an object of effect lists by arm; got {arms!r}", file=path, field="arms"
                )
            if arm not in arms:
                raise PegbtError(
                    f"no physics for arm {arm!r}; the file has {sorted(arms)}", file=path, field="arms"
                )
            entries = arms[arm]
        elif isinstance(data, dict) and isinstance(data.get("model"), dict) and "effects" in data["model"]:
            entries = data["model"]["effects"]
        elif isinstance(data, dict) and "effects" in data:
            entries = data["effects"]
        else:
            raise PegbtError("expected an object with 'arms' or 'effects'", file=path)
        try:
            return cls.from_dicts(entries)
        except PegbtError as error:
            raise PegbtError(error.message, file=path, field=error.field) from None

    @property
    def is_ideal(self) -> bool:
        return not self.effects

    def play_room(self, joint: str | int) -> tuple[float, float]:
        """How far (rad, m) `joint` can be turned down and up from where it stands now (after `reset` or
        `step`) without its own drive's cables taking up load: the free part of its backlash and of each
        own-drive hysteresis (the part k of that play reaching the joint). A joint that lags behind its
        command sits at one edge of its play and can be pushed across all of it towards the command."""
        j = joint_index(joint)
        if self._state is None:
            return 0.0, 0.0
        down = float(self._state[j] - (self._target[j] - self.half_width[j]))
        up = float(self._target[j] + self.half_width[j] - self._state[j])
        for n, (target, source, half_width, k) in enumerate(self.hysteresis):
            if target == source == j:
                below = k * (self._drive_play[n] - (self._drive_seen[n] - half_width))
                above = k * (self._drive_seen[n] + half_width - self._drive_play[n])
                down, up = down + max(below, -above), up + max(above, -below)  # k < 0 swaps the sides
        return down, up

    # ----------------------------------------------------------------- the physics
    def static_map(self, q_cmd: ArrayLike) -> NDArray[np.float64]:
        """Scale, coupling and offset applied to commands (..., 6): the settled joints without any play."""
        q_cmd = np.asarray(q_cmd, dtype=float)
        return self.scale * q_cmd + q_cmd @ self.coupling.T + self.offset

    def reset(self, q_cmd: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """Settle the arm at command `q_cmd` (no play taken up) and return its physical joints."""
        q_cmd = np.asarray(q_cmd, dtype=float).copy()
        self._state = self.static_map(q_cmd)
        self._target = self._state.copy()
        self._drive_play = np.array([self._drive(j, s, q_cmd, self._state) for j, s, _, _ in self.hysteresis])
        self._drive_seen = self._drive_play.copy()
        self._output = self._state.copy()
        self._time = time
        self._history = deque([(time, q_cmd)])
        return self._output.copy()

    def step(self, q_cmd: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Advance by `dt` seconds with the command held at `q_cmd`; return the physical joints."""
        q_cmd = np.asarray(q_cmd, dtype=float)
        if self._state is None or self._output is None:
            self.reset(q_cmd)
        assert self._state is not None and self._output is not None
        self._time += dt
        delayed = self._delayed_command(q_cmd)
        target = self.static_map(delayed)
        if target.ndim == 2:  # row j is the map of the command joint j sees; keep joint j of it
            target = np.diagonal(target).copy()
        static = target.copy()
        for n, (j, source, half_width, k) in enumerate(self.hysteresis):
            seen = self._drive(j, source, delayed[j] if delayed.ndim == 2 else delayed, static)
            self._drive_play[n] = np.clip(self._drive_play[n], seen - half_width, seen + half_width)
            self._drive_seen[n] = seen
            target[j] += k * (self._drive_play[n] - seen)
        self._state = _play(self._state, target, self.half_width)
        self._target = target
        alpha = np.where(self.tau > 0, 1.0 - np.exp(-dt / np.maximum(self.tau, 1e-12)), 1.0)
        self._output = self._output + alpha * (self._state - self._output)
        return self._output.copy()

    def _delayed_command(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        """The command as each joint sees it: (6,) without delays, else (6, 6), row j delayed by delay[j]."""
        if not self.delay.any():
            return q_cmd
        self._history.append((self._time, q_cmd.copy()))
        horizon = self._time - float(self.delay.max())
        while len(self._history) > 2 and self._history[1][0] <= horizon:
            self._history.popleft()
        times = np.array([t for t, _ in self._history])
        values = np.stack([q for _, q in self._history])
        rows = [
            np.array([np.interp(self._time - self.delay[j], times, values[:, k]) for k in range(N_JOINTS)])
            for j in range(N_JOINTS)
        ]
        return np.stack(rows)

    def simulate(self, q_cmd: ArrayLike, t: ArrayLike | None = None) -> NDArray[np.float64]:
        """Physical joints (N, 6) for a command sequence (N, 6).

        With `t` (N seconds, increasing) the sequence is a stream: delays and lags act in time. Without
        it, samples are settled set-points: lags have died out and delays are over before each sample.
        """
        q_cmd = np.asarray(q_cmd, dtype=float)
        if q_cmd.ndim != 2 or q_cmd.shape[1] != N_JOINTS:
            raise PegbtError(f"commands must be N×{N_JOINTS}, got shape {q_cmd.shape}", field="q_cmd")
        if t is None:
            return apply_play(self.settled_targets(q_cmd), self.half_width)
        t = np.asarray(t, dtype=float)
        delayed = [delay_series(q_cmd, t, float(self.delay[j])) for j in range(N_JOINTS)]
        return apply_lag(apply_play(self._with_hysteresis(delayed), self.half_width), t, self.tau)

    def settled_targets(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        """What each joint's backlash sees along settled set-points (N, 6): the static map plus hysteresis."""
        return self._with_hysteresis([q_cmd] * N_JOINTS)

    def _with_hysteresis(self, seen_by: list[NDArray[np.float64]]) -> NDArray[np.float64]:
        """Static targets (N, 6) from the commands each joint sees, plus the hysteresis terms."""
        static = np.column_stack([self.static_map(seen_by[j])[:, j] for j in range(N_JOINTS)])
        target = static.copy()
        for j, source, half_width, k in self.hysteresis:
            seen = self._drive(j, source, seen_by[j], static)
            target[:, j] += k * (play_grid(seen, half_width)[:, 0] - seen)
        return target

    @staticmethod
    def _drive(
        joint: int, source: int, commands: NDArray[np.float64], static: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The input of a hysteresis: the source's command, or the joint's own static target."""
        return static[..., joint] if source == joint else commands[..., source]


def _play(
    state: NDArray[np.float64], target: NDArray[np.float64], half_width: NDArray[np.float64]
) -> NDArray[np.float64]:
    """One step of the play operator: move the output only as far as the input has pushed it."""
    return np.clip(state, target - half_width, target + half_width)
