"""`pegbt bench NAME... [--json]`: run benchmarks and print their figures."""

from __future__ import annotations

import argparse
import json
import math

from pegbt.bench import Figures, benchmark_names, run_benchmark
from pegbt.errors import PegbtError
from pegbt.evaluation.cli import add_tls_options, checked_cluster_tls

SIM2REAL_OUTCOMES_ONLY = (
    "seeds", "first_seed", "workers", "cluster", "tls_ca_file", "tls_cert", "tls_key", "families", "out",
)  # fmt: skip


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="run benchmarks and print their figures",
        description="Run benchmarks. Each prints `name: value` lines, or one JSON object with --json "
        "(keyed by benchmark when several are named). Without NAME, list the benchmarks.",
    )
    parser.add_argument("names", nargs="*", metavar="NAME", help="benchmark(s) to run")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--seeds",
        type=int,
        metavar="N",
        help="sim2real-outcomes only: seeds per family (default 5, the goal's size; fewer to fit a session)",
    )
    parser.add_argument(
        "--first-seed",
        type=int,
        metavar="K",
        help="sim2real-outcomes only: run seeds K to K + N - 1 (default 0), to split the full run over "
        "sessions or machines",
    )
    parser.add_argument(
        "--workers",
        type=int,
        metavar="K",
        help="sim2real-outcomes only: local worker processes (default 2)",
    )
    parser.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="sim2real-outcomes only: simulate on this Dask scheduler instead of local workers "
        "(tls://HOST:PORT with the --tls options, or tcp://HOST:PORT on a trusted network)",
    )
    add_tls_options(parser)
    parser.add_argument(
        "--families",
        metavar="A,B",
        help="sim2real-outcomes only: the families to run, comma-separated (default all; names in "
        "`pegbt.bench.sim2real_outcomes.FAMILIES`)",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        help="sim2real-outcomes only: keep the pilot's plan and each family's and seed's score in "
        "DIR/records-CODE.jsonl as they complete; rerun with the same DIR (same code, same families) to "
        "simulate only what is missing",
    )
    parser.set_defaults(handler=_bench)


def _format_value(value: float | int | str) -> str:
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:.6g}"
    return str(value)


def _bench(args: argparse.Namespace) -> int:
    if not args.names:
        print("\n".join(benchmark_names()) or "no benchmarks registered")
        return 0
    given = [
        f"--{name.replace('_', '-')}" for name in SIM2REAL_OUTCOMES_ONLY if getattr(args, name) is not None
    ]
    if given and args.names != ["sim2real-outcomes"]:
        raise PegbtError(
            "--seeds, --first-seed, --workers, --cluster (with its --tls options), --families and --out are "
            "the sim2real-outcomes benchmark's alone: name only it",
            field=given[0],
        )
    if args.workers is not None and args.cluster is not None:
        raise PegbtError(
            "--workers sizes the local pool, which --cluster replaces: give one", field="--workers"
        )
    options: dict[str, object] = {}
    if args.seeds is not None:
        options["seeds"] = args.seeds
    if args.first_seed is not None:
        options["first_seed"] = args.first_seed
    if args.workers is not None:
        options["workers"] = args.workers
    tls = checked_cluster_tls(args)
    if args.cluster is not None:
        options["cluster"], options["tls"] = args.cluster, tls
    if args.families is not None:
        options["families"] = [f.strip() for f in args.families.split(",") if f.strip()]
    if args.out is not None:
        options["out"] = args.out
    results: dict[str, Figures] = {name: run_benchmark(name, **options) for name in args.names}
    if args.json:
        payload = results[args.names[0]] if len(args.names) == 1 else results
        print(json.dumps(payload, sort_keys=False))
    else:
        for name, figures in results.items():
            if len(results) > 1:
                print(f"# {name}")
            for key, value in figures.items():
                print(f"{key}: {_format_value(value)}")
    return 0
