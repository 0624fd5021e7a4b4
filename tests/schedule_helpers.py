"""How long the suite's longest modules take, for the order in which `-n` workers take them (`conftest.py`):
with `--dist loadfile` a free worker takes the next whole module, so the longest go first and the suite ends
on short ones, every worker finishing at about the same time."""

from __future__ import annotations

# seconds of wall each module took in the whole suite (`pytest -n 2 --durations=40` on a quiet machine, main
# at 7dc5656 and after; the three real-time trials now run at once); a module not listed takes a few seconds.
# The diagnosing modules scaled by the CPU their diagnoses took before and after play's float step and the
# jackknife's few-column sums (0.70 on set-points, 0.66 on streams; measured at load 15-20, not quiet)
LONGEST_S = {
    "tests/system/test_eval_cluster.py": 96,
    "tests/system/test_outcomes_phasesim_bilateral.py": 90,
    "tests/system/test_world_effects_eval.py": 75,
    "tests/system/test_realtime_trials.py": 66,
    "tests/system/test_measurement_faults.py": 48,
    "tests/system/test_sim2real_real.py": 40,
    "tests/system/test_dvrk_first_minutes.py": 40,  # its tests' sum in the fast tier at f2bb39f, less the clutch's 5 s
    "tests/system/test_sim2real_effects.py": 31,
    "tests/system/test_sim2real_diagnosis_memory.py": 30,
    "tests/system/test_outcomes_phasesim_vs_trial.py": 25,
    "tests/system/test_eval_cli.py": 23,
    "tests/system/test_sim2real_geometry.py": 19,
    "tests/system/test_sim2real_practical.py": 17,
    "tests/system/test_calibration_refit_realtime.py": 16,
    "tests/system/test_zivid_ros2.py": 15,
    "tests/system/test_sim2real_cli_diagnoses.py": 13,
    "tests/system/test_bag_recording_real.py": 13,
    "tests/system/test_eval_safety.py": 13,
    "tests/system/test_python_versions.py": 12,
    "tests/system/test_peg_trial.py": 11,
    "tests/system/test_monitor_stalled_pages.py": 10,
    "tests/system/test_sim2real_nested.py": 8,
}
