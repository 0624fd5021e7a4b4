"""`pegbt bench calibration`: the three calibration models on the real dVRK recordings, in one process.

- Split: train on the first 70 % of each recording, score the rest.
- Cross: train on all of one recording, score all of the other recording of the same arm (a later
  set-up, re-homed: its offsets differ).
- `train_s_MODEL`: seconds to fit on the ~2800 samples of `random_smooth_new1_PSM1`.
- `compensate_us_MODEL`: median microseconds of one compensated 10 ms step (Alg. 1 included) along a
  streamed trajectory through held-out set-points of grey1_PSM1.
Tip errors are means in mm through forward kinematics; joint RMSE in rad.

Closed loop on the simulator (`pegbt sim --lockstep --no-world --physics dvrk-real`, over zenoh): a
physics model is fitted to `SIM_SETPOINTS` set-points collected from the simulator (`calibrate collect`'s
motion), then the 48 waypoints of the twelve unilateral transfers are commanded on a fresh simulator,
uncompensated and through the `Compensator`, and the tip error is read from `fiducial_js`.
`tip_err_mm_uncompensated`, `tip_err_mm_compensated` and `tip_err_ratio` are PSM1's (the unilateral
task's arm); `sim.PSM2.*` the same for the other arm.
"""

from __future__ import annotations

import logging
import tempfile
import time
from pathlib import Path

import numpy as np

from pegbt.bench import Figures
from pegbt.calibration.base import CalibrationModel, new_model
from pegbt.calibration.closed_loop import collect_on_simulator, simulator_tip_errors
from pegbt.calibration.compensation import Compensator
from pegbt.calibration.evaluation import evaluate
from pegbt.calibration.task import transfer_goals
from pegbt.physics.recording import Recording, dvrk_data_dir, load_recording
from pegbt.psm import ARMS

PAIRS = (("grey1_PSM1", "new1_PSM1"), ("grey2_PSM2", "new2_PSM2"))  # (paper-era set-up, later set-up)
KINDS = ("lstm", "physics", "hybrid")
WRIST = ("q4", "q5", "q6")
# The reference paper's repository: mean tip error on peg-transfer motion (for comparison only).
PAPER_TIP_MM = {"uncompensated": 4.13, "lstm": 1.87}
SIM_SETPOINTS = 1500
SIM_SEED = 0


def _recording(name: str) -> Recording:
    return load_recording(dvrk_data_dir(required=True) / f"random_smooth_{name}")


def _arm(recording: Recording) -> str:
    assert recording.arm is not None, "the dVRK folders end in their arm's name"
    return recording.arm


def _score(figures: Figures, prefix: str, model: CalibrationModel, test: Recording, start: int) -> None:
    scores = evaluate(model, test, start)
    figures[f"{prefix}.uncompensated.tip_mm"] = scores["tip_err_mm_mean_uncompensated"]
    figures[f"{prefix}.{model.kind}.tip_mm"] = scores["tip_err_mm_mean"]
    for joint in WRIST:
        figures[f"{prefix}.uncompensated.{joint}_rmse"] = scores["joint_rmse_uncompensated"][joint]
        figures[f"{prefix}.{model.kind}.{joint}_rmse"] = scores["joint_rmse"][joint]


def _compensate_us(model: CalibrationModel, recording: Recording) -> float:
    """Median time of one streamed 10 ms step between held-out set-points, 0.5 s apart."""
    points = recording.q_cmd[recording.head(0.7) :][:40]
    stream = np.concatenate([np.linspace(a, b, 50, endpoint=False) for a, b in zip(points[:-1], points[1:])])
    compensator = Compensator(model)
    compensator.reset(stream[0])
    times = []
    for q_desired in stream:
        start = time.perf_counter()
        compensator.step(q_desired)
        times.append(time.perf_counter() - start)
    return 1e6 * float(np.median(times))


def _summarise(figures: Figures, split: str, recordings: list[str]) -> None:
    for kind in ("uncompensated", *KINDS):
        values = [float(figures[f"{split}.{name}.{kind}.tip_mm"]) for name in recordings]
        figures[f"{split}.mean.{kind}.tip_mm"] = float(np.mean(values))


def _simulator_figures(figures: Figures, arm: str) -> None:
    """Collect from the simulator, fit the physics model, command the transfer waypoints both ways."""
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        recording = load_recording(
            collect_on_simulator(arm, Path(folder) / f"sim_{arm}", SIM_SETPOINTS, SIM_SEED)
        )
        figures[f"sim.{arm}.collect_s"] = time.perf_counter() - start
    model = new_model("physics", arm).fit(recording)
    goals = transfer_goals(arm)
    uncompensated = simulator_tip_errors(arm, goals)
    compensated = simulator_tip_errors(arm, goals, model)
    figures[f"sim.{arm}.tip_err_mm_uncompensated"] = float(uncompensated.mean())
    figures[f"sim.{arm}.tip_err_mm_compensated"] = float(compensated.mean())
    figures[f"sim.{arm}.tip_err_mm_compensated_max"] = float(compensated.max())
    figures[f"sim.{arm}.tip_err_ratio"] = float(uncompensated.mean() / compensated.mean())


def run() -> Figures:
    logging.getLogger("pegbt.calibration").setLevel(logging.ERROR)  # clamps are counted, not printed here
    figures: Figures = {f"reference_paper.{k}.tip_mm": v for k, v in PAPER_TIP_MM.items()}
    recordings = {name: _recording(name) for pair in PAIRS for name in pair}
    train_s: dict[str, float] = {}
    for name, recording in recordings.items():
        n_train = recording.head(0.7)
        for kind in KINDS:
            model = new_model(kind, _arm(recording)).fit(recording.slice(0, n_train))
            _score(figures, f"split.{name}", model, recording, n_train)
            if name == "grey1_PSM1":
                figures[f"compensate_us_{kind}"] = _compensate_us(model, recording)
    for train, test in (pair for pair in PAIRS for pair in (pair, pair[::-1])):
        for kind in KINDS:
            start = time.perf_counter()
            model = new_model(kind, _arm(recordings[train])).fit(recordings[train])
            if train == "new1_PSM1":
                train_s[kind] = time.perf_counter() - start  # all 2794 samples
            _score(figures, f"cross.{train}->{test}", model, recordings[test], 0)
    _summarise(figures, "split", list(recordings))
    for kind in KINDS:
        figures[f"train_s_{kind}"] = train_s[kind]
    for arm in ARMS:
        _simulator_figures(figures, arm)
    for name in ("tip_err_mm_uncompensated", "tip_err_mm_compensated", "tip_err_ratio"):
        figures[name] = figures[f"sim.PSM1.{name}"]
    return figures
