"""A cell's figures from its trial records, the paper's beside them, and the table `pegbt eval` prints.

Mean transfer time pools the trials: time spent transferring over successful transfers, so a trial
with more successes weighs more (the paper's mean over its transfers). Trial times are of every trial
that ran (simulated seconds); wall times are medians (the machine is shared, so means mislead).
"""

from __future__ import annotations

import io
import statistics
from collections import Counter
from collections.abc import Sequence
from typing import Any

from rich.console import Console
from rich.table import Table

from pegbt.evaluation.campaign import Cell
from pegbt.evaluation.paper import GOAL_SUCCESS_RATE, GOAL_WALL_S, PAPER, goal_mean_transfer_s
from pegbt.evaluation.trial import TrialRecord
from pegbt.evaluation.truth import STEPS


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _std(values: Sequence[float]) -> float | None:
    return statistics.stdev(values) if len(values) > 1 else (0.0 if values else None)


def _median(values: Sequence[float]) -> float | None:
    return statistics.median(values) if values else None


def summarise(cell: Cell, records: Sequence[TrialRecord], workers: int = 1) -> dict[str, Any]:
    """The cell's figures (the keys `pegbt eval --json` prints); `workers`: how many trials ran at once."""
    ran = [r for r in records if r.outcome != "error"]
    attempted = sum(r.transfers_attempted for r in ran)
    succeeded = sum(r.transfers_succeeded for r in ran)
    busy = sum(
        r.mean_transfer_time_s * r.transfers_succeeded for r in ran if r.mean_transfer_time_s is not None
    )
    times = [t["seconds"] for r in ran for t in r.transfers if t["succeeded"]]
    trial_times = [r.trial_time_s for r in ran]
    faults = [f for r in ran for f in r.faults]
    checks = [c for r in ran for c in r.why]
    causes = Counter(t["cause"] for r in ran for t in r.transfers if not t["succeeded"])
    paper = PAPER[(cell.variant, cell.condition)]
    return {
        "variant": cell.variant,
        "condition": cell.condition,
        "trials": len(records),
        "seeds": [cell.seed, cell.seed + cell.trials - 1],
        "faults": "per-seed plans" if cell.inject_faults else (str(cell.faults) if cell.faults else "none"),
        "world_effects": str(cell.world_effects) if cell.world_effects else "none",
        "realtime": cell.realtime,
        "interface": cell.interface,
        "camera": cell.camera,
        "errors": len(records) - len(ran),
        "transfers_attempted": attempted,
        "transfers_succeeded": succeeded,
        "success_rate": succeeded / attempted if attempted else None,
        "mean_transfer_time_s": busy / succeeded if succeeded else None,
        "transfer_time_s_median": _median(times),
        "transfer_time_s_std": _std(times),
        "trials_complete": sum(r.complete for r in ran),
        "collisions_per_trial": _mean([r.arm_arm_collisions for r in ran]),
        "other_contacts_per_trial": _mean([r.other_contacts for r in ran]),
        "commands_clipped": sum(r.commands_clipped for r in records),
        "commands_clipped_per_trial": [r.commands_clipped for r in records],
        "arm_faults": sum(r.arm_faults for r in records),
        "arm_faults_per_trial": [r.arm_faults for r in records],
        "tip_path_m_per_trial": _mean([r.tip_path_m for r in ran]),
        "fallbacks_per_trial": _mean([r.fallbacks for r in ran]),
        "overruns_per_trial": _mean([r.overruns for r in ran]),
        "compute_waited_s_per_transfer": sum(r.compute_waited_s for r in ran) / succeeded
        if succeeded
        else None,
        "compute_s_per_transfer": sum(r.compute_s for r in ran) / succeeded if succeeded else None,
        "trial_time_s_mean": _mean(trial_times),
        "trial_time_s_std": _std(trial_times),
        "workers": workers,
        "wall_time_s_median": _median([r.wall_time_s for r in ran]),
        "run_wall_s_median": _median([r.run_wall_s for r in records]),
        "failures_by_step": {step: causes.get(step, 0) for step in STEPS},
        "faults_injected": len(faults),
        "faults_recovered": sum(f["recovered"] for f in faults),
        "recovery_rate": sum(f["recovered"] for f in faults) / len(faults) if faults else None,
        "why_checked": len(checks),
        "why_agreed": sum(c["agrees"] for c in checks),
        "why_agreement": sum(c["agrees"] for c in checks) / len(checks) if checks else None,
        "paper_mean_transfer_time_s": paper.mean_transfer_time_s,
        "paper_success_rate": paper.success_rate,
        "paper_trial_time_s": paper.trial_time_s,
        "goal_mean_transfer_time_s": goal_mean_transfer_s(cell.variant),
    }


def _s(value: float | None, unit: str = " s", digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}{unit}"


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def table(figures: dict[str, Any]) -> str:
    """The paper's table for one cell, measured beside the paper's, with the goals."""
    f = figures
    mode = "real time, wall clock" if f["realtime"] else "lockstep"
    title = (
        f"pegbt eval: {f['variant']}, {f['condition']}, {f['trials']} trial(s), seeds {f['seeds'][0]}..{f['seeds'][1]}, "
        f"faults: {f['faults']}, "
        + (f"world effects: {f['world_effects']}, " if f.get("world_effects", "none") != "none" else "")
        + f"{mode}, {f['interface']} interface"
        + (f", {f['camera']} camera" if f.get("camera", "stream") != "stream" else "")
        + " (judged by the simulator's ground truth)"
    )
    grid = Table()
    for column in ("", "measured", "paper", "goal"):
        grid.add_column(column, justify="left" if not column else "right")
    trial_time = f"{_s(f['trial_time_s_mean'], '', 1)} ± {_s(f['trial_time_s_std'], ' s', 1)}"
    paper_trial = _s(f["paper_trial_time_s"], " s", 1)
    rows = [
        (
            "mean transfer time",
            _s(f["mean_transfer_time_s"]),
            _s(f["paper_mean_transfer_time_s"], " s", 1),
            f"< {f['goal_mean_transfer_time_s']:.1f} s",
        ),
        ("successes / attempts", f"{f['transfers_succeeded']} / {f['transfers_attempted']}", "", ""),
        (
            "success rate",
            _pct(f["success_rate"]),
            _pct(f["paper_success_rate"]),
            f">= {100 * GOAL_SUCCESS_RATE:.0f} %" if f["condition"] != "uncalibrated" else "clearly worse",
        ),
        ("trials complete", f"{f['trials_complete']} / {f['trials']}", "", ""),
        ("trial time", trial_time, paper_trial, ""),
        ("arm-arm collisions / trial", _s(f["collisions_per_trial"], "", 2), "0", "0"),
        ("other contacts / trial", _s(f["other_contacts_per_trial"], "", 2), "", ""),
        (
            "commands clipped, arm FAULTs (dVRK limits and tracking)",
            f"{f['commands_clipped']}, {f['arm_faults']}",
            "",
            "0, 0",
        ),
        ("tool-tip path / trial (planned)", _s(f["tip_path_m_per_trial"], " m"), "", ""),
        (
            "optimised plans fallen back to cubics / trial",
            _s(f["fallbacks_per_trial"], "", 2),
            "",
            "0" if f["condition"] == "optimized" else "",
        ),
        (
            f"wall time / trial (median, {f['workers']} at once)",
            f"{_s(f['wall_time_s_median'])} ({_s(f['run_wall_s_median'])} with start-up)",
            "",
            f"<= {GOAL_WALL_S:.0f} s",
        ),
        (
            "perception and planning waited for / transfer (wall)",
            f"{_s(f['compute_waited_s_per_transfer'])} ({_s(f['compute_s_per_transfer'])} computing)",
            "",
            "",
        ),
        ("ticks over their period / trial", _s(f["overruns_per_trial"], "", 1), "", ""),
        ("failed transfers by step", ", ".join(f"{k} {v}" for k, v in f["failures_by_step"].items()), "", ""),
    ]
    if f["faults_injected"]:
        rows.append(
            (
                "injected faults recovered",
                f"{f['faults_recovered']} / {f['faults_injected']} ({_pct(f['recovery_rate'])})",
                "",
                ">= 90 %",
            )
        )
    if f["why_checked"]:
        rows.append(
            (
                "`pegbt log why` agrees",
                f"{f['why_agreed']} / {f['why_checked']} ({_pct(f['why_agreement'])})",
                "",
                "all",
            )
        )
    if f["errors"]:
        rows.append(("trials that could not run", str(f["errors"]), "", "0"))
    for row in rows:
        grid.add_row(*row)
    buffer = io.StringIO()
    Console(file=buffer, width=140, color_system=None).print(grid)
    return title + "\n" + buffer.getvalue().rstrip()
