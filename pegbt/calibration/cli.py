"""`pegbt calibrate train|eval`: fit a calibration model to a recording and score it on held-out data."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pegbt.errors import PegbtError
from pegbt.psm import ARMS, JOINT_NAMES

KINDS = ("lstm", "physics", "hybrid")


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("calibrate", help="learn an arm's cable effects and score the model")
    commands = parser.add_subparsers(dest="calibrate_command", metavar="COMMAND", required=True)

    train = commands.add_parser(
        "train",
        help="fit a model to a recording",
        description="Fit a model on the first --train-fraction of RECORDING, score it on the rest, and write "
        "it (with its held-out scores) to --out, by default skills/calibration/ARM-MODEL.json.",
    )
    train.add_argument("recording", type=Path, metavar="RECORDING", help="folder with q_cmd.npy and q_phy.npy")
    train.add_argument("--arm", required=True, choices=ARMS)
    train.add_argument("--model", required=True, choices=KINDS)
    train.add_argument("--out", type=Path, help="model file to write")
    train.add_argument("--train-fraction", type=float, default=0.7, help="share used for training (default 0.7; "
                       "1.0 trains on everything and records no held-out scores)")
    train.set_defaults(handler=_train)

    evaluate = commands.add_parser(
        "eval",
        help="score a model on a recording",
        description="Per-joint RMSE and tool-tip error (mm, through forward kinematics) of MODEL's prediction "
        "of the physical joints of RECORDING, next to the uncompensated error (q_phy against q_cmd).",
    )
    evaluate.add_argument("model", type=Path, metavar="MODEL", help="model file")
    evaluate.add_argument("recording", type=Path, metavar="RECORDING", help="folder with q_cmd.npy and q_phy.npy")
    evaluate.add_argument("--from-fraction", type=float, default=0.0,
                          help="score only samples after this share of the recording (0.7: the held-out part)")
    evaluate.add_argument("--json", action="store_true", help="print one JSON object")
    evaluate.set_defaults(handler=_eval)


def _train(args: argparse.Namespace) -> int:
    from pegbt.calibration.base import new_model
    from pegbt.calibration.compensation import skill_model_path
    from pegbt.calibration.evaluation import evaluate
    from pegbt.physics.recording import load_recording

    recording = load_recording(args.recording)
    n_train = recording.head(args.train_fraction)
    model = new_model(args.model, args.arm).fit(recording.slice(0, n_train))
    if n_train < len(recording):
        assert model.metadata is not None
        scores = evaluate(model, recording, start=n_train)
        model.metadata.heldout = scores
        print(_summary(scores))
    path = model.save(args.out or skill_model_path(args.arm, args.model))
    print(f"wrote {path}")
    return 0


def _eval(args: argparse.Namespace) -> int:
    from pegbt.calibration.base import CalibrationModel
    from pegbt.calibration.evaluation import evaluate
    from pegbt.physics.recording import load_recording

    model = CalibrationModel.load(args.model)
    recording = load_recording(args.recording)
    start = recording.head(args.from_fraction) if args.from_fraction > 0 else 0
    if start >= len(recording):
        raise PegbtError(f"--from-fraction {args.from_fraction} leaves no samples to score", field="--from-fraction")
    scores = evaluate(model, recording, start=start)
    print(json.dumps(scores) if args.json else _summary(scores))
    return 0


def _summary(scores: dict) -> str:
    header = "              " + " ".join(f"{j:>8}" for j in JOINT_NAMES) + "   tip mm"
    rows = [
        ("uncompensated", scores["joint_rmse_uncompensated"], scores["tip_err_mm_mean_uncompensated"]),
        (scores["model"], scores["joint_rmse"], scores["tip_err_mm_mean"]),
    ]
    lines = [f"{scores['samples']} held-out samples of {scores['recording']} (RMSE: rad, q3 in m)", header]
    for name, rmse, tip in rows:
        lines.append(f"{name:<13} " + " ".join(f"{rmse[j]:8.4f}" for j in JOINT_NAMES) + f" {tip:8.2f}")
    return "\n".join(lines)
