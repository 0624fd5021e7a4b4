"""A folder of tick logs of real runs as outcome cells: each log's header names its variant and condition,
and `pegbt.executive.phases.transfer_outcomes` reads from the log alone whether each transfer succeeded
and the phase it failed in. The header's protocol (`pegbt run --protocol`) says how the cells count: logs
of the paper's protocol (one attempt per block) as the paper's table does, a way back whose block was
lost not attempted; a folder holds one protocol, as one table does. Nothing else is read: no simulator log
(`*.truth.jsonl` files beside the tick logs of `pegbt eval --keep-logs` are passed over unread), no ground
truth."""

from __future__ import annotations

from collections import Counter, defaultdict
from pathlib import Path
from typing import Any, TypeGuard

from pegbt.errors import PegbtError
from pegbt.executive.logfile import TickLog, TickLogError, read_tick_log
from pegbt.executive.phases import TransferOutcome, begun_transfers, transfer_outcomes
from pegbt.runconditions import CONDITIONS, VARIANTS
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.confirm import ways_back_skipped
from pegbt.sim2real.outcomes.transfer_order import transfers as transfers_of

TRUTH_SUFFIX = ".truth.jsonl"


def read_tick_logs(folder: Path) -> Outcomes:
    """Cells (variant × condition) of every transfer begun in the tick logs under `folder`."""
    paths = sorted(p for p in folder.rglob("*.jsonl") if not p.name.endswith(TRUTH_SUFFIX))
    if not paths:
        raise PegbtError("no tick logs (*.jsonl) in this folder", file=folder)
    tallies: dict[tuple[str, str], Counter[str]] = defaultdict(Counter)
    protocols: dict[str, Path] = {}
    for path in paths:
        log = read_tick_log(path)
        variant, condition = log.variant, log.condition
        protocols.setdefault(log.protocol, path)
        if len(protocols) > 1:
            other = next(first for name, first in protocols.items() if name != log.protocol)
            raise PegbtError(
                f"its header names protocol {log.protocol!r}, and {other} another: a folder holds the "
                "cells of one protocol, counted one way",
                file=path,
                line=1,
                field="run.options.protocol",
            )
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
        outcomes = transfer_outcomes(log)
        skipped = _skipped(log, outcomes, variant) if log.protocol == "paper" else set()
        for outcome in outcomes:
            if outcome.transfer in skipped:
                continue
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
    return Outcomes(
        cells, f"{len(paths)} tick logs in {folder}", attempts_end_at_lost_block="paper" in protocols
    )


def _skipped(log: TickLog, outcomes: list[TransferOutcome], variant: str) -> set[int]:
    """The transfers of `log`, a `variant` trial, the paper's robot would have skipped (`ways_back_skipped`)."""
    begun = begun_transfers(log)
    return ways_back_skipped(
        [
            {"index": outcome.transfer, **_pegs(log, begin, variant), "succeeded": outcome.succeeded}
            for begin, outcome in zip(begun, outcomes, strict=True)
        ],
        variant,
    )


def _pegs(log: TickLog, begin: dict[str, Any], variant: str) -> dict[str, int]:
    """The pick and place pegs a `begin_transfer` node of `log` names, one of `variant`'s transfers, else a
    `TickLogError` on the node: the paper's count follows the blocks from peg to peg in the paper's order
    (`trees/shared/orders.yaml`), which also pairs a bilateral trial's transfers."""
    params = begin.get("params")
    pick, place = (params.get(name) if isinstance(params, dict) else None for name in ("pick", "place"))
    if _peg(pick) and _peg(place) and (pick, place) in {(a, b) for _, a, b in transfers_of(variant)}:
        return {"pick": pick, "place": place}
    raise TickLogError(
        f"its begin_transfer node {begin.get('id')} names pick {pick!r} and place {place!r}, not one of "
        f"{variant}'s transfers under the paper's protocol (trees/shared/orders.yaml)",
        file=log.path,
        line=1,
        field=f"nodes[{begin.get('id')}].params",
    )


def _peg(value: object) -> TypeGuard[int]:
    """Whether `value` is a peg's number (an int, not a bool)."""
    return isinstance(value, int) and not isinstance(value, bool)
