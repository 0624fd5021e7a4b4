"""What the phase simulator's paper handover adds to the paper's meeting (`pegbt.behaviours.paper_meeting`,
which the trees take too under the paper's protocol on rest-to-rest cubics).

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_handover.py`: once the giver holds the block out at
rest, the camera looks at it (`find_block_servo_handover`) and the receiver's grasp is worked out from what
it sees (`seen_held`); the receiver moves to 3 mm over that grasp point, down onto it and closes; the giver
opens and rises 10 mm (`offset_handover`, `GIVER_RISE`), and only then does the receiver carry the block
away, placing it at the paper's placing angle, 0 (`paperplacing`). Not reproduced: the paper's cubics are in
Cartesian pose (`dvrkArm.cubic_cartesian`), where these are in joints (docs/guides/sim-to-real.md).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

GIVER_RISE = 0.010  # m: the giver, opened, rises this far before the receiver leaves (`offset_handover`)


def seen_held(
    seen_point: NDArray[np.float64], truth: NDArray[np.float64], noise: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The held block's pose as the look sees it (`find_block_servo_handover` registers the block model to the
    cloud): `truth` (board frame, tilted as it hangs) at `seen_point`, moved by perception's `noise` in
    board x and y."""
    seen = truth.copy()
    seen[:3, 3] = seen_point + [noise[0], noise[1], 0.0]
    return seen
