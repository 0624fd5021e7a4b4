"""The shared arm-physics model: each effect does what its definition says."""

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.physics import ArmPhysics, Effect


def _commands(n: int = 400) -> np.ndarray:
    q = np.zeros((n, 6))
    q[:, 4] = 0.5 * np.sin(np.linspace(0, 4 * np.pi, n))
    q[:, 5] = 0.3 * np.cos(np.linspace(0, 6 * np.pi, n))
    return q


def test_ideal_arm_reproduces_the_command():
    q = _commands()
    assert np.array_equal(ArmPhysics().simulate(q), q)


def test_offset_scale_and_coupling_form_the_static_map():
    model = ArmPhysics(
        [
            Effect("offset", "q4", {"value": 0.2}),
            Effect("scale", "q5", {"value": 0.9}),
            Effect("coupling", "q5", {"source": "q6", "k": 0.25}),
        ]
    )
    q = _commands()
    out = model.simulate(q)
    assert np.allclose(out[:, 3], q[:, 3] + 0.2)
    assert np.allclose(out[:, 4], 0.9 * q[:, 4] + 0.25 * q[:, 5])
    assert np.allclose(out[:, 5], q[:, 5])


def test_backlash_holds_until_the_input_moves_past_the_play():
    model = ArmPhysics([Effect("backlash", "q5", {"half_width": 0.1})])
    q = np.zeros((5, 6))
    q[:, 4] = [0.0, 0.05, 0.3, 0.25, 0.1]
    out = model.simulate(q)[:, 4]
    assert np.allclose(out, [0.0, 0.0, 0.2, 0.2, 0.2])


def test_lag_settles_with_its_time_constant():
    model = ArmPhysics([Effect("lag", "q6", {"tau": 0.1})])
    t = np.arange(0, 1.0, 0.01)
    q = np.zeros((len(t), 6))
    q[1:, 5] = 1.0
    out = model.simulate(q, t)[:, 5]
    assert out[10] == pytest.approx(1 - np.exp(-1.0), abs=1e-9)  # ten 10 ms intervals = one tau
    assert np.allclose(model.simulate(q)[:, 5], q[:, 5])  # settled set-points: no lag left


def test_stepping_matches_replaying_a_stream():
    model = ArmPhysics.load("dvrk-real", "PSM1")
    t = np.arange(300) * 0.01
    q = _commands(300)
    first = model.reset(q[0], time=0.0)
    stepped = np.array([first] + [model.step(q[n], 0.01) for n in range(1, 300)])
    assert np.allclose(stepped, model.simulate(q, t), atol=1e-12)


def test_delay_shifts_the_command_in_time():
    model = ArmPhysics([Effect("delay", "q1", {"seconds": 0.05})])
    t = np.arange(200) * 0.01
    q = np.zeros((200, 6))
    q[:, 0] = np.linspace(0, 1, 200)
    out = model.simulate(q, t)
    assert out[100, 0] == pytest.approx(q[95, 0])


@pytest.mark.parametrize(
    "effect, joint, params, field",
    [
        ("friction", "q1", {}, "effect"),
        ("offset", "q9", {"value": 1.0}, "joint"),
        ("offset", "q1", {"val": 1.0}, "params"),
        ("backlash", "q5", {"half_width": -0.1}, "half_width"),
        ("coupling", "q5", {"source": "q5", "k": 0.1}, "source"),
        ("lag", "q5", {"tau": float("nan")}, "tau"),
    ],
)
def test_bad_effects_are_refused_with_the_field_named(effect, joint, params, field):
    with pytest.raises(PegbtError) as raised:
        Effect(effect, joint, params)
    assert raised.value.field == field


def test_unknown_preset_names_the_known_ones():
    with pytest.raises(PegbtError, match="dvrk-real"):
        ArmPhysics.load("no-such-preset")


def _naive_play(u, half_width, start):
    out, state = [], start
    for x in u:
        state = min(max(state, x - half_width), x + half_width)
        out.append(state)
    return np.array(out)


@pytest.mark.parametrize("n_widths", [1, 3, 12])  # a few widths step on floats, a grid on NumPy
def test_run_wise_play_matches_the_sample_by_sample_operator(n_widths):
    from pegbt.physics.kernels import play_grid

    rng = np.random.default_rng(0)
    for _ in range(100):
        u = np.round(rng.normal(size=int(rng.integers(1, 60))).cumsum(), 1)  # with repeats and reversals
        widths, starts = rng.uniform(0, 1, n_widths), rng.normal(size=n_widths) * 2
        grid = play_grid(u, widths, starts)
        for k in range(n_widths):
            assert np.allclose(grid[:, k], _naive_play(u, widths[k], starts[k]))


def test_lag_on_uneven_sample_times_matches_the_even_recursion():
    from pegbt.physics.kernels import lag_series

    t = np.arange(200) * 0.01
    u = np.sin(t * 7)
    jittered = t + np.r_[0, np.full(199, 1e-9)]
    assert np.allclose(lag_series(u, t, 0.05), lag_series(u, jittered, 0.05), atol=1e-6)


def test_hysteresis_from_another_joint_follows_that_joints_direction():
    model = ArmPhysics([Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.1, "k": -0.5})])
    q = np.zeros((5, 6))
    q[:, 5] = [0.0, 0.3, 0.6, 0.4, 0.2]
    out = model.simulate(q)
    assert np.allclose(out[:, 5], q[:, 5])
    assert np.allclose(out[:, 4], -0.5 * np.array([0.0, -0.1, -0.1, 0.1, 0.1]))


def test_own_hysteresis_is_partial_backlash_on_the_static_target():
    partial = ArmPhysics(
        [
            Effect("scale", "q6", {"value": 0.8}),
            Effect("hysteresis", "q6", {"source": "q6", "half_width": 0.05, "k": 1.0}),
        ]
    )
    full = ArmPhysics([Effect("scale", "q6", {"value": 0.8}), Effect("backlash", "q6", {"half_width": 0.05})])
    q = _commands()
    assert np.allclose(partial.simulate(q), full.simulate(q))


def test_stepping_with_hysteresis_matches_replaying_a_stream():
    model = ArmPhysics(
        [
            Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.04, "k": 0.3}),
            Effect("hysteresis", "q6", {"source": "q6", "half_width": 0.02, "k": 0.6}),
            Effect("delay", "q5", {"seconds": 0.02}),
            Effect("lag", "q6", {"tau": 0.05}),
        ]
    )
    t = np.arange(300) * 0.01
    q = _commands(300)
    first = model.reset(q[0], time=0.0)
    stepped = np.array([first] + [model.step(q[n], 0.01) for n in range(1, 300)])
    assert np.allclose(stepped, model.simulate(q, t), atol=1e-12)


def test_a_sim2real_report_loads_its_whole_model(tmp_path):
    report = tmp_path / "report.json"
    report.write_text(
        '{"effects": [{"effect": "offset", "joint": "q4", "params": {"value": 0.1}}], '
        '"model": {"effects": [{"effect": "offset", "joint": "q4", "params": {"value": 0.1}}, '
        '{"effect": "scale", "joint": "q6", "params": {"value": 0.9}}]}}'
    )
    model = ArmPhysics.load(report, "PSM2")
    assert model.offset[3] == 0.1 and model.scale[5] == 0.9


def test_hysteresis_of_several_widths_from_one_drive_adds_up_but_a_repeat_is_refused():
    loop = [Effect("hysteresis", "q5", {"source": "q6", "half_width": w, "k": 0.2}) for w in (0.02, 0.1)]
    q = _commands()
    shift = [ArmPhysics(effects).simulate(q)[:, 4] - q[:, 4] for effects in (loop, loop[:1], loop[1:])]
    assert np.allclose(shift[0], shift[1] + shift[2])
    with pytest.raises(PegbtError, match="given twice"):
        ArmPhysics([loop[0], loop[0]])
