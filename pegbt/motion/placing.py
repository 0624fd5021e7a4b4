"""The reference paper's placing heights, and a carry stopped at rest over its goal peg.

BerkeleyAutomation/FLSpegtransferHO, `motion/dvrkPegTransferMotion*.py` (`transfer_block_traj`): the carry
ends at rest at `height_ready` (−0.120 m in the arm's frame) over the goal peg, where the camera looks at the
held block (`place_servoing`, `FLSPegTransfer_*.py`); only then does the arm go down to `height_drop` and open.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pegbt.errors import PegbtError
from pegbt.motion.settings import MotionSettings
from pegbt.motion.trajectory import Trajectory

PEG_TOP_Z = -0.148  # m, the peg tops in the arm's frame (shared/reference/peg-transfer-geometry.md)
STOP_Z = -0.120  # m, `height_ready` of all three motion scripts: where the carry stops and the look is taken
# m, `height_drop` by script: where the tip stops before the jaw opens
DROP_Z = {"unilateral": -0.130, "bilateral": -0.135, "handover": -0.138}


def paper_heights(motion: MotionSettings, variant: str) -> MotionSettings:
    """`motion` with the carry's stop and the lowering at the paper's heights above the peg tops."""
    if variant not in DROP_Z:
        raise PegbtError(
            f"the paper's protocol has heights for {', '.join(DROP_Z)} only, not {variant!r}", field="variant"
        )
    transfer = replace(
        motion.transfer,
        transfer_height_above_peg_top=STOP_Z - PEG_TOP_Z,
        drop_height_above_peg_top=DROP_Z[variant] - PEG_TOP_Z,
    )
    return replace(motion, transfer=transfer)


def segment_times(planned: Trajectory) -> tuple[float, float]:
    """Planned times (s from the start) at which a carry's lift ends and its lowering starts: where the
    joint speed first dips (the cubics stop at each waypoint; a spline slows through them)."""
    speed = np.linalg.norm(planned.qd, axis=1)
    stops = [i for i in range(1, len(speed) - 1) if speed[i] <= speed[i - 1] and speed[i] <= speed[i + 1]]
    stops = (stops + [len(speed) - 1, len(speed) - 1])[:2]
    return float(planned.t[stops[0]] - planned.t[0]), float(planned.t[stops[1]] - planned.t[0])


def stopped_above(planned: Trajectory) -> Trajectory:
    """`planned` (a carry through lifted, above the goal peg and lowered onto it) up to its stop above the
    goal peg: the paper's carry, which ends there at rest."""
    _, lowering = segment_times(planned)
    stop = int(np.searchsorted(planned.t - planned.t[0], lowering + 1e-9))
    return Trajectory(planned.t[:stop], planned.q[:stop], planned.qd[:stop], planned.qdd[:stop])
