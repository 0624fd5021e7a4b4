"""`pegbt bench limit`: each variant's mean transfer, in lockstep and in real time, over its physical lower
bound (`pegbt.bench.limit_bound`), and where the difference goes.

Per variant, `TRIALS` calibrated + optimised trials from `SEED` in lockstep and as many in real time (pegbt's
interface). The bound is that of the transfers each trial made, in the order they began; figures are means
per transfer over the trials. The lockstep difference is split, for the arm busiest in the transfers, into
- `waypoints`: the bound through pegbt's own waypoints (transfer height, drop height, the approach from
  just above the block) less the bound;
- `path`: the time pegbt's arm moved in its transfers less the motion of that waypoint bound (its path's
  shape, the channels, timing);
- `jaw`: the time its jaw leaves ran (closing from the approach's opening, squeeze, opening to let go)
  less that waypoint bound's jaw (closing on the wall, a giver's opening off it, the block's fall from the
  drop height);
- `waits`: the time its other leaves ran in its transfers (perception, planning, waiting for the way or,
  in a handover, for the other arm: zero in lockstep for computation, which takes no simulated time);
- `sequencing`: the rest (the arm idle in a transfer: the other arm, the handover's order, ticks).
The table prints with the figures; the figure (a stacked bar per variant) is written to `FIGURE`.
"""

from __future__ import annotations

import multiprocessing
import statistics
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.bench import Figures
from pegbt.bench.limit_bound import Bound, Heights, TrialBound, trial_bound

if TYPE_CHECKING:
    from pegbt.evaluation.trial import TrialRecord
    from pegbt.executive.logfile import TickLog

TRIALS = 1
SEED = 1000
WORKERS = 2
FIGURE = Path("runs/bench/limit.png")
PARTS = ("path", "waypoints", "jaw", "waits", "sequencing")
JAW_LEAVES = ("grasp", "release")


@dataclass
class ArmTime:
    motion: float = 0.0
    jaw: float = 0.0
    waits: float = 0.0


def transfers_of(record: TrialRecord) -> list[tuple[str, int, int]]:
    """(arms, pick, place) of a trial's transfers in the order they began."""
    ordered = sorted(record.transfers, key=lambda transfer: (transfer["started"], transfer["index"]))
    return [(t["arms"], int(t["pick"]), int(t["place"])) for t in ordered]


def windows_of(record: TrialRecord) -> list[tuple[float, float]]:
    """Start-to-placement intervals of a trial's successful transfers."""
    return [
        (t["started"], t["started"] + t["seconds"])
        for t in record.transfers
        if t["succeeded"] and t["seconds"] is not None
    ]


def merged(windows: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The union of intervals as disjoint intervals (two arms' transfers overlap)."""
    union: list[tuple[float, float]] = []
    for start, end in sorted(windows):
        if union and start <= union[-1][1]:
            union[-1] = (union[-1][0], max(union[-1][1], end))
        else:
            union.append((start, end))
    return union


def _overlap(start: float, end: float, windows: list[tuple[float, float]]) -> float:
    return sum(max(0.0, min(end, b) - max(start, a)) for a, b in windows)


def arm_times(log: TickLog, windows: list[tuple[float, float]]) -> dict[str, ArmTime]:
    """Per arm, the time its leaves ran inside the transfers' windows: moving, jaw, anything else."""
    from pegbt.behaviours.base import MotionLeaf
    from pegbt.executive.registry import REGISTRY

    kinds: dict[int, tuple[str, str]] = {}
    for node in log.nodes:
        params = node.get("params") or {}
        arm = params.get("arm") or params.get("giver") or params.get("receiver")
        spec = REGISTRY.get(node["type"])
        if not isinstance(arm, str) or spec is None:
            continue
        factory = spec.factory
        moving = isinstance(factory, type) and issubclass(factory, MotionLeaf)
        kind = "jaw" if node["type"] in JAW_LEAVES else "motion" if moving else "waits"
        kinds[node["id"]] = (arm, kind)
    windows = merged(windows)
    times: dict[str, ArmTime] = {}
    started: dict[int, float] = {}
    for change in log.transitions:
        if change.node not in kinds:
            continue
        if change.after == "RUNNING" and change.before != "RUNNING":
            started[change.node] = change.t
        elif change.before == "RUNNING" and change.node in started:
            arm, kind = kinds[change.node]
            entry = times.setdefault(arm, ArmTime())
            setattr(entry, kind, getattr(entry, kind) + _overlap(started.pop(change.node), change.t, windows))
    return times


def breakdown(records: list[TrialRecord], bound: Bound, through_waypoints: Bound) -> dict[str, float]:
    """Mean per transfer over lockstep trials: achieved, bound, and the difference by `PARTS`."""
    from pegbt.executive.logfile import read_tick_log

    totals = dict.fromkeys(("achieved", "bound", *PARTS), 0.0)
    count = 0
    for record in records:
        if record.mean_transfer_time_s is None:
            continue
        transfers = transfers_of(record)
        n = len(windows_of(record))
        lowest: TrialBound = trial_bound(transfers, bound)
        waypoints = trial_bound(transfers, through_waypoints)
        achieved, floor = record.mean_transfer_time_s * n, lowest.per_transfer_s * len(transfers)
        times = arm_times(read_tick_log(record.log), windows_of(record)) if record.log else {}
        arm = max(lowest.arms, key=lambda name: lowest.arms[name].total)
        pegbt = times.get(arm, ArmTime())
        parts = {
            "waypoints": waypoints.arms[arm].total - lowest.arms[arm].total,
            "path": pegbt.motion - waypoints.arms[arm].motion,
            "jaw": pegbt.jaw - waypoints.arms[arm].jaw,
            "waits": pegbt.waits,
        }
        parts["sequencing"] = achieved - floor - sum(parts.values())
        totals["achieved"] += achieved
        totals["bound"] += floor
        for part, seconds in parts.items():
            totals[part] += seconds
        count += n
    return {key: value / count for key, value in totals.items()} if count else {}


def table(rows: dict[str, dict[str, float]]) -> str:
    """The breakdown as a Markdown table, seconds per transfer."""
    head = ["variant", "bound", "lockstep", "ratio", *PARTS, "real time", "ratio"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for variant, row in rows.items():
        cells = [row["bound_s"], row["lockstep_s"], row["lockstep_ratio"]]
        cells += [row[part] for part in PARTS] + [row["realtime_s"], row["realtime_ratio"]]
        lines.append(f"| {variant} | " + " | ".join(f"{value:.2f}" for value in cells) + " |")
    return "\n".join(lines)


def plot(rows: dict[str, dict[str, float]], path: Path) -> Path:
    """A stacked bar per variant: the bound, then each part of the lockstep difference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4))
    names = list(rows)
    bottom = [rows[name]["bound_s"] for name in names]
    axes.bar(names, bottom, label="bound", color="0.6")
    for part in PARTS:
        heights = [rows[name][part] for name in names]
        axes.bar(names, heights, bottom=bottom, label=part)
        bottom = [b + h for b, h in zip(bottom, heights)]
    axes.scatter(
        names, [rows[name]["realtime_s"] for name in names], marker="_", s=600, color="k", label="real time"
    )
    axes.set_ylabel("s per transfer")
    axes.set_title("mean transfer (lockstep) over its physical bound")
    axes.legend(fontsize=8, ncol=2)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(figure)
    return path


def variant_row(
    lockstep: list[TrialRecord], realtime: list[TrialRecord], bound: Bound, waypoints: Bound
) -> dict[str, float]:
    """One variant's figures from its lockstep and real-time trials."""
    parts = breakdown(lockstep, bound, waypoints)
    rt = [r.mean_transfer_time_s for r in realtime if r.mean_transfer_time_s is not None]
    rt_bound = [
        trial_bound(transfers_of(r), bound).per_transfer_s for r in realtime if r.mean_transfer_time_s
    ]
    realtime_s = statistics.fmean(rt) if rt else float("nan")
    realtime_bound = statistics.fmean(rt_bound) if rt_bound else float("nan")
    return {
        "bound_s": parts["bound"],
        "lockstep_s": parts["achieved"],
        "lockstep_ratio": parts["achieved"] / parts["bound"],
        "realtime_s": realtime_s,
        "realtime_ratio": realtime_s / realtime_bound,
        **{part: parts[part] for part in PARTS},
    }


def run() -> Figures:
    from pegbt.evaluation.campaign import Cell, trial_specs
    from pegbt.evaluation.trial import run_trial
    from pegbt.runconditions import VARIANTS

    bound = Bound()
    waypoints = Bound(Heights.pegbt(bound.motion))
    rows: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="pegbt-bench-limit-") as scratch:
        for variant in VARIANTS:
            specs = [
                spec
                for realtime in (False, True)
                for spec in trial_specs(
                    Cell(variant, "optimized", TRIALS, SEED, realtime=realtime),
                    Path(scratch) / f"{variant}-{'realtime' if realtime else 'lockstep'}",
                    keep_logs=True,
                )
            ]
            # the same seed in lockstep and in real time: `run_trials` keys its records by seed
            with ProcessPoolExecutor(WORKERS, mp_context=multiprocessing.get_context("spawn")) as pool:
                records = list(pool.map(run_trial, specs))
            failed = [f"{r.variant} seed {r.seed}: {r.error}" for r in records if not r.complete]
            if failed:
                raise RuntimeError(f"a trial did not place every block: {failed}")
            rows[variant] = variant_row(records[:TRIALS], records[TRIALS:], bound, waypoints)
    figures: Figures = {}
    for variant, row in rows.items():
        figures.update({f"{variant}_{key}": value for key, value in row.items()})
    figures["table"] = "\n" + table(rows)
    figures["figure"] = str(plot(rows, FIGURE))
    return figures
