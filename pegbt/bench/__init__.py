"""Every benchmark behind `pegbt bench NAME`: one registry, one output format.

A benchmark is a function `run() -> dict[str, float | int | str]` in its own module. It measures its
baselines in the same process as the thing under test, so that ratios hold on a noisy machine, and
reports medians. Register it in `BENCHMARKS` as `name: "module:function"`; modules load only when run.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from pegbt.errors import PegbtError

Figures = dict[str, float | int | str]

BENCHMARKS: dict[str, str] = {
    "world": "pegbt.bench.world:run",
    "executive": "pegbt.bench.executive:run",
    "calibration": "pegbt.bench.calibration:run",
    "calibration-refit": "pegbt.bench.calibration_refit:run",
    "perception": "pegbt.bench.perception:run",
    "transport": "pegbt.bench.transport:run",
    "sim": "pegbt.bench.sim:run",
    "tick": "pegbt.bench.tick:run",
    "dvrk-sim": "pegbt.bench.dvrk_sim:run",
    "motion": "pegbt.bench.motion:run",
    "limit": "pegbt.bench.limit:run",
    "sim2real": "pegbt.bench.sim2real:run",
    "sim2real-real": "pegbt.bench.sim2real_real:run",
    "sim2real-scale": "pegbt.bench.sim2real_scale:run",
    "sim2real-outcomes": "pegbt.bench.sim2real_outcomes:run",
    "eval": "pegbt.bench.eval:run",
    "monitor": "pegbt.bench.monitor:run",
    "monitor-limits": "pegbt.bench.monitor_limits:run",
    "servo": "pegbt.bench.servo:run",
    "offload": "pegbt.bench.offload:run",
    "fuzz": "pegbt.bench.fuzz:run",
    "startup": "pegbt.bench.startup:run",
}


def benchmark_names() -> list[str]:
    """Names of all registered benchmarks, sorted."""
    return sorted(BENCHMARKS)


def load_benchmark(name: str) -> Callable[[], Figures]:
    """The `run` function of benchmark NAME; a `PegbtError` naming the choices if it is unknown."""
    if name not in BENCHMARKS:
        known = ", ".join(benchmark_names()) or "none registered"
        raise PegbtError(f"unknown benchmark {name!r}; known: {known}", field="NAME")
    module_name, function_name = BENCHMARKS[name].split(":")
    return getattr(importlib.import_module(module_name), function_name)


def run_benchmark(name: str, **options: object) -> Figures:
    """Run benchmark NAME (with the reduced-size `options` it takes, if any) and return its figures."""
    return load_benchmark(name)(**options)
