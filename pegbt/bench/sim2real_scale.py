"""`pegbt bench sim2real-scale`: peak memory and time of `pegbt sim2real diagnose` as recordings grow.

A synthetic recording of each length in `MINUTES` (`pegbt sim2real synth --seconds`, 100 Hz, seed 0) is
diagnosed with `--bootstrap 0` in a child process, as a person runs it; the 10-minute one also with the
default bootstrap. Each diagnosis's wall seconds and its CPU seconds (user and system, `wait4`). `growth_kb_per_sample` is the peak's growth from the shortest to the longest, per sample:
what a longer recording costs beyond the fixed part (imports, Gram matrices, chunk buffers). Peak memory is that of the child's whole process tree: the sum of its processes'
resident sets, sampled every `SAMPLE_S`, or the child's own peak (`wait4`) if larger. Beside it, the
peak of their anonymous memory (resident less file-backed: `psutil`'s rss − shared), what the process
itself must hold: the recording-sized intermediates a diagnosis maps from scratch files
(`pegbt.scratch`) are resident only while the kernel has room for them, and
`anon_growth_kb_per_sample` is that peak's growth. The bank a diagnosis would hold were it kept (223
columns at 8 bytes a sample) is given beside it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

MINUTES = (10, 30, 60, 120)
SAMPLE_S = 0.05
BANK_COLUMNS = 223  # a 6-joint stream's regressor bank


def tree_rss(process: psutil.Process) -> tuple[int, int]:
    """(bytes resident, of them anonymous: not backed by a file) in a process and all its descendants
    now ((0, 0) once it is gone)."""
    total, anonymous = 0, 0
    for each in [process, *process.children(recursive=True)]:
        try:
            info = each.memory_info()
        except psutil.Error:
            continue  # ended between the listing and the reading
        total += info.rss
        anonymous += info.rss - getattr(info, "shared", 0)
    return total, anonymous


def measured(command: list[str]) -> tuple[float, float, float, float]:
    """(seconds, CPU seconds of the child, peak MB of the process tree, peak MB of its anonymous memory)
    of one command, which must succeed. CPU is the figure to compare on a loaded machine."""
    start = time.perf_counter()
    child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    process = psutil.Process(child.pid)
    peak = [0, 0]
    done = threading.Event()

    def sample() -> None:
        while not done.wait(SAMPLE_S):
            try:
                rss, anonymous = tree_rss(process)
            except psutil.Error:
                return
            peak[0], peak[1] = max(peak[0], rss), max(peak[1], anonymous)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    stderr = child.stderr.read() if child.stderr else b""
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    seconds = time.perf_counter() - start
    done.set()
    sampler.join()
    if child.returncode:
        raise RuntimeError(f"{' '.join(command)} failed ({child.returncode}): {stderr.decode()[-2000:]}")
    cpu = usage.ru_utime + usage.ru_stime
    return seconds, cpu, max(peak[0], usage.ru_maxrss * 1024) / 1e6, peak[1] / 1e6


def _pegbt(*args: str) -> list[str]:
    return [sys.executable, "-m", "pegbt", *args]


def run(minutes: tuple[int, ...] = MINUTES) -> dict[str, float | int | str]:
    figures: dict[str, float | int | str] = {"rate_hz": 100, "seed": 0}
    with tempfile.TemporaryDirectory(prefix="pegbt-scale-") as folder:
        for length in minutes:
            synth = Path(folder) / f"synth{length}"
            subprocess.run(
                _pegbt("sim2real", "synth", str(synth), "--seconds", str(60 * length)),
                check=True,
                stdout=subprocess.DEVNULL,
            )
            recording = str(synth / "recording")
            seconds, cpu, peak, anonymous = measured(
                _pegbt("sim2real", "diagnose", recording, "--bootstrap", "0", "--out", f"{folder}/d{length}")
            )
            figures[f"diagnose_{length}min_s"] = round(seconds, 1)
            figures[f"diagnose_{length}min_cpu_s"] = round(cpu, 1)
            figures[f"diagnose_{length}min_peak_mb"] = round(peak, 1)
            figures[f"diagnose_{length}min_anon_peak_mb"] = round(anonymous, 1)
            figures[f"bank_{length}min_mb"] = round(BANK_COLUMNS * 8 * 6000 * length / 1e6, 1)
            print(f"{length} min: {seconds:.1f} s, peak {peak:.1f} MB", file=sys.stderr, flush=True)
            if length == min(minutes):
                seconds, cpu, peak, anonymous = measured(
                    _pegbt("sim2real", "diagnose", recording, "--out", f"{folder}/b{length}")
                )
                figures[f"diagnose_{length}min_bootstrap_s"] = round(seconds, 1)
                figures[f"diagnose_{length}min_bootstrap_cpu_s"] = round(cpu, 1)
                figures[f"diagnose_{length}min_bootstrap_peak_mb"] = round(peak, 1)
                figures[f"diagnose_{length}min_bootstrap_anon_peak_mb"] = round(anonymous, 1)
        if len(minutes) > 1:
            short, long = min(minutes), max(minutes)
            for key, peak_key in (("growth", "peak_mb"), ("anon_growth", "anon_peak_mb")):
                figures[f"{key}_kb_per_sample"] = round(
                    (
                        float(figures[f"diagnose_{long}min_{peak_key}"])
                        - float(figures[f"diagnose_{short}min_{peak_key}"])
                    )
                    * 1e3
                    / (6000 * (long - short)),
                    3,
                )
            figures["peak_ratio_longest_over_shortest"] = round(
                float(figures[f"diagnose_{long}min_peak_mb"])
                / float(figures[f"diagnose_{short}min_peak_mb"]),
                3,
            )
    return figures
