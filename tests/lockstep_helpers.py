"""A lockstep simulator of the arms alone with PSM1's client, shared by the integration tests that step it."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from pegbt.sim.process import SimProcess
from pegbt.transport import ArmClient, SimClock, connect


@contextmanager
def lockstep_psm1(*options: str) -> Iterator[tuple[SimClock, ArmClient]]:
    """`pegbt sim --lockstep --no-world` with `options`, its clock and PSM1's client, ready."""
    with SimProcess(["--lockstep", *options, "--no-world"]) as sim:
        link = connect([sim.endpoint])
        clock = SimClock(link)
        psm1 = ArmClient(link, "PSM1", clock=clock)
        psm1.wait_until_ready(30.0)
        yield clock, psm1
        link.close()
