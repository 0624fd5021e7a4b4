"""The dVRK's joint trajectory: a time-synchronised, velocity- and acceleration-limited profile to a goal
at rest, evaluated afresh every control period from where the last evaluation left the set-point.

The dVRK evaluates Reflexxes Type II this way (sawIntuitiveResearchKit
`core/components/code/mtsIntuitiveResearchKitArm.cpp`: `control_move_jp`, `RunHoming`, set with
`Reflexxes_TIME` synchronisation in `trajectory_j_update_reflexxes`); Ruckig's online interface with an
unbounded jerk computes the same acceleration-limited profiles. Changing the goal mid-way (a jaw goal
during an arm move) continues from the current position and velocity, as the dVRK's does.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from ruckig import InputParameter, OutputParameter, Result, Ruckig, Synchronization

from pegbt.errors import PegbtError


class OnlineTrajectory:
    """One trajectory generator for a group of joints (the PSM's six and its jaw)."""

    def __init__(self, period: float, max_velocity: ArrayLike, max_acceleration: ArrayLike) -> None:
        velocity = np.asarray(max_velocity, dtype=float)
        self.dofs = len(velocity)
        self._generator = Ruckig(self.dofs, period)
        self._input = InputParameter(self.dofs)
        self._output = OutputParameter(self.dofs)
        self._input.max_velocity = velocity.tolist()
        self._input.max_acceleration = np.asarray(max_acceleration, dtype=float).tolist()
        self._input.max_jerk = [math.inf] * self.dofs
        self._input.synchronization = Synchronization.Time
        self.active = False

    def limit(self, max_velocity: ArrayLike, max_acceleration: ArrayLike) -> None:
        """New limits, from the next step on."""
        self._input.max_velocity = np.asarray(max_velocity, dtype=float).tolist()
        self._input.max_acceleration = np.asarray(max_acceleration, dtype=float).tolist()

    @property
    def goal(self) -> NDArray[np.float64]:
        return np.array(self._input.target_position)

    def start(self, position: ArrayLike, velocity: ArrayLike, goal: ArrayLike) -> None:
        """Start from `position` moving at `velocity`, towards `goal` at rest."""
        self._input.current_position = np.asarray(position, dtype=float).tolist()
        self._input.current_velocity = np.asarray(velocity, dtype=float).tolist()
        self._input.current_acceleration = [0.0] * self.dofs
        self.retarget(goal)

    def retarget(self, goal: ArrayLike) -> None:
        """A new goal; the profile continues from where it is."""
        self._input.target_position = np.asarray(goal, dtype=float).tolist()
        self._input.target_velocity = [0.0] * self.dofs
        self._input.target_acceleration = [0.0] * self.dofs
        self.active = True

    def step(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Position and velocity one period on; `active` turns False when the goal is reached."""
        result = self._generator.update(self._input, self._output)
        if result not in (Result.Working, Result.Finished):
            self.active = False
            raise PegbtError(f"error while evaluating trajectory: {result}", field="move_jp")
        self._output.pass_to_input(self._input)
        if result == Result.Finished:
            self.active = False
        return np.array(self._output.new_position), np.array(self._output.new_velocity)
