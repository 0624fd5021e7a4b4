"""One family and seed of `pegbt bench sim2real-outcomes`, diagnosed in process, its held-out cells laid open.

Prints the concealed ("real") cells, what was named (estimate, interval, the grid's weights, the worlds the
prediction mixes: `predict.nodes`) and, per held-out cell, the real count, the predicted rate and interval,
and the concealed world's own count on the prediction's seeds (what a perfect fit would predict). `--memo`
keeps the simulated transfers in a pickle between runs, so a run after a change to the fit or the
prediction simulates only what changed. Run (docs/guides/sim-to-real.md):
`PYTHONPATH=$PWD nice -n 5 .venv/bin/python dev/held_out_cells.py --family registration_offset --seed 0`
(`--size N`: the fit cells' real transfers, as the bench plans them for the family).
"""

from __future__ import annotations

import argparse
import os
import pickle
import time
from pathlib import Path

import numpy as np

from pegbt.bench.sim2real_outcomes import FAMILIES, REAL_TRANSFERS, SETTINGS, concealed_outcomes, score
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cache import MemoMapper
from pegbt.sim2real.outcomes.diagnose import diagnose
from pegbt.sim2real.outcomes.predict import PREDICT_SEED, nodes
from pegbt.sim2real.outcomes.simulate import simulate_cells
from pegbt.sim2real.outcomes.workers import LocalMapper


def _save(memo: MemoMapper, path: Path | None) -> None:
    if path is not None:
        path.with_suffix(".tmp").write_bytes(pickle.dumps(memo.known))
        os.replace(path.with_suffix(".tmp"), path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", choices=list(FAMILIES), default="registration_offset")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--size",
        type=int,
        default=REAL_TRANSFERS,
        help="real transfers a fit cell (the bench plans it per family)",
    )
    parser.add_argument("--memo", type=Path, help="pickle of simulated transfers, read and written")
    args = parser.parse_args()
    memo = MemoMapper(LocalMapper(0))
    if args.memo is not None and args.memo.exists():
        memo.known = pickle.loads(args.memo.read_bytes())
    started = time.process_time()
    hidden = WorldEffects.of(FAMILIES[args.family])
    (real,) = concealed_outcomes(memo, [hidden], args.seed, args.size, REAL_TRANSFERS)
    for cell in real.cells:
        print(f"real {cell.key}: {cell.succeeded}/{cell.attempted} {dict(cell.failures)}")
    d = diagnose(real, SETTINGS, memo)
    _save(memo, args.memo)
    print(f"score {score(d, FAMILIES[args.family])}; {d.simulated} transfers needed")
    for fitted in d.verdict.named:
        low, high = fitted.interval()
        values, weights = nodes(*fitted.posterior())
        print(
            f"named {fitted.candidate.name}: estimate {fitted.estimate:.4g} (95 % {low:.4g}–{high:.4g}); "
            f"grid {np.round(fitted.values, 5).tolist()} weights {np.round(fitted.weights(), 3).tolist()}; "
            f"predicted at {np.round(values, 5).tolist()} weighing {weights.tolist()}"
        )
    keys = [c.key for c in d.held_out]
    own = simulate_cells(memo, [hidden], keys, SETTINGS.transfers, first_seed=PREDICT_SEED)[0]
    many = simulate_cells(memo, [hidden], keys, REAL_TRANSFERS, first_seed=PREDICT_SEED)[0]
    _save(memo, args.memo)
    for cell in d.held_out:
        p = d.predictions[cell.key]
        print(
            f"held out {cell.key}: real {cell.succeeded}/{cell.attempted}, predicted {p.rate:.3f} "
            f"({p.low:.3f}–{p.high:.3f}, width {p.high - p.low:.3f}) {'inside' if p.inside else 'OUTSIDE'}; "
            f"concealed world on the prediction's seeds {own[cell.key].succeeded}/{own[cell.key].attempted}, "
            f"{many[cell.key].succeeded}/{many[cell.key].attempted}"
        )
    print(f"{time.process_time() - started:.0f} s of CPU, {memo.simulated} transfers simulated")


if __name__ == "__main__":
    main()
