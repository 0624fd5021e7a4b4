"""Direction memory of the wrist commands: a bank of play operators of a few widths.

A play operator of half width w follows its input but lags it by up to w; the gap (input − output) says
which way the input last moved and how far since it turned (saturating at ±w). A few widths together
describe the recent turning points of the command path without any notion of time, which is what a
cable's hysteresis depends on. The hybrid model's residual network reads these gaps: they carry the
cross-joint hysteresis (q5's error depends on which way q6 last moved) that no `ArmPhysics` effect has.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from pegbt.physics.kernels import apply_play


class PlayBank:
    """Play operators of each half width in `widths` on each of `n_inputs` signals."""

    def __init__(self, widths: Sequence[float], n_inputs: int) -> None:
        self.widths = tuple(float(w) for w in widths)
        self.n_inputs = n_inputs
        self.half_widths = np.repeat(np.asarray(self.widths), n_inputs)  # input-major within each width

    def _tiled(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.tile(u, len(self.widths))

    def settle(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Operator outputs after resting at input `u` (n_inputs,)."""
        return self._tiled(u)

    def step(
        self, outputs: NDArray[np.float64], u: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(gaps, new outputs) after the input moves to `u`."""
        tiled = self._tiled(u)
        new = np.clip(outputs, tiled - self.half_widths, tiled + self.half_widths)
        return tiled - new, new

    def gaps(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gaps along a whole sequence u (N, n_inputs), starting at rest: (N, n_inputs × len(widths))."""
        tiled = self._tiled(u)
        return tiled - apply_play(tiled, self.half_widths)
