"""`report.json`, `report.md`, the figure and the fitted world file(s) of a diagnosis."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pegbt.sim.world_effects import write_world_file
from pegbt.sim2real.outcomes.alternatives import shares
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.diagnose import OPEN_MIXED, Diagnosis, profile_parameters
from pegbt.sim2real.outcomes.goals import Trials, judge, percent, placed_in_full, time_agrees, verdict_text
from pegbt.sim2real.outcomes.intervals import rate_interval
from pegbt.sim2real.outcomes.likelihood import has_phases
from pegbt.sim2real.outcomes.predict import KEEPS, Prediction
from pegbt.sim2real.outcomes.simulate import CATEGORIES, SimCounts
from pegbt.sim2real.outcomes.transfer_order import arms_at_once


def trial_seconds(variant: str, counts: SimCounts) -> float | None:
    """A trial's seconds per transfer placed, as a real table states it: one simulated transfer's seconds
    shared among the transfers that run at once (`arms_at_once`)."""
    seconds = counts.mean_transfer_s
    return None if seconds is None else seconds / arms_at_once(variant)


def _seconds(cell: Cell, before: SimCounts, after: SimCounts) -> str:
    """A cell's mean transfer times, real / simulated before / after, and whether after agrees."""

    def show(value: float | None) -> str:
        return "–" if value is None else f"{value:.1f}"

    simulated = trial_seconds(cell.variant, after)
    agrees = time_agrees(cell.mean_transfer_s, simulated)
    verdict = "" if agrees is None else (" (within 20 %)" if agrees else " (**off by > 20 %**)")
    return f"{show(cell.mean_transfer_s)} / {show(trial_seconds(cell.variant, before))} / {show(simulated)}{verdict}"


def report_dict(diagnosis: Diagnosis, commands: list[str] | None = None) -> dict[str, Any]:
    """The report as JSON-ready data: `cells`, `named`, and what could not be named or explained."""
    d = diagnosis
    held = {c.key for c in d.held_out}
    cells = []
    for cell in d.outcomes.cells:
        before, p = d.before[cell.key], d.predictions[cell.key]
        entry: dict[str, Any] = {
            "variant": cell.variant,
            "condition": cell.condition,
            "real": {"attempted": cell.attempted, "succeeded": cell.succeeded},
            "real_interval": list(rate_interval(cell.succeeded, cell.attempted)),
            "simulated_before": before.rate,
            "simulated_after": p.at_best.rate,
            "simulated_after_counts": [p.at_best.succeeded, p.at_best.attempted],
            "simulated_after_wilson_low": p.keeps,
            "simulated_after_pooled": d.pools_after,  # counts: the pooled worlds' effective transfers
            "predicted": {"rate": p.rate, "low": p.low, "high": p.high},
            "held_out": cell.key in held,
            "inside": p.inside,
            "rate_in_real_interval": rate_in_real_interval(cell, p),
            "simulated_transfers": before.attempted,
            "simulated_phases_before": dict(before.counts),
            "simulated_phases_after": dict(p.at_best.counts),
            "simulated_seconds_before": before.seconds,
            "simulated_seconds_after": p.at_best.seconds,
            "simulated_mean_transfer_s_before": trial_seconds(cell.variant, before),
            "simulated_mean_transfer_s_after": trial_seconds(cell.variant, p.at_best),
        }
        if cell.mean_transfer_s is not None:
            entry["real_mean_transfer_s"] = cell.mean_transfer_s
            entry["mean_transfer_s_within_20_percent"] = time_agrees(
                cell.mean_transfer_s, trial_seconds(cell.variant, p.at_best)
            )
        if cell.failures:
            entry["real"]["failures"] = dict(cell.failures)
        if d.predicted_by:
            entry["predicted_span"] = list(tie_span(d, cell))
        for name, predictions in d.predicted_by.items():
            if cell.key not in predictions:  # an open effect beside a world that explains the fit cells
                continue
            q = predictions[cell.key]
            entry.setdefault("predicted_by", {})[name] = {
                "rate": q.rate,
                "low": q.low,
                "high": q.high,
                "inside": q.inside,
                "rate_in_real_interval": rate_in_real_interval(cell, q),
            }
        cells.append(entry)
    named = []
    for fitted in d.verdict.named:
        values, intervals = profile_parameters(fitted)
        named.append({"effect": fitted.candidate.kind, "parameters": values, "intervals": intervals})
    return {
        "source": d.outcomes.source,
        "counting": "until_lost" if d.outcomes.attempts_end_at_lost_block else "every_attempt",
        "fit_on": d.settings.fit,
        "transfers_per_cell": d.settings.transfers,
        "transfers_per_cell_default_world": d.settings.located,
        "grid_points": d.settings.points,
        "cells": cells,
        "disagreements": [
            {
                "variant": r.variant,
                "condition": r.condition,
                "phase": r.phase,
                "real": list(r.real),
                "simulated": list(r.simulated),
                "real_interval": list(r.real_interval),
                "simulated_interval": list(r.simulated_interval),
                "p_value": r.p_value,
                "beyond_chance": r.disagrees,
            }
            for r in d.rows
        ],
        "named": named,
        "unchecked": d.verdict.unchecked,
        "indistinguishable": [
            {
                "effect": t.candidate.kind,
                "world": t.label,
                "parameter": t.candidate.parameter,
                "value": t.estimate,
                "interval": list(t.interval()),
                "log_likelihood": float(t.total.max()),
            }
            for t in d.verdict.tied
        ],
        "candidates": [
            {
                "candidate": p.candidate.name,
                "best": p.value,
                "log_likelihood": float(p.total.max()),
                "paired_gain": p.paired_gain,
                "passed": p.candidate.name in d.verdict.passing,
                "weighed": p.candidate.name in d.verdict.tested,
            }
            for p in d.verdict.tried
        ],
        "null_log_likelihood": float(d.verdict.null.sum()),
        "open": [
            {
                "candidate": a.name,
                "allowed": [min(a.allowed), max(a.allowed)],
                "value": a.value,
                "world": a.label,
                "share": float(share),
            }
            for a, share in zip(d.alternatives, shares(d.alternatives))
        ],
        "unreplicated": list(d.unreplicated),
        "tie": d.resolved,
        "unexplained": [
            {"variant": r.variant, "condition": r.condition, "phase": r.phase, "p_value": r.p_value}
            for r in d.unexplained
        ],
        "simulated_transfers": d.simulated,
        "seconds": d.seconds,
        "commands": commands or [],
    }


def rate_in_real_interval(cell: Cell, prediction: Prediction) -> bool:
    """Whether the predicted rate lies in the real count's 95 % interval: the issue's test of a prediction,
    stricter than the real count lying in the (wider) predictive interval."""
    low, high = rate_interval(cell.succeeded, cell.attempted)
    return low <= prediction.rate <= high


def fitted_world_name(d: Diagnosis) -> str:
    """What the cells' main prediction (`predictions`) was made with."""
    if d.verdict.named:
        return " + ".join(f.candidate.kind for f in d.verdict.named)
    if d.verdict.tied:
        return "the tie, mixed" if len(d.verdict.tied) > 1 else d.verdict.tied[0].label
    return OPEN_MIXED if d.predicts_open_mixture else "the default world"


def _verdict(cell: Cell, q: Prediction, kept: bool = True) -> str:
    """A held-out cell's verdict. `kept`: a cell placed in full is judged by what the world's best value
    keeps (`KEEPS`), not by a rate a few transfers estimate; a prediction over an open effect's range has no
    best value to keep, so it is judged as the other cells are."""
    if kept and placed_in_full(cell):
        return f"{q.at_best.succeeded}/{q.at_best.attempted} placed"
    in_real = "in" if rate_in_real_interval(cell, q) else "**not in**"
    return f"{percent(q.rate)} ({percent(q.low)}–{percent(q.high)}): {'inside' if q.inside else '**outside**'}; rate {in_real} real 95 %"


def _held_out_by_world(d: Diagnosis) -> list[str]:
    """Per held-out cell, each world's prediction and both tests, and the summary: how many cells the
    fitted world alone gets inside, and which cells only a world the fit cells cannot tell from it
    reaches."""
    if not d.held_out:
        return []
    fitted = fitted_world_name(d)
    main = [d.predictions[c.key] for c in d.held_out]
    partial = [(c, d.predictions[c.key]) for c in d.held_out if not placed_in_full(c)]
    lines = [
        "",
        f"With {fitted} (the prediction above): {sum(q.inside for q in main)} of {len(main)} held-out cells "
        "inside their 95 % predictive interval"
        + (
            f"; of the {len(partial)} the real robot did not place in full, the predicted rate inside the "
            f"real count's 95 % interval in {sum(rate_in_real_interval(c, q) for c, q in partial)}"
            if partial
            else ""
        )
        + ".",
    ]
    if not d.predicted_by:
        return lines
    worlds = list(d.predicted_by)
    lines += [
        "",
        "Held-out cells per world (predicted rate, 95 % predictive interval: whether the real count is "
        "inside; whether the predicted rate is in the real count's 95 % interval):",
        "",
        "| world | "
        + " | ".join(f"{c.variant} {c.condition} (real {percent(c.rate)})" for c in d.held_out)
        + " |",
        "|---|" + "---|" * len(d.held_out),
    ]
    ranged = {a.label for a in d.alternatives} | {OPEN_MIXED}
    for world in worlds:
        row = [_verdict(c, d.predicted_by[world][c.key], world not in ranged) for c in d.held_out]
        lines.append(f"| {world} | " + " | ".join(row) + " |")
    label = "alternatives" if d.alternatives else "tied worlds"
    lines.append("")
    for cell, q in partial:
        reaching = [w for w in worlds if rate_in_real_interval(cell, d.predicted_by[w][cell.key])]
        if rate_in_real_interval(cell, q):
            continue
        if reaching:
            lines.append(
                f"- {cell.variant} {cell.condition}: the predicted rate reaches the real count's 95 % interval "
                f"only with {', '.join(reaching)}, which the fit cells cannot tell apart from the rest; "
                f"with {fitted} it does not."
            )
        else:
            lines.append(
                f"- {cell.variant} {cell.condition}: no world here (neither {fitted} nor the {label}) "
                "predicts a rate in the real count's 95 % interval."
            )
    return lines


def _passed(d: Diagnosis, name: str) -> str:
    """Whether a candidate passed alone; one the screen's leaders led beyond the χ² margin, and that did not
    rise to them when probed, was never tested (`fit.leaders_to_weigh`)."""
    if name in d.verdict.passing:
        return "yes"
    return "no" if name in d.verdict.tested else "not tested: trailed the leaders"


def _unphased(d: Diagnosis) -> list[str]:
    """Cells whose failures per phase are set aside: some failed in no phase the simulator tells apart (a
    tick log's `unknown`), or they do not add up to the failures, so the cell is judged on its placed rate."""
    lines = []
    for cell in d.outcomes.cells:
        if cell.failures and not has_phases(cell):
            failed, phased = cell.attempted - cell.succeeded, sum(cell.failures.values())
            unknown = {phase: n for phase, n in cell.failures.items() if phase not in CATEGORIES}
            lines.append(
                f"{cell.variant} {cell.condition}: its failures per phase are set aside and it is compared on "
                "its placed rate alone ("
                + (
                    ", ".join(f"{n} failed in `{phase}`" for phase, n in sorted(unknown.items()))
                    + ", no phase the simulator tells apart"
                    if unknown
                    else f"{phased} failures per phase for {failed} failed"
                )
                + ")."
            )
    return ["", *lines] if lines else []


def _span_heading(d: Diagnosis) -> str:
    """What the span of the worlds' rates is: the prediction itself only where a tie predicts."""
    if len(d.verdict.tied) > 1:
        return "Across the tie (the prediction is this span of rates, not one effect's):"
    return f"Across the worlds above (the span of their rates; predicted with {fitted_world_name(d)}):"


def tie_span(d: Diagnosis, cell: Cell) -> tuple[float, float]:
    """The lowest and highest rate the worlds of `Diagnosis.predicted_by` predict for `cell`: a tie's, or
    the world that predicts and those left open beside it."""
    rates = [predictions[cell.key].rate for predictions in d.predicted_by.values() if cell.key in predictions]
    return min(rates), max(rates)


def _allowed(values: tuple[float, ...]) -> str:
    low, high = min(values), max(values)
    return f"{low:.4g}" if low == high else f"any of {low:.4g}–{high:.4g}"


def _finding(d: Diagnosis) -> list[str]:
    lines = []
    if not d.verdict.tried and not d.verdict.named:
        return ["No fit cell disagrees with the default world beyond chance: nothing is named."]
    if d.verdict.named:
        for fitted in d.verdict.named:
            low, high = fitted.interval()
            lines.append(
                f"**Named: {fitted.candidate.kind}**, {fitted.candidate.parameter} = {fitted.estimate:.4g} "
                f"(95 % interval {low:.4g}–{high:.4g}, read between grid values)."
            )
    elif d.verdict.unchecked:
        names = ", ".join(f"{t.label} ({t.candidate.name} ≈ {t.estimate:.4g})" for t in d.verdict.tied)
        lines.append(
            f"**Explained, not named:** {names} "
            + ("fits" if len(d.verdict.tied) == 1 else "fit")
            + " the fit cells better than the default world beyond chance (χ² at 95 %, and again on fresh "
            "seeds), but the fit cells hold one informative count, so no fit cell is left to hold out and "
            "test it on: none is named, and "
            + ("it predicts" if len(d.verdict.tied) == 1 else "each predicts, mixed equally,")
            + " the other cells below."
        )
    elif d.verdict.tied:
        names = ", ".join(f"{t.label} ({t.candidate.name} ≈ {t.estimate:.4g})" for t in d.verdict.tied)
        lines.append(
            f"**Not told apart:** {names} explain the fit cells equally well (log-likelihoods within 1); with "
            + (
                "one informative count per cell and no phases"
                if not any(c.failures for c in d.fit_cells)
                else "these phases"
            )
            + " the data cannot say which, so neither is named and each predicts the other cells below."
        )
    else:
        lines.append(
            "**Unexplained:** the fit cells disagree, and no registered world effect fits them better beyond chance and on held-out cells."
        )
    if d.alternatives:
        opened = "; ".join(f"{a.name} ({_allowed(a.allowed)} fits as well)" for a in d.alternatives)
        lines.append(
            f"**Not told apart:** the fit cells leave open {opened}. Each changes the held-out cells: at its "
            "farthest allowed value it predicts them otherwise than the world without it, so no value is "
            "named. The held-out cells are predicted below with each over its registered range (a flat "
            "prior, weighed by the fit cells), and with all of them mixed ("
            + ", ".join(f"{a.name} {percent(w)}" for a, w in zip(d.alternatives, shares(d.alternatives)))
            + ", each weighed by how well it fits the fit cells on average over its range): what a "
            "prediction carries when the fit cells cannot say whether an effect acts, where the world "
            "without them assumes none does."
            + (
                " The fit's gate rejects the default world in the fit cells and no effect explains them "
                "alone, so the mixture is the prediction (Prove); "
                "the default world is shown beside it."
                if d.predicts_open_mixture
                else ""
            )
        )
    if d.resolved:
        lines.append(d.resolved)
    if d.unreplicated:
        lines.append(
            f"Chosen by the fit but not named: {', '.join(d.unreplicated)}; simulated again on fresh seeds, "
            "its gain over the world before it was within chance (the grid's best on the fit's own "
            "simulations is biased upwards by the pick)."
        )
    for row in d.unexplained:
        lines.append(
            f"Still unexplained at the fitted world: {row.variant} {row.condition} {row.what} (p = {row.p_value:.3g})."
        )
    return lines


def report_markdown(d: Diagnosis, commands: list[str] | None = None) -> str:
    lines = [
        "# Sim to real at the task level",
        "",
        f"Real outcomes: {d.outcomes.source}"
        + (" (attempts end at a block lost for good)" if d.outcomes.attempts_end_at_lost_block else "")
        + ". Simulator: each transfer's phases on the world with the `dvrk-real` arm, "
        f"{max(d.settings.located, d.settings.transfers)} "
        f"transfers per fit cell in the default world ({d.settings.transfers} per held-out cell) and "
        f"{d.settings.transfers} per cell and fitted world, "
        f"{d.simulated} in all, {d.seconds:.0f} s. Fitted on: {d.settings.fit}.",
        "",
        "## Locate",
        "| variant | condition | what | real | 95 % | simulated (default world) | 95 % | p | beyond chance |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in d.rows:
        lines.append(
            f"| {r.variant} | {r.condition} | {r.what} | {r.real[0]}/{r.real[1]} | "
            f"{percent(r.real_interval[0])}–{percent(r.real_interval[1])} | {r.simulated[0]}/{r.simulated[1]} | "
            f"{percent(r.simulated_interval[0])}–{percent(r.simulated_interval[1])} | {r.p_value:.3g} | {'yes' if r.disagrees else 'no'} |"
        )
    lines += _unphased(d)
    lines += ["", "## Name", *_finding(d), ""]
    if d.verdict.tried:
        lines += [
            "| candidate | best value | log-likelihood (null " + f"{d.verdict.null.sum():.1f}) "
            "| gain over the default world on the same seeds | passed |",
            "|---|---|---|---|---|",
        ]
        for p in d.verdict.tried:
            lines.append(
                f"| {p.candidate.name} | {p.value:.4g} | {p.total.max():.1f} | {p.paired_gain:+.1f} | {_passed(d, p.candidate.name)} |"
            )
        lines.append("")
    lines += [
        "## Prove",
        f"Predicted with {fitted_world_name(d)}.",
        "",
        "| variant | condition | real | simulated before | after | predicted (95 %) | held out | inside "
        "| s per transfer placed (trial): real / before / after |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    held = {c.key for c in d.held_out}
    for cell in d.outcomes.cells:
        q = d.predictions[cell.key]
        lines.append(
            f"| {cell.variant} | {cell.condition} | {cell.succeeded}/{cell.attempted} ({percent(cell.rate)}) | "
            f"{percent(d.before[cell.key].rate)} | {percent(q.at_best.rate)} | {percent(q.rate)} ({percent(q.low)}–{percent(q.high)}) | "
            f"{'yes' if cell.key in held else 'no'} | {'yes' if q.inside else '**no**'} | "
            f"{_seconds(cell, d.before[cell.key], q.at_best)} |"
        )
    lines += _held_out_by_world(d)
    if d.predicted_by and d.held_out:
        lines += ["", _span_heading(d)]
        for cell in d.held_out:
            low, high = tie_span(d, cell)
            real_low, real_high = rate_interval(cell.succeeded, cell.attempted)
            reaches = (
                "inside"
                if real_low <= low and high <= real_high
                else ("overlapping" if low <= real_high and real_low <= high else "outside")
            )
            lines.append(
                f"- {cell.variant} {cell.condition}: {percent(low)}–{percent(high)}; real {percent(cell.rate)} "
                f"({percent(real_low)}–{percent(real_high)}): {reaches}"
            )
    full = [c for c in d.outcomes.cells if placed_in_full(c)]
    if full:
        lines += [
            "",
            f"Cells the real robot placed in full, at {fitted_world_name(d)} (goal: ≥ {percent(KEEPS)} kept):",
        ]
        for cell in full:
            q = d.predictions[cell.key]
            lines.append(
                f"- {cell.variant} {cell.condition}: {q.at_best.succeeded}/{q.at_best.attempted} placed"
                + (" (the pooled worlds' effective transfers)" if d.pools_after else "")
                + f", Wilson 95 % lower bound {percent(q.keeps)}: {'kept' if q.keeps >= KEEPS else '**not shown**'}"
            )
    if commands:
        lines += ["", "## Commands", "```bash", *commands, "```"]
    return "\n".join(lines) + "\n"


def write_figure(d: Diagnosis, path: Path) -> Path:
    """Real against simulated success per cell, before and after, with intervals, and the phases."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells: list[Cell] = list(d.outcomes.cells)
    figure, (rates, phases) = plt.subplots(1, 2, figsize=(13, 4.8))
    x = range(len(cells))
    labels = [
        f"{c.variant[:4]}\n{c.condition[:5]}" + ("\n(held out)" if c in d.held_out else "") for c in cells
    ]
    real = [c.rate for c in cells]
    err = [
        [c.rate - rate_interval(c.succeeded, c.attempted)[0] for c in cells],
        [rate_interval(c.succeeded, c.attempted)[1] - c.rate for c in cells],
    ]
    rates.errorbar([i - 0.2 for i in x], real, yerr=err, fmt="o", color="black", label="real (95 %)")
    rates.plot(
        [i - 0.05 for i in x],
        [d.before[c.key].rate for c in cells],
        "x",
        color="tab:red",
        label="simulated, default world",
    )
    predicted = [d.predictions[c.key] for c in cells]
    rates.errorbar(
        [i + 0.15 for i in x],
        [p.rate for p in predicted],
        yerr=[[p.rate - p.low for p in predicted], [p.high - p.rate for p in predicted]],
        fmt="s",
        color="tab:blue",
        label=f"predicted with {fitted_world_name(d)} (95 %)",
    )
    rates.set_xticks(list(x), labels, fontsize=7)
    rates.set_ylabel("transfers placed")
    rates.set_ylim(-0.02, 1.05)
    rates.legend(fontsize=7)
    rates.set_title("success per cell")
    bottom = [0.0] * len(cells)
    width = 0.35
    for k, category in enumerate(CATEGORIES[1:]):
        before = [d.before[c.key].counts[category] / max(d.before[c.key].attempted, 1) for c in cells]
        after = [
            d.predictions[c.key].at_best.counts[category] / max(d.predictions[c.key].at_best.attempted, 1)
            for c in cells
        ]
        color = plt.get_cmap("tab10")(k)
        phases.bar([i - width / 2 for i in x], before, width, bottom=bottom, color=color, label=category)
        phases.bar(
            [i + width / 2 for i in x],
            after,
            width,
            bottom=[0.0] * len(cells) if k == 0 else _after_bottom(d, cells, k),
            color=color,
            hatch="//",
        )
        bottom = [b + v for b, v in zip(bottom, before)]
    phases.set_xticks(list(x), labels, fontsize=7)
    phases.set_ylabel("simulated transfers failed, by phase (left before, hatched after)")
    phases.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def _after_bottom(d: Diagnosis, cells: list[Cell], upto: int) -> list[float]:
    return [
        sum(d.predictions[c.key].at_best.counts[cat] for cat in CATEGORIES[1 : upto + 1])
        / max(d.predictions[c.key].at_best.attempted, 1)
        for c in cells
    ]


Confirmed = dict[str, dict[tuple[str, str], Trials]]


def _confirmed(d: Diagnosis, data: dict[str, Any], confirmed: Confirmed) -> list[str]:
    """Each world's whole trials per cell and their verdicts, into `data`'s cells (`confirmed`, per world
    file) and as the report's last section."""
    lines = [
        "",
        "## Confirmed by whole trials (`pegbt eval --world-effects`)",
        f"Goals: a cell the real robot placed in full keeps ≥ {percent(KEEPS)}, judged by the rate placed, "
        "its Wilson 95 % interval beside it; any other cell's rate inside the real count's 95 % interval, "
        "and uncalibrated, its mean transfer time within 20 % of the real one."
        + (
            " Counted as the real cells are: a way back whose block was lost on the way out is skipped, "
            "not attempted."
            if d.outcomes.attempts_end_at_lost_block
            else ""
        ),
        "",
        "| world | variant | condition | placed (95 %) | real | mean transfer: trials / real | verdict "
        "| errored trials |",
        "|---|---|---|---|---|---|---|---|",
    ]
    entries = {(e["variant"], e["condition"]): e for e in data["cells"]}
    for world, cells in confirmed.items():
        held = 0
        for key, trials in cells.items():
            real = d.outcomes.cell(*key)
            assert real is not None  # confirm ran the diagnosis's own cells
            verdict = judge(real, trials)
            held += verdict["holds"]
            entries[key].setdefault("confirmed", {})[world] = {
                "attempted": trials.attempted,
                "succeeded": trials.succeeded,
                "skipped": trials.skipped,
                "first_tries": trials.first_tries,
                "first_try_mean_transfer_s": trials.first_try_mean_transfer_s,
                "mean_transfer_s": trials.mean_transfer_s,
                "trials": trials.trials,
                "errors": trials.errors,
                **verdict,
            }
            low, high = verdict["interval"]
            time = "–" if trials.mean_transfer_s is None else f"{trials.mean_transfer_s:.2f}"
            real_time = "–" if real.mean_transfer_s is None else f"{real.mean_transfer_s:.1f}"
            lines.append(
                f"| {world} | {real.variant} | {real.condition} | {trials.succeeded}/{trials.attempted} "
                f"({percent(trials.rate)}; {percent(low)}–{percent(high)}) | "
                f"{real.succeeded}/{real.attempted} | {time} / {real_time} s | {verdict_text(verdict)} | "
                f"{trials.errors} of {trials.trials} |"
            )
        lines += ["", f"At {world}: the goals hold in {held} of {len(cells)} cells.", ""]
    return lines


def write_report(
    d: Diagnosis, out: Path, commands: list[str] | None = None, confirmed: Confirmed | None = None
) -> dict[str, Any]:
    """Everything into `out`: report.json, report.md, outcomes.png, the fitted world file(s) and each open
    alternative's world (`world-open-NAME.yaml`, for `pegbt eval --world-effects`; never confirmed here, a
    campaign each); with `confirmed` (per world file, per cell: whole trials in it) those too, with their
    verdicts."""
    out.mkdir(parents=True, exist_ok=True)
    data = report_dict(d, commands)
    markdown = report_markdown(d, commands)
    if confirmed:
        markdown += "\n".join(_confirmed(d, data, confirmed))
    worlds = []
    if d.verdict.named:
        worlds.append(str(write_world_file(d.world(), out / "world.yaml")))
    for tied in d.verdict.tied:
        worlds.append(str(write_world_file(tied.estimated_world(), out / f"world-{tied.label}.yaml")))
    data["world_files"] = worlds
    data["open_world_files"] = [
        str(write_world_file(a.world(), out / f"world-open-{a.name}.yaml")) for a in d.alternatives
    ]
    (out / "report.json").write_text(json.dumps(data, indent=2) + "\n")
    (out / "report.md").write_text(markdown)
    write_figure(d, out / "outcomes.png")
    return data
