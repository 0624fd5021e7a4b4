"""A simulated PSM that behaves as a dVRK 2.x PSM does behind its CRTK interface.

The joints, the jaw, their servo response and the cable physics are the simulator's (`SimArm`, driven
here by set-points only); what this class adds is the dVRK's controller, reproduced from jhu-dvrk/
sawIntuitiveResearchKit `core/components/code/mtsIntuitiveResearchKitArm.cpp` (Arm.cpp below) and
`mtsIntuitiveResearchKitPSM.cpp` (PSM.cpp), with the figures of `pegbt.sim.dvrk_config`:

- the arm's state machine (Arm.cpp `Init`, `SetDesiredState`, the `Enter*`/`Transition*`/`Run*` callbacks):
  DISABLED at start; `enable` powers it (POWERING, then ENABLED); `home` goes on through
  CALIBRATING_ENCODERS_FROM_POTS, ENCODERS_BIASED, HOMING (a trajectory to the homing goal, which for a
  PSM holding a tool is where it stands: PSM.cpp `SetGoalHomingArm`), HOMED, then engages the adapter and
  the tool (PSM.cpp `TransitionHomed`, `EnterEngagingAdapter`, `RunEngagingTool`: no motion, the tool's tip
  being past the cannula); `disable`, `pause`,
  `resume`, `unhome`; which command is valid in which state is cisst's `prmOperatingState::ValidCommand`
  (jhu-cisst/cisst `cisstParameterTypes/code/prmOperatingState.cpp`); a PSM is homed when powered, its
  encoders biased and its tool engaged (PSM.cpp `is_homed`);
- commands (Arm.cpp `servo_jp`, `move_jp`, `hold`; PSM.cpp `jaw_servo_jp`, `jaw_move_jp`): a command to an
  arm that is not ready is dropped with a warning at most every 2 s counting the drops (Arm.cpp
  `ArmIsReady`); commands act only in the HOMED state, the one whose run callback executes them (Arm.cpp
  `RunHomed`); every set-point is clipped to the joint limits (Arm.cpp `clip_jp`, PSM.cpp `clip_jaw_jp`,
  `servo_jp_internal`) and each clip of a command is a safety event; `move_jp` runs the dVRK's
  trajectory (`pegbt.sim.dvrk_trajectory`) and the arm is busy until it ends; switching from a move to
  `servo_jp` or `hold` ends the move where it is (Arm.cpp `SetControlSpaceAndMode`);
- FAULT when an actuator's set-point and measured position differ by more than its tolerance (jhu-saw/
  sawControllers `core/components/code/mtsPID.cpp`, relayed by Arm.cpp `ErrorEventHandler`); entering
  FAULT powers the arm off (Arm.cpp `EnterFault`, `IO.PowerOffSequence`), and a PSM has no brakes: nothing
  holds it until it is disabled and enabled again;
- every `UpdateOperatingStateAndBusy` and `UpdateIsBusy` of Arm.cpp publishes the operating state, changed
  or not, the homing sequence's intermediate ones too (`state_events`): a `move_jp` while busy republishes busy (Arm.cpp
  `control_move_jp_on_start`);
- the joints are valid only once the arm is powered and its encoders biased (PSM.cpp `is_joint_ready`),
  the tool's joints and the jaw only once the tool engages (PSM.cpp `is_cartesian_ready`); until then the
  dVRK sends zeros marked invalid, and the PID's seven joints (Arm.cpp `get_robot_data`,
  `UpdateStateJointKinematics`), which `pegbt.sim.dvrk_endpoint` publishes as the dVRK's bridge does;
- the clutch (PSM.cpp `EventHandlerManipClutch`): pressed on a ready arm, MANUAL (still ENABLED, homed and
  busy: PSM.cpp `EnterManual`), the PID off so that a person moves the arm (`free`), though a `servo_jp`
  that comes meanwhile is executed (PSM.cpp `RunManual` runs the control callback); released, back to the
  state before, holding where the arm is (PSM.cpp `LeaveManual`: `hold`).

Until HOMING (DISABLED, POWERING, ENABLED, the encoders' calibration), in FAULT and in MANUAL the PID is off
(Arm.cpp `EnterDisabled`, `EnterEnabled`, `EnterFault`; PSM.cpp `EnterManual`): the set-point follows the
encoders. Status, warning and error texts follow the dVRK's (`reports`); what the simulator's judge needs
(clips, dropped commands, faults) is in `safety`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.physics import ArmPhysics
from pegbt.psm import JOINT_LABELS
from pegbt.sim import dvrk_config as dvrk
from pegbt.sim.arm import DEFAULT_SERVO_TAU, SimArm
from pegbt.sim.dvrk_trajectory import OnlineTrajectory

# cisst's prmOperatingState::ValidCommand: DISABLED falls through to ENABLED's commands.
VALID_COMMANDS = {
    "DISABLED": ("enable", "disable", "pause", "unhome", "home"),
    "ENABLED": ("enable", "disable", "pause", "unhome", "home"),
    "PAUSED": ("disable", "pause", "resume", "unhome"),
    "FAULT": ("disable", "unhome"),
}
KNOWN_COMMANDS = ("enable", "disable", "home", "unhome", "pause", "resume")
PID_OFF = ("DISABLED", "POWERING", "ENABLED", "CALIBRATING_ENCODERS_FROM_POTS", "ENCODERS_BIASED")


@dataclass(frozen=True)
class Report:
    """A message on one of the arm's event topics: `status`, `warning` or `error`."""

    topic: str
    text: str


@dataclass(frozen=True)
class StateEvent:
    """An operating state the arm published: CRTK's state, homed, busy, and the dVRK's own state name."""

    state: str
    is_homed: bool
    is_busy: bool
    substate: str


@dataclass(frozen=True)
class SafetyEvent:
    """What the simulator's log records about a command or the arm: a clip, a dropped command, a fault."""

    event: str
    command: str = ""
    details: dict[str, Any] = field(default_factory=dict)


class DvrkArm:
    """One PSM with the dVRK's controller. Commands are methods; `advance` runs one control period."""

    def __init__(
        self,
        name: str,
        settings: ArmSettings,
        physics: ArmPhysics,
        *,
        q0: ArrayLike,
        jaw0: float = 0.0,
        servo_tau: float = DEFAULT_SERVO_TAU,
    ) -> None:
        self.name = name
        self.sim = SimArm(name, settings, physics, q0=q0, jaw0=jaw0, servo_tau=servo_tau, enabled=False)
        self.period = self.sim.period
        self.lower, self.upper, self.jaw_lower, self.jaw_upper = dvrk.clip_bounds(settings)
        self.reports: list[Report] = []
        self.safety: list[SafetyEvent] = []
        self.state = "DISABLED"  # the CRTK operating state
        self.is_busy = False
        self.current = "DISABLED"  # the dVRK's arm state
        self.desired = "DISABLED"
        self._powered = False
        self._biased = False
        self._adapter_engaged = False
        self._tool_engaged = False
        self._mode = ""  # "position" or "trajectory" while HOMED, else ""
        self._trajectory = OnlineTrajectory(
            self.period, dvrk.TRAJECTORY_VELOCITY, dvrk.TRAJECTORY_ACCELERATION
        )
        self.trajectory_ratio = {"v": 1.0, "a": 1.0}  # of the limits the trajectory runs at
        self._velocity = np.zeros(7)  # the trajectory's velocity at the last set-point
        self._homing_end = 0.0
        self._entered = 0.0
        self._resume = ("DISABLED", "DISABLED")
        self._not_ready_count = 0
        self._not_ready_last = -np.inf
        self.now = 0.0
        self._tracking_checked_from = 0.0
        self.state_events: list[StateEvent] = []  # operating states to publish (each `_operating`)
        self._clutch_from = ""  # the state MANUAL returns to when the clutch is released
        self._operating("DISABLED", False)  # Arm.cpp `EnterDisabled` at start

    # ------------------------------------------------------------------ what it reports
    @property
    def is_homed(self) -> bool:
        """PSM.cpp `is_homed` with a tool present: powered, encoders biased, adapter and tool engaged."""
        return self._powered and self._biased and self._adapter_engaged and self._tool_engaged

    @property
    def joint_ready(self) -> bool:
        """PSM.cpp `is_joint_ready`: the joints the dVRK reports are valid (powered, encoders biased)."""
        return self._powered and self._biased

    @property
    def cartesian_ready(self) -> bool:
        """PSM.cpp `is_cartesian_ready`: the tool's joints, the jaw and the tip's pose are valid."""
        return self.joint_ready and self._tool_engaged

    @property
    def setpoint(self) -> NDArray[np.float64]:
        """The seven set-points: six joints and the jaw."""
        return np.concatenate([self.sim.joints.setpoint, self.sim.jaw.setpoint])

    @property
    def measured(self) -> NDArray[np.float64]:
        return np.concatenate([self.sim.joints.encoder, self.sim.jaw.encoder])

    def _report(self, topic: str, text: str) -> None:
        self.reports.append(Report(topic, f"{self.name}: {text}"))

    def _operating(self, state: str, busy: bool) -> None:
        """Arm.cpp `UpdateOperatingStateAndBusy` (and `UpdateIsBusy`): published, changed or not."""
        self.state, self.is_busy = state, busy
        self.state_events.append(StateEvent(state, self.is_homed, busy, self.current))

    # ------------------------------------------------------------------ the state machine
    def _set_desired(self, state: str) -> None:
        """Arm.cpp `SetDesiredState`: DISABLED, PAUSED and FAULT are entered at once, others by transitions."""
        if state == "PAUSED" and self.current != "PAUSED":
            self._resume = (self.current, self.desired)  # Arm.cpp `EnterPaused`
        self.desired = state
        self._report("status", f"desired state {state}")
        if state in ("DISABLED", "PAUSED", "FAULT"):
            self._enter(state)

    def _enter(self, state: str) -> None:
        """Arm.cpp `StateChanged` and the state's enter callback."""
        self.current, self._entered = state, self.now
        self._report("status", f"current state {state}")
        if state in PID_OFF:
            self._mode = ""
            self._trajectory.active = False
        enter: Callable[[], None] | None = getattr(self, f"_enter_{state.lower()}", None)
        if enter is not None:
            enter()

    def _enter_disabled(self) -> None:
        self._powered = False
        self._operating("DISABLED", False)

    def _enter_powering(self) -> None:
        self._operating("DISABLED", True)
        self._report("status", "power requested")

    def _enter_enabled(self) -> None:
        self._powered = True
        self._operating("ENABLED", False)

    def _enter_calibrating_encoders_from_pots(self) -> None:
        self._operating("ENABLED", True)
        if self._biased:
            self._report("status", "encoders have already been calibrated, skipping")

    def _enter_encoders_biased(self) -> None:
        self._operating("ENABLED", False)

    def _enter_homing(self) -> None:
        self._operating("ENABLED", True)
        self._start_trajectory(self.setpoint)  # a PSM holding a tool homes where it stands
        self._homing_end = np.inf

    def _enter_homed(self) -> None:
        self._operating("ENABLED", False)
        self._mode = ""
        self._trajectory.active = False

    def _enter_engaging_adapter(self) -> None:
        self._operating("ENABLED", True)
        self._adapter_engaged = True  # a tool is present: the adapter is engaged (PSM.cpp)
        self._enter("HOMED")

    def _enter_engaging_tool(self) -> None:
        """PSM.cpp `RunEngagingTool`: a tool whose tip is past the cannula (25 mm from the remote centre,
        mtsIntuitiveResearchKit.h `EngageDepthCannula`) needs no engaging motion. pegbt's insertion limit
        (0.08 m, `skills/psm.yaml`) keeps every simulated tip past it."""
        self._operating("ENABLED", True)
        self._report(
            "status",
            'tool tip is outside the cannula, assuming it doesn\'t need to "engage".  If the tool is not '
            "engaged properly, move the sterile adapter all the way up and re-insert the tool.",
        )
        self._enter("TOOL_ENGAGED")

    def _enter_tool_engaged(self) -> None:
        self._tool_engaged = True
        self._operating("ENABLED", False)

    def _enter_paused(self) -> None:
        self._operating("PAUSED", False)

    def _enter_fault(self) -> None:
        self._powered = False
        self._operating("FAULT", False)
        self._mode = ""
        self._trajectory.active = False

    def _transition(self) -> bool:
        """One `Transition*` callback of the current state; whether the state changed."""
        state, elapsed = self.current, self.now - self._entered
        target = ""
        if state == "DISABLED" and self.desired != "DISABLED":
            target = "POWERING"
        elif state == "POWERING" and elapsed >= dvrk.POWER_ON_TIME - 1e-9:
            self._report("status", "power on")
            target = "ENABLED"
        elif state == "ENABLED" and self.desired != "ENABLED":
            target = "CALIBRATING_ENCODERS_FROM_POTS"
        elif state == "CALIBRATING_ENCODERS_FROM_POTS" and (
            self._biased or elapsed >= dvrk.ENCODER_BIAS_TIME - 1e-9
        ):
            self._biased = True
            target = "ENCODERS_BIASED"
        elif state == "ENCODERS_BIASED" and self.desired != state:
            target = "HOMING"
        elif state == "HOMED" and not self._adapter_engaged:
            target = "ENGAGING_ADAPTER"
        elif state == "HOMED" and not self._tool_engaged:
            target = "ENGAGING_TOOL"
        elif state == "TOOL_ENGAGED" and self.desired != state:
            target = "HOMED"
        if target:
            self._enter(target)
        return bool(target)

    # ------------------------------------------------------------------ state commands
    def state_command(self, command: str) -> None:
        """Arm.cpp `state_command`, checked by `prmOperatingState::ValidCommand`."""
        if command not in KNOWN_COMMANDS:
            self._report("warning", f"{command} doesn't seem to be a valid state_command (unknown command)")
            return
        if command not in VALID_COMMANDS[self.state]:
            self._report(
                "warning", f'command "{command}" is not supported in state "{self.state}" ({self.current})'
            )
            return
        if command == "enable":
            self._set_desired("ENABLED")
        elif command == "disable":
            self._set_desired("DISABLED")
        elif command == "home":
            self._set_desired("HOMED")
        elif command == "pause":
            self._set_desired("PAUSED")
        elif command == "unhome":
            self._tool_engaged = False  # PSM.cpp `unhome` with a tool present
            self._operating(self.state, self.is_busy)
        else:  # resume
            current, self.desired = self._resume
            self._enter(current)

    def clutch(self, pressed: bool) -> None:
        """The arm's clutch button (PSM.cpp `EventHandlerManipClutch`): pressed on an arm ENABLED with valid
        joints, MANUAL; released, back to the state it was in, holding where the arm is."""
        if pressed and self.current != "MANUAL":
            if self.state == "ENABLED" and self.joint_ready:
                self._clutch_from = self.current
                self._enter("MANUAL")
            else:
                self._report("warning", "arm not ready yet, manipulator clutch ignored")
        elif not pressed and self.current == "MANUAL":
            self._operating("ENABLED", False)  # PSM.cpp `LeaveManual`
            self._hold_where_measured()
            self._mode = "position"
            self._enter(self._clutch_from)

    def trajectory_j_set_ratio(self, kind: str, ratio: float) -> bool:
        """Arm.cpp `trajectory_j_set_ratio_v` (`kind` "v") or `_a` ("a"): `move_jp` and homing run at `ratio`
        of the trajectory's velocity (acceleration) limits from now on; a ratio outside ]0, 1] is refused
        with a warning. True if taken (the arm then publishes its ratio)."""
        if not 0.0 < ratio <= 1.0:
            self._report(
                "warning", f"trajectory_j_set_ratio_{kind}, ratio must be within ]0;1], received {ratio:g}"
            )
            return False
        self.trajectory_ratio[kind] = ratio
        self._trajectory.limit(
            dvrk.TRAJECTORY_VELOCITY * self.trajectory_ratio["v"],
            dvrk.TRAJECTORY_ACCELERATION * self.trajectory_ratio["a"],
        )
        return True

    def _enter_manual(self) -> None:
        """PSM.cpp `EnterManual`: busy, and `free`: the PID off until a command comes."""
        self._operating("ENABLED", True)
        self._mode = ""
        self._trajectory.active = False

    # ------------------------------------------------------------------ motion commands
    def _ready(self, method: str, cartesian: bool) -> bool:
        """Arm.cpp `ArmIsReady`: ENABLED and powered with biased encoders (and an engaged tool for the jaw,
        which needs the cartesian space); else a warning, at most every 2 s, counting the drops. A ready arm
        acts on a command only in the HOMED state."""
        ready = self.state == "ENABLED" and self._powered and self._biased
        if ready and (self._tool_engaged or not cartesian):
            self._not_ready_count, self._not_ready_last = 0, -np.inf
            if self.current in ("HOMED", "MANUAL"):  # PSM.cpp `RunManual` runs the control callback too
                return True
            self.safety.append(SafetyEvent("ignored", method, {"substate": self.current}))
            return False
        if self.now - self._not_ready_last > dvrk.NOT_READY_THROTTLE:
            count = f" ({self._not_ready_count} errors)" if self._not_ready_count > 1 else ""
            self._report("warning", f"{method}, arm not ready{count}")
            self._not_ready_last = self.now
            details = {"state": self.state, "substate": self.current, "dropped_before": self._not_ready_count}
            self.safety.append(SafetyEvent("not_ready", method, details))
        self._not_ready_count += 1
        return False

    def servo_jp(self, positions: ArrayLike) -> None:
        q = self._positions(positions, 6, "servo_jp")
        if q is None or not self._ready("servo_jp", cartesian=False):
            return
        self._position_mode()
        self.sim.joints.setpoint = self._clip_joints(q, "servo_jp")

    def move_jp(self, positions: ArrayLike) -> None:
        q = self._positions(positions, 6, "move_jp")
        if q is None or not self._ready("move_jp", cartesian=False):
            return
        goal = self._trajectory_mode()
        goal[:6] = self._clip_joints(q, "move_jp")
        self._trajectory.retarget(goal)
        self._operating(self.state, True)

    def hold(self) -> None:
        if self._ready("hold", cartesian=False):
            self._position_mode()

    def jaw_servo_jp(self, positions: ArrayLike) -> None:
        angle = self._positions(positions, 1, "jaw/servo_jp")
        if angle is None or not self._ready("jaw_servo_jp", cartesian=True):
            return
        self._position_mode()
        self.sim.jaw.setpoint = self._clip_jaw(angle, "jaw/servo_jp")

    def jaw_move_jp(self, positions: ArrayLike) -> None:
        angle = self._positions(positions, 1, "jaw/move_jp")
        if angle is None or not self._ready("jaw_move_jp", cartesian=True):
            return
        goal = self._trajectory_mode()
        goal[6] = self._clip_jaw(angle, "jaw/move_jp")[0]
        self._trajectory.retarget(goal)
        self._operating(self.state, True)

    def _positions(self, values: ArrayLike, size: int, command: str) -> NDArray[np.float64] | None:
        """The command's positions; None (refused, and said on `warning`) if they are not `size` finite
        numbers. The dVRK does not check; a simulator that passed NaN on would move nothing sensibly."""
        q = np.asarray(values, dtype=float).reshape(-1)
        if q.size == size and np.all(np.isfinite(q)):
            return q
        reason = f"expected {size} finite positions, got {q.tolist()}"
        self._report("warning", f"{command}, {reason}")
        self.safety.append(SafetyEvent("refused", command, {"reason": reason}))
        return None

    def _clip_joints(self, q: NDArray[np.float64], command: str) -> NDArray[np.float64]:
        clipped = np.clip(q, self.lower, self.upper)
        if np.any(clipped != q):
            joints = [JOINT_LABELS[i] for i in np.flatnonzero(clipped != q)]
            self.safety.append(
                SafetyEvent(
                    "clip", command, {"requested": q.tolist(), "clipped": clipped.tolist(), "joints": joints}
                )
            )
        return clipped

    def _clip_jaw(self, angle: NDArray[np.float64], command: str) -> NDArray[np.float64]:
        clipped = np.clip(angle, self.jaw_lower, self.jaw_upper)
        if np.any(clipped != angle):
            self.safety.append(
                SafetyEvent(
                    "clip",
                    command,
                    {"requested": angle.tolist(), "clipped": clipped.tolist(), "joints": ["jaw"]},
                )
            )
        return clipped

    def _position_mode(self) -> None:
        """Arm.cpp `SetControlSpaceAndMode` to position: a move in progress ends where it is."""
        if self._mode == "position":
            return
        if self._trajectory.active:
            self._trajectory.active = False
            self._operating(self.state, False)
        self._mode = "position"
        self._report("status", "control JOINT_SPACE/POSITION_MODE")

    def _trajectory_mode(self) -> NDArray[np.float64]:
        """Arm.cpp `SetControlSpaceAndMode` to trajectory, starting from the set-point, at the measured
        velocity when servoing was under way; the goal to change (the move's, or where the arm stands)."""
        if self._mode != "trajectory":
            moving = self._mode == "position"
            self._mode = "trajectory"
            self._report("status", "control JOINT_SPACE/TRAJECTORY_MODE")
            velocity = np.concatenate([self.sim.joints.velocity, self.sim.jaw.velocity]) if moving else None
            self._start_trajectory(self.setpoint, velocity)
        elif not self._trajectory.active:
            self._start_trajectory(self.setpoint)
        return self._trajectory.goal

    def _start_trajectory(
        self, goal: NDArray[np.float64], velocity: NDArray[np.float64] | None = None
    ) -> None:
        self._trajectory.start(self.setpoint, np.zeros(7) if velocity is None else velocity, goal)

    # ------------------------------------------------------------------ time
    def advance(self, now: float) -> None:
        """One control period ending at `now` (s since the simulator started)."""
        self.now = now
        if self.current == "HOMING" or (self.current in ("HOMED", "MANUAL") and self._mode == "trajectory"):
            self._run_trajectory()
        for _ in range(12):  # a chain of immediate transitions settles within one period
            if not self._transition():
                break
        if (
            self.current in PID_OFF
            or self.current == "FAULT"
            or (self.current == "MANUAL" and not self._mode)
        ):
            self._hold_where_measured()
        elif self.current not in ("FAULT", "PAUSED") and self.now >= self._tracking_checked_from:
            self._check_tracking()
        self.sim.advance(self.period)

    def _run_trajectory(self) -> None:
        if not self._trajectory.active:
            self._trajectory_ended()
            return
        try:
            position, _ = self._trajectory.step()
        except PegbtError as error:
            self._report("error", error.message)
            self._set_desired("FAULT")
            return
        self.sim.joints.setpoint = np.clip(position[:6], self.lower, self.upper)
        self.sim.jaw.setpoint = np.clip(position[6:], self.jaw_lower, self.jaw_upper)
        if not self._trajectory.active:
            self._homing_end = min(self._homing_end, self.now)
            self._trajectory_ended()

    def _trajectory_ended(self) -> None:
        """Arm.cpp `control_move_jp_on_stop`, and `RunHoming`'s goal check."""
        if self.current == "HOMED" and self.is_busy:
            self._operating(self.state, False)  # Arm.cpp `control_move_jp_on_stop`
        elif self.current == "HOMING":
            error = np.abs(self._trajectory.goal - self.measured)
            if np.all(error < dvrk.HOMING_TOLERANCE):
                self._enter("HOMED")
            elif self.now > self._homing_end + dvrk.HOMING_EXTRA_TIME:
                self._report("error", "unable to reach home position during calibration on pots")
                self._set_desired("FAULT")

    def _hold_where_measured(self) -> None:
        """The PID is off: its set-point is the measured position (sawControllers mtsPID.cpp)."""
        self.sim.joints.setpoint = self.sim.joints.encoder.copy()
        self.sim.jaw.setpoint = self.sim.jaw.encoder.copy()

    def excuse_tracking(self, until: float) -> None:
        """No tracking-error check before `until` (s): the simulator itself ran late, and the set-points that
        queued meanwhile arrive at once, a jump no real controller, whose loop never runs late, would see."""
        self._tracking_checked_from = max(self._tracking_checked_from, until)

    def _check_tracking(self) -> None:
        """mtsPID.cpp's tracking-error check, on the actuators (joints through the tool's coupling)."""
        errors = dvrk.actuator_errors(self.setpoint - self.measured)
        beyond = np.abs(errors) > dvrk.ACTUATOR_TOLERANCE
        if not np.any(beyond):
            return
        mask = " ".join("1" if flag else "0" for flag in beyond)
        self._report("error", f"received [{self.name}-PID: tracking error, mask (1 for error): {mask}]")
        self.safety.append(
            SafetyEvent(
                "tracking_error",
                details={
                    "actuator_errors": np.round(errors, 6).tolist(),
                    "tolerances": dvrk.ACTUATOR_TOLERANCE.tolist(),
                },
            )
        )
        self._set_desired("FAULT")
