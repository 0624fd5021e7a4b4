"""PNG figures of a diagnosis (matplotlib, Agg backend): where, which loops, how well it fits held out."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from pegbt.psm import JOINT_NAMES
from pegbt.sim2real.diagnose import Diagnosis
from pegbt.sim2real.explain import unit

if TYPE_CHECKING:
    from matplotlib.figure import Figure

MAX_POINTS = 6000  # plot at most this many samples per curve (long streams are thinned evenly)


def _thin(n: int) -> np.ndarray:
    return np.arange(0, n, max(1, n // MAX_POINTS))


def write_plots(diagnosis: Diagnosis, out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    recording = diagnosis.recording
    times = recording.times
    label = "time (s)" if recording.t is not None else "sample"
    before, after = diagnosis.residual_before, diagnosis.residual_after
    keep = _thin(recording.n)
    paths = []

    fig, axes = plt.subplots(6, 1, figsize=(11, 13), sharex=True)
    for j, ax in enumerate(axes):
        ax.plot(times[keep], before[keep, j], lw=0.6, color="tab:red", label="real − sim (before)")
        ax.plot(times[keep], after[keep, j], lw=0.6, color="tab:blue", label="real − model (held out)")
        for t0, t1, _ in diagnosis.mismatch[j].windows:
            ax.axvspan(t0, t1, color="orange", alpha=0.25, lw=0)
        ax.set_ylabel(f"{JOINT_NAMES[j]} ({unit(JOINT_NAMES[j])})")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Residual over time; shaded: where the error concentrates")
    axes[-1].set_xlabel(label)
    paths.append(_save(fig, out / "residual_over_time.png", plt))

    fig, axes = plt.subplots(2, 6, figsize=(18, 6))
    for j in range(6):
        for row, (residual, name) in enumerate(((before, "before"), (after, "after, held out"))):
            ax = axes[row, j]
            ax.plot(
                recording.q_cmd[keep, j],
                residual[keep, j],
                lw=0.3,
                color="tab:red" if row == 0 else "tab:blue",
            )
            ax.set_title(f"{JOINT_NAMES[j]} error {name}", fontsize=9)
            ax.set_xlabel(f"{JOINT_NAMES[j]} command")
    fig.suptitle("Error versus command: loops are hysteresis or play, slopes are scale, levels are offsets")
    paths.append(_save(fig, out / "error_vs_command.png", plt))

    a, b = max(diagnosis.fold_ranges, key=lambda r: r[1] - r[0])
    span = np.arange(a, b)[_thin(b - a)]
    fig, axes = plt.subplots(6, 1, figsize=(11, 13), sharex=True)
    for j, ax in enumerate(axes):
        ax.plot(times[span], recording.q_phy[span, j], lw=1.2, color="black", label="measured")
        ax.plot(times[span], diagnosis.simulated[span, j], lw=0.8, color="tab:red", label="simulator before")
        ax.plot(
            times[span],
            diagnosis.heldout_prediction[span, j],
            lw=0.8,
            color="tab:blue",
            label="model (held out)",
        )
        ax.set_ylabel(f"{JOINT_NAMES[j]} ({unit(JOINT_NAMES[j])})")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Held-out segment: measured joints, the simulator before, and the fitted model")
    axes[-1].set_xlabel(label)
    paths.append(_save(fig, out / "heldout_fit.png", plt))
    return paths


def _save(fig: Figure, path: Path, plt: ModuleType) -> str:
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return str(path)
