"""SQP refinement of a transfer (the paper's second stage), solved with OSQP.

The path is a uniform quadratic B-spline over the horizon T = S·h: S segments, S+2 control points c_i
per joint. Its velocity is linear between the knots with values (c_{i+1} − c_i)/h there, and its
acceleration is constant per segment, a_i = (c_{i+2} − 2c_{i+1} + c_i)/h², so velocity and
acceleration limits on the control points hold *everywhere* on the path, and the path (inside the
convex hull of its control points) stays inside the joint limits. Doubled control points at each end
start and stop at rest. The decision variables are the control points and the segment accelerations,
tied by equality rows (ADMM converges much faster on bounds of variables than on bounds of differences).

The QP minimises the squared jumps of acceleration between segments (the discrete jerk, each joint
relative to its acceleration limit, from rest to rest) subject to
- the start and goal configurations, at rest; joint, velocity and acceleration limits;
- the channel, linearised with the Jacobian at the previous iterate and imposed at every knot and
  segment middle (each a fixed combination of three control points): while the block is on a peg, the
  tip stays on the peg axis (within the tolerance) and the tool upright; the sample where the block
  leaves the start peg, every later one in transit, and the one where it reaches the goal peg are above
  the clearing height; none on a peg goes below the grasp or drop point.
The channel is re-linearised until the true tip positions meet it (sequential QP).

Variables are scaled per joint and per horizon, č = c/(a_max·h²), ǎ = a/a_max: the acceleration
bounds are then ±1 and the acceleration definitions have constant coefficients whatever the horizon,
and the cost matrix never changes. Between solves only the channel rows' coefficients and the bounds
change, never the sparsity, so one `osqp.OSQP` object is set up per planner and updated: fresh set-ups
are 5-20x slower.

The horizon is shortened by a fixed fraction until the QP is infeasible (or not solved within the
iteration cap), then bisected; every feasible solution is also played as fast as its limits allow
(exact uniform time scaling), which shortens it for free.
"""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sparse
from numpy.typing import NDArray

from pegbt.motion.channel import Channel
from pegbt.motion.jacobian import cross, jacobian_from_frames
from pegbt.motion.kinematics import link_frames, tip_position
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import SqpSettings
from pegbt.motion.trajectory import HermitePath, fit_to_limits

N = 6  # joints
CHANNEL_ROWS = 5  # per path sample: lateral position (2), height, tool tilt (2)
CHANNEL_UNIT = 1e-3  # channel rows are written in millimetres and milliradians, so their bounds are O(1)
INSIDE_TOLERANCE = 0.5  # fraction of the channel tolerance the samples may use (the rest: between them)
HEIGHT_SLACK = 1e-5  # m the path may end below a clearing height
MAX_TILT = np.sin(np.radians(2.0))  # the tool may lean this far from the peg axis while the block is on it
FIRST_SOLVE_ITERATIONS = 4  # times the iteration cap, for the first (must-succeed) horizon
FIRST_STRETCHES = (1.1, 1.4, 1.8)  # horizons tried first, relative to the spline's duration
# OSQP's tolerance is absolute and shared by every row, and ADMM closes the last hundredth of a
# millimetre slowly. An iterate is accepted when its violations are physically negligible: this much
# of a velocity or acceleration limit (the exact retiming afterwards removes it) and of a millimetre or
# milliradian in the channel rows.
ACCEPTED_VIOLATION = {"limits": 0.02, "channel": 0.05}


class _FixedPattern:
    """A sparse matrix whose nonzero positions never change while its values do.

    Entries are given once as (row, column) lists, repeats summed; `data(values)` returns the values in
    the compressed-column order OSQP stores, so they can be passed to `OSQP.update`."""

    def __init__(self, rows: NDArray[np.int64], cols: NDArray[np.int64], shape: tuple[int, int]) -> None:
        self._rows, self._cols = rows, cols
        keys, self._inverse = np.unique(cols * shape[0] + rows, return_inverse=True)
        self._count = len(keys)
        self.indices = keys % shape[0]
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(keys // shape[0], minlength=shape[1]))])
        self.shape = shape

    def data(self, values: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.bincount(self._inverse, weights=values, minlength=self._count)

    def product(self, values: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The matrix with entry `values` times the vector `x`, without building the matrix."""
        return np.bincount(self._rows, weights=values * x[self._cols], minlength=self.shape[0])

    def matrix(self, values: NDArray[np.float64]) -> sparse.csc_matrix:
        return sparse.csc_matrix((self.data(values), self.indices, self.indptr), shape=self.shape)


def _differences(count: int, order: int) -> sparse.csr_matrix:
    """The `order`-th forward difference operator on `count` points, ((count − order) × count)."""
    D = sparse.identity(count, format="csr")
    for _ in range(order):
        D = D[1:] - D[:-1]
    return D


def _sample_weights(segments: int) -> NDArray[np.float64]:
    """Weights (2S+1, 3) of the quadratic B-spline at its knots and segment midpoints, in order, on
    control points i, i+1, i+2 with i = sample // 2: a knot is the midpoint of two control points, a
    segment's middle is (c_i + 6·c_{i+1} + c_{i+2})/8. The last knot (i = S − 1) uses the last two."""
    weights = np.tile([[0.5, 0.5, 0.0], [0.125, 0.75, 0.125]], (segments, 1))
    return np.vstack([weights, [[0.0, 0.5, 0.5]]])


def _b_spline_path(control: NDArray[np.float64], h: float) -> HermitePath:
    """The quadratic B-spline of `control` points (S+2, 6) with knot spacing `h`, as cubic Hermite
    segments (each exactly quadratic): knots at the midpoints of consecutive control points."""
    times = h * np.arange(len(control) - 1)
    return HermitePath(times, 0.5 * (control[1:] + control[:-1]), np.diff(control, axis=0) / h)


class SqpRefiner:
    """The SQP stage for one arm: one OSQP problem, set up once, updated for every solve."""

    def __init__(self, settings: ArmSettings, sqp: SqpSettings) -> None:
        self.settings = settings
        self.sqp = sqp
        self.segments = sqp.segments
        self.points = sqp.segments + 2  # control points
        # The channel is held at the knots and halfway along every segment: each such sample of the
        # path is a fixed combination of three consecutive control points.
        self._weights = _sample_weights(self.segments)  # (2S+1, 3), on control points i, i+1, i+2
        self.sample_count = len(self._weights)
        self._first = np.minimum(np.arange(self.sample_count) // 2, self.segments - 1)  # i of each sample
        self.n_control = N * self.points
        self.n = self.n_control + N * self.segments  # control points, then each segment's acceleration
        self._build_pattern()
        self._solver = osqp.OSQP()
        self._solver.setup(
            self._jerk_cost(),
            np.zeros(self.n),
            self._A.matrix(self._constraint_values(np.ones((self.sample_count, CHANNEL_ROWS, N)))),
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
        self._linearised: tuple | None = None

    # --- fixed structure ------------------------------------------------------------------------
    def _build_pattern(self) -> None:
        """Rows: identity (joint and acceleration limits), velocity, the definition of each segment's
        acceleration (an equality: ADMM handles bounds on variables far better than on differences),
        then the channel rows per knot. Joints never mix except in the channel rows."""
        eye = sparse.identity(N)
        no_acceleration = sparse.csr_matrix((N * (self.points - 1), N * self.segments))
        self._limit_rows = sparse.vstack(
            [
                sparse.identity(self.n),
                sparse.hstack([sparse.kron(_differences(self.points, 1), eye), no_acceleration]),
                sparse.hstack([sparse.kron(_differences(self.points, 2), eye), -sparse.identity(N * self.segments)]),
            ],
            format="coo",
        )
        limit_count = self._limit_rows.shape[0]
        # Channel rows act on path samples, each a combination of three consecutive control points.
        sample = np.arange(self.sample_count)
        channel_rows = limit_count + CHANNEL_ROWS * sample[:, None] + np.arange(CHANNEL_ROWS)  # (samples, 5)
        three = N * (self._first[:, None] + np.arange(3))[:, :, None] + np.arange(N)  # (samples, 3, 6)
        rows = np.concatenate([self._limit_rows.row, np.repeat(channel_rows.ravel(), 3 * N)])
        cols = np.concatenate(
            [self._limit_rows.col, np.broadcast_to(three[:, None], (self.sample_count, CHANNEL_ROWS, 3, N)).ravel()]
        )
        self._channel_base = limit_count
        self._rows = limit_count + CHANNEL_ROWS * self.sample_count
        self._A = _FixedPattern(rows, cols, (self._rows, self.n))

    def _jerk_cost(self) -> sparse.csc_matrix:
        """Σ of squared acceleration jumps between segments, from rest and back to rest, upper triangle."""
        zero = sparse.csr_matrix((1, self.segments))
        jumps = _differences(self.segments + 2, 1) @ sparse.vstack([zero, sparse.identity(self.segments), zero])
        jerk = sparse.hstack([sparse.csr_matrix(((self.segments + 1) * N, self.n_control)), sparse.kron(jumps, sparse.identity(N))])
        return sparse.triu(2.0 * jerk.T @ jerk, format="csc")

    def _constraint_values(self, channel: NDArray[np.float64]) -> NDArray[np.float64]:
        """All values of A; `channel` (samples, 5, 6) are the rows' coefficients on a path sample's
        position, shared out over its three control points by the sample's weights."""
        shares = channel[:, :, None, :] * self._weights[:, None, :, None]
        return np.concatenate([self._limit_rows.data, shares.ravel()])

    # --- scaling ------------------------------------------------------------------------------------
    def _scale(self, h: float) -> NDArray[np.float64]:
        """Radians (metres) per scaled unit of each joint's control points."""
        return self.settings.planner_acceleration * h * h

    # --- one linearisation --------------------------------------------------------------------------
    def _linearise(
        self, control: NDArray[np.float64], phases: tuple[int, int], pick: Channel, place: Channel
    ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """Channel coefficients (samples, 5, 6) on a path sample's physical position, linearised at
        the samples of `control` points, the rows' bounds (samples, 5), and the tips there (samples, 3).
        The last result is kept: a probe starts from the previous probe's solution, whose
        linearisation (and tips, already computed for its channel check) it reuses."""
        key = (control.tobytes(), phases, id(pick), id(place))
        if self._linearised is not None and self._linearised[0] == key:
            return self._linearised[1]
        lift, lower = phases
        c = self._sample(control)
        frames = link_frames(c)
        pose, J = frames[-1], jacobian_from_frames(frames)
        tip, tool, Jp, Jw = pose[:, :3, 3], pose[:, :3, 2], J[:, :3], J[:, 3:]
        index = np.arange(self.sample_count)
        on_place = index >= lower
        on_peg = (index <= lift) | on_place
        point = np.where(on_place[:, None], place.point, pick.point)
        normals = np.where(on_place[:, None, None], place.normals, pick.normals)  # (points, 2, 3)
        lateral = np.einsum("kic,kcj->kij", normals, Jp)
        vertical = np.einsum("c,kcj->kj", pick.axis, Jp)
        # The tool axis turns by ω×axis: its lateral components change by (axis × n)·ω.
        tilt = np.einsum("kic,kcj->kij", cross(tool[:, None, :], normals), Jw)
        physical = np.concatenate([lateral, vertical[:, None], tilt], axis=1) / CHANNEL_UNIT
        # A row is c·q + (value at q̄ − c·q̄): the constant goes into the bounds.
        base = np.einsum("krj,kj->kr", physical, c)
        base[:, 0:2] -= np.einsum("kic,kc->ki", normals, tip - point) / CHANNEL_UNIT
        base[:, 2] -= (tip - point) @ pick.axis / CHANNEL_UNIT
        base[:, 3:5] -= np.einsum("kic,kc->ki", normals, tool) / CHANNEL_UNIT
        required = np.zeros(self.sample_count)  # never below the grasp or drop point while on a peg
        required[lift + 1 : lower] = max(pick.clear, place.clear + float((place.point - pick.point) @ pick.axis))
        required[lift] = pick.clear
        required[lower] = place.clear
        tolerance = INSIDE_TOLERANCE * pick.tolerance / CHANNEL_UNIT / np.sqrt(2)  # per lateral direction
        allowed = np.array([tolerance, tolerance, np.inf, MAX_TILT / CHANNEL_UNIT, MAX_TILT / CHANNEL_UNIT])
        lo = np.full((self.sample_count, CHANNEL_ROWS), -np.inf)
        hi = np.full((self.sample_count, CHANNEL_ROWS), np.inf)
        lo[on_peg] = base[on_peg] - allowed
        hi[on_peg] = base[on_peg] + allowed
        lo[:, 2] = base[:, 2] + required / CHANNEL_UNIT
        hi[:, 2] = np.inf
        result = (physical, lo, hi, tip)
        self._linearised = (key, result)
        return result

    def _bounds(self, h: float, start: NDArray, goal: NDArray) -> tuple[NDArray, NDArray]:
        """Bounds of the identity (joint limits, fixed ends), velocity and acceleration rows, scaled."""
        s, scale = self.settings, self._scale(h)
        lo = np.tile(s.lower / scale, self.points)
        hi = np.tile(s.upper / scale, self.points)
        lo[: 2 * N] = hi[: 2 * N] = np.tile(start / scale, 2)
        lo[-2 * N :] = hi[-2 * N :] = np.tile(goal / scale, 2)
        acceleration = np.ones(N * self.segments)
        velocity = np.tile(s.planner_velocity * h / scale, self.points - 1)
        definition = np.zeros(N * self.segments)
        return (
            np.concatenate([lo, -acceleration, -velocity, definition]),
            np.concatenate([hi, acceleration, velocity, definition]),
        )

    def _acceptable(self, x: NDArray, coefficients: NDArray, lo: NDArray, hi: NDArray) -> bool:
        if not np.all(np.isfinite(x)):
            return False
        values = self._A.product(self._constraint_values(coefficients), x)
        violation = np.maximum(lo - values, 0.0) + np.maximum(values - hi, 0.0)
        # Velocity rows relative to their bound; accelerations are already relative (bound 1).
        velocity = slice(self.n, self.n + N * (self.points - 1))
        return bool(
            np.max(violation[velocity] / hi[velocity]) <= ACCEPTED_VIOLATION["limits"]
            and violation[self.n_control : self.n].max() <= ACCEPTED_VIOLATION["limits"]
            and violation[velocity.stop : self._channel_base].max() <= ACCEPTED_VIOLATION["limits"]
            and violation[self._channel_base :].max() <= ACCEPTED_VIOLATION["channel"]
        )

    def _sample(self, control: NDArray[np.float64]) -> NDArray[np.float64]:
        """The path at its samples (knots and segment midpoints), from control points (S+2, 6)."""
        return np.einsum("ki,kij->kj", self._weights, control[self._first[:, None] + np.arange(3)])

    def _channel_met(self, tip: NDArray, phases: tuple[int, int], pick: Channel, place: Channel) -> bool:
        """The true tips at the path's samples meet the channel."""
        lift, lower = phases
        slack = 1.2 * INSIDE_TOLERANCE  # the linearisation may be off by a little at convergence
        return bool(
            np.all(pick.distance(tip[: lift + 1]) <= slack * pick.tolerance)
            and np.all(place.distance(tip[lower:]) <= slack * place.tolerance)
            and pick.height(tip[lift]) >= pick.clear - HEIGHT_SLACK
            and place.height(tip[lower]) >= place.clear - HEIGHT_SLACK
        )

    def _solve(
        self, control: NDArray, T: float, phases: tuple[int, int], pick: Channel, place: Channel
    ) -> tuple[HermitePath, NDArray] | None:
        """The path for horizon `T` and its control points, warm-started from `control` (physical)
        and re-linearised until the channel holds; None if it is infeasible or does not converge."""
        h = T / self.segments
        scale = self._scale(h)
        start, goal = control[0], control[-1]
        limits_lo, limits_hi = self._bounds(h, start, goal)
        scaled = control / scale
        x = np.concatenate([scaled.ravel(), (scaled[2:] - 2 * scaled[1:-1] + scaled[:-2]).ravel()])
        physical, channel_lo, channel_hi, _ = self._linearise(control, phases, pick, place)
        for _ in range(self.sqp.max_iterations):
            coefficients = physical * scale
            lo = np.concatenate([limits_lo, channel_lo.ravel()])
            hi = np.concatenate([limits_hi, channel_hi.ravel()])
            self._solver.update(Ax=self._A.data(self._constraint_values(coefficients)), l=lo, u=hi)
            self._solver.warm_start(x=x)
            x = self._solver.solve(raise_error=False).x
            self.solves += 1
            if not self._acceptable(x, coefficients, lo, hi):
                return None
            # OSQP meets bounds only to its tolerance: pin the fixed ends and clip to the joint limits
            # exactly (the path stays in the convex hull of its control points).
            control = np.clip(x[: self.n_control].reshape(-1, N) * scale, self.settings.lower, self.settings.upper)
            control[:2], control[-2:] = start, goal
            physical, channel_lo, channel_hi, tip = self._linearise(control, phases, pick, place)
            if self._channel_met(tip, phases, pick, place):
                return _b_spline_path(control, h), control
        return None

    def _fastest(self, path: HermitePath) -> HermitePath:
        """`path` played as fast as its velocity and acceleration limits allow."""
        return fit_to_limits(path, self.settings.planner_velocity, self.settings.planner_acceleration, speed_up=True)

    # --- horizon ------------------------------------------------------------------------------------
    def refine(self, warm: HermitePath, pick: Channel, place: Channel) -> HermitePath | None:
        """The shortest channel-respecting path found, warm-started from `warm`; None if not even a
        horizon somewhat longer than `warm`'s admits one."""
        # Control points on the warm path at the times they sit nearest to, ends doubled; the phases
        # (the samples where the block leaves the start peg and reaches the goal peg) come from it.
        times = np.clip((np.arange(self.points) - 0.5) / self.segments, 0.0, 1.0) * warm.duration
        control = warm.evaluate(warm.times[0] + times)[0]
        control[:2], control[-2:] = warm.positions[0], warm.positions[-1]
        phases = self._phases(tip_position(self._sample(control)), pick, place)
        # The first horizon must succeed, so it starts with some slack and may take longer; the
        # shorter ones after it are capped.
        self._solver.update_settings(max_iter=FIRST_SOLVE_ITERATIONS * self.sqp.max_solver_iterations)
        found = None
        for stretch in FIRST_STRETCHES:
            found = self._solve(control, stretch * warm.duration, phases, pick, place)
            if found is not None:
                break
        self._solver.update_settings(max_iter=self.sqp.max_solver_iterations)
        if found is None:
            return None
        # Shorten the horizon by a fixed fraction until the QP is infeasible, then bisect. Control
        # points are positions, so the best one so far warm-starts any horizon as it is.
        best, control = self._fastest(found[0]), found[1]
        low = 0.0
        for _ in range(self.sqp.horizon_probes):
            trial = (1 - self.sqp.horizon_step) * best.duration if low == 0.0 else 0.5 * (low + best.duration)
            found = self._solve(control, trial, phases, pick, place)
            if found is None:
                low = trial
                if best.duration - low < 0.5 * self.sqp.horizon_step * best.duration:
                    break
            else:
                best, control = self._fastest(found[0]), found[1]
        return best

    def _phases(self, tip: NDArray, pick: Channel, place: Channel) -> tuple[int, int]:
        """The samples where the block leaves the start peg and reaches the goal peg, for tips at the
        samples of the warm start."""
        lift = int(np.argmax(pick.height(tip) >= pick.clear))
        lower = int(self.sample_count - 1 - np.argmax(place.height(tip)[::-1] >= place.clear))
        return max(lift, 1), min(max(lower, lift + 1), self.sample_count - 2)
