"""The diagnosis as `report.json` (for tools, and for `ArmPhysics.load`) and `report.md` (for a person).

`report.json["model"]["effects"]` is the whole identified model (the physics diagnosed against, with
what was found merged in), so `pegbt sim --physics DIR/report.json` simulates it directly;
`report.json["effects"]` lists only what this diagnosis named, each with its evidence and a sentence.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pegbt.errors import PegbtError
from pegbt.physics import Effect
from pegbt.psm import JOINT_NAMES
from pegbt.sim2real.compare import compare
from pegbt.sim2real.crossval import N_FOLDS
from pegbt.sim2real.diagnose import Diagnosis
from pegbt.sim2real.explain import unit
from pegbt.sim2real.select import ALPHA

HELDOUT_METHOD = (
    f"nested blocked cross-validation: {N_FOLDS} contiguous held-out segments; for each, the effects, widths "
    "and coefficients are chosen again on the rest of the recording alone (with its own inner folds), then "
    "the merged physics model is replayed over the segment; the effects named above are the whole "
    "recording's choice"
)


ZERO_OFFSET_LABEL = "Zero offset of the arm, geometry and not a cable effect"


def read_named_effects(path: str | Path) -> list[Effect]:
    """The effects an earlier report named (to compare two diagnoses of the same arm)."""
    try:
        return [Effect.from_dict(entry) for entry in json.loads(Path(path).read_text())["effects"]]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise PegbtError(f"not a sim2real report: {error}", file=path) from None
    except PegbtError as error:
        raise PegbtError(error.message, file=path, field=error.field) from None


def report_dict(
    diagnosis: Diagnosis, compared_with: str | Path | None = None, resolution_note: str = ""
) -> dict[str, Any]:
    """The report; with `compared_with` (an earlier report, e.g. of the same arm after re-homing), also
    which kinds of effect both name and which parameters differ; `resolution_note` says where the
    resolution came from when the recording did not state it."""
    recording = diagnosis.recording
    times = recording.times
    comparison = None
    if compared_with is not None:
        names = ("this", str(compared_with))
        comparison = compare([e.effect for e in diagnosis.effects], read_named_effects(compared_with), names)
        comparison = {
            "report": str(compared_with),
            **{k.replace(f"only_{names[1]}", "only_other"): v for k, v in comparison.items()},
        }
    report = {
        "recording": str(recording.path),
        "samples": len(diagnosis.times_before_exclusion),
        "sampling": {"mode": diagnosis.sampling.mode, "reason": diagnosis.sampling.reason},
        "time_unit": "s" if recording.t is not None else "sample",
        "sim": diagnosis.sim,
        "arm": diagnosis.arm,
        "joints": list(JOINT_NAMES),
        "units": {q: unit(q) for q in JOINT_NAMES},
        "mismatch": [m.to_dict() for m in diagnosis.mismatch],
        "effects": [e.to_dict() for e in diagnosis.effects],
        "resolution": None if diagnosis.resolution is None else dict(zip(JOINT_NAMES, diagnosis.resolution)),
        "resolution_note": resolution_note,
        "below_resolution": [b.to_dict() for b in diagnosis.below_resolution],
        "measurement_faults": diagnosis.faults.to_dict(diagnosis.times_before_exclusion),
        "geometry": None if diagnosis.geometry is None else diagnosis.geometry.to_dict(),
        "zero_offsets": [e.to_dict() for e in diagnosis.zero_offsets],
        "not_identifiable": list(diagnosis.not_identifiable),
        "selection": {
            "alpha": ALPHA,
            "hypotheses": diagnosis.hypotheses,
            "level": ALPHA / diagnosis.hypotheses,
            "stopped": {JOINT_NAMES[s.joint]: s.stopped for s in diagnosis.selections},
        },
        "fit": {
            "heldout_rmse_before": diagnosis.rmse_before(),
            "heldout_rmse_after": diagnosis.rmse_after(),
            "method": HELDOUT_METHOD,
            "samples": recording.n,
            "samples_excluded": diagnosis.faults.count,
            "folds": [[float(times[a]), float(times[b - 1])] for a, b in diagnosis.fold_ranges],
            "fold_effects": diagnosis.fold_named,
        },
        "remaining": diagnosis.remaining(),
        "model": {
            "base": diagnosis.sim,
            "effects": [effect.to_dict() for effect in diagnosis.physics.effects],
        },
    }
    if comparison is not None:
        report["comparison"] = comparison
    return report


def _number(value: float) -> str:
    return f"{value:.4g}"


def _pvalue(value: float) -> str:
    return "< 1e-16" if value < 1e-16 else f"= {value:.2g}"


def report_markdown(report: dict[str, Any], plots: list[str]) -> str:
    """`report.md`: the report's content for a person (where, what, how sure, what is left, the plots).

    Written from the JSON report rather than the diagnosis, so the two files can never disagree."""
    lines = [f"# Sim-to-real diagnosis of `{report['recording']}`", ""]
    if report["effects"]:
        lines += ["In order of what they explain:", ""]
        lines += [f"{n}. {e['text']}." for n, e in enumerate(report["effects"], 1)]
    else:
        lines.append("No effect large enough to name.")
    lines.append("")
    lines += [
        f"- {report['samples']} samples; {report['sampling']['reason']}.",
        f"- Measurement faults: {report['measurement_faults']['text']}.",
        *([f"- Geometry: {report['geometry']['text']}."] if report.get("geometry") else []),
        *[f"- {ZERO_OFFSET_LABEL}: {e['text']}." for e in report["zero_offsets"]],
        f"- Simulator physics: `{report['sim']}` (arm {report['arm']}).",
        *([f"- Resolution: {report['resolution_note']}."] if report.get("resolution_note") else []),
        f"- Effects chosen by blocked cross-validation; each must gain in every held-out fold and beat "
        f"circularly shifted data at α = {report['selection']['alpha']} / {report['selection']['hypotheses']} "
        f"tests (joints × effects, Bonferroni).",
        "",
    ]
    lines += [
        "## Where the mismatch is",
        "",
        "| joint | RMSE | bias | share | windows | strongest regimes |",
        "|---|---|---|---|---|---|",
    ]
    for m in report["mismatch"]:
        windows = ", ".join(f"{a:.4g}–{b:.4g}" for a, b in m["windows"][:3]) or "spread evenly"
        regimes = (
            "; ".join(
                f"{r['regime']}: RMSE {_number(r['rmse_in'])} vs {_number(r['rmse_out'])}, bias {_number(r['bias_in'])} "
                f"vs {_number(r['bias_out'])}"
                for r in m["regimes"][:2]
            )
            or "none stands out"
        )
        lines.append(
            f"| {m['joint']} | {_number(m['rmse'])} | {_number(m['bias'])} | {100 * m['share']:.1f} % | "
            f"{windows} | {regimes} |"
        )
    lines += ["", "## What the simulator left out", ""]
    if not report["effects"]:
        lines.append("Nothing: no candidate effect passed the tests.")
    for e in report["effects"]:
        params = ", ".join(
            f"{k} = {v}" if isinstance(v, str) else f"{k} = {_number(v)}" for k, v in e["params"].items()
        )
        ci = ", ".join(f"{k} ∈ [{_number(lo)}, {_number(hi)}]" for k, (lo, hi) in e["ci"].items())
        lines.append(
            f"- **{e['effect']} on {e['joint']}** ({params}; 95 % CI {ci or 'n/a'}; explains "
            f"{100 * e['explains']:.1f} % of the joint's error; p {_pvalue(e['p_value'])}): {e['text']}."
        )
    if report["below_resolution"]:
        lines += ["", "## Below resolution (in the model, not named)", ""]
        lines += [f"- {b['effect']}: {b['reason']}" for b in report["below_resolution"]]
    if report["not_identifiable"]:
        lines += ["", "## Not identifiable from these data", ""]
        lines += [f"- {statement}" for statement in report["not_identifiable"]]
    fit = report["fit"]
    lines += [
        "",
        "## Held-out fit",
        "",
        f"{fit['method']}; on the {fit['samples']} samples kept ({fit['samples_excluded']} excluded as "
        "measurement faults).",
        "",
        "| joint | before | after |",
        "|---|---|---|",
    ]
    for q in report["joints"]:
        lines.append(
            f"| {q} ({report['units'][q]}) | {_number(fit['heldout_rmse_before'][q])} | "
            f"{_number(fit['heldout_rmse_after'][q])} |"
        )
    lines += ["", "Effects named without each held-out segment (the nested choices):", ""]
    lines += [
        f"- segment {n} ({a:.4g}–{b:.4g}): {', '.join(named) or 'none'}"
        for n, ((a, b), named) in enumerate(zip(fit["folds"], fit["fold_effects"]), 1)
    ]
    lines += ["", "## What remains", ""] + [f"- {text}" for text in report["remaining"]]
    if "comparison" in report:
        c = report["comparison"]
        lines += [
            "",
            f"## Compared with `{c['report']}`",
            "",
            f"- Same kinds of effect ({100 * c['agreement']:.0f} % of all named): {', '.join(c['shared']) or 'none'}.",
            f"- Only here: {', '.join(c['only_this']) or 'none'}; only there: {', '.join(c['only_other']) or 'none'}.",
            "- Parameters that differ by more than 25 % (offsets move when an arm is re-homed): "
            + ("; ".join(c["differences"]) or "none")
            + ".",
        ]
    if plots:
        lines += ["", "## Plots", ""] + [f"![{Path(p).stem}]({Path(p).name})" for p in plots]
    return "\n".join(lines) + "\n"


def write_report(
    diagnosis: Diagnosis, out: str | Path, compared_with: str | Path | None = None, resolution_note: str = ""
) -> dict[str, Any]:
    """Write report.json, report.md and the plots into `out`; return the report dictionary."""
    report = report_dict(diagnosis, compared_with, resolution_note)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    from pegbt.sim2real.plots import write_plots

    plots = write_plots(diagnosis, out)
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    (out / "report.md").write_text(report_markdown(report, plots))
    return report
