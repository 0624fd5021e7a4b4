"""A folder of tick logs of real runs as outcome cells: each log's header names its variant and condition,
and `pegbt.executive.phases.transfer_outcomes` reads from the log alone whether each transfer succeeded
and the phase it failed in. Nothing else is read: no simulator log (`*.truth.jsonl` files beside the tick
logs of `pegbt eval --keep-logs` are passed over unread), no ground truth."""

from __future__ import annotations

from collections import Counter, defaultdict
from pathlib import Path

from pegbt.errors import PegbtError
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import transfer_outcomes
from pegbt.runconditions import CONDITIONS, VARIANTS
from pegbt.sim2real.outcomes.cells import Cell, Outcomes

TRUTH_SUFFIX = ".truth.jsonl"


def read_tick_logs(folder: Path) -> Outcomes:
    """Cells (variant × condition) of every transfer begun in the tick logs under `folder`."""
    paths = sorted(p for p in folder.rglob("*.jsonl") if not p.name.endswith(TRUTH_SUFFIX))
    if not paths:
        raise PegbtError("no tick logs (*.jsonl) in this folder", file=folder)
    tallies: dict[tuple[str, str], Counter[str]] = defaultdict(Counter)
    for path in paths:
        log = read_tick_log(path)
        variant, condition = log.variant, log.condition
        if variant not in VARIANTS:
            raise PegbtError(
                f"its header names variant {variant!r}; expected one of {', '.join(VARIANTS)}",
                file=path,
                line=1,
                field="variant",
            )
        if condition not in CONDITIONS:
            raise PegbtError(
                f"its header names no condition ({condition!r}); expected one of {', '.join(CONDITIONS)} "
                "(a log written before headers recorded it)",
                file=path,
                line=1,
                field="condition",
            )
        tally = tallies[(variant, condition)]
        for outcome in transfer_outcomes(log):
            tally["attempted"] += 1
            if outcome.succeeded:
                tally["succeeded"] += 1
            else:
                tally[f"phase:{outcome.phase or 'unknown'}"] += 1
    cells = tuple(
        Cell(
            variant,
            condition,
            tally["attempted"],
            tally["succeeded"],
            None,
            {key.removeprefix("phase:"): n for key, n in tally.items() if key.startswith("phase:")},
        )
        for (variant, condition), tally in sorted(
            tallies.items(), key=lambda item: (VARIANTS.index(item[0][0]), CONDITIONS.index(item[0][1]))
        )
    )
    return Outcomes(cells, f"{len(paths)} tick logs in {folder}")
