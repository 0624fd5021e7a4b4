"""`pegbt bench sim`: how much faster than real time the lockstep simulator runs a whole peg-transfer trial.

The simulator runs in its own process with the world and camera (`pegbt sim --lockstep`, dvrk-real
cables off so that every scripted grasp holds). A client drives both arms through the reference's 12
unilateral transfers, alternating PSM1 and PSM2, each as IK joint motions of the scripted keyframes
(`pegbt.sim.arm_script`): a joint goal, joint trajectories, jaw moves. Like an executive it polls its
motion handles and steps the `SimClock` once per tick: `realtime_factor` at a 10 ms tick,
`realtime_factor_20ms` at 20 ms; simulated seconds over wall seconds. `transfers_placed` counts the
`place` events in the simulator's truth, so a fast but broken trial shows.
"""

from __future__ import annotations

import time

from pegbt.bench import Figures

STEP = 0.01  # s between the samples of the scripted joint trajectories
SPEED = 0.1  # m/s of the tool along the scripted straight moves
SEED = 0


def _trial(endpoint: str, trial: list, tick: float) -> tuple[float, float, int]:
    """Play the trial at `tick`; (simulated seconds, wall seconds, blocks placed)."""
    from pegbt.psm import ARMS
    from pegbt.sim.arm_script import MotionPlayer
    from pegbt.sim.truth import ask_truth
    from pegbt.transport import ArmClient, SimClock, connect

    with connect([endpoint]) as link:
        clock = SimClock(link)
        arms = {name: ArmClient(link, name, clock=clock) for name in ARMS}
        for arm in arms.values():
            arm.wait_until_ready()
        started_sim, started_wall = clock.now(), time.perf_counter()
        for arm, motions in trial:
            player = MotionPlayer(arms[arm], motions)
            while player.poll():
                clock.wait(tick)
        simulated, wall = clock.now() - started_sim, time.perf_counter() - started_wall
        return simulated, wall, len(ask_truth(link).events("place"))


def run() -> Figures:
    from pegbt.sim.arm_script import scripted_trial
    from pegbt.sim.process import SimProcess
    from pegbt.sim.world import World
    from pegbt.workcell import UNILATERAL_ORDER

    transfers = [
        ("PSM1" if i % 2 == 0 else "PSM2", start, goal) for i, (start, goal) in enumerate(UNILATERAL_ORDER)
    ]
    trial = scripted_trial(World(SEED), transfers, STEP, SPEED)
    figures: Figures = {}
    for tick, suffix in ((0.01, ""), (0.02, "_20ms")):
        with SimProcess(["--lockstep", "--seed", str(SEED)]) as sim:
            simulated, wall, placed = _trial(sim.endpoint, trial, tick)
        figures[f"realtime_factor{suffix}"] = simulated / wall
        figures[f"simulated_s{suffix}"] = simulated
        figures[f"transfers_placed{suffix}"] = placed
    return figures
