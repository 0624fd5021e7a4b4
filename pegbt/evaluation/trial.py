"""One evaluation trial: a task variant's tree on a fresh simulator (dvrk-real physics, perception
noise; lockstep, or real time with the run on the wall clock), seeded, judged by the simulator's ground
truth, distilled into plain data.

A fresh simulator per trial: the simulator has no reset, and its start-up (≈1.6 s) is the price of a
clean world, a fresh seed and identical results whatever ran before. With pegbt's interface the run
starts it (`--endpoint auto`); with another the trial starts it itself, as `pegbt sim --interface` in
a shell would be, and the run connects to its address with `--interface`. `run_trial` is what a
worker process calls, so its argument and result are picklable.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pegbt.behaviours.resources.robot import SIMULATOR_ARGS, simulated_world
from pegbt.behaviours.resources.skills import SIMULATOR_CALIBRATION
from pegbt.behaviours.resources.trial import count_contacts
from pegbt.errors import PegbtError
from pegbt.evaluation.truth import count_safety, failure_cause, injected_faults
from pegbt.executive.runoptions import RunOptions
from pegbt.sim.log import read_sim_log
from pegbt.sim.process import SimProcess

if TYPE_CHECKING:
    from pegbt.executive.session import RunOutput

TREES = Path(__file__).resolve().parents[2] / "trees"
# A trial that has not ended after this much simulated time is stopped (a tree that loops, a hung recovery):
# the paper's trials took 40–75 s; recoveries, uncalibrated, take a few times that.
TRIAL_TIMEOUT_S = 600.0
INTERFACES = ("pegbt", "dvrk")  # pegbt: pegbt's own topics and extensions; dvrk: what a dVRK 2.x serves


@dataclass(frozen=True)
class TrialSpec:
    variant: str
    condition: str
    seed: int
    log: Path  # where the tick log goes
    faults: Path | None = None  # fault plan for the simulator
    keep_log: bool = False  # keep the tick log of a trial in which every transfer succeeded
    tree: Path | None = None  # another tree than the variant's (tests: a short task)
    realtime: bool = False  # the simulator in real time and the run on the wall clock (else lockstep)
    interface: str = "pegbt"  # what the simulator serves and the run speaks (`INTERFACES`)
    world_effects: Path | None = None  # world file for the simulator (`pegbt sim --world-effects`)
    camera: str = "stream"  # the dVRK interface's depth camera: streaming, or a Zivid's capture service
    speed: float = 1.0  # the fraction of the planner's speed (`pegbt run --speed`)
    robot_clock_offset: float = 0.0  # s the simulated robot's clock is from this one's (`--interface dvrk`)
    protocol: str = "pegbt"  # the trees' own, or the reference paper's (`pegbt run --protocol`)


@dataclass
class TrialRecord:
    """A judged trial as plain data: figures, one dict per transfer (with the simulator's cause of each
    failure), the injected faults and, for failed transfers, whether `pegbt log why` agrees."""

    variant: str
    condition: str
    seed: int
    outcome: str  # the tree's: success, failure, error
    error: str = ""
    transfers_attempted: int = 0
    transfers_succeeded: int = 0
    mean_transfer_time_s: float | None = None
    trial_time_s: float = 0.0  # simulated
    wall_time_s: float = 0.0  # of the trial itself
    run_wall_s: float = 0.0  # including the simulator's start-up
    arm_arm_collisions: int = 0
    other_contacts: int = 0
    commands_clipped: int = 0  # by the simulator, to the dVRK's limits (its `--interface dvrk`)
    arm_faults: int = 0  # times an arm entered FAULT (its `--interface dvrk`)
    tip_path_m: float = 0.0  # planned tool-tip path, both arms
    fallbacks: int = 0  # optimised plans that fell back to cubics
    overruns: int = 0  # ticks that took longer than the period
    compute_waited_s: float = 0.0  # wall time from asking for perception or planning to picking it up
    compute_s: float = 0.0  # wall time the worker threads computed
    log: str = ""  # kept tick log ("" if deleted)
    transfers: list[dict[str, Any]] = field(default_factory=list)
    faults: list[dict[str, Any]] = field(default_factory=list)
    why: list[dict[str, Any]] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """Every transfer placed, as the simulator judged."""
        return (
            self.outcome != "error"
            and self.transfers_attempted > 0
            and self.transfers_succeeded == self.transfers_attempted
        )


def tree_path(variant: str) -> Path:
    return TREES / f"{variant}.yaml"


def run_trial(spec: TrialSpec) -> TrialRecord:
    """Run and judge one trial. A trial that cannot run (simulator gone, bad plan) is an `error` record."""
    from pegbt.evaluation.why import check_why
    from pegbt.executive.logfile import read_tick_log

    truth = truth_path(spec.log)
    truth.unlink(missing_ok=True)  # the simulator appends
    record = TrialRecord(spec.variant, spec.condition, spec.seed, "error")
    started = time.perf_counter()
    try:
        output = _run(spec, truth)
    except PegbtError as error:
        record.error, record.run_wall_s = str(error), time.perf_counter() - started
        record.log = str(spec.log) if spec.log.exists() else ""
        if truth.exists():  # kept, beside the tick log: a fault may be why the run stopped
            record.commands_clipped, record.arm_faults = count_safety(read_sim_log(truth))
        return record
    record.run_wall_s = time.perf_counter() - started
    record.outcome, record.trial_time_s = output.result.outcome, output.result.duration
    record.overruns = output.result.overruns
    record.compute_waited_s = output.result.work.waited_s
    record.compute_s = output.result.work.compute_s
    entries = read_sim_log(truth)
    record.arm_arm_collisions, record.other_contacts = count_contacts(entries)
    record.commands_clipped, record.arm_faults = count_safety(entries)
    judged, skills = output.reports.get("robot"), output.reports.get("skills")
    if skills is not None:
        record.tip_path_m = sum(skills.tip_path_m.values())
        record.fallbacks = sum(skills.fallbacks.values())
    if judged is not None:
        if not judged.judged_by.startswith("the simulator"):
            record.outcome, record.error = (
                "error",
                f"the run was not judged by the simulator: {judged.judged_by}",
            )
            return record
        _fill_from_judge(record, judged.as_dict())
    log = read_tick_log(spec.log)
    record.transfers_attempted = max(
        len(record.transfers), sum(node["type"] == "begin_transfer" for node in log.nodes)
    )
    for transfer in record.transfers:
        cause = None if transfer["succeeded"] else failure_cause(transfer, entries, record.transfers)
        transfer["cause"], transfer["cause_event"] = (cause.step, cause.event) if cause else ("", "")
    record.faults = [
        asdict(fault) for fault in injected_faults(record.transfers, entries, record.outcome == "success")
    ]
    failed = [transfer for transfer in record.transfers if not transfer["succeeded"]]
    if failed or record.outcome != "success":
        record.why = [
            {**asdict(check), "agrees": check.agrees} for check in check_why(log, record.transfers, entries)
        ]
    if spec.keep_log or not record.complete or record.faults or record.commands_clipped or record.arm_faults:
        record.log = str(spec.log)
    else:
        spec.log.unlink(missing_ok=True)
        truth.unlink(missing_ok=True)
    return record


def _run(spec: TrialSpec, truth: Path) -> RunOutput:
    """The trial's run. pegbt's interface: on the embedded simulator (`--endpoint auto`, in real time with
    `--clock wall`), which the run knows for a simulator without asking (a probe can time out on a busy
    machine). Another interface: on a simulator started here with `--interface`, at its address."""
    from pegbt.executive.session import run_tree_file

    if spec.interface == "pegbt":
        options = {
            "endpoint": "auto",
            "condition": spec.condition,
            "seed": spec.seed,
            "simlog": str(truth),
            "faults": None if spec.faults is None else str(spec.faults),
            "world-effects": None if spec.world_effects is None else str(spec.world_effects),
            "speed": spec.speed,
            "protocol": spec.protocol,
        }
        return run_tree_file(trial_run_options(spec, options))
    with SimProcess(simulator_args(spec, truth)) as simulator:
        return run_tree_file(trial_run_options(spec, run_options(spec, simulator.endpoint)))


def trial_run_options(spec: TrialSpec, options: dict[str, Any]) -> RunOptions:
    """The run of a trial with the providers' `options`: its variant, its simulator's world in the header."""
    clock = "wall" if spec.realtime else None
    started = {
        "seed": spec.seed,
        "faults": None if spec.faults is None else str(spec.faults),
        "world-effects": None if spec.world_effects is None else str(spec.world_effects),
    }
    return RunOptions(
        spec.tree or tree_path(spec.variant),
        spec.log,
        options,
        clock=clock,
        timeout=TRIAL_TIMEOUT_S,
        variant=spec.variant,
        world=simulated_world(options, clock, started),
    )


def simulator_args(spec: TrialSpec, truth: Path) -> list[str]:
    """`pegbt sim` arguments of a trial started here: seeded, logging its ground truth to `truth` (the
    embedded simulator of `--endpoint auto` gets the same)."""
    return [
        *SIMULATOR_ARGS,
        *([] if spec.realtime else ["--lockstep"]),
        *([] if spec.interface == "pegbt" else ["--interface", spec.interface]),
        *([] if spec.camera == "stream" else ["--camera", spec.camera]),
        "--seed",
        str(spec.seed),
        "--log",
        str(truth),
        *([] if spec.faults is None else ["--faults", str(spec.faults)]),
        *([] if spec.world_effects is None else ["--world-effects", str(spec.world_effects)]),
        *(["--robot-clock-offset", repr(spec.robot_clock_offset)] if spec.robot_clock_offset else []),
    ]


# s without the arms' measured_js before the run stops: a simulator shares this machine with the run and
# may stall for a second under load, which a robot's 1 s would take for a dead robot
SIMULATOR_LIVENESS_S = 5.0


def run_options(spec: TrialSpec, endpoint: str) -> dict[str, Any]:
    """`pegbt run` options of a trial on the simulator started here, at `endpoint` (its arms' calibration
    models are the simulator's own, as `--endpoint auto` would take)."""
    return {
        "endpoint": endpoint,
        "condition": spec.condition,
        "calibration": str(SIMULATOR_CALIBRATION),
        "interface": spec.interface,
        "simlog": str(truth_path(spec.log)),  # the judge: the simulator's log file (no `sim/truth` here)
        "liveness": SIMULATOR_LIVENESS_S,
        "camera": spec.camera,
        "speed": spec.speed,
        "protocol": spec.protocol,
    }


def truth_path(log: Path) -> Path:
    """Where a trial's simulator log (its ground truth) goes: beside its tick log."""
    return log.with_name(log.name.removesuffix(".jsonl") + ".truth.jsonl")


def _fill_from_judge(record: TrialRecord, figures: dict[str, Any]) -> None:
    record.transfers_succeeded = figures["transfers_succeeded"]
    record.mean_transfer_time_s = figures["mean_transfer_time_s"]
    record.wall_time_s = figures["wall_time_s"]
    record.transfers = [dict(transfer) for transfer in figures["transfers"]]
