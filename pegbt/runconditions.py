"""The task variants and run conditions of the reference paper's experiments, as every part names them (the
skills that run them, the leaves whose defaults depend on them, the evaluation's tables, sim2real's outcome
cells): a cell of the paper's Tables II-IV is a variant under a condition.

- `uncalibrated`: rest-to-rest cubic motions, commands sent as planned;
- `calibrated`: the same motions, every commanded row pre-compensated by the arm's calibration model;
- `optimized`: transfers planned as the paper's spline refined by SQP, pre-compensated.
"""

from __future__ import annotations

from pegbt.errors import PegbtError

VARIANTS = ("unilateral", "bilateral", "handover")  # one tree each: trees/VARIANT.yaml
CONDITIONS = ("uncalibrated", "calibrated", "optimized")
COMPENSATED = ("calibrated", "optimized")  # their commands correct the cables' error at the tip
OPTIMIZED = ("optimized",)  # their transfers are planned by the optimiser


def known_condition(condition: object) -> str:
    """`condition` if it names a run condition, else a `PegbtError` on `--condition`."""
    if condition not in CONDITIONS:
        raise PegbtError(
            f"unknown condition {condition!r}; known: {', '.join(CONDITIONS)}", field="--condition"
        )
    return str(condition)
