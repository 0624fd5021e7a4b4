"""`pegbt bench fuzz`: a campaign of bad input against every reader (trees, settings, recordings, tick
logs, payloads), most of it mutations of valid inputs that get past the parser to the validators.

Each input is read by the reader a command uses; the outcome is one of: accepted, refused (a
`PegbtError`), a traceback (any other exception), or a hang (over `HANG_S`). An input made absurd on
purpose (a non-finite or far out-of-range number, a recording in the wrong unit or of noise) that is
accepted counts as `absurd_accepted`; for recordings, acceptance is what lets `sim2real diagnose` and
`calibrate train` write a result, so it counts as `written_from_non_arm` too. All of those must be 0.
`parsed_share` is the share of inputs that got past the parser (YAML, JSON, .npy, CDR) to the checks.
"""

from __future__ import annotations

import json
import random
import shutil
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from pegbt.bench.fuzz_bags import fuzz_mcap, fuzz_rosbag2
from pegbt.bench.fuzz_btlog import fuzz_btlog
from pegbt.bench.fuzz_monitor import fuzz_monitor_requests
from pegbt.bench.fuzz_outcomes import fuzz_outcome_tables
from pegbt.bench.fuzz_rmw_zenoh import fuzz_rmw_zenoh
from pegbt.bench.fuzz_robot_config import fuzz_robot_config
from pegbt.bench.fuzz_world import fuzz_world_files
from pegbt.bench.fuzzing import REPORTED, SILENT, Tally, mutate_records, mutate_text
from pegbt.errors import PegbtError

REPO = Path(__file__).resolve().parents[2]


def _parses(text: str) -> tuple[bool, bool]:
    """(whether the text is YAML, whether it holds an absurd number as a number, not inside a string)."""
    from pegbt.yamlfile import parse_yaml

    try:
        document = parse_yaml(text, "<fuzz>")
    except PegbtError:
        return False, False
    return True, document is not None and _holds_absurd(document.plain())


def _holds_absurd(value: Any) -> bool:
    if isinstance(value, dict):
        return any(_holds_absurd(item) for item in value.values())
    if isinstance(value, list):
        return any(_holds_absurd(item) for item in value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return abs(value) >= 1e300 if isinstance(value, int) else not abs(value) < 1e300


# ---------------------------------------------------------------------------------------------- readers
def fuzz_trees(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.executive.loader import check_tree
    from pegbt.executive.registry import REGISTRY

    REGISTRY.names()  # import every behaviour now, not within the first input's time
    tally = Tally()
    folder = work / "trees"
    shutil.copytree(REPO / "trees", folder, dirs_exist_ok=True)
    seeds = sorted(folder.rglob("*.yaml"))
    texts = {path: path.read_text() for path in seeds}
    for n in range(count):
        source = rng.choice(seeds)
        text, absurd, what = mutate_text(texts[source], rng)
        target = source.with_name(f"fuzz-{n}.yaml")
        target.write_text(text, encoding="utf-8", errors="surrogateescape")
        parsed, holds = _parses(text)
        tally.record(
            lambda: not check_tree(target),  # called at once, within this iteration
            parsed=parsed,
            absurd=absurd and holds,
            what=f"{source.name}: {what}",
        )
        target.unlink()
    return tally


def fuzz_settings(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.motion.limits import arm_settings
    from pegbt.motion.settings import motion_settings
    from pegbt.sim.fault_plan import FaultPlan
    from pegbt.workcell import load_workcell

    plan = "seed: 7\nloss: {probability: 0.05, topics: [servo_jp]}\nlatency: {seconds: 0.02, jitter: 0.005}\ncrash: {at: 30.0}\nworld: {slips: [{time: 12.0, arm: PSM1}], miss_attempts: [0], slip_rate: 0.0}\ncamera: {bursts: [{start: 5.0, duration: 1.0, sigma: 0.003}]}\n"
    readers: dict[str, tuple[str, Callable[[Path], Any]]] = {
        "psm.yaml": (
            (REPO / "skills" / "psm.yaml").read_text(),
            lambda p: (arm_settings("PSM1", p), arm_settings("PSM2", p)),
        ),
        "motion.yaml": ((REPO / "skills" / "motion.yaml").read_text(), lambda p: motion_settings(p)),
        "workcell.yaml": ((REPO / "skills" / "workcell.yaml").read_text(), load_workcell),
        "faults.yaml": (plan, FaultPlan.load),
    }
    tally = Tally()
    for n in range(count):
        name = rng.choice(sorted(readers))
        base, read = readers[name]
        text, absurd, what = mutate_text(base, rng)
        target = work / f"settings-{n}-{name}"
        target.write_text(text, encoding="utf-8", errors="surrogateescape")
        parsed, holds = _parses(text)
        tally.record(
            partial(read, target),
            parsed=parsed,
            absurd=absurd and holds,
            what=f"{name}: {what}",
        )
        target.unlink()
    return tally


_Arrays = dict[str, np.ndarray]
# Recordings a real robot makes (issue 26's): past the planner's limits but not the robot's, or with the
# tracker losing the tool; refusing one counts as `good_refused`.
GOOD_RECORDINGS = ("roll past the planner's limit", "insertion 0.2412 m", "tracker lost the tool")
_Mutation = Callable[[_Arrays, random.Random], tuple[_Arrays, bool]]


def _recording_mutations() -> dict[str, _Mutation]:
    def scaled(factor: float, joints: slice = slice(None)) -> _Mutation:
        def apply(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
            a["q_cmd"][:, joints] *= factor
            a["q_phy"][:, joints] *= factor
            return a, True

        return apply

    def noise(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        a["q_phy"] = np.random.default_rng(rng.randrange(2**32)).uniform(-1.4, 1.4, a["q_phy"].shape)
        a["q_phy"][:, 2] = 0.16
        return a, True

    def cast(dtype: str) -> _Mutation:
        def apply(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
            a[rng.choice(["q_cmd", "q_phy", "t"])] = (
                (a["q_cmd"] * 50).astype(dtype)
                if dtype != "timedelta64[s]"
                else np.arange(len(a["t"])).astype(dtype)
            )
            return a, True

        return apply

    def nan(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        a["q_phy"][rng.randrange(len(a["q_phy"])), rng.randrange(6)] = rng.choice([np.nan, np.inf, -np.inf])
        return a, True

    def far_out(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        a["q_phy"][rng.randrange(len(a["q_phy"])), rng.randrange(6)] = rng.choice([1.7e308, -1.7e308, 57.3])
        return a, False  # one tracked sample no arm could reach: a measurement fault, to be reported

    def denormal(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        a["t"] = np.arange(len(a["t"])) * 5e-324
        return a, True

    def short(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        keep = rng.randrange(1, 60)
        return {k: v[:keep] for k, v in a.items()}, False

    def swap(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        a["q_cmd"], a["q_phy"] = a["q_cmd"][:, ::-1].copy(), a["q_phy"][:, ::-1].copy()
        return a, True

    def jitter(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        a["q_phy"] = a["q_phy"] + np.random.default_rng(rng.randrange(2**32)).normal(
            0, 0.002, a["q_phy"].shape
        )
        return a, False

    def roll_past_planner(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        scale = -1.761 / min(a["q_cmd"][:, 3].min(), -1e-3)  # issue 26: a session commanded to -100.9°
        a["q_cmd"][:, 3] *= scale
        a["q_phy"][:, 3] *= scale
        return a, False

    def deep_insertion(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        at = rng.randrange(len(a["q_cmd"]) - 3)  # dVRK 1.x's 0.2412 m for three samples
        a["q_cmd"][at : at + 3, 2] = a["q_phy"][at : at + 3, 2] = 0.2412
        return a, False

    def tracker_lost(a: _Arrays, rng: random.Random) -> tuple[_Arrays, bool]:
        n = len(a["q_phy"])
        at = rng.randrange(n - n // 10)
        a["q_phy"][at : at + n // 10, 2] = 0.0  # the tracker lost the tool: insertion read as 0 m
        return a, False

    return {
        "roll past the planner's limit": roll_past_planner,
        "insertion 0.2412 m": deep_insertion,
        "tracker lost the tool": tracker_lost,
        "degrees": scaled(57.29577951308232),
        "millimetres": scaled(1000.0, slice(2, 3)),
        "x100": scaled(100.0),
        "noise": noise,
        "int8": cast("int8"),
        "uint8": cast("uint8"),
        "complex": cast("complex128"),
        "timedelta": cast("timedelta64[s]"),
        "non-finite": nan,
        "a tracked sample far out": far_out,
        "denormal t": denormal,
        "too short": short,
        "joints reversed": swap,
        "tracker jitter": jitter,
    }


def fuzz_recordings(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.physics.recording import write_recording
    from pegbt.sim2real.synth import FAMILIES, generate

    bases = [generate(family, seed).recording for family in FAMILIES for seed in range(2)]
    mutations = _recording_mutations()
    names = sorted(mutations)
    tally = Tally()
    for n in range(count):
        base = rng.choice(bases)
        arrays = {"q_cmd": base.q_cmd.copy(), "q_phy": base.q_phy.copy(), "t": base.times.copy()}
        folder = work / f"rec-{n}_PSM1"
        kind = rng.choice(names + ["file"])
        if kind == "file":
            write_recording(folder, arrays["q_cmd"], arrays["q_phy"], arrays["t"])
            target = folder / rng.choice(["q_cmd.npy", "q_phy.npy", "t_stamp.npy", "meta.json"])
            _damage_file(target, rng)
            absurd, what = False, f"{target.name} damaged"
        else:
            arrays, absurd = mutations[kind](arrays, rng)
            folder.mkdir()
            for name, file in (("q_cmd", "q_cmd.npy"), ("q_phy", "q_phy.npy"), ("t", "t_stamp.npy")):
                np.save(folder / file, arrays[name])
            what = kind
        parsed = all(_npy_header_ok(folder / f) for f in ("q_cmd.npy", "q_phy.npy"))
        before = tally.absurd_accepted
        tally.record(
            partial(_read_recording, folder, kind == "a tracked sample far out"),
            parsed=parsed,
            absurd=absurd,
            what=what,
            good=kind in GOOD_RECORDINGS,
        )
        tally.written_from_non_arm += tally.absurd_accepted - before
        shutil.rmtree(folder)
    return tally


def _read_recording(folder: Path, far_out: bool) -> object:
    """`load_recording`; a recording with a tracked sample no arm could reach is accepted only with that
    sample among its measurement faults (what the diagnosis reports and leaves out)."""
    from pegbt.physics.faults import detect_faults
    from pegbt.physics.recording import load_recording

    recording = load_recording(folder)
    if not far_out:
        return True
    far = np.flatnonzero(np.abs(recording.q_phy).max(axis=1) > 50)
    faults = detect_faults(recording.q_cmd, recording.q_phy, recording.limits)
    return REPORTED if far.size and faults.mask[far].all() else SILENT


def _damage_file(path: Path, rng: random.Random) -> None:
    choice = rng.choice(["truncate", "bytes", "npz", "huge header", "not utf-8", "deep json"])
    if path.suffix == ".json" or not path.exists():
        path.write_bytes(
            {"not utf-8": b'{"arm": "PSM1\xff"}', "deep json": b"[" * 50_000}.get(choice, b'{"arm": 7}')
        )
        return
    data = path.read_bytes()
    if choice == "truncate":
        path.write_bytes(data[: rng.randrange(len(data))])
    elif choice == "bytes":
        raw = bytearray(data)
        for _ in range(rng.randint(1, 16)):
            raw[rng.randrange(len(raw))] = rng.randrange(256)
        path.write_bytes(bytes(raw))
    elif choice == "npz":
        with open(path, "wb") as handle:
            np.savez(handle, x=np.zeros(3))
    else:
        with open(path, "wb") as handle:
            np.lib.format.write_array_header_1_0(
                handle, {"descr": "<f8", "fortran_order": False, "shape": (983_040_000, 6)}
            )
            handle.write(b"\0" * 64)


def _npy_header_ok(path: Path) -> bool:
    try:
        with open(path, "rb") as handle:
            np.lib.format.read_magic(handle)
            np.lib.format.read_array_header_1_0(handle)
        return True
    except (OSError, ValueError, EOFError, SyntaxError):
        return False


def fuzz_tick_logs(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.executive.analysis import replay, summary, why
    from pegbt.executive.btlog import export_btlog
    from pegbt.executive.logfile import read_tick_log
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file

    valid = work / "valid.jsonl"
    run_tree_file(RunOptions(REPO / "trees" / "example.yaml", valid, clock="manual"))
    records = [json.loads(line) for line in valid.read_text().splitlines()]
    tally = Tally()

    def read(path: Path) -> bool:
        log = read_tick_log(path)
        summary(log), why(log), replay(log, tick=min(1, log.last_n))
        export_btlog(log, work / "out.btlog")
        bad_t = not all(np.isfinite(change.t) for change in log.transitions) or not np.isfinite(log.last_t)
        if bad_t:
            raise AssertionError("a non-finite time was accepted")
        return True

    for n in range(count):
        mutated = json.loads(json.dumps(records))
        absurd, what = mutate_records(mutated, rng)
        lines = [
            json.dumps(record, allow_nan=True) if not isinstance(record, str) else record
            for record in mutated
        ]
        tail = ""
        if rng.random() < 0.1:  # the run died while writing its last line: that line is not read
            tail = lines.pop()[: rng.randrange(1, 40)]
            absurd = absurd and f"line {len(lines) + 1}:" not in what
        path = work / f"log-{n}.jsonl"
        path.write_text("".join(line + "\n" for line in lines) + tail)
        tally.record(partial(read, path), parsed=_json_lines(lines), absurd=absurd, what=what)
        path.unlink()
    return tally


def _json_lines(lines: list[str]) -> bool:
    """Whether every line is JSON (the mutation left the syntax alone and reached the record checks)."""
    try:
        for line in lines:
            json.loads(line)
    except (ValueError, RecursionError):
        return False
    return True


def fuzz_payloads(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.motion.limits import arm_settings
    from pegbt.physics import ArmPhysics
    from pegbt.sim.arm import SimArm
    from pegbt.transport import codec
    from pegbt.transport.sequencing import Tag

    settings = arm_settings("PSM1")
    q = np.array([0.1, 0.1, 0.12, 0.1, 0.1, 0.1])
    valid = {
        "servo_jp": codec.encode_joint_state(1.0, q),
        "move_jp": codec.encode_joint_state(1.0, q + 0.2),
        "tag": Tag("abc", 42, "x:PSM1/move_jp:3", "done").encode(),
    }
    tally = Tally()
    for n in range(count):
        kind = rng.choice(sorted(valid))
        data = bytearray(valid[kind])
        absurd = False
        choice = rng.random()
        if kind != "tag" and choice < 0.4:  # positions made absurd, the message well formed
            bad = q.copy()
            bad[rng.randrange(6)] = rng.choice([np.nan, np.inf, 1e300, 57.3, 120.0])
            data, absurd = bytearray(codec.encode_joint_state(1.0, bad)), True
        elif kind == "tag" and choice < 0.4:
            data = bytearray(
                rng.choice([b"a|\xc2\xb2|c|d", b"a|" + b"9" * 5000 + b"|c|d", b"a|-3|c|d", b"a||c|d"])
            )
        else:
            for _ in range(rng.randint(1, 6)):
                if data:
                    data[rng.randrange(len(data))] = rng.randrange(256)
        payload = bytes(data)

        def admit(kind: str = kind, payload: bytes = payload) -> bool:
            if kind == "tag":
                Tag.decode(payload)
                return True
            arm = SimArm("PSM1", settings, ArmPhysics())
            position = codec.decode_joint_state(payload).position
            handler = arm.servo_jp if kind == "servo_jp" else arm.move_jp
            outcomes = handler(position, "fuzz")
            if any(t.outcome == "refused" for t in outcomes):
                return False
            for _ in range(400):
                arm.advance(arm.period)
            within = np.all(np.isfinite(arm.joints.setpoint)) and np.all(
                (arm.joints.setpoint >= settings.lower - 1e-9)
                & (arm.joints.setpoint <= settings.upper + 1e-9)
            )
            if not within:
                raise AssertionError("an out-of-limit set-point was applied")
            return True

        tally.record(admit, parsed=_decodes(kind, payload), absurd=absurd, what=f"{kind} #{n}")
    return tally


def _decodes(kind: str, payload: bytes) -> bool:
    """Whether the payload is a well-formed message (CDR, or a tag's four fields): past the parser."""
    from pegbt.transport import codec

    if kind == "tag":
        return payload.count(b"|") == 3
    try:
        codec.decode_joint_state(payload)
    except Exception:  # noqa: BLE001 - any failure to decode is "did not parse"
        return False
    return True


READERS: dict[str, Callable[[int, random.Random, Path], Tally]] = {
    "trees": fuzz_trees,
    "settings": fuzz_settings,
    "recordings": fuzz_recordings,
    "tick_logs": fuzz_tick_logs,
    "payloads": fuzz_payloads,
    "mcap_bags": fuzz_mcap,
    "rosbag2_bags": fuzz_rosbag2,
    "btlog_files": fuzz_btlog,
    "robot_config_folders": fuzz_robot_config,
    "rmw_zenoh_wire": fuzz_rmw_zenoh,
    "world_files": fuzz_world_files,
    "outcome_tables": fuzz_outcome_tables,
    "monitor_requests": fuzz_monitor_requests,
}


def campaign(per_reader: int, seed: int = 0, readers: tuple[str, ...] = tuple(READERS)) -> dict[str, Tally]:
    """Run `per_reader` inputs through each reader; the tallies by reader."""
    import logging

    logging.getLogger("pegbt").setLevel(logging.CRITICAL)  # the campaign's own inputs are not news
    tallies = {}
    with tempfile.TemporaryDirectory(prefix="pegbt-fuzz-") as folder:
        for name in readers:
            work = Path(folder) / name
            work.mkdir()
            tallies[name] = READERS[name](per_reader, random.Random(f"{seed}:{name}"), work)
    return tallies


def run(per_reader: int = 1000) -> dict[str, float | int | str]:
    """The campaign of the issue: at least 1000 inputs per reader; every failure count must be 0."""
    start = time.perf_counter()
    tallies = campaign(per_reader)
    figures: dict[str, float | int | str] = {}
    for name, tally in tallies.items():
        figures |= tally.figures(name)
    total_inputs = sum(t.inputs for t in tallies.values())
    figures["total_inputs"] = total_inputs
    for key in ("tracebacks", "hangs", "absurd_accepted", "reported"):
        figures[f"total_{key}"] = sum(getattr(t, key) for t in tallies.values())
    figures["total_written_from_non_arm"] = tallies["recordings"].written_from_non_arm
    figures["total_good_refused"] = sum(t.good_refused for t in tallies.values())
    figures["parsed_share"] = round(sum(t.parsed for t in tallies.values()) / total_inputs, 3)
    figures["seconds"] = round(time.perf_counter() - start, 1)
    return figures
