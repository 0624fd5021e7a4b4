"""A simulated PSM: the controller side of one arm, with no transport in it.

Commands are checked against the arm's limits (`pegbt.transport.guards`, the checks the client runs
too) and refused whole, never clipped. Accepted commands move the set-point; the encoders follow the
set-point through a short first-order servo response (`measured_js`); the physical joints follow the
encoders through the shared cable model `ArmPhysics` (`fiducial_js`, and what moves the tool in the
world). Each command's fate comes back as `Transition`s for the endpoint to publish.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.motion.limits import ArmSettings
from pegbt.physics import ArmPhysics
from pegbt.sim.playback import Playback, goal_playback, ramp_playback, trajectory_playback
from pegbt.transport import guards
from pegbt.transport.codec import TrajectoryPoints

DEFAULT_JOINTS = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
DEFAULT_SERVO_TAU = 0.004  # s: encoders settle on a new set-point within about 20 ms


@dataclass(frozen=True)
class Transition:
    """What became of a command: accepted, refused (with why), done or aborted."""

    command_id: str
    outcome: str
    text: str = ""


Problems = Callable[[NDArray[np.float64]], list[str]]


class JointGroup:
    """Set-point, encoders and the motion being played for one group of joints (the arm's six, or the jaw)."""

    def __init__(
        self, q0: ArrayLike, servo_tau: float, problems: Problems, step_problems: Callable[..., list[str]]
    ) -> None:
        self.setpoint = np.asarray(q0, dtype=float).copy()
        self.tick_setpoint = self.setpoint.copy()  # the set-point at the last control tick
        self.previous_tick_setpoint = self.setpoint.copy()
        self.encoder = self.setpoint.copy()
        self.velocity = np.zeros_like(self.setpoint)
        self.motion: Playback | None = None
        self.lowest: NDArray[np.float64] | None = None  # the encoders cannot go below it (a block in the jaw)
        self._stop_bytes = b""  # the stop's value as bytes, while `lowest` is set
        self._elapsed = 0.0
        self._servo_tau = servo_tau
        self._alpha_dt, self._alpha = math.nan, 1.0  # the servo gain of the last tick's period
        self._settled: tuple[float, bytes, bytes, bytes] | None = None  # `_settled_key` of a settled tick
        self._problems = problems
        self._step_problems = step_problems

    def servo(self, q: NDArray[np.float64], command_id: str, period: float) -> list[Transition]:
        problems = self._problems(q) or self._step_problems(q, self.tick_setpoint, period)
        if problems:
            return [Transition(command_id, "refused", "; ".join(problems))]
        transitions = self.abort("preempted by servo_jp")
        self.setpoint = q.copy()
        return transitions

    def hold(self, command_id: str, stopping: str = "") -> list[Transition]:
        """Stop at the set-point of the last control tick: a step of zero, which no guard can refuse.

        A hold that names the motion it stops (`stopping`) does nothing once another command took over:
        it was sent before that command and overtook it on the way (other keys), and the later command
        already ended the motion, as a dVRK's `move_jp` restarts its trajectory from where the arm is
        (sawIntuitiveResearchKit 9e535e6, core/components/code/mtsIntuitiveResearchKitArm.cpp
        `move_jp`, `control_move_jp_on_start`). Unnamed, it stops whatever runs, as the dVRK's `hold`."""
        if stopping and (self.motion is None or self.motion.command_id != stopping):
            return [Transition(command_id, "done")]
        transitions = self.abort("held")
        self.setpoint = self.tick_setpoint.copy()
        return transitions + [Transition(command_id, "done")]

    def start(self, playback: Playback) -> list[Transition]:
        transitions = self.abort("preempted by a newer motion")
        self.motion, self._elapsed = playback, 0.0
        return transitions + [Transition(playback.command_id, "accepted")]

    def abort(self, reason: str) -> list[Transition]:
        if self.motion is None:
            return []
        command_id, self.motion = self.motion.command_id, None
        return [Transition(command_id, "aborted", reason)]

    def stop_at(self, lowest: float | None) -> None:
        """Keep the encoders at or above `lowest` from now on (None: free), as a gripped block stops a jaw.

        The same stop again (asked each tick) changes nothing: the encoders were kept above it since it
        was set, and the maximum of them and it is them, bit for bit."""
        if lowest is None:
            self.lowest = None
            return
        if self.lowest is not None and self._stop_bytes == struct.pack("d", lowest):
            return
        self.lowest = np.full_like(self.encoder, lowest)
        self._stop_bytes = self.lowest[:1].tobytes()
        self.encoder = np.maximum(self.encoder, self.lowest)

    def setpoint_velocity(self, period: float) -> NDArray[np.float64]:
        return (self.tick_setpoint - self.previous_tick_setpoint) / period

    def advance(self, dt: float) -> list[Transition]:
        if self.motion is None and self._settled == self._settled_key(dt):
            return []  # settled: this tick would give every value again, bit for bit
        transitions = []
        if self.motion is not None:
            self._elapsed += dt
            self.setpoint = self.motion.at(self._elapsed)
            if self._elapsed >= self.motion.duration - 1e-9:
                transitions.append(Transition(self.motion.command_id, "done"))
                self.motion = None
        self.previous_tick_setpoint, self.tick_setpoint = self.tick_setpoint, self.setpoint.copy()
        if dt != self._alpha_dt:  # the period hardly ever changes: its servo gain is kept
            self._alpha_dt = dt
            self._alpha = 1.0 - math.exp(-dt / self._servo_tau) if self._servo_tau > 0 else 1.0
        alpha = self._alpha
        previous = self.encoder
        self.encoder = previous + alpha * (self.setpoint - previous)
        if self.lowest is not None:
            self.encoder = np.maximum(self.encoder, self.lowest)
        self.velocity = (self.encoder - previous) / dt
        self._settled = self._settled_key(dt) if self.motion is None and self._is_settled() else None
        return transitions

    def _settled_key(self, dt: float) -> tuple[float, bytes, bytes, bytes]:
        """What a settled tick depends on: its period, the set-point, the encoders, the stop."""
        stop = b"" if self.lowest is None else self.lowest.tobytes()
        return dt, self.setpoint.tobytes(), self.encoder.tobytes(), stop

    def _is_settled(self) -> bool:
        """Whether a tick without a motion would change nothing: the encoders sit exactly at the set-point
        (none at -0.0, which adding the servo's zero step would turn to +0.0), as did the last two ticks'
        set-points, and they stand still. The stop (`lowest`) then holds them where they are."""
        at = self.setpoint.tobytes()
        return (
            at
            == self.encoder.tobytes()
            == self.tick_setpoint.tobytes()
            == self.previous_tick_setpoint.tobytes()
            and not self.velocity.any()
            and not np.signbit(self.velocity).any()
            and not np.signbit(self.encoder[self.encoder == 0.0]).any()
        )


class SimArm:
    """One PSM: joints, jaw, operating state and cable physics."""

    def __init__(
        self,
        name: str,
        settings: ArmSettings,
        physics: ArmPhysics,
        *,
        q0: ArrayLike = DEFAULT_JOINTS,
        jaw0: float = 0.0,
        servo_tau: float = DEFAULT_SERVO_TAU,
        enabled: bool = True,
    ) -> None:
        self.name = name
        self.settings = settings
        self.physics = physics
        self.period = settings.control_period
        self.state = "ENABLED" if enabled else "DISABLED"
        self.is_homed = enabled
        self.joints = JointGroup(
            q0,
            servo_tau,
            lambda q: guards.joint_problems(q, settings),
            lambda q, ref, seconds: guards.step_problems(q, ref, settings, seconds),
        )
        self.jaw = JointGroup(
            [jaw0],
            servo_tau,
            lambda a: guards.jaw_problems(a, settings),
            lambda a, ref, seconds: guards.jaw_step_problems(float(a[0]), float(ref[0]), settings, seconds),
        )
        initial = guards.joint_problems(self.joints.setpoint, settings) + guards.jaw_problems(jaw0, settings)
        guards.refuse_if(initial, f"{name} initial joints", "q0")
        self.physical = physics.reset(self.joints.encoder)

    @property
    def is_busy(self) -> bool:
        return self.joints.motion is not None or self.jaw.motion is not None

    def _refusal(self, command_id: str, problems: list[str]) -> list[Transition]:
        """The refusal of a command that finds the arm not ready or has `problems`; empty if it may run."""
        if self.state != "ENABLED":
            return [
                Transition(command_id, "refused", f"{self.name} is {self.state}; send state_command enable")
            ]
        if not self.is_homed:
            return [Transition(command_id, "refused", f"{self.name} is not homed; send state_command home")]
        return [Transition(command_id, "refused", "; ".join(problems))] if problems else []

    @staticmethod
    def _sized(values: ArrayLike, size: int) -> tuple[NDArray[np.float64], list[str]]:
        q = np.asarray(values, dtype=float).reshape(-1)
        return q, ([] if q.size == size else [f"expected {size} values, got {q.size}"])

    # ------------------------------------------------------------------ commands
    def servo_jp(self, q: ArrayLike, command_id: str) -> list[Transition]:
        q, problems = self._sized(q, 6)
        return self._refusal(command_id, problems) or self.joints.servo(q, command_id, self.period)

    def move_jp(self, goal: ArrayLike, command_id: str) -> list[Transition]:
        goal, problems = self._sized(goal, 6)
        refusal = self._refusal(command_id, problems or guards.joint_problems(goal, self.settings))
        if refusal:
            return refusal
        s = self.settings
        playback = goal_playback(
            command_id,
            self.joints.tick_setpoint,
            self.joints.setpoint_velocity(self.period),
            goal,
            s.planner_velocity,
            s.planner_acceleration,
            self.period,
        )
        # A profile from a moving start can overshoot a limit: refuse rather than clip.
        outside = guards.trajectory_problems(TrajectoryPoints(playback.times, playback.positions), s)
        return self._refusal(command_id, [f"planned profile: {p}" for p in outside]) or self.joints.start(
            playback
        )

    def follow_jt(
        self, t: ArrayLike, q: ArrayLike, qd: ArrayLike | None, command_id: str
    ) -> list[Transition]:
        trajectory = TrajectoryPoints(
            np.asarray(t, dtype=float),
            np.asarray(q, dtype=float),
            None if qd is None else np.asarray(qd, dtype=float),
        )
        problems = guards.trajectory_problems(trajectory, self.settings)
        if not problems:
            lead = max(float(trajectory.t[0]), self.period)
            problems = guards.step_problems(trajectory.q[0], self.joints.tick_setpoint, self.settings, lead)
        refusal = self._refusal(command_id, problems)
        if refusal:
            return refusal
        playback = trajectory_playback(
            command_id, self.joints.tick_setpoint, trajectory.t, trajectory.q, self.period
        )
        return self.joints.start(playback)

    def jaw_servo_jp(self, angle: ArrayLike, command_id: str) -> list[Transition]:
        angle, problems = self._sized(angle, 1)
        return self._refusal(command_id, problems) or self.jaw.servo(angle, command_id, self.period)

    def hold(self, jaw: bool, command_id: str, stopping: str = "") -> list[Transition]:
        """The robot's `hold`: the arm (or jaw) stops where it is commanded now (only the motion `stopping`,
        if named: `JointGroup.hold`); always accepted."""
        return (self.jaw if jaw else self.joints).hold(command_id, stopping)

    def jaw_move_jp(self, angle: ArrayLike, command_id: str) -> list[Transition]:
        angle, problems = self._sized(angle, 1)
        refusal = self._refusal(command_id, problems or guards.jaw_problems(angle, self.settings))
        if refusal:
            return refusal
        start = float(self.jaw.tick_setpoint[0])
        return self.jaw.start(
            ramp_playback(command_id, start, float(angle[0]), self.settings.jaw_velocity, self.period)
        )

    def state_command(self, command: str, command_id: str) -> list[Transition]:
        """CRTK state commands; disabling or unhoming aborts any motion."""
        if command == "enable":
            self.state = "ENABLED"
        elif command == "disable":
            self.state = "DISABLED"
        elif command == "home":
            self.is_homed = True
        elif command == "unhome":
            self.is_homed = False
        else:
            return [Transition(command_id, "refused", f"unknown state command {command!r}")]
        aborted = [] if self.state == "ENABLED" and self.is_homed else self.abort_all(f"{command} command")
        return aborted + [Transition(command_id, "done")]

    def abort_all(self, reason: str) -> list[Transition]:
        return self.joints.abort(reason) + self.jaw.abort(reason)

    # ------------------------------------------------------------------ time
    def advance(self, dt: float) -> list[Transition]:
        """One control tick: play motions, move encoders, run the cable physics."""
        transitions = self.joints.advance(dt) + self.jaw.advance(dt)
        # ideal cables: the physical joints are the encoders (and the simulator skips the model's arithmetic)
        self.physical = (
            self.joints.encoder if self.physics.is_ideal else self.physics.step(self.joints.encoder, dt)
        )
        return transitions
