"""A whole trial on the embedded simulator beside the phase simulator playing the same transfers in order,
which the system tests of each variant compare. Here so that no test module imports another."""

from __future__ import annotations

from pathlib import Path

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import transfer_outcomes
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.trialsim import simulate_trial

DEFLECTION = 0.0015  # m: the peg bends this far


def trial_beside_simulated(tmp_path: Path, variant: str, seed: int) -> tuple[list[str], list[str]]:
    """Each transfer's outcome ("placed", or the phase it failed in) in `variant`'s uncalibrated trial on
    world `seed` with a bending peg, read from its tick log alone as a real robot's would be, and as the
    phase simulator plays the same transfers in order on one world (`simulate_trial`)."""
    world = tmp_path / "hidden.yaml"
    world.write_text(f"effects:\n  - {{kind: peg_compliance, deflection: {DEFLECTION}}}\n")
    log = tmp_path / "trial.jsonl"
    run_trial(TrialSpec(variant, "uncalibrated", seed, log, keep_log=True, world_effects=world))
    trial = ["placed" if o.succeeded else o.phase for o in transfer_outcomes(read_tick_log(log))]
    played = simulate_trial(
        [WorldEffects.of({"peg_compliance": {"deflection": DEFLECTION}})],
        variant,
        "uncalibrated",
        seed,
        len(trial),
    )
    return trial, ["placed" if r.succeeded else r.phase for (r,) in played]
