"""With glibc's mmap threshold pinned (`pegbt.scratch.pin_mmap_threshold`, as `pegbt sim2real diagnose`
does), a recording-sized temporary goes back to the system when freed; left to adapt, glibc serves it from
the heap once a larger block has been freed, and keeps it resident behind a small block still alive. Each
case in a fresh child process: the allocator's state is the process's."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

CHILD = """
import sys
import numpy as np
from pegbt.scratch import pin_mmap_threshold

def anon_kb():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("RssAnon:"))

if sys.argv[1] == "pinned":
    pin_mmap_threshold()
chunk = np.ones(2**21)  # 16 MB, freed: glibc left to adapt serves blocks up to this size from the heap
del chunk
held, before = [], anon_kb()
for _ in range(20):
    column = np.ones(2**18)  # 2 MB: a column of 8 bytes a sample, 3.6 minutes at 100 Hz
    held.append(np.ones(1000))  # alive after it
    del column
print(anon_kb() - before)
"""


def _kept_kb(case: str) -> int:
    done = subprocess.run([sys.executable, "-c", CHILD, case], capture_output=True, text=True, check=True)
    return int(done.stdout)


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the C library is not glibc: no mallopt")
def test_a_freed_column_goes_back_to_the_system_once_the_threshold_is_pinned() -> None:
    assert _kept_kb("adapting") > 1500  # the case the pin is for, on this C library
    assert _kept_kb("pinned") < 500
