"""A replay a chunk at a time, each from the state the chunk before left, gives the numbers of one
replay of the whole recording: what lets `sim2real diagnose` replay an hour without holding it."""

import numpy as np
import pytest

from pegbt.physics import ArmPhysics, Effect

EFFECTS = [
    Effect("offset", "q1", {"value": 0.01}),
    Effect("scale", "q2", {"value": 1.03}),
    Effect("coupling", "q6", {"source": "q5", "k": 0.2}),
    Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.05, "k": -0.6}),
    Effect("hysteresis", "q6", {"source": "q6", "half_width": 0.04, "k": 0.6}),
    Effect("backlash", "q3", {"half_width": 0.0005}),
    Effect("backlash", "q4", {"half_width": 0.03}),
    Effect("lag", "q4", {"tau": 0.05}),
    Effect("lag", "q1", {"tau": 0.03}),
    Effect("delay", "q2", {"seconds": 0.023}),
    Effect("delay", "q5", {"seconds": 0.04}),
]


def _commands(n: int, rng: np.random.Generator) -> np.ndarray:
    steps = rng.normal(size=(n, 6)) * [0.01, 0.01, 0.0005, 0.02, 0.02, 0.02]
    return np.cumsum(steps, axis=0)


@pytest.mark.parametrize("times", ["uniform", "jittered", "settled"])
@pytest.mark.parametrize("rows", [1, 7, 250])
def test_a_chunked_replay_equals_one_replay(times, rows):
    rng = np.random.default_rng(3)
    n = 400
    q_cmd = _commands(n, rng)
    t = {
        "uniform": np.arange(n) * 0.01,
        "jittered": np.cumsum(rng.uniform(0.005, 0.015, n)),
        "settled": None,
    }[times]
    physics = ArmPhysics(EFFECTS)
    whole = physics.simulate(q_cmd, t)
    chunks = list(physics.replay(q_cmd, t, rows=rows))
    assert [a for a, _ in chunks] == list(range(0, n, rows))
    assert np.array_equal(np.concatenate([c for _, c in chunks]), whole)


def test_a_replay_stopped_early_gives_the_rows_of_the_whole():
    rng = np.random.default_rng(4)
    q_cmd = _commands(600, rng)
    t = np.arange(600) * 0.01
    physics = ArmPhysics(EFFECTS)
    part = np.concatenate([c for _, c in physics.replay(q_cmd, t, stop=333, rows=100)])
    assert np.array_equal(part, physics.simulate(q_cmd, t)[:333])
