"""`pegbt log plot LOG`: one run's timeline as a figure (matplotlib).

Lanes, top down: each arm's activity (its leaves while running, coloured by behaviour), the leaves of no
arm (sensing), the transfers (`begin_transfer` to `finish_transfer`, by the transfer number both leaves
write in their feedback; green placed, red failed, grey skipped, hatched if the run ended first), and the
trouble: each leaf failure, each recovery as it starts (`recover`'s second child), each failure the tree
gave up on and the run's first cause, as `pegbt log why` names them (`pegbt.executive.causes`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.errors import PegbtError
from pegbt.executive.causes import CONTROL_FLOW, Timeline, failure_chains
from pegbt.executive.logfile import TickLog

if TYPE_CHECKING:
    from matplotlib.axes import Axes

ARM_PARAMS = ("arm", "arms")
OUTCOME_COLOURS = {"placed": "tab:green", "failed": "tab:red", "skipped": "tab:gray"}
_TRANSFER = re.compile(r"transfer (\d+)")
_FINISH = re.compile(r"transfer \d+ (\w+)")


def leaf_arm(node: dict) -> str:
    """The arm a leaf works for: its `arm` parameter (a handover's `arms`: the giver), else 'no arm'."""
    for name in ARM_PARAMS:
        value = node["params"].get(name)
        if isinstance(value, str) and value.startswith("PSM"):
            return re.split(r"[^A-Z0-9]", value)[0]
    return "no arm"


def running_spans(log: TickLog) -> list[tuple[int, float, float]]:
    """(leaf, start, end) of every time a leaf ran, in executive seconds (end of the log if still running)."""
    leaves = {node["id"] for node in log.nodes if not log.children(node["id"])}
    started: dict[int, float] = {}
    spans = []
    for change in log.transitions:
        if change.node not in leaves:
            continue
        if change.after == "RUNNING" and change.before != "RUNNING":
            started[change.node] = change.t
        elif change.before == "RUNNING" and change.node in started:
            spans.append((change.node, started.pop(change.node), change.t))
    spans += [(node, since, log.last_t) for node, since in started.items()]
    return spans


def transfers(log: TickLog) -> list[dict]:
    """Each transfer: number, label, start, end (None if unfinished) and outcome, from the bookkeeping leaves."""
    found: dict[int, dict] = {}
    for change in log.transitions:
        node = log.nodes[change.node]
        if change.after != "SUCCESS" or node["type"] not in ("begin_transfer", "finish_transfer"):
            continue
        number = _TRANSFER.search(change.feedback)
        if number is None:
            continue
        index = int(number.group(1))
        if node["type"] == "begin_transfer":
            params = node["params"]
            found[index] = {
                "index": index,
                "label": f"{params.get('pick')}→{params.get('place')}",
                "start": change.t,
            }
            found[index].update(end=None, outcome="unfinished")
        elif index in found:
            outcome = _FINISH.search(change.feedback)
            found[index].update(end=change.t, outcome=outcome.group(1) if outcome else "placed")
    return [found[index] for index in sorted(found)]


def figure_format(out: Path) -> str:
    """The format `out` is written in: its suffix's, PNG without one (written to `out` as named, where
    matplotlib would add `.png`); a suffix matplotlib cannot write is a `PegbtError` before any drawing."""
    from matplotlib.backend_bases import FigureCanvasBase

    suffix = out.suffix[1:].lower()
    known = FigureCanvasBase.get_supported_filetypes()
    if suffix and suffix not in known:
        raise PegbtError(
            f"cannot write a .{suffix} figure; the formats are {', '.join(sorted(known))}",
            file=out,
            field="--out",
        )
    return suffix or "png"


def plot_timeline(log: TickLog, out: Path, faults: Sequence[dict] = ()) -> Path:
    """Draw the run's timeline (see the module docstring) to `out` (PNG, SVG or PDF by its suffix); `faults`
    (run time `t`, `detail`) are those the simulator injected, when known."""
    file_format = figure_format(out)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spans = running_spans(log)
    arms = sorted({leaf_arm(log.nodes[node]) for node, _, _ in spans} - {"no arm"}) + ["no arm"]
    lanes = [*arms, "transfers", "trouble"]
    types = sorted({log.nodes[node]["type"] for node, _, _ in spans})
    palette = plt.get_cmap("tab20")
    colour = {kind: palette(i % 20) for i, kind in enumerate(types)}
    figure, axis = plt.subplots(figsize=(14, 1.0 + 0.8 * len(lanes)))
    y = {lane: len(lanes) - 1 - i for i, lane in enumerate(lanes)}
    for node, start, end in spans:
        kind = log.nodes[node]["type"]
        axis.barh(
            y[leaf_arm(log.nodes[node])], max(end - start, 1e-3), left=start, height=0.6, color=colour[kind]
        )
    for transfer in transfers(log):
        end = transfer["end"] if transfer["end"] is not None else log.last_t
        axis.barh(
            y["transfers"],
            end - transfer["start"],
            left=transfer["start"],
            height=0.6,
            color=OUTCOME_COLOURS.get(transfer["outcome"], "white"),
            edgecolor="black",
            hatch="//" if transfer["end"] is None else None,
        )
        axis.text(
            (transfer["start"] + end) / 2,
            y["transfers"],
            transfer["label"],
            ha="center",
            va="center",
            fontsize=7,
        )
    _trouble(log, axis, y["trouble"])
    if faults:
        axis.scatter(
            [fault["t"] for fault in faults],
            [y["trouble"] + 0.3] * len(faults),
            marker="v",
            s=60,
            color="tab:purple",
            label="fault injected (simulator)",
        )
    axis.set_yticks(list(y.values()), list(y.keys()))
    axis.set_xlabel("run time (s, executive clock)")
    axis.set_xlim(0, max(log.last_t, 1e-3))
    axis.set_title(f"{log.header.get('tree')}: {log.outcome} after {log.last_t:.2f} s, {log.last_n} ticks")
    kinds = [plt.Rectangle((0, 0), 1, 1, color=colour[kind]) for kind in types]
    first = axis.legend(
        kinds, types, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, title="leaves"
    )
    axis.add_artist(first)
    axis.legend(loc="lower left", bbox_to_anchor=(1.01, 0.0), fontsize=7, title="trouble")
    axis.grid(axis="x", alpha=0.3)
    figure.tight_layout()
    figure.savefig(out, dpi=100, format=file_format)
    plt.close(figure)
    return out


def _trouble(log: TickLog, axis: Axes, row: float) -> None:
    leaves = {node["id"] for node in log.nodes if not log.children(node["id"])}
    checks = {node["id"] for node in log.nodes if node["type"] in CONTROL_FLOW}
    second_children = {log.children(node["id"])[1] for node in log.nodes if node["type"] == "recover"}
    failures = [c.t for c in log.transitions if c.node in leaves - checks and c.after == "FAILURE"]
    recoveries = [
        c.t
        for c in log.transitions
        if c.node in second_children and c.before != "RUNNING" and c.after != "INVALID"
    ]
    halts = [c.t for c in log.transitions if c.halted and c.node in leaves]
    axis.scatter(failures, [row + 0.15] * len(failures), marker="x", color="tab:red", label="leaf failure")
    axis.scatter(
        recoveries, [row - 0.15] * len(recoveries), marker="^", color="tab:orange", label="recovery starts"
    )
    if halts:
        axis.scatter(halts, [row] * len(halts), marker="|", s=200, color="black", label="halted")
    timeline = Timeline(log)
    given_up = [chain for chain in failure_chains(log, timeline) if chain.handled == "given up"]
    if given_up:
        axis.scatter(
            [chain.first_cause.t for chain in given_up],
            [row] * len(given_up),
            marker="X",
            s=90,
            color="black",
            label="given up on (first cause)",
        )
    root_failure = timeline.final_failure(0)
    if log.end and log.end["outcome"] == "failure" and root_failure is not None:
        first = timeline.first_origin(root_failure)
        axis.scatter(
            [first.t],
            [row],
            marker="*",
            s=260,
            color="tab:red",
            edgecolor="black",
            label="first cause (log why)",
        )
