"""How long the suite's longest modules take, for the order in which `-n` workers take them (`conftest.py`):
with `--dist loadfile` a free worker takes the next whole module, so the longest go first and the suite ends
on short ones, every worker finishing at about the same time."""

from __future__ import annotations

# seconds of wall each module took in the whole suite (`pytest -n 2 --durations=40` on a quiet machine, main
# at 7dc5656 and after; the three real-time trials now run at once); a module not listed takes a few seconds
LONGEST_S = {
    "tests/system/test_eval_cluster.py": 96,
    "tests/system/test_sim2real_real.py": 76,
    "tests/system/test_measurement_faults.py": 68,
    "tests/system/test_realtime_trials.py": 66,
    "tests/system/test_world_effects_eval.py": 57,
    "tests/system/test_sim2real_effects.py": 46,
    "tests/system/test_outcomes_ticklogs.py": 38,
    "tests/system/test_sim2real_geometry.py": 27,
    "tests/system/test_outcomes_phasesim_vs_trial.py": 25,
    "tests/system/test_sim2real_practical.py": 25,
    "tests/system/test_eval_cli.py": 23,
    "tests/system/test_sim2real_cli_diagnoses.py": 19,
    "tests/system/test_bag_recording_real.py": 18,
    "tests/integration/test_dvrk_first_minutes.py": 17,
    "tests/system/test_calibration_refit_realtime.py": 16,
    "tests/system/test_zivid_ros2.py": 15,
    "tests/system/test_eval_safety.py": 13,
    "tests/system/test_python_versions.py": 12,
    "tests/system/test_sim2real_nested.py": 11,
    "tests/system/test_peg_trial.py": 11,
    "tests/system/test_monitor_stalled_pages.py": 10,
}
