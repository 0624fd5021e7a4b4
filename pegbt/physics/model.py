"""`ArmPhysics`: the physical joints of one PSM as a function of its command history.

Per joint, in the order of `pegbt.physics.effects.STAGES`: delay the command, map it statically (scale,
coupling from other joints' commands, offset), add hysteresis (play in a drive: another joint's command,
or for a joint's own hysteresis its static target, the same input its backlash sees), then pass the
target through the joint's transforms: stateless ones, play (backlash), then dynamics (first-order lag).
Each effect's kind puts it there (`EffectKind.install`); the static map is vectorised, and the transforms
run their kind's kernels: `step()` sample by sample, `simulate()` over whole sequences.

Two ways to run it: `step()` at the control period (the simulator endpoint), and `simulate()` over a
whole recording, either as a time stream or as settled set-points (`t=None`: lag and delay have died
out before each sample, as in the dVRK recordings).
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.physics.effects import TRANSFORM_STAGES, ArmParameters, Effect, EffectKind, joint_index
from pegbt.physics.kernels import delay_chunk, delay_series, play_grid
from pegbt.psm import N_JOINTS

PRESET_DIR = Path(__file__).parent / "presets"
REPLAY_ROWS = 8192  # samples a chunked replay computes at once: a few MB however long the recording


class ArmPhysics(ArmParameters):
    """Cable physics of one arm, built from a list of `Effect`s (none: the ideal arm); its kinds install
    themselves through `ArmParameters`, the part of it they may read and write."""

    def __init__(self, effects: Iterable[Effect] = ()) -> None:
        self.effects: tuple[Effect, ...] = tuple(effects)
        self.scale = np.ones(N_JOINTS)
        self.offset = np.zeros(N_JOINTS)
        self.coupling = np.zeros((N_JOINTS, N_JOINTS))  # coupling[j, s]: k of source s into joint j
        self.half_width = np.zeros(N_JOINTS)
        self.tau = np.zeros(N_JOINTS)
        self.delay = np.zeros(N_JOINTS)
        self.hysteresis: list[tuple[int, int, float, float]] = []  # (joint, source, half_width, k)
        self.transforms: list[tuple[int, EffectKind, Effect]] = []  # (joint, kind, effect) in stage order
        seen: set[tuple[str, str, str, float]] = set()
        for effect in self.effects:
            if effect.slot in seen:
                raise PegbtError(f"{effect.effect} on {effect.joint} given twice", field=effect.joint)
            seen.add(effect.slot)
            effect.kind.install(self, effect)
        self.transforms.sort(key=lambda entry: TRANSFORM_STAGES.index(entry[1].stage))
        self._kernel_states: list[object] = [None] * len(self.transforms)
        # What `step` reads 100 times a second, laid out once: each hysteresis as arrays, so a tick clips
        # every play in one call, and where the transforms' stages begin (they are sorted by stage).
        self._drive_joint = np.array([h[0] for h in self.hysteresis], dtype=np.intp)
        self._drive_source = np.array([h[1] for h in self.hysteresis], dtype=np.intp)
        self._drive_own = self._drive_joint == self._drive_source
        self._drive_half = np.array([h[2] for h in self.hysteresis], dtype=float)
        self._drive_gain = np.array([h[3] for h in self.hysteresis], dtype=float)
        self._own_drives = {
            j: [
                (n, half, k)
                for n, (target, source, half, k) in enumerate(self.hysteresis)
                if target == source == j
            ]
            for j in range(N_JOINTS)
        }
        self._delays = bool(self.delay.any())
        stages = [kind.stage for _, kind, _ in self.transforms]
        self._play_from = next((n for n, stage in enumerate(stages) if stage != "target"), len(stages))
        self._output_from = next((n for n, stage in enumerate(stages) if stage == "output"), len(stages))
        self._state: NDArray[np.float64] | None = None  # output of the play stage
        self._target: NDArray[np.float64] = np.zeros(N_JOINTS)  # input of the play stage
        self._drive_seen: NDArray[np.float64] = np.zeros(len(self.hysteresis))  # input of each hysteresis
        self._drive_play: NDArray[np.float64] = np.zeros(
            len(self.hysteresis)
        )  # play state of each hysteresis
        self._output: NDArray[np.float64] | None = None  # lag output
        self._history: deque[tuple[float, NDArray[np.float64]]] = deque()
        self._time = 0.0

    def add_transform(self, kind: EffectKind, effect: Effect) -> None:
        """Run `effect` as a per-joint transform of its stage (what `EffectKind.install` does by default)."""
        if kind.stage not in TRANSFORM_STAGES:
            raise PegbtError(f"{kind.name} acts at stage {kind.stage!r}, not a transform", field="effect")
        self.transforms.append((effect.index, kind, effect))

    def settled_transforms(self) -> list[tuple[int, EffectKind, Effect]]:
        """The transforms that set-points keep (output dynamics settle out between them)."""
        return [entry for entry in self.transforms if entry[1].stage != "output"]

    # ----------------------------------------------------------------- construction helpers
    @classmethod
    def from_dicts(cls, entries: object) -> ArmPhysics:
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
    def load(cls, source: str | Path, arm: str = "PSM1") -> ArmPhysics:
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
        state, target, half = self._state.item(j), self._target.item(j), self.half_width.item(j)
        down, up = state - (target - half), target + half - state
        for n, half_width, k in self._own_drives[j]:
            play, seen = self._drive_play.item(n), self._drive_seen.item(n)
            below, above = k * (play - (seen - half_width)), k * (seen + half_width - play)
            down, up = down + max(below, -above), up + max(above, -below)  # k < 0 swaps the sides
        return down, up

    # ----------------------------------------------------------------- the physics
    def static_map(self, q_cmd: ArrayLike) -> NDArray[np.float64]:
        """Scale, coupling and offset applied to commands (..., 6): the settled joints without any play."""
        q_cmd = np.asarray(q_cmd, dtype=float)
        mapped = q_cmd @ self.coupling.T  # summed in place: one array the commands' size, not three
        mapped += self.scale * q_cmd
        mapped += self.offset
        return mapped

    def reset(self, q_cmd: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """Settle the arm at command `q_cmd` (no play taken up) and return its physical joints."""
        q_cmd = np.asarray(q_cmd, dtype=float).copy()
        static = self.static_map(q_cmd)
        self._drive_play = np.array([self._drive(j, s, q_cmd, static) for j, s, _, _ in self.hysteresis])
        self._drive_seen = self._drive_play.copy()
        self._output = self._run_stages(static, 0.0, starting=True)
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
        if self.hysteresis:
            joints, sources = self._drive_joint, self._drive_source
            commands = delayed[joints, sources] if delayed.ndim == 2 else delayed[sources]
            seen = np.where(self._drive_own, target[joints], commands)  # read before any term is added
            self._drive_play = np.clip(self._drive_play, seen - self._drive_half, seen + self._drive_half)
            self._drive_seen = seen
            np.add.at(
                target, joints, self._drive_gain * (self._drive_play - seen)
            )  # in order, as a loop would
        self._output = self._run_stages(target, dt)
        return self._output.copy()

    def _run_stages(
        self, target: NDArray[np.float64], dt: float, starting: bool = False
    ) -> NDArray[np.float64]:
        """Pass the target (taken over, not copied) through each transform's step kernel (`starting`:
        settle each kernel at its input first), keeping the play stage's input (`_target`) and output
        (`_state`)."""
        signal = target
        for n, (j, kind, effect) in enumerate(self.transforms):
            if n == self._play_from:
                self._target = signal.copy()
            if n == self._output_from:
                self._state = signal.copy()
            if starting:
                self._kernel_states[n] = kind.start(effect, float(signal[j]))
            signal[j], self._kernel_states[n] = kind.step(
                effect, self._kernel_states[n], float(signal[j]), dt
            )
        if self._play_from == len(self.transforms):
            self._target = signal.copy()
        if self._output_from == len(self.transforms):
            self._state = signal  # the output, which is never written to in place
        return signal

    def _delayed_command(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        """The command as each joint sees it: (6,) without delays, else (6, 6), row j delayed by delay[j]."""
        if not self._delays:
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
            return self._transformed(self.settled_targets(q_cmd), None)
        t = np.asarray(t, dtype=float)
        by_delay: dict[float, NDArray[np.float64]] = {}
        for seconds in map(float, self.delay):
            if seconds not in by_delay:
                by_delay[seconds] = q_cmd if seconds <= 0 else delay_series(q_cmd, t, seconds)
        return self._transformed(self._with_hysteresis([by_delay[float(d)] for d in self.delay]), t)

    def replay(
        self,
        q_cmd: ArrayLike,
        t: ArrayLike | None = None,
        stop: int | None = None,
        rows: int | None = None,
    ) -> Iterator[tuple[int, NDArray[np.float64]]]:
        """`simulate(q_cmd, t)` `rows` (`REPLAY_ROWS`) samples at a time, each chunk from the state the one before left:
        (its first row, its physical joints), the same values as one `simulate`, in memory bounded by a
        chunk (commands and times are only read: they may be memory-mapped). A replay is causal, so
        `stop` ends it there: rows [0, stop) are those of the whole replay."""
        q_cmd = np.asarray(q_cmd, dtype=float)
        if q_cmd.ndim != 2 or q_cmd.shape[1] != N_JOINTS:
            raise PegbtError(f"commands must be N×{N_JOINTS}, got shape {q_cmd.shape}", field="q_cmd")
        times = None if t is None else np.asarray(t, dtype=float)
        transforms = self.transforms if times is not None else self.settled_transforms()
        kernel_states: list[Any] = [None] * len(transforms)
        play_states: list[Any] = [None] * len(self.hysteresis)
        end = len(q_cmd) if stop is None else stop
        rows = REPLAY_ROWS if rows is None else rows
        for a in range(0, end, rows):
            b = min(a + rows, end)
            if times is None:
                seen_by = [q_cmd[a:b]] * N_JOINTS
            else:
                by_delay = {
                    s: delay_chunk(q_cmd, times, a, b, s) for s in dict.fromkeys(map(float, self.delay))
                }
                seen_by = [by_delay[float(d)] for d in self.delay]
            targets = self._with_hysteresis(seen_by, play_states)
            for n, (j, kind, effect) in enumerate(transforms):
                targets[:, j], kernel_states[n] = kind.sequence_from(
                    effect, targets[:, j], times, a, kernel_states[n]
                )
            yield a, targets

    def _transformed(
        self, targets: NDArray[np.float64], t: NDArray[np.float64] | None
    ) -> NDArray[np.float64]:
        """Each joint's targets (N, 6) through its transforms' sequence kernels (settled: no dynamics),
        in place: callers pass an array of their own, and a recording's length is not copied again."""
        for j, kind, effect in self.transforms if t is not None else self.settled_transforms():
            targets[:, j] = kind.sequence(effect, targets[:, j], t)
        return targets

    def settled_targets(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        """What each joint's backlash sees along settled set-points (N, 6): the static map plus hysteresis."""
        return self._with_hysteresis([q_cmd] * N_JOINTS)

    def _with_hysteresis(
        self, seen_by: list[NDArray[np.float64]], play_states: list[Any] | None = None
    ) -> NDArray[np.float64]:
        """Static targets (N, 6) from the commands each joint sees, plus the hysteresis terms. Joints that
        see the same commands (all of them without delays) share one static map of them. `play_states`
        (one per hysteresis, None at the start) carry each play's output across chunks of a replay."""
        distinct = list({id(seen): seen for seen in seen_by}.values())
        if len(distinct) == 1:
            static = self.static_map(distinct[0])
        else:
            static = np.empty((len(seen_by[0]), N_JOINTS))
            for seen in distinct:
                joints = [j for j in range(N_JOINTS) if seen_by[j] is seen]
                static[:, joints] = self.static_map(seen)[:, joints]
        if not self.hysteresis:
            return static
        target = static.copy()
        for n, (j, source, half_width, k) in enumerate(self.hysteresis):
            seen = self._drive(j, source, seen_by[j], static)
            play = play_grid(seen, half_width, None if play_states is None else play_states[n])[:, 0]
            if play_states is not None:
                play_states[n] = play[-1]
            target[:, j] += k * (play - seen)
        return target

    @staticmethod
    def _drive(
        joint: int, source: int, commands: NDArray[np.float64], static: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The input of a hysteresis: the source's command, or the joint's own static target."""
        return static[..., joint] if source == joint else commands[..., source]
