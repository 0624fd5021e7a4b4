"""The `robot` resource: both PSMs and the depth camera over one zenoh link, and the run's clock.

`--endpoint auto` starts the embedded simulator (`pegbt sim --lockstep --physics dvrk-real`) as a child
process on a free loopback port; an address connects to a simulator or a robot already running there.
A simulator answers `sim/clock`: its `SimClock` becomes the run's clock (lockstep: time advances only when
the executive waits) and its ground truth (`sim/truth`) judges the trial. Anything else is a
robot, run on the wall clock and judged by what the executive believes.
"""

from __future__ import annotations

from typing import Any

from pegbt.behaviours.trial import Trial
from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.executive.providers import ProviderSetup
from pegbt.psm import ARMS
from pegbt.sim.process import SimProcess
from pegbt.sim.truth import ask_truth
from pegbt.transport import ArmClient, CameraClient, EndpointSilent, Link, SimClock, connect

SIMULATOR_ARGS = ("--lockstep", "--physics", "dvrk-real")
PROBE_TIMEOUT = 2.0  # s to wait for a simulator to answer `sim/clock` at an address (no answer: a robot)
STEP_TIMEOUT = 5.0  # s to wait for a lockstep step: a camera capture on a loaded 2-core machine took over 2
READY_TIMEOUT = 5.0  # s to wait for each arm's first state


class SimulatorTruth:
    """The simulator's ground truth, for the judge only (behaviours know the world through camera and arms)."""

    def __init__(self, link: Link) -> None:
        self._link = link

    def entries(self, clock: Clock) -> list[dict[str, Any]]:
        """Every entry of the simulator's log so far (world events, injected faults), in order, each `time`
        on `clock` (the simulator logs seconds since it started)."""
        truth = ask_truth(self._link)
        offset = clock.now() - truth.time
        return [{**entry, "time": entry["time"] + offset} for entry in truth.log]


class Robot:
    """Arms, camera and clock of one run; `trial` records the transfers for the judge."""

    def __init__(
        self,
        link: Link,
        clock: Clock,
        *,
        simulator: SimProcess | None = None,
        lockstep: bool = False,
        truth: SimulatorTruth | None = None,
        endpoint: str = "",
    ) -> None:
        self.link = link
        self.run_clock = clock
        self.simulator = simulator
        self.lockstep = lockstep
        self.truth = truth
        self.endpoint = endpoint
        self.arms = {name: ArmClient(link, name, clock=clock) for name in ARMS}
        self.camera = CameraClient(link, clock=clock)
        self.trial = Trial(clock, truth)

    def arm(self, name: str) -> ArmClient:
        if name not in self.arms:
            raise PegbtError(f"unknown arm {name!r}; known: {', '.join(self.arms)}", field="arm")
        return self.arms[name]

    def wait_until_ready(self) -> None:
        for arm in self.arms.values():
            arm.wait_until_ready(READY_TIMEOUT)

    def report(self) -> Any:
        """The judged trial (None when the tree moved no block)."""
        return self.trial.result() if self.trial.transfers else None

    def progress(self) -> Any:
        return self.trial.progress_listener()

    def close(self) -> None:
        self.link.close()
        if self.simulator is not None:
            self.simulator.stop()


def _probe_simulator(link: Link) -> SimClock | None:
    """The simulator's clock if a simulator answers at the other end of `link`, else None (a robot). Only
    the probe is short: a step (a camera capture, say) may take longer on a busy machine."""
    try:
        return SimClock(link, reply_timeout=STEP_TIMEOUT, probe_timeout=PROBE_TIMEOUT)
    except PegbtError:
        return None


def connect_robot(
    endpoint: str, seed: int = 0, faults: str | None = None, simlog: str | None = None
) -> Robot:
    """A `Robot` on `endpoint` (`auto`: a fresh embedded simulator seeded with `seed`, injecting the fault
    plan `faults` if given, appending its log to `simlog` if given)."""
    for value, flag, sim_flag in ((faults, "--faults", "--faults"), (simlog, "--simlog", "--log")):
        if value is not None and endpoint != "auto":
            raise PegbtError(
                f"{flag} is for the embedded simulator (--endpoint auto); give `pegbt sim {sim_flag}` to a "
                "simulator you start yourself",
                field=flag,
            )
    simulator = None
    if endpoint == "auto":
        simulator = SimProcess(
            [
                *SIMULATOR_ARGS,
                "--seed",
                str(seed),
                *(["--faults", faults] if faults else []),
                *(["--log", simlog] if simlog else []),
            ]
        )
    try:
        link = connect([simulator.endpoint if simulator else endpoint])
        try:
            # the simulator we started must answer, however busy the machine: no probe timeout for it
            sim_clock = (
                SimClock(link, reply_timeout=STEP_TIMEOUT)
                if simulator is not None
                else _probe_simulator(link)
            )
            truth = SimulatorTruth(link) if sim_clock is not None else None
            robot = Robot(
                link,
                sim_clock or WallClock(),
                simulator=simulator,
                truth=truth,
                lockstep=bool(sim_clock and sim_clock.lockstep),
                endpoint=endpoint,
            )
            try:
                robot.wait_until_ready()
            except EndpointSilent as error:
                where = simulator.endpoint if simulator else endpoint
                raise EndpointSilent(
                    f"no endpoint answered at {where}: {error.message}", field=error.field
                ) from None
        except BaseException:
            link.close()
            raise
    except BaseException:
        if simulator is not None:
            simulator.stop()
        raise
    return robot


def provide_robot(setup: ProviderSetup) -> Robot:
    """The `robot` resource for `pegbt run` (options `endpoint`, `seed`, `faults` and `simlog`)."""
    options = setup.options
    return connect_robot(
        str(options.get("endpoint") or "auto"),
        int(options.get("seed") or 0),
        options.get("faults"),
        options.get("simlog"),
    )
