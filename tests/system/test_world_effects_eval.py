"""`pegbt eval --world-effects` and what reads a trial's logs afterwards, on shared trials (each whole trial
costs tens of seconds of CPU, so a trial serves every test that reads it):

- the default world is today's on fixed seeds, event for event (fingerprints of the simulator's ground
  truth recorded without a world file with `pegbt eval --variant unilateral --trials 1 --seed S
  [--condition C] --keep-logs` on branch limuni, after the jaw's actions overlapped the arm's motions
  and the SQP took 10 segments: as many events and placements as before, and the same events with
  every effect at its inert default; uncalibrated again on branch phasefix, once its jaw let go at rest:
  main's 68 events in order, each 0.14 s later from the first placement on, default and inert worlds
  alike; uncalibrated again on branch bilat, once a jaw closing on a wall its peg holds yields within the
  wrist's cable play: transfer 3 -> 8, which missed four times 2.2-2.4 mm off the wall's centre, grips at
  the first and is placed, 80 events, 2 placed; optimised again on branch carry4, once the SQP holds the
  tool's turn about a peg's axis while the block is on it: 48 events, 12 placed, the default and inert
  worlds alike; optimised again on main 85f4913+, once each pick closes its jaw as the tip arrives and
  the way out of a block widens above its top: 48 events, 12 placed, the default and inert worlds
  alike), and a world file's effects reach the trials' simulator;
- `pegbt sim2real outcomes` end to end: the default world's tick logs (and nothing else) read into cells,
  diagnosed against the phase simulator, and the report written."""

from __future__ import annotations

import hashlib
import json
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects, write_world_file

pytestmark = [pytest.mark.system, pytest.mark.slow]

# (condition, seed): (world events, fingerprint of them, transfers placed of 12), recorded as above
BEFORE = {
    ("uncalibrated", 6): (80, "ae945a31550d8ea5", 2),
    ("optimized", 5): (48, "643ec5a59e958079", 12),
}
BEND = {"peg_compliance": {"deflection": 0.0015}}  # the uncalibrated arm's blocks catch 0.1–0.4 mm past it


@dataclass(frozen=True)
class Evaluated:
    """One `pegbt eval --keep-logs` trial: its JSON figures, the simulator's ground-truth events and their
    fingerprint, its output folder and the executive's tick log there."""

    figures: dict[str, Any]
    events: list[dict[str, Any]]
    fingerprint: str
    out: Path
    tick_log: Path


def _eval(pegbt_cli: Any, out: Path, condition: str, seed: int, *extra: str) -> Evaluated:
    done = pegbt_cli(
        *("eval", "--variant", "unilateral", "--condition", condition, "--trials", "1", "--seed", seed),
        *("--workers", "1", "--keep-logs", "--json", "--quiet", "--out", out, *extra),
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    log = out / "logs" / f"unilateral-{condition}-{seed}.jsonl"
    truth = log.with_name(f"{log.stem}.truth.jsonl")
    events = [
        entry for line in truth.read_text().splitlines() if (entry := json.loads(line))["kind"] != "start"
    ]
    text = "\n".join(json.dumps(event, sort_keys=True) for event in events)
    return Evaluated(
        json.loads(done.stdout), events, hashlib.sha256(text.encode()).hexdigest()[:16], out, log
    )


@pytest.fixture(scope="module")
def uncalibrated_6(tmp_path_factory: pytest.TempPathFactory, pegbt_cli: Any) -> Evaluated:
    """Uncalibrated, seed 6, no world file."""
    return _eval(pegbt_cli, tmp_path_factory.mktemp("default"), "uncalibrated", 6)


@pytest.fixture(scope="module")
def bent_6(tmp_path_factory: pytest.TempPathFactory, pegbt_cli: Any) -> Evaluated:
    """Uncalibrated, seed 6, its pegs bending 1.5 mm (`BEND`)."""
    out = tmp_path_factory.mktemp("bend")
    world = write_world_file(WorldEffects.of(BEND), out / "bend.yaml")
    return _eval(pegbt_cli, out, "uncalibrated", 6, "--world-effects", str(world))


def test_the_default_world_gives_the_same_trial_event_for_event(uncalibrated_6: Evaluated) -> None:
    trial = uncalibrated_6
    assert (len(trial.events), trial.fingerprint, trial.figures["transfers_succeeded"]) == BEFORE[
        "uncalibrated", 6
    ]
    assert trial.figures["world_effects"] == "none"


def test_every_world_effect_at_its_inert_default_gives_the_same_trial_event_for_event(
    tmp_path: Path, pegbt_cli: Any
) -> None:
    world = write_world_file(
        WorldEffects.of({name: {} for name in WORLD_EFFECT_KINDS}), tmp_path / "inert.yaml"
    )
    trial = _eval(pegbt_cli, tmp_path, "optimized", 5, "--world-effects", str(world))
    assert (len(trial.events), trial.fingerprint, trial.figures["transfers_succeeded"]) == BEFORE[
        "optimized", 5
    ]
    assert trial.figures["world_effects"] == str(world)


def test_a_world_file_s_effects_reach_the_trial_s_simulator(bent_6: Evaluated) -> None:
    # the uncalibrated arm catches its blocks on their pegs 0.1 to 0.4 mm past the clearance (seed 6: 11 of 12)
    caught = [event for event in bent_6.events if event["detail"].startswith("block-peg: caught on peg")]
    assert bent_6.figures["transfers_succeeded"] > BEFORE["uncalibrated", 6][2] and len(caught) < 5


def test_tick_logs_of_a_campaign_are_diagnosed_from_the_logs_alone(
    uncalibrated_6: Evaluated, tmp_path: Path, pegbt_cli: Any
) -> None:
    real = tmp_path / "real"
    real.mkdir()
    logs = [p for p in uncalibrated_6.out.rglob("*.jsonl") if not p.name.endswith(".truth.jsonl")]
    assert uncalibrated_6.tick_log in logs
    for log in logs:  # the executive's logs alone: no ground truth, no figures
        shutil.copy(log, real / log.name)
    out = tmp_path / "report"
    diagnosed = pegbt_cli(
        *("sim2real", "outcomes", real, "--transfers", "2", "--located", "2", "--points", "2"),
        *("--workers", "0", "--out", out, "--json"),
        timeout=900,
    )
    assert diagnosed.returncode == 0, diagnosed.stderr
    report = json.loads((out / "report.json").read_text())
    (cell,) = report["cells"]
    assert (cell["variant"], cell["condition"]) == ("unilateral", "uncalibrated")
    assert cell["real"]["attempted"] == 12
    failed = cell["real"]["attempted"] - cell["real"]["succeeded"]
    assert sum(cell["real"].get("failures", {}).values()) == failed
    assert 0.0 <= cell["simulated_before"] <= 1.0 and cell["held_out"] is False
    assert (out / "report.md").exists() and (out / "outcomes.png").stat().st_size > 0
    assert json.loads(diagnosed.stdout)["cells"] == report["cells"]
