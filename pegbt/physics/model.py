"""`ArmPhysics`: the physical joints of one PSM as a function of its command history.

Per joint, in this order: delay the command, map it statically (scale, coupling from other joints'
commands, offset), pass it through backlash (play), then through a first-order lag. The static map is
vectorised; backlash and lag carry state, so they run sample by sample.

Two ways to run it: `step()` at the control period (the simulator endpoint), and `simulate()` over a
whole recording, either as a time stream or as settled set-points (`t=None`: lag and delay have died
out before each sample, as in the dVRK recordings).
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.physics.effects import JOINT_NAMES, Effect, joint_index

N_JOINTS = len(JOINT_NAMES)
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
        seen: set[tuple[str, str, str]] = set()
        for effect in self.effects:
            source = str(effect.params.get("source", ""))
            key = (effect.effect, effect.joint, source)
            if key in seen:
                raise PegbtError(f"{effect.effect} on {effect.joint} given twice", field=effect.joint)
            seen.add(key)
            self._apply(effect)
        self._state: NDArray[np.float64] | None = None  # backlash output
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

    # ----------------------------------------------------------------- construction helpers
    @classmethod
    def from_dicts(cls, entries: Iterable[dict]) -> "ArmPhysics":
        return cls(Effect.from_dict(entry) for entry in entries)

    @classmethod
    def load(cls, source: str | Path, arm: str = "PSM1") -> "ArmPhysics":
        """Effects for `arm` from a preset name (`ideal`, `dvrk-real`) or a JSON file.

        A file may be a preset (`{"arms": {"PSM1": [effects...]}}`) or a sim-to-real report
        (`{"effects": [...]}`, which applies to whichever arm it is loaded for).
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
            if arm not in arms:
                raise PegbtError(f"no physics for arm {arm!r}; the file has {sorted(arms)}", file=path, field="arms")
            entries = arms[arm]
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

    # ----------------------------------------------------------------- the physics
    def static_map(self, q_cmd: ArrayLike) -> NDArray[np.float64]:
        """Scale, coupling and offset applied to commands (..., 6): the settled physical joints without play."""
        q_cmd = np.asarray(q_cmd, dtype=float)
        return self.scale * q_cmd + q_cmd @ self.coupling.T + self.offset

    def reset(self, q_cmd: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """Settle the arm at command `q_cmd` (no play taken up) and return its physical joints."""
        q_cmd = np.asarray(q_cmd, dtype=float).copy()
        self._state = self.static_map(q_cmd)
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
        self._state = _play(self._state, target, self.half_width)
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
            return apply_play(self.static_map(q_cmd), self.half_width)
        t = np.asarray(t, dtype=float)
        delayed = [
            np.column_stack([np.interp(t - self.delay[j], t, q_cmd[:, k]) for k in range(N_JOINTS)])
            if self.delay[j] > 0
            else q_cmd
            for j in range(N_JOINTS)
        ]
        target = np.column_stack([self.static_map(delayed[j])[:, j] for j in range(N_JOINTS)])
        played = apply_play(target, self.half_width)
        return apply_lag(played, t, self.tau)


def _play(state: NDArray[np.float64], target: NDArray[np.float64], half_width: NDArray[np.float64]) -> NDArray[np.float64]:
    """One step of the play operator: move the output only as far as the input has pushed it."""
    return np.clip(state, target - half_width, target + half_width)


def apply_play(u: NDArray[np.float64], half_width: ArrayLike, initial: ArrayLike | None = None) -> NDArray[np.float64]:
    """Backlash (play) along a sequence u (N, J), per-column half widths; starts centred unless `initial`."""
    half_width = np.broadcast_to(np.asarray(half_width, dtype=float), u.shape[1:])
    if not half_width.any():
        return u.copy()
    out = np.empty_like(u)
    state = u[0].copy() if initial is None else np.asarray(initial, dtype=float).copy()
    for n in range(len(u)):
        state = _play(state, u[n], half_width)
        out[n] = state
    return out


def apply_lag(u: NDArray[np.float64], t: NDArray[np.float64], tau: ArrayLike) -> NDArray[np.float64]:
    """First-order lag along a sequence u (N, J) sampled at times t, per-column time constants."""
    tau = np.broadcast_to(np.asarray(tau, dtype=float), u.shape[1:])
    if not tau.any():
        return u.copy()
    dt = np.diff(t, prepend=t[0])
    alpha = np.where(tau > 0, 1.0 - np.exp(-dt[:, None] / np.maximum(tau, 1e-12)), 1.0)
    out = np.empty_like(u)
    y = u[0].copy()
    for n in range(len(u)):
        y = y + alpha[n] * (u[n] - y)
        out[n] = y
    return out
