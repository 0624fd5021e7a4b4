"""SQP refinement of a transfer (the paper's second stage), solved with OSQP.

The horizon T is split into K steps of h = T/K with a constant acceleration per step, so the joint
path is piecewise quadratic and C1, velocities are exact at the knots and linear in between. The
decision variables per knot k are the position q_k, the velocity v_k and the acceleration a_k of the
step that follows (a_K = 0). The QP minimises the sum of squared acceleration changes (the discrete
jerk, each joint relative to its acceleration limit) subject to
- the dynamics q_{k+1} = q_k + h·v_k + h²/2·a_k and v_{k+1} = v_k + h·a_k;
- the start and goal configurations, at rest; joint, velocity and acceleration limits;
- the channel, linearised with the Jacobian at the previous iterate: while the block is on a peg, the
  tip and its velocity stay on the peg axis (within the tolerance) and the tool stays upright; the knot
  where the block leaves the start peg, every later knot in transit, and the knot where it reaches the
  goal peg are above the clearing height; no knot on a peg goes below the grasp or drop point.
The channel is re-linearised until the true tip positions meet it (sequential QP).

Variables are scaled per joint and per horizon, q̌ = q/(a_max·h²), v̌ = v/(a_max·h), ǎ = a/a_max, so
the dynamics rows have constant coefficients (1, ½) and the acceleration bounds are ±1 whatever the
horizon; the cost matrix never changes. Between solves only the channel rows' coefficients and the
bounds change, never the sparsity, so one `osqp.OSQP` object is set up per planner and updated:
fresh set-ups are 5-20x slower.

The horizon is shortened by bisection until the QP becomes infeasible (or does not converge within
the iteration cap); every feasible solution is also played as fast as its limits allow (exact uniform
time scaling), which lowers the top of the bisection for free.
"""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sparse
from numpy.typing import NDArray

from pegbt.motion.channel import Channel
from pegbt.motion.jacobian import jacobian
from pegbt.motion.kinematics import forward_kinematics, tip_position
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import SqpSettings
from pegbt.motion.trajectory import HermitePath, fit_to_limits

N = 6  # joints
STRIDE = 3 * N  # variables per knot: q̌, v̌, ǎ
CHANNEL_ROWS = 7  # per knot: lateral position (2), lateral velocity (2), height, tool tilt (2)
CHANNEL_UNIT = 1e-3  # channel rows are written in millimetres and milliradians, so their bounds are O(1)
INSIDE_TOLERANCE = 0.5  # fraction of the channel tolerance the knots may use (the rest is for between knots)
HEIGHT_SLACK = 1e-5  # m a knot may end below a clearing height
MAX_TILT = np.sin(np.radians(2.0))  # the tool may lean this far from the peg axis while the block is on it
# OSQP's own tolerance is absolute and shared by every row; ADMM closes the last hundredth of a
# millimetre slowly. An iterate is accepted when its violations are physically negligible: this much
# of an acceleration or velocity limit (uniform retiming removes it exactly afterwards), of the step's
# a_max·h² in the dynamics, and of a millimetre or milliradian in the channel rows.
FIRST_SOLVE_ITERATIONS = 4  # times the iteration cap, for the first (must-succeed) horizon
ACCEPTED_VIOLATION = {"limits": 0.02, "dynamics": 0.01, "channel": 0.05}


class _FixedPattern:
    """A sparse matrix whose nonzero positions never change while its values do.

    Entries are given once as (row, column) lists, repeats summed; `data(values)` returns the values in
    the compressed-column order OSQP stores, so they can be passed to `OSQP.update`."""

    def __init__(self, rows: NDArray[np.int64], cols: NDArray[np.int64], shape: tuple[int, int]) -> None:
        keys, self._inverse = np.unique(cols * shape[0] + rows, return_inverse=True)
        self._count = len(keys)
        self.indices = keys % shape[0]
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(keys // shape[0], minlength=shape[1]))])
        self.shape = shape

    def data(self, values: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.bincount(self._inverse, weights=values, minlength=self._count)

    def matrix(self, values: NDArray[np.float64]) -> sparse.csc_matrix:
        return sparse.csc_matrix((self.data(values), self.indices, self.indptr), shape=self.shape)


class SqpRefiner:
    """The SQP stage for one arm: one OSQP problem, set up once, updated for every solve."""

    def __init__(self, settings: ArmSettings, sqp: SqpSettings) -> None:
        self.settings = settings
        self.sqp = sqp
        K = self.knots = sqp.knots
        self.n = STRIDE * (K + 1)
        self._build_pattern()
        self._solver = osqp.OSQP()
        self._solver.setup(
            self._jerk_cost(),
            np.zeros(self.n),
            self._A.matrix(self._constraint_values(1.0, np.ones((K + 1, CHANNEL_ROWS, N)))),
            -np.ones(self._rows),
            np.ones(self._rows),
            eps_abs=sqp.eps,
            eps_rel=sqp.eps,
            max_iter=sqp.max_solver_iterations,
            polishing=False,
            warm_starting=True,
            verbose=False,
        )
        self.solves = 0  # QPs solved so far (for benchmarks)

    # --- fixed structure ------------------------------------------------------------------------
    def _build_pattern(self) -> None:
        K, n = self.knots, self.n
        step, joint = (a.ravel() for a in np.meshgrid(np.arange(K), np.arange(N), indexing="ij"))
        q0, v0, a0 = STRIDE * step + joint, STRIDE * step + N + joint, STRIDE * step + 2 * N + joint
        q1, v1 = q0 + STRIDE, v0 + STRIDE
        rows, cols = [np.arange(n)], [np.arange(n)]  # identity: joint, velocity, acceleration bounds
        position = n + 2 * (N * step + joint)  # q̌1 − q̌0 − v̌0 − ǎ0/2 = 0
        rows.append(np.repeat(position, 4))
        cols.append(np.stack([q1, q0, v0, a0], axis=1).ravel())
        rows.append(np.repeat(position + 1, 3))  # v̌1 − v̌0 − ǎ0 = 0
        cols.append(np.stack([v1, v0, a0], axis=1).ravel())
        self._channel_base = n + 2 * K * N
        knot = np.arange(K + 1)
        for r, offset in enumerate((0, 0, N, N, 0, 0, 0)):  # position rows act on q̌, velocity rows on v̌
            rows.append(np.repeat(self._channel_base + CHANNEL_ROWS * knot + r, N))
            cols.append((STRIDE * knot[:, None] + offset + np.arange(N)).ravel())
        self._rows = self._channel_base + CHANNEL_ROWS * (K + 1)
        self._A = _FixedPattern(np.concatenate(rows), np.concatenate(cols), (self._rows, n))
        self._dynamics_values = np.concatenate([np.tile([1.0, -1.0, -1.0, -0.5], K * N), np.tile([1.0, -1.0, -1.0], K * N)])

    def _jerk_cost(self) -> sparse.csc_matrix:
        """Σ (ǎ_{k+1} − ǎ_k)² over every step, starting from rest (ǎ_{−1} = 0), upper triangle."""
        K = self.knots
        a = STRIDE * np.arange(K + 1)[:, None] + 2 * N + np.arange(N)  # (K+1, N) acceleration indices
        difference = sparse.lil_matrix(((K + 1) * N, self.n))
        for k in range(K + 1):
            for j in range(N):
                difference[k * N + j, a[k, j]] = 1.0
                if k > 0:
                    difference[k * N + j, a[k - 1, j]] = -1.0
        difference = difference.tocsr()
        return sparse.triu(2.0 * difference.T @ difference, format="csc")

    def _constraint_values(self, h: float, channel: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([np.ones(self.n), self._dynamics_values, channel.transpose(1, 0, 2).ravel()])

    # --- scaling ------------------------------------------------------------------------------------
    def _scales(self, h: float) -> NDArray[np.float64]:
        """Physical value per scaled unit of every variable of one knot (q, v, a)."""
        a = self.settings.planner_acceleration
        return np.concatenate([a * h * h, a * h, a])

    def _to_scaled(self, path: HermitePath, h: float) -> NDArray[np.float64]:
        times = np.linspace(path.times[0], path.times[-1], self.knots + 1)
        q, v, _ = path.evaluate(times)
        a = np.zeros_like(v)
        a[:-1] = np.diff(v, axis=0) / h
        return (np.concatenate([q, v, a], axis=1) / self._scales(h)).ravel()

    # --- one linearisation --------------------------------------------------------------------------
    def _channel_rows(
        self, q: NDArray[np.float64], h: float, phases: tuple[int, int], pick: Channel, place: Channel
    ) -> tuple[NDArray, NDArray, NDArray]:
        """Channel coefficients (K+1, 7, 6) on the scaled variables, linearised at knot positions `q`
        (physical), and their bounds (K+1, 7)."""
        K = self.knots
        lift, lower = phases
        pose, J = forward_kinematics(q), jacobian(q)
        tip, tool, Jp, Jw = pose[:, :3, 3], pose[:, :3, 2], J[:, :3], J[:, 3:]
        on_place = np.arange(K + 1) >= lower
        on_peg = (np.arange(K + 1) <= lift) | on_place
        point = np.where(on_place[:, None], place.point, pick.point)
        normals = np.where(on_place[:, None, None], place.normals(), pick.normals())  # (K+1, 2, 3)
        lateral = np.einsum("kic,kcj->kij", normals, Jp) / CHANNEL_UNIT
        vertical = np.einsum("c,kcj->kj", pick.axis, Jp) / CHANNEL_UNIT
        # The tool axis turns by ω×axis: its lateral components change by (axis × n)·ω.
        tilt = np.einsum("kic,kcj->kij", np.cross(tool[:, None, :], normals), Jw) / CHANNEL_UNIT
        physical = np.concatenate([lateral, lateral, vertical[:, None], tilt], axis=1)
        # A row is c·q + (value at q̄ − c·q̄): the constant goes into the bounds.
        base = np.einsum("krj,kj->kr", physical, q)
        base[:, 0:2] -= np.einsum("kic,kc->ki", normals, tip - point) / CHANNEL_UNIT
        base[:, 2:4] = 0.0  # velocity rows are linear, not affine
        base[:, 4] -= (tip - point) @ pick.axis / CHANNEL_UNIT
        base[:, 5:7] -= np.einsum("kic,kc->ki", normals, tool) / CHANNEL_UNIT
        required = np.zeros(K + 1)  # never below the grasp or drop point while on a peg
        required[lift + 1 : lower] = max(pick.clear, place.clear + float((place.point - pick.point) @ pick.axis))
        required[lift] = pick.clear
        required[lower] = place.clear
        tolerance = INSIDE_TOLERANCE * pick.tolerance / CHANNEL_UNIT
        tilt_allowed = MAX_TILT / CHANNEL_UNIT
        allowed = np.array([tolerance, tolerance, 0.0, 0.0, np.inf, tilt_allowed, tilt_allowed])
        lo = np.full((K + 1, CHANNEL_ROWS), -np.inf)
        hi = np.full((K + 1, CHANNEL_ROWS), np.inf)
        lo[on_peg] = base[on_peg] - allowed
        hi[on_peg] = base[on_peg] + allowed
        lo[:, 4] = base[:, 4] + required / CHANNEL_UNIT
        hi[:, 4] = np.inf
        scale = self._scales(h)
        coefficients = physical * np.where(np.arange(CHANNEL_ROWS)[:, None] // 2 == 1, scale[N : 2 * N], scale[:N])
        return coefficients, lo, hi

    def _bounds(self, h: float, start: NDArray, goal: NDArray) -> tuple[NDArray, NDArray]:
        """Bounds of the identity (joint, velocity, acceleration) and dynamics rows, scaled."""
        s, K = self.settings, self.knots
        scale = self._scales(h)
        lo = np.tile(np.concatenate([s.lower, -s.planner_velocity, -s.planner_acceleration]) / scale, K + 1)
        hi = np.tile(np.concatenate([s.upper, s.planner_velocity, s.planner_acceleration]) / scale, K + 1)
        lo[:STRIDE - N] = hi[:STRIDE - N] = np.concatenate([start / scale[:N], np.zeros(N)])
        lo[-STRIDE:] = hi[-STRIDE:] = np.concatenate([goal / scale[:N], np.zeros(2 * N)])
        zeros = np.zeros(2 * K * N)
        return np.concatenate([lo, zeros]), np.concatenate([hi, zeros])

    def _acceptable(
        self, x: NDArray, h: float, coefficients: NDArray, lo: NDArray, hi: NDArray, channel_lo: NDArray, channel_hi: NDArray
    ) -> bool:
        if not np.all(np.isfinite(x)):
            return False
        A = self._A.matrix(self._constraint_values(h, coefficients))
        values = A @ x
        violation = np.maximum(np.concatenate([lo, channel_lo.ravel()]) - values, 0.0)
        violation += np.maximum(values - np.concatenate([hi, channel_hi.ravel()]), 0.0)
        return bool(
            violation[: self.n].max() <= ACCEPTED_VIOLATION["limits"]
            and violation[self.n : self._channel_base].max() <= ACCEPTED_VIOLATION["dynamics"]
            and violation[self._channel_base :].max() <= ACCEPTED_VIOLATION["channel"]
        )

    def _channel_met(self, q: NDArray[np.float64], phases: tuple[int, int], pick: Channel, place: Channel) -> bool:
        tip = tip_position(q)
        lift, lower = phases
        slack = 1.2 * INSIDE_TOLERANCE  # the linearisation may be off by a little at convergence
        return bool(
            np.all(pick.distance(tip[: lift + 1]) <= slack * pick.tolerance)
            and np.all(place.distance(tip[lower:]) <= slack * place.tolerance)
            and pick.height(tip[lift]) >= pick.clear - HEIGHT_SLACK
            and place.height(tip[lower]) >= place.clear - HEIGHT_SLACK
        )

    def _solve(self, path: HermitePath, phases: tuple[int, int], pick: Channel, place: Channel) -> HermitePath | None:
        """The QP at `path`'s horizon, warm-started from it and re-linearised until the channel holds;
        None if it is infeasible or does not converge."""
        K = self.knots
        h = path.duration / K
        scale = self._scales(h)
        x = self._to_scaled(path, h)
        lo, hi = self._bounds(h, path.positions[0], path.positions[-1])
        for _ in range(self.sqp.max_iterations):
            q = x.reshape(K + 1, STRIDE)[:, :N] * scale[:N]
            coefficients, channel_lo, channel_hi = self._channel_rows(q, h, phases, pick, place)
            self._solver.update(
                Ax=self._A.data(self._constraint_values(h, coefficients)),
                l=np.concatenate([lo, channel_lo.ravel()]),
                u=np.concatenate([hi, channel_hi.ravel()]),
            )
            self._solver.warm_start(x=x)
            x = self._solver.solve(raise_error=False).x
            self.solves += 1
            if not self._acceptable(x, h, coefficients, lo, hi, channel_lo, channel_hi):
                return None
            knots = x.reshape(K + 1, STRIDE) * scale
            # OSQP meets equalities only to its tolerance: pin the fixed ends exactly.
            knots[0, :N], knots[-1, :N] = path.positions[0], path.positions[-1]
            knots[0, N : 2 * N] = knots[-1, N : 2 * N] = 0.0
            if self._channel_met(knots[:, :N], phases, pick, place):
                return HermitePath(np.linspace(0.0, path.duration, K + 1), knots[:, :N], knots[:, N : 2 * N])
        return None

    def _fastest(self, path: HermitePath) -> HermitePath:
        """`path` played as fast as its velocity and acceleration limits allow."""
        return fit_to_limits(path, self.settings.planner_velocity, self.settings.planner_acceleration, speed_up=True)

    # --- horizon ------------------------------------------------------------------------------------
    def refine(self, warm: HermitePath, pick: Channel, place: Channel) -> HermitePath | None:
        """The shortest channel-respecting path found, warm-started from `warm`; None if not even
        `warm`'s horizon (or a little more) admits one."""
        K = self.knots
        guess = HermitePath(warm.times - warm.times[0], warm.positions, warm.velocities)
        tip = tip_position(guess.evaluate(np.linspace(0.0, guess.duration, K + 1))[0])
        lift = int(np.argmax(pick.height(tip) >= pick.clear))
        lower = int(K - np.argmax(place.height(tip)[::-1] >= place.clear))
        phases = (max(lift, 1), min(max(lower, lift + 1), K - 1))
        # The first horizon must succeed, so it may take longer; probes below it are capped.
        self._solver.update_settings(max_iter=FIRST_SOLVE_ITERATIONS * self.sqp.max_solver_iterations)
        best = None
        for stretch in (1.0, 1.25, 1.6):
            best = self._solve(guess.retimed(stretch), phases, pick, place)
            if best is not None:
                break
        self._solver.update_settings(max_iter=self.sqp.max_solver_iterations)
        if best is None:
            return None
        best = self._fastest(best)
        low = _rest_to_rest_lower_bound(best.positions[-1] - best.positions[0], self.settings)
        for _ in range(self.sqp.horizon_probes):
            trial = 0.5 * (low + best.duration)
            found = self._solve(best.retimed(trial / best.duration), phases, pick, place)
            if found is None:
                low = trial
            else:
                best = self._fastest(found)
        return best


def _rest_to_rest_lower_bound(delta: NDArray[np.float64], settings: ArmSettings) -> float:
    """No path between two configurations is faster than each joint's bang-bang rest-to-rest move."""
    v, a = settings.planner_velocity, settings.planner_acceleration
    d = np.abs(delta)
    return float(np.max(np.where(d <= v * v / a, 2 * np.sqrt(d / a), d / v + v / a)))
