"""The modules `schedule_helpers.LONGEST_S` times, which `-n` workers take first, are the suite's own: a
renamed or merged module would otherwise lose its place silently and start last."""

from pathlib import Path

from schedule_helpers import LONGEST_S

REPO = Path(__file__).resolve().parents[2]


def test_every_timed_module_is_a_test_module_of_the_suite():
    missing = [name for name in LONGEST_S if not (REPO / name).is_file()]
    assert not missing, f"LONGEST_S names modules that are not in tests/: {missing}"
    assert all(name.startswith("tests/") and Path(name).name.startswith("test_") for name in LONGEST_S)
