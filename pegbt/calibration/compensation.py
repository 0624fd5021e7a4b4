"""Pre-compensation of joint commands (the reference paper's Alg. 1), one command at a time or a whole
streamed trajectory at once (`trajectory`: the same commands, its limits checked once for the array).

To make the arm reach q_d, issue the q_c a forward model says lands there: iterate
q_c ← q_c + α (q_d − f(q_c; history)) M times, issue q_c, and record what was actually
issued as the history of the next command. Where the model has explicit physics, the iteration runs on
the physics' target and the physics is inverted exactly (`command_for`), so a physics model needs no
iteration and a hybrid model iterates only on its small learned residual. The iteration starts from
the last command's correction (q_c − q_d), not from q_d: from one 10 ms step to the next the correction
barely changes, and starting from q_d would swing the candidate back across the arm's play and make a
hysteretic model flip between its two solutions.

Safety, in this order: a desired command outside the joint limits is refused (`PegbtError`); a model
that returns NaN is an error; if the iteration ends further from q_d (by the model) than the raw
command, the raw command is issued; the result is clamped into the joint limits and, for streamed
steps, into the velocity limits over one control period. Each of these last three is logged and counted;
a warning is logged when it starts happening, on its 1st, 10th, 100th... start (never a flood at 100 Hz).
"""

from __future__ import annotations

import copy
import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.calibration.base import CalibrationModel, require_finite
from pegbt.errors import PegbtError
from pegbt.motion.limits import SKILLS_DIR, ArmSettings, arm_settings
from pegbt.psm import JOINT_NAMES

log = logging.getLogger(__name__)
CALIBRATION_DIR = SKILLS_DIR / "calibration"
CONVERGED = 1e-9  # rad or m: the model says the command lands on the desired joints


@dataclass(frozen=True)
class Iterations:
    """M and α of Alg. 1."""

    count: int
    alpha: float

    def __post_init__(self) -> None:
        if self.count < 0 or not 0.0 < self.alpha <= 1.0:
            raise PegbtError(
                f"need M >= 0 and 0 < alpha <= 1, got M={self.count}, alpha={self.alpha}", field="alpha"
            )


# Single goals iterate M = 5 times. Streamed steps carry the correction from step to step, so one full
# step per 10 ms continues the same iteration over time; more per step made the hybrid model chatter
# (measured on grey1_PSM1: 0.03 rad per step at M = 5 against 0.004 at M = 1, for 0.0017 of motion).
GOAL_ITERATIONS = Iterations(5, 0.5)
STREAM_ITERATIONS = Iterations(1, 1.0)


class Compensator:
    """Turns desired joints into the commands that reach them, for one arm and one model."""

    def __init__(
        self,
        model: CalibrationModel,
        *,
        goal: Iterations = GOAL_ITERATIONS,
        stream: Iterations = STREAM_ITERATIONS,
        settings: ArmSettings | None = None,
    ) -> None:
        self.model = model
        self.iterations = {False: goal, True: stream}
        self.settings = settings or arm_settings(model.arm)
        self.max_step = self.settings.velocity * self.settings.control_period
        self._predicted = f"the {model.kind} model's prediction"
        self.state: Any = None
        self.last_issued: NDArray[np.float64] | None = None
        self._last_entry: NDArray[np.float64] | None = None
        self._correction = np.zeros(len(JOINT_NAMES))  # target − desired of the last command: the warm start
        self.counts = {"fallback": 0, "joint_limit": 0, "velocity_limit": 0}  # steps affected
        self._starts = dict.fromkeys(self.counts, 0)
        self._active: set[str] = set()

    def reset(self, q_now: ArrayLike) -> None:
        """Start from an arm that has settled at command `q_now` (no history of motion)."""
        q_now = self._checked(q_now, "the current command")
        self.state = self.model.initial_state(q_now)
        self.last_issued = q_now.copy()
        self._last_entry = q_now.copy()
        self._correction = np.zeros_like(q_now)
        self._active.clear()

    def fork(self) -> Compensator:
        """A copy that compensates on from this one's history without changing it (the model is shared:
        models are not changed by compensating)."""
        twin = copy.copy(self)
        twin.counts, twin._starts, twin._active = dict(self.counts), dict(self._starts), set(self._active)
        return twin

    def step(self, q_desired: ArrayLike) -> NDArray[np.float64]:
        """The command to issue on this control step of a streamed trajectory (every 10 ms)."""
        return self._issue(q_desired, streamed=True)

    def goal(self, q_desired: ArrayLike) -> NDArray[np.float64]:
        """The command to issue for a single goal (a set-point the arm settles at)."""
        return self._issue(q_desired, streamed=False)

    def trajectory(self, desired: ArrayLike) -> NDArray[np.float64]:
        """The commands (N, 6) of a streamed trajectory's desired rows (N, 6), as `step` gives them row by
        row. The rows are checked against the joint limits all at once, before any is issued: a trajectory
        with a row outside them is refused whole, and leaves the history as it was."""
        rows = np.asarray(desired, dtype=float)
        if rows.ndim != 2 or rows.shape[1] != len(JOINT_NAMES) or len(rows) == 0:
            raise PegbtError(
                f"a desired trajectory must be N×{len(JOINT_NAMES)} with N > 0, got shape {rows.shape}",
                field="q",
            )
        inside = ((rows >= self.settings.lower) & (rows <= self.settings.upper)).all(axis=1)  # NaN: outside
        if not inside.all():
            row = int(np.argmin(inside))
            self._checked(rows[row], f"row {row} of the desired trajectory")
        if self.state is None:
            self.reset(rows[0])
        commands = np.empty_like(rows)
        for n, q_d in enumerate(rows):
            commands[n] = self._compensate(q_d, streamed=True)
        return commands

    # ------------------------------------------------------------------ internals
    def _checked(self, q: ArrayLike, what: str) -> NDArray[np.float64]:
        q = np.asarray(q, dtype=float)
        if q.shape != (len(JOINT_NAMES),):
            raise PegbtError(f"{what} must have {len(JOINT_NAMES)} joints, got shape {q.shape}", field="q")
        problems = self.settings.joint_violations(q)
        if problems:
            raise PegbtError(
                f"{what} is outside {self.model.arm}'s joint limits: {'; '.join(problems)}", field="q"
            )
        return q

    def _issue(self, q_desired: ArrayLike, streamed: bool) -> NDArray[np.float64]:
        q_d = self._checked(q_desired, "the desired command")
        if self.state is None:
            self.reset(q_d)
        return self._compensate(q_d, streamed).copy()

    def _compensate(self, q_d: NDArray[np.float64], streamed: bool) -> NDArray[np.float64]:
        """The command for `q_d` (already checked), clamped, with the history advanced past it. The clamps
        are np.clip's minimum of maximum, without its per-call overhead (the command is finite)."""
        assert self.last_issued is not None and self._last_entry is not None
        lower, upper = self.settings.lower, self.settings.upper
        q_c = self._solve(q_d, self.iterations[streamed])
        self._note(
            "joint_limit",
            bool(((q_c < lower) | (q_c > upper)).any()),
            "compensated command clamped into the joint limits",
        )
        q_c = np.minimum(np.maximum(q_c, lower), upper)
        if streamed:
            move = q_c - self.last_issued
            self._note(
                "velocity_limit",
                bool((np.abs(move) > self.max_step).any()),
                "compensated command clamped to the velocity limits",
            )
            q_c = self.last_issued + np.minimum(np.maximum(move, -self.max_step), self.max_step)
        self.last_issued = q_c
        spacing = self.model.history_spacing
        if not streamed or spacing <= 0 or np.max(np.abs(q_c - self._last_entry)) >= spacing:
            self.state = self.model.advance(self.state, q_c)
            self._last_entry = q_c
        return q_c

    def _solve(self, q_d: NDArray[np.float64], iterations: Iterations) -> NDArray[np.float64]:
        """Alg. 1 on the target of the model's explicit physics, which is inverted exactly: with none
        (lstm) this is the paper's q_c ← q_c + α (q_d − f(q_c)); with physics alone it is exact at once.
        The raw command is returned if the iteration ended further from q_d (by the model)."""
        what = self._predicted
        target = q_d + self._correction
        q_c = self.model.command_for(target, self.state)
        predicted = require_finite(self.model.forward(q_c, self.state), what)
        raw = require_finite(self.model.forward(q_d, self.state), what)
        for _ in range(iterations.count):
            if np.max(np.abs(q_d - predicted)) < CONVERGED:
                break
            target = target + iterations.alpha * (q_d - predicted)
            q_c = self.model.command_for(target, self.state)
            predicted = require_finite(self.model.forward(q_c, self.state), what)
        q_c = require_finite(q_c, "the compensated command")
        worse = np.max(np.abs(q_d - predicted)) > np.max(np.abs(q_d - raw))
        self._note(
            "fallback", bool(worse), "compensation did not converge; issuing the uncompensated command"
        )
        self._correction = np.zeros_like(q_d) if worse else target - q_d
        return q_d.copy() if worse else q_c

    def _note(self, event: str, happened: bool, message: str) -> None:
        if not happened:
            self._active.discard(event)
            return
        self.counts[event] += 1
        if event not in self._active:
            self._active.add(event)
            self._starts[event] += 1
            if _is_power_of_ten(self._starts[event]):
                log.warning(
                    "%s (%s, %s model; %d step(s) so far)",
                    message,
                    self.model.arm,
                    self.model.kind,
                    self.counts[event],
                )


def _is_power_of_ten(n: int) -> bool:
    """Warn on the 1st, 10th, 100th... start of a problem: seen, but never a flood at 100 Hz."""
    while n % 10 == 0:
        n //= 10
    return n == 1
