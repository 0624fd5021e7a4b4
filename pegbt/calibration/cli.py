"""`pegbt calibrate collect|train|eval`: record an arm, fit a calibration model to a recording, score it.

`collect` runs `trees/calibrate_collect.yaml` on the executive (like `pegbt run`), with the tree's
blackboard values set from its options: a command, like the benchmarks, may use any layer below it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.bagoptions import add_bag_arguments, add_record_arguments, bag_options, record_options
from pegbt.errors import PegbtError
from pegbt.numbers import NumberOption
from pegbt.psm import ARMS, JOINT_NAMES

if TYPE_CHECKING:  # the command module loads with `pegbt --help`; the models load when a command runs
    from pegbt.calibration.base import CalibrationModel
    from pegbt.physics.recording import Recording

KINDS = ("lstm", "physics", "hybrid")
RECORDING_HELP = (
    "recording: a folder with q_cmd.npy and q_phy.npy (the dVRK dataset layout), a CSV, an MCAP file or a "
    "rosbag2 folder"
)
COLLECT_TREE = Path(__file__).resolve().parents[2] / "trees" / "calibrate_collect.yaml"
OUTPUT_DIR = Path("runs") / "calibration"  # what the commands write unless told: never the committed skills/


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("calibrate", help="learn an arm's cable effects and score the model")
    commands = parser.add_subparsers(dest="calibrate_command", metavar="COMMAND", required=True)

    collect = commands.add_parser(
        "collect",
        help="drive an arm through random smooth set-points and record commanded and physical joints",
        description="Run trees/calibrate_collect.yaml on the executive: ARM walks through random smooth set-points "
        "over the joints peg transfer uses, uncompensated; each is a straight move plus 0.3 s of settling, then "
        "the set-point and the physical joints (fiducial_js) are sampled. The number of set-points comes from "
        "--minutes of the arm's time (printed before it starts). Writes the dataset layout to --out.",
    )
    collect.add_argument("--arm", required=True, choices=ARMS)
    collect.add_argument(
        "--minutes",
        action=NumberOption,
        above=0.0,
        metavar="N",
        help="the arm's time to spend (a lockstep simulator runs faster than that); required without --refit",
    )
    collect.add_argument(
        "--refit",
        type=Path,
        metavar="MODEL",
        help="recalibrate a re-homed arm instead: collect only --samples set-points and write MODEL refitted "
        "on them (see `pegbt calibrate refit`) to --model-out",
    )
    collect.add_argument(
        "--samples",
        action=NumberOption,
        type=int,
        at_least=1,
        default=20,
        metavar="N",
        help="set-points to collect with --refit (default 20)",
    )
    collect.add_argument(
        "--model-out",
        type=Path,
        metavar="FILE",
        help=f"refitted model to write with --refit (default {OUTPUT_DIR}/ARM-physics-refit.json)",
    )
    collect.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help=f"recording folder (default {OUTPUT_DIR}/sim-ARM with --endpoint auto, else {OUTPUT_DIR}/ARM)",
    )
    collect.add_argument(
        "--endpoint",
        default="auto",
        metavar="auto|ADDRESS",
        help="auto (default): the embedded simulator (lockstep, dvrk-real physics); or the zenoh "
        "address of a running simulator or robot",
    )
    collect.add_argument(
        "--seed",
        action=NumberOption,
        type=int,
        at_least=0,
        default=0,
        help="seed of the set-points and of the embedded simulator (default 0)",
    )
    collect.add_argument(
        "--log",
        type=Path,
        metavar="FILE",
        help="tick log path (default runs/calibrate_collect-DATE-TIME.jsonl)",
    )
    add_record_arguments(collect)
    collect.set_defaults(handler=_collect)

    refit = commands.add_parser(
        "refit",
        help="recalibrate a re-homed arm: refit a physics model's offsets and gains from a few set-points",
        description="Keep MODEL's effects and their widths and refit what moves between set-ups from the first "
        "--samples set-points of RECORDING (a new session of the same arm): every joint's offset, and its gains "
        "(scale, couplings, hysteresis) under a prior toward MODEL's whose strength the set-points choose by "
        "leave-one-out error.",
    )
    refit.add_argument("model", metavar="MODEL")
    refit.add_argument("recording", metavar="RECORDING")
    refit.add_argument("--samples", action=NumberOption, type=int, at_least=1, default=20, metavar="N")
    refit.add_argument("--out", type=Path, required=True, metavar="FILE")
    refit.set_defaults(handler=_refit)

    train = commands.add_parser(
        "train",
        help="fit a model to a recording",
        description="Fit a model on the first --train-fraction of RECORDING, score it on the rest, and write "
        f"it (with its held-out scores) to --out, by default {OUTPUT_DIR}/ARM-MODEL.json (the models pegbt run "
        "uses are in skills/calibration/: give that path to --out to replace one).",
    )
    train.add_argument("recording", type=Path, metavar="RECORDING", help=RECORDING_HELP)
    train.add_argument("--arm", required=True, choices=ARMS)
    train.add_argument("--model", required=True, choices=KINDS)
    train.add_argument("--out", type=Path, help="model file to write")
    train.add_argument(
        "--train-fraction",
        action=NumberOption,
        above=0.0,
        at_most=1.0,
        default=0.7,
        help="share used for training (default 0.7; 1.0 trains on everything and records no held-out scores)",
    )
    add_bag_arguments(train)
    train.set_defaults(handler=_train)

    evaluate = commands.add_parser(
        "eval",
        help="score a model on a recording",
        description="Per-joint RMSE and tool-tip error (mm, through forward kinematics) of MODEL's prediction "
        "of the physical joints of RECORDING, next to the uncompensated error (q_phy against q_cmd).",
    )
    evaluate.add_argument("model", type=Path, metavar="MODEL", help="model file")
    evaluate.add_argument("recording", type=Path, metavar="RECORDING", help=RECORDING_HELP)
    evaluate.add_argument(
        "--from-fraction",
        action=NumberOption,
        at_least=0.0,
        below=1.0,
        default=0.0,
        help="score only samples after this share of the recording (0.7: the held-out part)",
    )
    evaluate.add_argument("--json", action="store_true", help="print one JSON object")
    add_bag_arguments(evaluate)
    evaluate.set_defaults(handler=_eval)


def _collect(args: argparse.Namespace) -> int:
    from pegbt.behaviours.resources.robot import simulated_world
    from pegbt.calibration.collect import SETTLE_S, setpoints_for_minutes
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import default_log_path, run_tree_file
    from pegbt.physics.recording import MIN_SAMPLES, load_recording

    model = _refit_model(args) if args.refit else None
    if model is not None:
        count = args.samples
    elif args.minutes is None:
        raise PegbtError("say how long to collect (--minutes), or --refit MODEL", field="--minutes")
    else:
        count, step = setpoints_for_minutes(args.minutes, args.arm, args.seed)
        if count < MIN_SAMPLES:
            raise PegbtError(
                f"{args.minutes:g} min holds {count} set-points of {step:.2f} s; a recording needs at least "
                f"{MIN_SAMPLES} ({MIN_SAMPLES * step / 60:.2f} min)",
                field="--minutes",
            )
    name = f"{args.arm}-refit" if model is not None else args.arm
    out = args.out or OUTPUT_DIR / (f"sim-{name}" if args.endpoint == "auto" else name)
    if model is not None:
        print(f"{args.arm}: {count} set-points to refit {args.refit}", flush=True)
    else:
        print(
            f"{args.arm}: {count} set-points in {args.minutes:g} min, {step:.2f} s each "
            f"(move {step - SETTLE_S:.2f} s + {SETTLE_S:g} s settle, estimated)",
            flush=True,
        )
    log_path = args.log or default_log_path(COLLECT_TREE)
    options = {"endpoint": args.endpoint, "seed": args.seed}
    run = RunOptions(
        COLLECT_TREE,
        Path(log_path),
        options,
        blackboard={
            "arm": args.arm,
            "setpoints": count,
            "design": "spread" if model is not None else "smooth",
            "out": str(out),
            "seed": args.seed,
        },
        world=simulated_world(options, None),
        **record_options(args),
    )
    output = run_tree_file(run, quiet=False)
    print(f"outcome: {output.result.outcome} in {output.result.duration:.1f} s of the run's clock")
    if output.ok:
        print(f"recording: {out}")
    print(f"tick log: {log_path}")
    if output.ok and model is not None:
        from pegbt.calibration.refit import MIN_REFIT_SAMPLES

        recording = load_recording(out, arm=args.arm, min_samples=MIN_REFIT_SAMPLES)
        _write_refit(model, recording, count, args.model_out or OUTPUT_DIR / f"{args.arm}-physics-refit.json")
    return 0 if output.ok else 1


def _refit_model(args: argparse.Namespace) -> CalibrationModel:
    """The model `collect --refit` recalibrates, checked before the arm moves: a physics model of this arm,
    and enough set-points for a refit."""
    from pegbt.calibration.base import CalibrationModel
    from pegbt.calibration.physics_model import PhysicsModel
    from pegbt.calibration.refit import MIN_REFIT_SAMPLES

    model = CalibrationModel.load(args.refit)
    if not isinstance(model, PhysicsModel):
        raise PegbtError(
            f"refit keeps a physics model's shape; this is a {model.kind} model", file=args.refit
        )
    if model.arm != args.arm:
        raise PegbtError(f"the model is {model.arm}'s, not {args.arm}'s", file=args.refit, field="arm")
    if args.samples < MIN_REFIT_SAMPLES:
        raise PegbtError(
            f"a refit needs at least {MIN_REFIT_SAMPLES} set-points, got {args.samples}", field="--samples"
        )
    return model


def _train(args: argparse.Namespace) -> int:
    from pegbt.calibration.base import new_model
    from pegbt.calibration.evaluation import evaluate
    from pegbt.calibration.modelfile import model_file_name
    from pegbt.physics.faults import detect_faults
    from pegbt.physics.recording import load_recording

    recording = load_recording(args.recording, arm=args.arm, **bag_options(args))
    recording.warn()
    n_train = recording.head(args.train_fraction)
    faults = detect_faults(recording.q_cmd, recording.q_phy, recording.limits)
    print(f"measurement faults: {faults.sentence(recording.times)}")
    training = recording.slice(0, n_train).subset(faults.kept[:n_train])
    model = new_model(args.model, args.arm).fit(training)
    if n_train < len(recording):
        assert model.metadata is not None
        scores = evaluate(model, recording, start=n_train, kept=faults.kept)
        model.metadata.heldout = scores
        print(_summary(scores))
    path = model.save(args.out or OUTPUT_DIR / model_file_name(args.arm, args.model))
    print(f"wrote {path}")
    return 0


def _refit(args: argparse.Namespace) -> int:
    from pegbt.calibration.base import CalibrationModel
    from pegbt.physics.recording import load_recording

    model = CalibrationModel.load(args.model)
    from pegbt.calibration.refit import MIN_REFIT_SAMPLES

    recording = load_recording(args.recording, min_samples=MIN_REFIT_SAMPLES)
    _write_refit(model, recording, args.samples, args.out)
    return 0


def _write_refit(model: CalibrationModel, recording: Recording, samples: int, out: Path) -> Path:
    """Refit `model` on the first `samples` set-points of `recording`, say what moved, write it to `out`."""
    from pegbt.calibration.refit import refit

    refitted, moved = refit(model, recording, samples)
    for joint in moved:
        prior = (
            "gains kept" if joint.prior == float("inf") else f"gains refitted, prior strength {joint.prior:g}"
        )
        if joint.width_factor != 1.0:
            prior = f"play widths ×{joint.width_factor:g}, {prior}"
        if joint.held:
            prior = f"{prior}, {joint.held}"
        changes = ", ".join(f"{name} {old:.4g} → {new:.4g}" for name, old, new in joint.moved)
        print(f"{joint.joint}: {prior}: {changes or 'nothing moved'}")
    narrow = [joint.joint for joint in moved if joint.narrow]
    if narrow:
        print(
            f"note: only offsets moved on {', '.join(narrow)}; set-points spread over every joint's range "
            "(`pegbt calibrate collect --refit MODEL`) let a refit follow gains and play widths too"
        )
    path = refitted.save(out)
    print(f"wrote {path}")
    return path


def _eval(args: argparse.Namespace) -> int:
    from pegbt.calibration.base import CalibrationModel
    from pegbt.calibration.evaluation import evaluate
    from pegbt.physics.recording import load_recording

    model = CalibrationModel.load(args.model)
    recording = load_recording(args.recording, arm=model.arm, **bag_options(args))
    recording.warn()
    start = recording.head(args.from_fraction) if args.from_fraction > 0 else 0
    if start >= len(recording):
        raise PegbtError(
            f"--from-fraction {args.from_fraction} leaves no samples to score", field="--from-fraction"
        )
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
