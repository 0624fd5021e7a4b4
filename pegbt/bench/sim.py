"""`pegbt bench sim`: how much faster than real time the lockstep simulator runs a peg-transfer-like trial.

Both arms run a scripted 12-transfer motion (approach, descend, close jaw, lift, carry, descend, open
jaw, lift; the arms alternate as in a handover-free trial) through `ArmClient.move_jp`, with the client
polling and stepping the clock every control period (10 ms), as an executive ticking at 100 Hz would.
`realtime_factor` = simulated seconds / wall seconds; `realtime_factor_poll_30ms` steps every 30 ms.
"""

from __future__ import annotations

import time

import numpy as np

from pegbt.sim.process import SimProcess
from pegbt.transport import ArmClient, SimClock, connect

TRANSFERS = 12
ABOVE, DOWN = 0.12, 0.16  # insertion (m) above the board and at a block


def _waypoints(rng: np.random.Generator, side: float) -> list[tuple[str, np.ndarray | float]]:
    """One transfer: joint goals and jaw angles, picked at random positions on one side of the board."""
    pick = np.array([side * rng.uniform(0.05, 0.25), rng.uniform(-0.2, 0.2), ABOVE, rng.uniform(-0.5, 0.5), 0.0, 0.0])
    place = pick + [-side * rng.uniform(0.1, 0.3), rng.uniform(-0.1, 0.1), 0, rng.uniform(-0.3, 0.3), 0.1, -0.1]
    down = np.array([0, 0, DOWN - ABOVE, 0, 0, 0])
    return [
        ("arm", pick), ("jaw", 0.8), ("arm", pick + down), ("jaw", 0.0), ("arm", pick),
        ("arm", place), ("arm", place + down), ("jaw", 0.8), ("arm", place), ("jaw", 0.0),
    ]


def _trial(endpoint: str, poll: float) -> tuple[float, float]:
    """Run the scripted trial; (simulated seconds, wall seconds)."""
    with connect([endpoint]) as link:
        clock = SimClock(link)
        arms = [ArmClient(link, name, clock=clock) for name in ("PSM1", "PSM2")]
        for arm in arms:
            arm.wait_until_ready()
        rng = np.random.default_rng(0)
        plans = [[step for _ in range(TRANSFERS // 2) for step in _waypoints(rng, side)] for side in (1.0, -1.0)]
        handles = [None, None]
        started_sim, started_wall = clock.now(), time.perf_counter()
        while any(plans) or any(h is not None and h.busy for h in handles):
            for i, arm in enumerate(arms):
                if plans[i] and (handles[i] is None or not handles[i].busy):
                    kind, target = plans[i].pop(0)
                    handles[i] = arm.move_jp(target) if kind == "arm" else arm.jaw.move_jp(float(target))
            clock.wait(poll)
        assert all(h.done for h in handles if h is not None)
        return clock.now() - started_sim, time.perf_counter() - started_wall


def run() -> dict[str, float | int | str]:
    with SimProcess(["--lockstep", "--physics", "dvrk-real"]) as sim:
        simulated, wall = _trial(sim.endpoint, 0.01)
    with SimProcess(["--lockstep", "--physics", "dvrk-real"]) as sim:
        simulated_30, wall_30 = _trial(sim.endpoint, 0.03)
    return {
        "realtime_factor": simulated / wall,
        "realtime_factor_poll_30ms": simulated_30 / wall_30,
        "simulated_s": simulated,
        "wall_s": wall,
        "transfers": TRANSFERS,
    }
