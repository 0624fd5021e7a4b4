"""What `pegbt sim2real synth` writes is what the robot could measure, however long the recording: the
noise an SNR sets may be large, but no sample lies beyond the arm's joint limits or, on q1–q3, farther
from its command than its controller allows."""

from __future__ import annotations

import numpy as np

from pegbt.motion.robot_config import DVRK_LIMITS
from pegbt.physics.faults import unreachable
from pegbt.sim2real.synth import generate


def test_a_loud_offset_stays_within_the_joint_limits():
    synthetic = generate("weak", 0, seconds=120)  # an offset on q6 at SNR 0.5: noise σ 0.37 rad
    q_phy, q_cmd = synthetic.recording.q_phy, synthetic.recording.q_cmd
    assert synthetic.noise["sigma"][5] > 0.3
    assert (q_phy >= DVRK_LIMITS.lower).all() and (q_phy <= DVRK_LIMITS.upper).all()
    assert not unreachable(q_cmd, q_phy).any()
    assert np.ptp(q_phy[:, 5]) > 2.0  # the noise is kept, not shrunk: only its tails are held at the limits
