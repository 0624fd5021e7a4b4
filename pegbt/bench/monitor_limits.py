"""`pegbt bench monitor-limits`: what pages can cost the run a monitor watches (`pegbt run --monitor`).

- `overruns_none`, `overruns_stalled_20`: median over `ROUNDS` of the ticks that overran their 0.02 s
  period in a `SECONDS`-long run on the wall clock that publishes `PAYLOAD` bytes a tick to its monitor
  (a cloud's worth), with no page, and with `STALLED` pages that connect and never read (run in turn);
  `ticks_none`, `ticks_stalled_20`: how many ticks those runs made (a run held back ticks less often
  without overrunning: the runner counts an overrun inside the tick, not a late wake-up);
  `dropped_of_20`: how many of those pages the server dropped (median).
- `huge_frame_hwm_growth_mb`: how much the peak memory (VmHWM) of a `pegbt run --monitor` process grew
  while a page sent it a frame declaring 400 MB (the run's outcome is `huge_frame_run`).
- `history_kb_1min`, `history_kb_1h`: memory the live history holds (traced allocations) after a minute
  and an hour of a 50 Hz run of `trees/example.yaml`'s tick records with world samples at 10 Hz;
  `every_message_mb_1h`: what keeping every message's JSON, as the history did before, takes for that hour.
"""

from __future__ import annotations

import json
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

from pegbt.bench import Figures

TREES = Path(__file__).resolve().parents[2] / "trees"
ROUNDS = 3
SECONDS = 6.0
PAYLOAD = 100_000
STALLED = 20
HUGE_FRAME = 400 * 1024 * 1024
TICK_RATE = 50  # Hz: pegbt run's default period
WORLD_RATE = 10  # Hz: the world sampler's default period


def run() -> Figures:
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        rounds: dict[int, list[tuple[int, int, int]]] = {0: [], STALLED: []}
        for _ in range(ROUNDS):
            for pages in rounds:
                rounds[pages].append(run_with_stalled_pages(pages, folder))
        growth, outcome = huge_frame_growth(folder)
        one_minute, hour, every = history_memory(folder)
    return {
        "overruns_none": statistics.median(overruns for overruns, _, _ in rounds[0]),
        "overruns_stalled_20": statistics.median(overruns for overruns, _, _ in rounds[STALLED]),
        "ticks_none": statistics.median(ticks for _, ticks, _ in rounds[0]),
        "ticks_stalled_20": statistics.median(ticks for _, ticks, _ in rounds[STALLED]),
        "dropped_of_20": statistics.median(dropped for _, _, dropped in rounds[STALLED]),
        "huge_frame_hwm_growth_mb": round(growth / 2**20, 1),
        "huge_frame_run": outcome,
        "history_kb_1min": round(one_minute / 1024, 1),
        "history_kb_1h": round(hour / 1024, 1),
        "every_message_mb_1h": round(every / 2**20, 1),
    }


def busy_tree(folder: Path) -> Path:
    """A tree whose leaf changes status every tick (running, success, over and over) until halted, so that
    every tick writes a record, as a trial's moving arms do."""
    tree = folder / "busy.yaml"
    tree.write_text(
        "tree:\n  repeat:\n    name: forever\n    times: -1\n    child:\n"
        "      scripted: {name: spin, outcomes: [running, success], then: cycle}\n"
    )
    return tree


def run_with_stalled_pages(pages: int, folder: Path, seconds: float = SECONDS) -> tuple[int, int, int]:
    """Overruns and ticks of a run publishing `PAYLOAD` bytes a tick while `pages` pages never read, and
    how many of them the server dropped."""
    from pegbt.bench.monitor_clients import open_socket
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file
    from pegbt.monitor.server import start_ephemeral

    server = start_ephemeral()
    sockets = [open_socket(server.port, token=server.token, receive_buffer=4096)[1] for _ in range(pages)]
    blob = "x" * PAYLOAD

    def watch(built: Any, resources: Any) -> list[Any]:
        return [lambda record: server.publish({"type": "world", "n": record.get("n", 0), "note": blob})]

    try:
        output = run_tree_file(
            RunOptions(busy_tree(folder), folder / "busy.jsonl", clock="wall", period=0.02, timeout=seconds),
            watch=watch,
        )
    finally:
        for connection in sockets:
            connection.close()
        server.stop()
    return output.result.overruns, output.result.ticks, server.dropped


def huge_frame_growth(folder: Path, seconds: float = 8.0) -> tuple[int, str]:
    """VmHWM growth (bytes) of a `pegbt run --monitor` child sent a frame declaring `HUGE_FRAME` bytes, which
    this process streams (zeros, 1 MB at a time) until the child closes the socket; and the run's outcome."""
    from pegbt.bench.monitor_clients import frame_header, open_socket, read_messages
    from pegbt.executive.logfile import read_tick_log
    from pegbt.sim.process import free_port

    port, log = free_port(), folder / "huge.jsonl"
    command = [sys.executable, "-m", "pegbt", "run", str(busy_tree(folder)), "--timeout", str(seconds)]
    child = subprocess.Popen(
        [*command, "--monitor", str(port), "--log", str(log), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout is not None, "piped"
        printed = re.search(r"monitor: http://\S+?(?:\?token=([\w-]+))?$", child.stdout.readline().strip())
        if printed is None:
            raise RuntimeError("pegbt run --monitor printed no URL")
        _, watcher = open_socket(port, token=printed.group(1))
        read_messages(watcher)  # the run is under way: its memory so far is the baseline
        before = peak_memory(child.pid)
        _, sender = open_socket(port, token=printed.group(1))
        chunk = bytes(2**20)
        try:
            sender.sendall(frame_header(HUGE_FRAME))
            for _ in range(HUGE_FRAME // len(chunk)):
                sender.sendall(chunk)
        except OSError:  # the child closed the socket: what it should do at the header
            pass
        time.sleep(0.5)
        growth = peak_memory(child.pid) - before
        sender.close()
        watcher.close()
        while "has ended" not in child.stdout.readline():
            pass
        child.send_signal(signal.SIGINT)
        child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    return growth, read_tick_log(log).outcome


def peak_memory(pid: int) -> int:
    """VmHWM of process `pid`, bytes."""
    status = Path(f"/proc/{pid}/status").read_text()
    match = re.search(r"^VmHWM:\s+(\d+) kB", status, re.MULTILINE)
    assert match is not None, "Linux reports VmHWM"
    return int(match.group(1)) * 1024


def synthetic_run(
    history: Any, seconds: float, records: list[dict[str, Any]], start: int = 0
) -> tuple[int, int]:
    """Feed `history` `seconds` of a live run: `records` (tick records) over and over, renumbered, with a
    world sample of both tools every 0.1 s. Returns the next tick number and the bytes of JSON fed."""
    tool = [[0.01 * i, 0.02, 0.03] for i in range(7)]
    fed = 0
    n = start
    for n in range(start, start + int(seconds * TICK_RATE)):
        messages = [{**records[n % len(records)], "n": n, "t": n / TICK_RATE}]
        if n % (TICK_RATE // WORLD_RATE) == 0:
            messages.append(
                {"type": "world", "n": n, "t": n / TICK_RATE, "tools": {"PSM1": tool, "PSM2": tool}}
            )
        for message in messages:
            text = json.dumps(message, separators=(",", ":"))
            fed += len(text)
            history.add(message, text)
    return n + 1, fed


def example_records(folder: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The header and tick records of a run of `trees/example.yaml`."""
    from pegbt.executive.logfile import read_tick_log
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file

    run_tree_file(RunOptions(TREES / "example.yaml", folder / "example.jsonl", clock="manual"))
    log = read_tick_log(folder / "example.jsonl", keep_records=True)
    assert log.records is not None, "read with keep_records"
    return log.records[0], [record for record in log.records if record["type"] == "tick"]


def history_memory(folder: Path) -> tuple[int, int, int]:
    """Traced bytes the live history holds after a minute and after an hour, and the hour's JSON."""
    from pegbt.monitor.history import History

    header, records = example_records(folder)
    tracemalloc.start()
    try:
        history = History()
        history.add(header, json.dumps(header))
        n, fed = synthetic_run(history, 60, records)
        one_minute = tracemalloc.get_traced_memory()[0]
        _, more = synthetic_run(history, 3540, records, start=n)
        hour = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    return one_minute, hour, fed + more
