"""`pegbt sim2real diagnose`, `pegbt sim2real synth`, `pegbt sim2real preset` and `pegbt sim2real outcomes`."""

from __future__ import annotations

import argparse
import json
import sys

from pegbt.bagoptions import add_bag_arguments, bag_options
from pegbt.errors import PegbtError
from pegbt.evaluation.cli import add_tls_options, checked_cluster_tls
from pegbt.numbers import NumberOption
from pegbt.psm import ARMS

PRESET_OUT = "runs/sim2real/preset.json"  # never a shipped preset unless --out names it


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sim2real",
        help="find, name and fit the physics a simulator leaves out",
        description="Locate where recordings and the simulator's arm physics disagree, name the missing effects, "
        "fit them, and prove it on synthetic recordings with concealed effects.",
    )
    commands = parser.add_subparsers(dest="sim2real_command", metavar="COMMAND", required=True)

    diagnose = commands.add_parser(
        "diagnose",
        help="diagnose a recording against the simulator's arm physics",
        description="RECORDING is a folder with q_cmd.npy, q_phy.npy and optional t_stamp.npy (the dVRK dataset "
        "layout), a CSV with columns t,q1_cmd..q6_cmd,q1_meas..q6_meas, or a ROS 2 bag (an MCAP file or a "
        "rosbag2 folder) with --cmd and --phy joint-state topics.",
    )
    diagnose.add_argument("recording", metavar="RECORDING")
    diagnose.add_argument(
        "--sim",
        default="ideal",
        metavar="ideal|PRESET|REPORT.json",
        help="physics to replay the commands through (default: ideal)",
    )
    diagnose.add_argument("--arm", choices=ARMS, help="arm for presets (default: from the recording's name)")
    diagnose.add_argument("--out", metavar="DIR", help="write report.json, report.md and PNG plots here")
    diagnose.add_argument("--json", action="store_true", help="print report.json to standard output")
    diagnose.add_argument(
        "--compare",
        metavar="REPORT.json",
        help="an earlier report (e.g. the same arm after re-homing): say what agrees and what differs",
    )
    diagnose.add_argument(
        "--bootstrap",
        action=NumberOption,
        type=int,
        at_least=0,
        default=100,
        metavar="N",
        help="bootstrap resamples for intervals",
    )
    add_bag_arguments(diagnose)
    diagnose.add_argument(
        "--resolution",
        metavar="R1,...,R6",
        help="what the measurement resolves per joint, in the joints' units (the paper's fiducial set-up: "
        "0.01,0.01,0.0005,0.01,0.01,0.01); effects smaller are listed below resolution, not named "
        "(default: the recording's meta.json, when it says; else, for a dVRK arm's recording, the paper's)",
    )
    diagnose.set_defaults(handler=_diagnose)

    synth = commands.add_parser(
        "synth",
        help="make a recording with concealed effects and its ground truth",
        description="Writes OUTDIR/recording/ (what diagnose reads) and OUTDIR/truth.json (what it never reads).",
    )
    synth.add_argument("outdir", metavar="OUTDIR")
    synth.add_argument(
        "--family",
        default="weak",
        help="weak, masked, regime, coupled, null-white or null-ar1 (default: weak)",
    )
    synth.add_argument("--seed", action=NumberOption, type=int, at_least=0, default=0)
    synth.add_argument("--seconds", action=NumberOption, above=0.0, default=30.0)
    synth.add_argument(
        "--rate",
        action=NumberOption,
        above=0.0,
        default=100.0,
        metavar="HZ",
        help="stream rate (default 100 Hz)",
    )
    synth.add_argument("--sampling", default="stream", choices=("stream", "setpoints"))
    synth.add_argument(
        "--snr",
        action=NumberOption,
        above=0.0,
        help="SNR of the concealed effect (default: drawn per family)",
    )
    synth.add_argument(
        "--effect",
        metavar="KIND",
        help="the kind of effect the weak family conceals (default: drawn from every registered kind)",
    )
    synth.set_defaults(handler=_synth)

    preset = commands.add_parser(
        "preset",
        help="identify a physics preset (one model per arm) from recordings",
        description="Diagnose each arm's recording against the ideal arm and write the identified models as a "
        f"preset that `ArmPhysics.load` and `pegbt sim --physics` read: to --out, by default {PRESET_OUT} (the "
        "presets pegbt ships are in pegbt/physics/presets/: give that path to --out to replace one).",
    )
    preset.add_argument(
        "--out", default=PRESET_OUT, metavar="OUT.json", help=f"preset file to write (default {PRESET_OUT})"
    )
    preset.add_argument(
        "--from",
        dest="sources",
        action="append",
        required=True,
        metavar="ARM=RECORDING",
        help="an arm and its recording, e.g. PSM1=../shared/data/dvrk/random_smooth_grey1_PSM1",
    )
    preset.set_defaults(handler=_preset)

    outcomes = commands.add_parser(
        "outcomes",
        help="task-level sim to real: where trial outcomes disagree, the world effects that explain it",
        description="REAL is a folder of tick logs of real runs (their headers say variant and condition), or an "
        "outcome table (YAML or CSV: variant, condition, attempted, succeeded, optional mean_transfer_s and "
        "failures per phase); --table paper uses the reference paper's Tables II-IV. Locates the cells and phases "
        "where real and simulated outcomes disagree, names the world effects that explain it, writes the fitted "
        "world file, and predicts the cells the fit did not see (--fit). --effects lists the registered world "
        "effects (pegbt sim --world-effects) with their parameters, units, ranges and inert defaults.",
    )
    outcomes.add_argument("real", metavar="REAL", nargs="?", help="tick-log folder or outcome table")
    outcomes.add_argument("--table", choices=("paper",), help="a built-in outcome table instead of REAL")
    outcomes.add_argument(
        "--effects", action="store_true", help="list the registered world effects and their parameters"
    )
    outcomes.add_argument("--json", action="store_true", help="print the listing (or report.json) as JSON")
    outcomes.add_argument(
        "--out", metavar="DIR", help="write report.json, report.md, outcomes.png, world.yaml here"
    )
    outcomes.add_argument(
        "--fit",
        default="all",
        metavar="all|VARIANT|CONDITION",
        help="fit on these cells and predict the others (default: all, nothing held out)",
    )
    outcomes.add_argument(
        "--transfers",
        action=NumberOption,
        type=int,
        at_least=2,
        default=16,
        help="simulated transfers per cell and world (default 16)",
    )
    outcomes.add_argument(
        "--located",
        action=NumberOption,
        type=int,
        at_least=2,
        default=48,
        help="simulated transfers per fit cell in the default world, which the gate and the fit compare "
        "against (default 48; held-out cells get --transfers there)",
    )
    outcomes.add_argument(
        "--points",
        action=NumberOption,
        type=int,
        at_least=2,
        default=5,
        help="grid steps across each fitted parameter's range: POINTS + 1 values, less the inert default; each "
        "profile's maximum between them joins them (default 5)",
    )
    outcomes.add_argument(
        "--workers",
        action=NumberOption,
        type=int,
        at_least=0,
        default=2,
        help="local worker processes (0: none)",
    )
    outcomes.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="simulate on this Dask scheduler instead (tls://HOST:PORT with the --tls options, or "
        "tcp://HOST:PORT on a trusted network)",
    )
    add_tls_options(outcomes)
    outcomes.add_argument(
        "--confirm",
        action=NumberOption,
        type=int,
        at_least=0,
        default=0,
        metavar="TRIALS",
        help="then run TRIALS whole trials per cell in each fitted world (pegbt eval --world-effects, in "
        "--workers local processes, even with --cluster) and report them beside the prediction (default 0: "
        "none)",
    )
    outcomes.set_defaults(handler=_outcomes)


def _diagnose(args: argparse.Namespace) -> int:
    from pegbt.physics.recording import load_recording, parse_resolution
    from pegbt.sim2real.diagnose import diagnose
    from pegbt.sim2real.practical import PAPER_RESOLUTION
    from pegbt.sim2real.report import ZERO_OFFSET_LABEL, read_named_effects, report_dict, write_report

    resolution = None if args.resolution is None else parse_resolution(args.resolution)
    recording = load_recording(args.recording, arm=args.arm, **bag_options(args))
    recording.warn()
    if args.compare:
        read_named_effects(args.compare)  # refuse a bad report before the work, not after it
    note = ""
    if resolution is None and recording.resolution is None and (args.arm or recording.arm) in ARMS:
        resolution = PAPER_RESOLUTION
        note = (
            f"the recording states no resolution: diagnosed at the paper's fiducial tracker's "
            f"{','.join(f'{r:g}' for r in resolution)} (q1-q6; rad, q3 m); change it with --resolution R1,...,R6"
        )
        print(f"pegbt: {note}", file=sys.stderr)
    diagnosis = diagnose(recording, args.sim, args.arm, n_bootstrap=args.bootstrap, resolution=resolution)
    report = (
        write_report(diagnosis, args.out, args.compare, resolution_note=note)
        if args.out
        else report_dict(diagnosis, args.compare, resolution_note=note)
    )
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"{recording.path}: {recording.n} samples; {recording.sampling.reason}")
    print(f"simulator physics: {diagnosis.sim} ({diagnosis.arm})")
    print(f"measurement faults: {report['measurement_faults']['text']}")
    if report["geometry"]:
        print(f"geometry: {report['geometry']['text']}")
    for zero in report["zero_offsets"]:
        print(f"{ZERO_OFFSET_LABEL.lower()}: {zero['text']}")
    before, after = report["fit"]["heldout_rmse_before"], report["fit"]["heldout_rmse_after"]
    print(
        "held-out RMSE before → after: " + ", ".join(f"{q} {before[q]:.4g} → {after[q]:.4g}" for q in before)
    )
    for effect in report["effects"]:
        print(f"  {effect['effect']} on {effect['joint']}: {effect['text']}")
    for below in report["below_resolution"]:
        print(f"  below resolution, in the model, not named: {below['effect']}: {below['reason']}")
    for statement in report["not_identifiable"]:
        print(f"  {statement}")
    if "comparison" in report:
        differences = report["comparison"]["differences"]
        print(
            f"compared with {args.compare}: {100 * report['comparison']['agreement']:.0f} % of kinds agree; "
            f"{len(differences)} parameter(s) differ" + (f", e.g. {differences[0]}" if differences else "")
        )
    if args.out:
        print(f"report: {args.out}/report.md")
    return 0


def _outcomes(args: argparse.Namespace) -> int:
    from pegbt.sim2real.world_listing import listing_json, listing_text

    if args.effects:
        print(listing_json() if args.json else listing_text())
        return 0
    if (args.real is None) == (args.table is None):
        raise PegbtError(
            "give REAL (a tick-log folder or an outcome table) or --table paper", field="outcomes"
        )
    tls = checked_cluster_tls(args)  # a bad --cluster is said before any simulation
    from pegbt.sim2real.outcomes.cli import run_outcomes

    return run_outcomes(args, tls)


def _preset(args: argparse.Namespace) -> int:
    from pegbt.sim2real.preset import parse_sources, write_preset

    sources = parse_sources(args.sources)
    command = "pegbt sim2real preset " + " ".join(
        [f"--out {args.out}"] + [f"--from {pair}" for pair in args.sources]
    )
    print(f"preset: {write_preset(args.out, sources, command)}")
    return 0


def _synth(args: argparse.Namespace) -> int:
    from pegbt.sim2real.synth import generate, write_synthetic

    synthetic = generate(
        args.family, args.seed, args.seconds, args.rate, args.sampling, args.snr, args.effect
    )
    folder, truth = write_synthetic(synthetic, args.outdir)
    print(f"recording: {folder}\ntruth: {truth}")
    return 0
