"""Base classes of the peg-transfer leaves: resources, failures with reasons, and non-blocking motions.

A `RobotLeaf` fetches the `robot` and `skills` resources in `setup()`. Anything the world or a user
can cause (an unreachable pose, a refused command, a poor fit) arrives as a `PegbtError`; the leaf
then fails with the error's text as its feedback message, so the tick log and `pegbt log why` say why.
An endpoint that went silent is different: no recovery in a tree can bring it back, so `EndpointSilent`
propagates, and the runner halts the tree (every motion told to stop), logs the cause and ends the
run. Other exceptions are bugs and crash the run the same way.

A `MotionLeaf` starts its motions in `initialise` (one per arm or jaw, planned and sent at once), polls
them in `update` and, when halted, stops whatever still moves in `terminate`. It never blocks a tick.
Before an arm motion is sent, it is checked against where the other arm is meant to be at the same
times (moving or at rest): if the tools would come closer than `keep_apart`, nothing is sent and the
leaf waits, planning again a little later, until the way is clear (or fails after `BLOCKED_PATIENCE`).
Two arms can block each other, each resting in the other's way; then the one that is not carrying a
block and started waiting last steps back: it withdraws its tool along its own shaft (insertion only,
which takes the tool away from everything), and plans again from there.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from py_trees.common import Status

from pegbt.behaviours.arm_motion import ArmMotion
from pegbt.behaviours.robot import Robot
from pegbt.behaviours.skills import Skills
from pegbt.errors import PegbtError
from pegbt.executive.leaf import Leaf
from pegbt.executive.params import Param
from pegbt.motion.trajectory import Trajectory
from pegbt.psm import ARMS
from pegbt.transport import ArmClient, EndpointSilent, MotionHandle

log = logging.getLogger("pegbt.behaviours")
RESOURCES = ("robot", "skills")
BLOCKED_RETRY = 0.1  # s between attempts of a motion that would come too close to the other arm
BLOCKED_PATIENCE = 15.0  # s a motion waits for the other arm to clear its way before the leaf fails
MAX_KEEP_APART = 0.1  # m between the tools' axes: farther apart than the two arms' shared workspace allows
STEP_BACK = 0.03  # m of insertion an arm gives up to let the other arm past


class Blocked(Exception):
    """A motion not sent because it would bring the arms too close; the leaf waits and tries again."""


def arm_param(doc: str = "which arm", *, blackboard: bool = False) -> Param:
    return Param("arm", str, doc, choices=ARMS, blackboard=blackboard)


def peg_param(name: str, doc: str) -> Param:
    return Param(name, int, doc, choices=tuple(range(12)), blackboard=True)


def keep_apart_param(default: float | None = None) -> Param:
    """`keep_apart`, by default skills/motion.yaml's `two_arms.keep_apart` (read when the leaf runs)."""
    from_skills = " (None: two_arms.keep_apart of skills/motion.yaml)" if default is None else ""
    return Param(
        "keep_apart",
        float,
        f"m: an arm motion waits until it keeps the tools this far apart{from_skills}; 0: "
        "no check, for the handover, where the tools meet on purpose",
        default=default,
        minimum=0.0,
        maximum=MAX_KEEP_APART,
    )


def key_param(name: str, access: str, doc: str) -> Param:
    """A parameter naming the blackboard key where a leaf reads or writes `name` (default: `name` itself,
    in the leaf's namespace; shared subtrees use per-arm keys such as `/PSM1/grasp`)."""
    return Param(
        name, str, f"key {'read' if access == 'read' else 'written'}: {doc}", default=name, key=access
    )


class RobotLeaf(Leaf):
    """A leaf using the robot and the skills; `PegbtError`s from `act()` fail it with their reason."""

    def setup(self, **kwargs: object) -> None:
        self.robot = self.context.resource("robot", Robot)
        self.skills = self.context.resource("skills", Skills)

    def client(self, arm: str | None = None) -> ArmClient:
        return self.robot.arm(arm or self.param("arm"))

    def motion(self, arm: str | None = None) -> ArmMotion:
        return self.skills.arm(arm or self.param("arm"))

    def get(self, name: str) -> object:
        """The value of the blackboard key named by key parameter `name`."""
        return self.read(self.params[name])

    def put(self, name: str, value: object) -> None:
        """Write the blackboard key named by key parameter `name`."""
        self.write(self.params[name], value)

    def fail(self, reason: str) -> Status:
        self.feedback_message = reason
        return Status.FAILURE

    def update(self) -> Status:
        try:
            return self.act()
        except EndpointSilent:
            raise
        except PegbtError as error:
            return self.fail(str(error))

    def act(self) -> Status:
        """One tick's work (instant leaves do everything here)."""
        raise NotImplementedError


@dataclass
class Running:
    """A motion this leaf started: what it is, its handle, how to stop it."""

    what: str
    handle: MotionHandle
    stop: Callable[[], None]


class MotionLeaf(RobotLeaf):
    """A leaf whose work is motions: `begin()` starts them with `move`/`move_jaw`; `done()` judges the result."""

    may_step_back = True  # False for motions that carry a block: withdrawing would drag it off its peg

    def initialise(self) -> None:
        self.running: list[Running] = []
        self.problem: str | None = None
        self.feedback_message = ""
        self.expected_end = self.wake_at = None
        self.blocked_since: float | None = None
        self.stepping_back: Running | None = None
        self.stepped_back = False
        self._start()

    def _start(self) -> None:
        """Plan and send (`begin`); a motion that would come too close to the other arm leaves the leaf waiting."""
        arm = self.param("arm")
        try:
            self.begin()
            self.blocked_since = self.skills.waiting[arm] = None
        except Blocked as blocked:
            now = self.context.clock.now()
            if self.blocked_since is None:
                self.blocked_since = self.skills.waiting[arm] = now
            self.feedback_message = f"waiting: {blocked}"
            self.wake_at = now + BLOCKED_RETRY
        except EndpointSilent:
            raise
        except PegbtError as error:
            self.problem = str(error)
            self.halt_motions()

    def _wait_for_the_way(self) -> Status:
        """A tick while blocked by the other arm: step back if both arms wait on each other, try again, give up."""
        now = self.context.clock.now()
        if self.stepping_back is not None:
            if self.stepping_back.handle.failed:
                return self.fail(f"{self.stepping_back.what}: {self.stepping_back.handle.error}")
            if self.stepping_back.handle.busy:
                return Status.RUNNING
            self.stepping_back = None
        elif self._should_step_back():
            self._step_back()
            return Status.RUNNING
        if now - self.blocked_since > BLOCKED_PATIENCE:
            return self.fail(f"gave up after {BLOCKED_PATIENCE:g} s {self.feedback_message}")
        if now >= self.wake_at - 1e-9:
            self._start()
        return Status.RUNNING if self.problem is None else self.fail(self.problem)

    def _should_step_back(self) -> bool:
        """This arm gives way when the other arm waits too, and waited first (or as long)."""
        if not self.may_step_back or self.stepped_back:
            return False
        others = [
            since
            for arm, since in self.skills.waiting.items()
            if arm != self.param("arm") and since is not None
        ]
        return bool(others) and min(others) <= self.blocked_since

    def _step_back(self) -> None:
        """Withdraw the tool along its shaft by `STEP_BACK` (insertion only: away from everything around it)."""
        arm = self.param("arm")
        client, motion = self.client(arm), self.motion(arm)
        start = motion.start_from(client)
        target = start.copy()
        target[2] = max(motion.settings.lower[2], start[2] - STEP_BACK)
        handle = motion.send(client, motion.through(start, [target], ["stepped back"]))
        self.stepping_back = Running(
            f"{arm} stepping back for the other arm", handle, lambda: motion.stop(client)
        )
        self.running.append(self.stepping_back)
        self.stepped_back = True
        self.feedback_message = f"{arm} steps back along its shaft: both arms were waiting for each other"

    def begin(self) -> None:
        raise NotImplementedError

    def move(self, arm: str, trajectory: Trajectory, what: str) -> None:
        """Send a planned arm trajectory (compensated by the condition's skills), unless it would bring the
        tools closer than `keep_apart` (then `Blocked`: nothing is sent)."""
        client, motion = self.client(arm), self.motion(arm)
        keep_apart = self.params.get("keep_apart", 0.0)
        if keep_apart is None:
            keep_apart = self.skills.motion.two_arms.keep_apart
        if keep_apart > 0:
            others = {
                name: other.setpoint_js.position for name, other in self.robot.arms.items() if name != arm
            }
            gap = self.skills.clearance(arm, trajectory, self.context.clock.now(), others)
            if gap < keep_apart:
                raise Blocked(
                    f"{what} would bring the tools within {gap * 1000:.1f} mm of each other "
                    f"(keep apart {keep_apart * 1000:.0f} mm)"
                )
        handle = motion.send(client, trajectory)
        self.running.append(Running(what, handle, lambda: motion.stop(client)))
        self._expect(trajectory.duration)

    def move_jaw(self, arm: str, angle: float, what: str) -> None:
        jaw = self.client(arm).jaw
        seconds = abs(angle - float(jaw.setpoint_js.position[0])) / self.motion(arm).settings.jaw_velocity
        handle = jaw.move_jp(angle)
        self.running.append(Running(what, handle, handle.stop))
        self._expect(seconds)

    def _expect(self, seconds: float) -> None:
        """Note that a motion of `seconds` started: the runner need not tick this leaf before it ends."""
        end = self.context.clock.now() + seconds
        self.expected_end = end if self.expected_end is None else max(self.expected_end, end)

    def act(self) -> Status:
        if self.problem is not None:
            return self.fail(self.problem)
        if self.blocked_since is not None:
            return self._wait_for_the_way()
        for motion in self.running:
            if motion.handle.failed:
                self.halt_motions()
                return self.fail(f"{motion.what}: {motion.handle.error}")
        if any(motion.handle.busy for motion in self.running):
            ahead = self.expected_end is not None and self.context.clock.now() < self.expected_end
            self.wake_at = self.expected_end if ahead else None
            return self.watch()
        self.wake_at = None
        return self.done()

    def watch(self) -> Status:
        """Called on ticks while motions run; a subclass may fail early (a slipping block) and may ask to be
        ticked sooner by lowering `wake_at`."""
        return Status.RUNNING

    def done(self) -> Status:
        """Called once every motion finished; SUCCESS unless a subclass checks otherwise."""
        return Status.SUCCESS

    def update(self) -> Status:
        status = super().update()
        if status == Status.FAILURE:
            self.halt_motions()
        return status

    def terminate(self, new_status: Status) -> None:
        if getattr(self, "blocked_since", None) is not None:
            self.skills.waiting[self.param("arm")] = None
        if new_status == Status.INVALID:
            self.halt_motions()

    def halt_motions(self) -> None:
        """Stop every motion still running; an unreachable endpoint is logged (there is nothing left to stop)."""
        for motion in getattr(self, "running", []):
            try:
                if motion.handle.busy:
                    motion.stop()
            except PegbtError as error:
                log.warning("%s: could not stop %s: %s", self.name, motion.what, error)
        self.running = []
