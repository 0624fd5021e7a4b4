"""The `skills` resource: motion, calibration and perception as the run's condition asks for them.

The conditions are the reference paper's (`pegbt.runconditions`): a compensated one pre-compensates every
commanded row by the arm's calibration model, an optimised one plans transfers as the paper's spline
refined by SQP.

Calibration models are read from the directory `--calibration` (by default `skills/calibration/`, and
for `--endpoint auto` `skills/calibration/sim-dvrk-real/`: models fitted on recordings of the simulator's
arms made by `trees/calibrate_collect.yaml`): per arm the first of `ARM-hybrid.json`, `ARM-physics.json`,
`ARM-lstm.json` found. Models are per set-up: a model fitted on one robot (or on the simulator) does not
fit another.

Under the paper's protocol (`--protocol paper`) an uncalibrated arm plans where the paper's hand-eye
registration, made with that arm, puts its base (`pegbt.calibration.registration`, with the simulator's
`dvrk-real` physics: a robot would be registered for real), and a carry that stops to look before lowering
goes at the paper's heights for the run's variant (`paper_variant`, `pegbt.motion.placing`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.compensation import CALIBRATION_DIR, Compensator
from pegbt.calibration.modelfile import model_file_name
from pegbt.calibration.registration import registered_arm_from_board
from pegbt.errors import PegbtError
from pegbt.executive.providers import ProviderSetup
from pegbt.motion.handover import tool_distance
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.peg_clearance import tool_peg_gap
from pegbt.motion.placing import paper_variant
from pegbt.motion.robot_config import DEFAULT_TOOL, robot_arm_settings
from pegbt.motion.settings import MotionSettings, motion_settings
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.transfer import TransferPlanner
from pegbt.numbers import checked_number
from pegbt.perception.blocks import BlockLocator
from pegbt.perception.board import PegboardRegistration
from pegbt.perception.grasp import GraspSelector
from pegbt.psm import ARMS
from pegbt.runconditions import COMPENSATED, LONE_VARIANTS, OPTIMIZED, known_condition, known_protocol
from pegbt.workcell import Workcell, workcell

SIMULATOR_CALIBRATION = CALIBRATION_DIR / "sim-dvrk-real"
MODEL_PREFERENCE = ("hybrid", "physics", "lstm")
REGISTRATION_PHYSICS = "dvrk-real"  # the embedded simulator's arms, which the paper's protocol registers
CLEARANCE_STRIDE = 3  # check every third 10 ms row: tools move well under a millimetre in 30 ms


def calibration_model(directory: Path, arm: str) -> CalibrationModel:
    """The preferred calibration model of `arm` in `directory`; a `PegbtError` if there is none."""
    for kind in MODEL_PREFERENCE:
        path = directory / model_file_name(arm, kind)
        if path.exists():
            return CalibrationModel.load(path, arm=arm)
    names = ", ".join(model_file_name(arm, kind) for kind in MODEL_PREFERENCE)
    raise PegbtError(
        f"no calibration model for {arm} (looked for {names})", file=directory, field="--calibration"
    )


class Skills:
    """Per-arm motion under one condition, the work cell, and the perception pipeline's state."""

    def __init__(
        self,
        condition: str,
        calibration: Path | None = None,
        cell: Workcell | None = None,
        motion: MotionSettings | None = None,
        robot_config: Path | None = None,
        robot_tool: str = DEFAULT_TOOL,
        speed: float = 1.0,
        protocol: str = "pegbt",
        variant: str = "",
    ) -> None:
        """`robot_config`: a dVRK's share/ folder, whose limits narrow skills/psm.yaml's (`robot_arm_settings`);
        `speed`: the fraction of the planner's speed every motion is planned at (`ArmSettings.at_speed`);
        `protocol` and `variant`: the paper's protocol registers the arms and places at its heights; in a
        variant whose other arm stays parked (`LONE_VARIANTS`) an approach passes lower over the pegs."""
        self.condition = known_condition(condition)
        self.other_arm_parked = variant in LONE_VARIANTS
        self.protocol = known_protocol(protocol)
        self.cell = cell or workcell()
        if protocol == "paper" and condition not in COMPENSATED:
            # a compensated arm is not registered: its calibration corrects the whole error, the part a
            # registration takes up too (the paper's models learnt what its registration left)
            registered = {arm: registered_arm_from_board(arm, REGISTRATION_PHYSICS) for arm in ARMS}
            self.cell = replace(self.cell, arm_from_board=registered)
        self.motion = motion or motion_settings()
        # the variant whose heights a carry stopping to look goes at: the paper's, under its protocol
        self.paper_variant = paper_variant(variant) if protocol == "paper" else None
        self.arms: dict[str, ArmMotion] = {}
        self.speed = checked_number(speed, "--speed", above=0.0, at_most=1.0)
        self.settings = {
            arm: robot_arm_settings(arm, robot_config, robot_tool).at_speed(self.speed) for arm in ARMS
        }
        for arm in ARMS:
            settings = self.settings[arm]
            compensator = None
            if condition in COMPENSATED:
                compensator = Compensator(
                    calibration_model(calibration or CALIBRATION_DIR, arm), settings=settings
                )
            planner = TransferPlanner(settings, self.motion) if condition in OPTIMIZED else None
            self.arms[arm] = ArmMotion(settings, planner=planner, compensator=compensator)
        self.registration = PegboardRegistration(self.cell)
        self.locator = BlockLocator(self.cell)
        self.selectors = {arm: GraspSelector(arm, self._reachable(arm), self.cell) for arm in ARMS}
        self.waiting: dict[str, float | None] = dict.fromkeys(ARMS)  # since when each arm waits for the other

    def _reachable(self, arm: str) -> Callable[[NDArray[np.float64]], NDArray[np.bool_]]:
        """The selectors' predicate: the arm reaches the grasp, and its tool there overlaps no peg
        (`tool_peg_gap`). The shaft leans back towards the arm's remote centre: gripping a block a slip had
        dropped beside a peg on its side facing that peg brought the shaft's end onto the peg (3 tool-peg
        contacts in 60 handovers with `--inject-faults`, docs/internals/motion.md)."""
        settings, board_from_arm = self.settings[arm], self.cell.arm_to_board(arm)

        def reachable(poses: NDArray[np.float64]) -> NDArray[np.bool_]:
            solved = inverse_kinematics(poses, settings)
            ok = np.asarray(solved.ok, dtype=bool).reshape(len(poses))
            if ok.any():
                ok[ok] = tool_peg_gap(solved.q.reshape(len(poses), 6)[ok], board_from_arm, self.cell) >= 0.0
            return ok

        return reachable

    def arm(self, name: str) -> ArmMotion:
        if name not in self.arms:
            raise PegbtError(f"unknown arm {name!r}; known: {', '.join(self.arms)}", field="arm")
        return self.arms[name]

    def clearances(
        self, arm: str, planned: Trajectory, start: float, others: dict[str, NDArray[np.float64]]
    ) -> NDArray[np.float64]:
        """Closest distance (m) between `arm`'s tool and any other arm's tool at every third row of `planned`
        and its last (starting at clock time `start`), each other arm where it is meant to be at the same
        times (along its own motion, or at rest: `others` gives each other arm's set-point in case it has
        not moved yet). Tools are their shafts and wrist-to-tip segments, as
        `pegbt.motion.handover.tool_distance` measures them."""
        rows = np.unique(np.r_[np.arange(0, len(planned), CLEARANCE_STRIDE), len(planned) - 1])
        times = start + planned.t[rows]
        closest = np.full(len(rows), np.inf)
        for other, resting in others.items():
            theirs = self.arms[other].joints_at(times, resting)
            distance = tool_distance(
                planned.q[rows], self.cell.board_to_arm(arm), theirs, self.cell.board_to_arm(other)
            )
            closest = np.minimum(closest, distance)
        return closest

    def report(self) -> SkillsReport | None:
        """How the motions went (None if nothing moved): trajectories sent, fallbacks, planned tool-tip paths."""
        if not any(motion.plans for motion in self.arms.values()):
            return None
        return SkillsReport(
            self.condition,
            {name: motion.plans for name, motion in self.arms.items()},
            {name: motion.fallbacks for name, motion in self.arms.items()},
            {name: motion.tip_path for name, motion in self.arms.items()},
        )


@dataclass(frozen=True)
class SkillsReport:
    """Per arm: trajectories sent, optimised plans that fell back to cubics, length of the planned tool-tip path (m)."""

    condition: str
    plans: dict[str, int]
    fallbacks: dict[str, int]
    tip_path_m: dict[str, float]

    def as_dict(self) -> dict[str, object]:
        return {
            "condition": self.condition,
            "plans": dict(self.plans),
            "fallbacks": dict(self.fallbacks),
            "tip_path_m": dict(self.tip_path_m),
        }

    def __str__(self) -> str:
        arms = "; ".join(
            f"{arm} {self.plans[arm]} trajectories, planned tool-tip path {self.tip_path_m[arm]:.2f} m"
            + (
                f", {self.fallbacks[arm]} optimised plan(s) fell back to cubics"
                if self.fallbacks[arm]
                else ""
            )
            for arm in self.plans
        )
        return f"motion ({self.condition}): {arms}"


def provide_skills(setup: ProviderSetup) -> Skills:
    """The `skills` resource for `pegbt run` (options `condition`, `calibration`, `endpoint`, `robot-config`,
    `robot-tool`, `speed`, `protocol`; the run's variant)."""
    options = setup.options
    directory = options.get("calibration")
    if directory is None:
        directory = SIMULATOR_CALIBRATION if options.get("endpoint", "auto") == "auto" else CALIBRATION_DIR
    robot_config = options.get("robot-config")
    return Skills(
        str(options.get("condition") or "optimized"),
        Path(directory),
        robot_config=None if robot_config is None else Path(robot_config),
        robot_tool=str(options.get("robot-tool") or DEFAULT_TOOL),
        speed=1.0 if options.get("speed") is None else float(options["speed"]),
        protocol=str(options.get("protocol") or "pegbt"),
        variant=setup.variant,
    )
