"""`pegbt bench perception` is registered and reachable from the command line."""

from pegbt.bench import load_benchmark
from pegbt.bench.perception import run


def test_the_perception_benchmark_is_listed_by_the_command_line(pegbt_cli):
    listed = pegbt_cli("bench")
    assert listed.returncode == 0 and "perception" in listed.stdout.split()
    assert load_benchmark("perception") is run
