"""`pegbt sim2real diagnose` as a real process: bad input exits non-zero without a traceback."""

from tests.sim2real_helpers import bad_recordings


def test_the_process_exits_non_zero_without_a_traceback(tmp_path, pegbt_cli):
    path, problem = bad_recordings(tmp_path)["nan"]
    done = pegbt_cli("sim2real", "diagnose", path)
    assert done.returncode == 2 and problem in done.stderr and "Traceback" not in done.stderr
