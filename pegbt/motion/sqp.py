"""SQP refinement of a transfer (the paper's second stage), solved with OSQP.

The path is a uniform quadratic B-spline over a horizon T = S·h: S segments, S+2 control points c_i
per joint. Its velocity is linear between the knots with values (c_{i+1} − c_i)/h there, and its
acceleration is constant per segment, a_i = (c_{i+2} − 2c_{i+1} + c_i)/h², so velocity and
acceleration limits on the control points hold *everywhere* on the path, and the path (inside the
convex hull of its control points) stays inside the joint limits. Doubled control points at each end
start and stop at rest.

Shortening the horizon is a 1-D problem: the same path played k times slower has k² smaller
accelerations, and the channel is geometry, untouched by timing. So instead of searching the horizon
(one QP per probe, the infeasible ones the slowest), the horizon stays fixed and one variable λ bounds
every segment's acceleration relative to its limit, |a_i| ≤ λ·a_max: the path then plays in T·√λ,
and minimising λ minimises the transfer time in a single QP. Its cost is λ² plus a small weight on the
squared acceleration jumps between segments (the discrete jerk, from rest to rest), which picks the
smoothest of the fastest paths. The constraints:
- the start and goal configurations, at rest; joint limits; velocity limits (for the path slowed by
  √λ of the previous iterate: velocity scales with 1/k, not 1/k²; the exact retiming at the end
  settles any difference);
- the channel, linearised with the Jacobian at the previous iterate and imposed at every knot and
  segment middle (each a fixed combination of three control points): while the block is on a peg, the
  tip stays on the peg axis (within half the tolerance) and the tool turns about it by at most the
  channel's `max_twist` (the block's hole, gripped off the tip's line, swings round it as the tool turns);
  the tool stays upright all along; the sample where the block leaves the start peg, every later one in
  transit, and the one where it reaches the goal peg are above the clearing height; none on a peg goes
  below the grasp or drop point;
- a trust region: each joint moves at most `step_limit` per linearisation, so that the linear model
  of the channel holds (without it the QP turns roll against wrist pitch, which cancel to first order
  but tilt the tool by tens of degrees).
The channel is re-linearised until the path, retimed exactly to its limits and sampled at the control
period, passes the trajectory checks (sequential QP). The samples on the pegs' channels are fixed by the
warm start (`_phases`), and the path found depends on them: the refinement runs from each of
`PHASE_SHIFTS` and keeps the fastest. The warm path's control points are first turned
upright (`pegbt.motion.straighten`): the trust region could not take back the lean of a joint-space
spline that turns the roll, and the first QP would be infeasible. A QP without a solution ends the
refinement with that reason: OSQP's answer then is a certificate of infeasibility, not a step.

Variables are the changes of the control points from the linearisation point, scaled per joint,
δč = δc/(a_max·h²), the segment accelerations ǎ = a/a_max (tied to them by equality rows: ADMM handles
bounds on variables far better than bounds on differences) and λ. Between solves only the channel
rows' coefficients and the bounds change, never the sparsity, so one `osqp.OSQP` object is set up per
planner and updated, and each QP of a refinement starts from the previous one's primal and dual solution.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.channel import Channel, Upright
from pegbt.motion.checks import trajectory_problems
from pegbt.motion.jacobian import cross, jacobian_from_frames
from pegbt.motion.kinematics import link_frames, tip_position
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import SqpSettings
from pegbt.motion.straighten import upright_configurations
from pegbt.motion.trajectory import HermitePath, Trajectory, fit_to_limits

if TYPE_CHECKING:
    import scipy.sparse as sparse

N = 6  # joints
CHANNEL_ROWS = 6  # per path sample: lateral position (2), height, tool tilt (2), turn about the axis
# Channel rows are written in units of 30 mm (30 mrad), so that OSQP's absolute tolerance (1e-3) is
# 30 µm there, about a sixth of what the samples may use; in millimetres ADMM took 2-7x more
# iterations for the same accuracy of λ (measured).
CHANNEL_UNIT = 0.03
INSIDE_TOLERANCE = 0.5  # fraction of the channel tolerance the samples may use (the rest: between them)
# Samples by which the block leaves the start peg later than on the spline. Over the 24 reference
# transfers (both arms), 0 gives a median of 1.66 s, 1 gives 1.60 s, 2 gives 1.71 s (measured).
LIFT_LATER = 1
# Samples by which the tool reaches the goal channel earlier than on the warm start, each tried: over the
# 11 approaches of the unilateral trial (PSM1) the warm start's own phases give 1.15 s, the best of them
# and one sample earlier 1.10 s (its 12 carries stay at 1.52 s; measured, more shifts gain < 5 ms).
PHASE_SHIFTS = (0, 1)


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
        return np.bincount(self._inverse, weights=values, minlength=self._count).astype(np.float64)

    def matrix(self, values: NDArray[np.float64]) -> sparse.csc_matrix:
        import scipy.sparse as sparse

        return sparse.csc_matrix((self.data(values), self.indices, self.indptr), shape=self.shape)


def _differences(count: int, order: int) -> sparse.csr_matrix:
    """The `order`-th forward difference operator on `count` points, ((count − order) × count)."""
    import scipy.sparse as sparse

    D = sparse.identity(count, format="csr")
    for _ in range(order):
        D = D[1:] - D[:-1]
    return D


def _no_solution(status: int) -> bool:
    """Whether OSQP answered with a certificate, not a step: the linearisation has no solution."""
    from osqp import SolverStatus

    return status in (
        SolverStatus.OSQP_PRIMAL_INFEASIBLE,
        SolverStatus.OSQP_PRIMAL_INFEASIBLE_INACCURATE,
        SolverStatus.OSQP_DUAL_INFEASIBLE,
        SolverStatus.OSQP_DUAL_INFEASIBLE_INACCURATE,
    )


def _sample_weights(segments: int) -> NDArray[np.float64]:
    """Weights (2S+1, 3) of the quadratic B-spline at its knots and segment midpoints, in order, on
    control points i, i+1, i+2 with i = sample // 2: a knot is the midpoint of two control points, a
    segment's middle is (c_i + 6·c_{i+1} + c_{i+2})/8. The last knot (i = S − 1) uses the last two."""
    weights = np.tile([[0.5, 0.5, 0.0], [0.125, 0.75, 0.125]], (segments, 1))
    return np.vstack([weights, [[0.0, 0.5, 0.5]]])


def _b_spline_path(control: NDArray[np.float64], h: float) -> HermitePath:
    """The quadratic B-spline of `control` points (S+2, 6) with knot spacing `h`, as cubic Hermite
    segments (each exactly quadratic): knots at the midpoints of consecutive control points."""
    times = h * np.arange(len(control) - 1, dtype=np.float64)
    return HermitePath(times, 0.5 * (control[1:] + control[:-1]), np.diff(control, axis=0) / h)


class SqpRefiner:
    """The SQP stage for one arm: one OSQP problem, set up once, updated for every solve."""

    def __init__(self, settings: ArmSettings, sqp: SqpSettings) -> None:
        import osqp

        self.settings = settings
        self.sqp = sqp
        self.segments = sqp.segments
        self.points = sqp.segments + 2  # control points
        self._step_limit = np.asarray(sqp.step_limit)
        # The channel is held at the knots and halfway along every segment: each such sample of the
        # path is a fixed combination of three consecutive control points.
        self._weights = _sample_weights(self.segments)  # (2S+1, 3), on control points i, i+1, i+2
        self.sample_count = len(self._weights)
        self._first = np.minimum(np.arange(self.sample_count) // 2, self.segments - 1)  # i of each sample
        self.n_control = N * self.points
        self.n_acceleration = N * self.segments
        self.n = self.n_control + self.n_acceleration + 1  # control point changes, accelerations, λ
        self._build_pattern()
        self._solver = osqp.OSQP()
        self._solver.setup(
            self._cost(),
            np.zeros(self.n),
            self._A.matrix(self._constraint_values(np.ones((self.sample_count, CHANNEL_ROWS, N)))),
            -np.ones(self._rows),
            np.ones(self._rows),
            eps_abs=sqp.eps,
            eps_rel=sqp.eps,
            rho=sqp.rho,
            max_iter=sqp.max_solver_iterations,
            polishing=False,
            warm_starting=True,
            verbose=False,
        )
        self.solves = 0  # QPs solved so far (for benchmarks)

    # --- fixed structure ------------------------------------------------------------------------
    def _build_pattern(self) -> None:
        """Rows: the control point changes (joint limits, trust region, fixed ends) and λ ≥ 0;
        velocities; the definition of each segment's acceleration (equalities); each acceleration
        within ±λ; then the channel rows per sample. Joints never mix except in the channel rows."""
        import scipy.sparse as sparse

        eye, acc, moves = sparse.identity(N), self.n_acceleration, N * (self.points - 1)

        def row_block(
            count: int,
            control: sparse.spmatrix | None = None,
            acceleration: sparse.spmatrix | None = None,
            slow_down: sparse.spmatrix | None = None,
        ) -> sparse.spmatrix:
            """`count` rows with the given blocks on the control point, acceleration and λ columns."""
            widths = (self.n_control, acc, 1)
            blocks = (control, acceleration, slow_down)
            return sparse.hstack(
                [
                    sparse.csr_matrix((count, width)) if block is None else block
                    for block, width in zip(blocks, widths)
                ]
            )

        lam = sparse.csr_matrix(np.ones((acc, 1)))
        self._limit_rows = sparse.vstack(
            [
                row_block(self.n_control, control=sparse.identity(self.n_control)),
                row_block(1, slow_down=sparse.identity(1)),
                row_block(moves, control=sparse.kron(_differences(self.points, 1), eye)),
                row_block(
                    acc,
                    control=sparse.kron(_differences(self.points, 2), eye),
                    acceleration=-sparse.identity(acc),
                ),
                row_block(acc, acceleration=sparse.identity(acc), slow_down=-lam),
                row_block(acc, acceleration=sparse.identity(acc), slow_down=lam),
            ]
        ).tocoo()
        limit_count = self._limit_rows.shape[0]
        sample = np.arange(self.sample_count)
        channel_rows = limit_count + CHANNEL_ROWS * sample[:, None] + np.arange(CHANNEL_ROWS)  # (samples, 5)
        three = N * (self._first[:, None] + np.arange(3))[:, :, None] + np.arange(N)  # (samples, 3, 6)
        rows = np.concatenate([self._limit_rows.row, np.repeat(channel_rows.ravel(), 3 * N)])
        cols = np.concatenate(
            [
                self._limit_rows.col,
                np.broadcast_to(three[:, None], (self.sample_count, CHANNEL_ROWS, 3, N)).ravel(),
            ]
        )
        self._rows = limit_count + CHANNEL_ROWS * self.sample_count
        self._A = _FixedPattern(rows, cols, (self._rows, self.n))

    def _cost(self) -> sparse.csc_matrix:
        """λ² plus `jerk_weight` times the squared acceleration jumps between segments, from rest and
        back to rest; upper triangle."""
        import scipy.sparse as sparse

        zero = sparse.csr_matrix((1, self.segments))
        jumps = _differences(self.segments + 2, 1) @ sparse.vstack(
            [zero, sparse.identity(self.segments), zero]
        )
        count = (self.segments + 1) * N
        jerk = sparse.hstack(
            [
                sparse.csr_matrix((count, self.n_control)),
                sparse.kron(jumps, sparse.identity(N)),
                sparse.csr_matrix((count, 1)),
            ]
        )
        slow_down = sparse.csr_matrix(([1.0], ([0], [self.n - 1])), shape=(1, self.n))
        return sparse.triu(
            2.0 * (self.sqp.jerk_weight * jerk.T @ jerk + slow_down.T @ slow_down), format="csc"
        )

    def _constraint_values(self, channel: NDArray[np.float64]) -> NDArray[np.float64]:
        """All values of A; `channel` (samples, 6, 6) are the rows' coefficients on a path sample's
        position, shared out over its three control points by the sample's weights."""
        shares = channel[:, :, None, :] * self._weights[:, None, :, None]
        return np.concatenate([self._limit_rows.data, shares.ravel()])

    # --- one linearisation --------------------------------------------------------------------------
    def _linearise(
        self,
        control: NDArray[np.float64],
        phases: tuple[int, int],
        pick: Channel,
        place: Channel,
        upright: Upright,
        floor: float,
    ) -> tuple[NDArray, NDArray, NDArray]:
        """Channel coefficients (samples, 6, 6) on the change of a path sample's physical position,
        linearised at the samples of `control` points, and the bounds (samples, 6) on those changes;
        `floor` is the lowest height above `pick.point` of the samples in transit."""
        lift, lower = phases
        c = self._sample(control)
        frames = link_frames(c)
        pose, J = frames[-1], jacobian_from_frames(frames)
        tip, tool, Jp, Jw = pose[:, :3, 3], pose[:, :3, 2], J[:, :3], J[:, 3:]
        index = np.arange(self.sample_count)
        on_place = index >= lower
        on_peg = (index <= lift) | on_place
        point = np.where(on_place[:, None], place.point, pick.point)
        normals = np.where(on_place[:, None, None], place.normals, pick.normals)  # (samples, 2, 3)
        axis = np.where(on_place[:, None], place.axis, pick.axis)  # a goal's may point down: heights are its
        lateral = np.einsum("kic,kcj->kij", normals, Jp)
        vertical = np.einsum("kc,kcj->kj", axis, Jp)
        # The tool axis turns by ω×axis: its components across the upright axis change by (axis × n)·ω.
        tilt = np.einsum("kic,kcj->kij", cross(tool[:, None, :], upright.normals), Jw)
        turn = np.einsum("kc,kcj->kj", axis, Jw)  # about the pegs' axis, the tool near upright
        physical = np.concatenate([lateral, vertical[:, None], tilt, turn[:, None]], axis=1) / CHANNEL_UNIT
        # Each row's value at the linearisation point: the bounds on its change are what is left.
        value = np.empty((self.sample_count, CHANNEL_ROWS))
        value[:, 0:2] = np.einsum("kic,kc->ki", normals, tip - point)
        value[:, 2] = np.einsum("kc,kc->k", tip - point, axis)
        value[:, 3:5] = tool @ upright.normals.T
        # the turn from the tool's orientation where the block sits on each peg: the start, the goal
        jaws = pose[:, :3, 0]
        value[:, 5] = np.where(on_place, place.twist(jaws, jaws[-1]), pick.twist(jaws, jaws[0]))
        # never below the grasp or drop point while on a peg (never above a goal pointing down)
        required = np.zeros(self.sample_count)
        required[lift + 1 : lower] = floor
        required[lift] = pick.clear
        required[lower] = place.clear
        # per direction, inside the circle; a funnel's widening (at the sample's present height) in full
        allowed = np.where(on_place, place.allowed(place.height(tip)), pick.allowed(pick.height(tip)))
        tolerance = np.where(on_place, place.tolerance, pick.tolerance)
        lateral_allowed = (allowed - (1 - INSIDE_TOLERANCE) * tolerance) / np.sqrt(2)
        tilt_allowed = INSIDE_TOLERANCE * np.sin(upright.max_tilt) / np.sqrt(2)
        lo = np.full((self.sample_count, CHANNEL_ROWS), -np.inf)
        hi = np.full((self.sample_count, CHANNEL_ROWS), np.inf)
        lo[on_peg, 0:2] = -lateral_allowed[on_peg, None]
        hi[on_peg, 0:2] = lateral_allowed[on_peg, None]
        lo[:, 2] = required
        lo[:, 3:5], hi[:, 3:5] = -tilt_allowed, tilt_allowed
        # the whole turn at the samples: it varies slowly between them, and the checks hold every set-point
        turn_allowed = np.where(on_place, place.max_twist, pick.max_twist)
        lo[on_peg, 5], hi[on_peg, 5] = -turn_allowed[on_peg], turn_allowed[on_peg]
        return physical, (lo - value) / CHANNEL_UNIT, (hi - value) / CHANNEL_UNIT

    def _bounds(self, h: float, scaled: NDArray, slow_down: float) -> tuple[NDArray, NDArray]:
        """Bounds of the rows other than the channel's, for changes of the `scaled` control points:
        joint limits and the trust region (the ends fixed), λ ≥ 0, velocities (for the path slowed by
        √`slow_down`), the acceleration definitions and the ±λ rows."""
        s, scale = self.settings, self._scale(h)
        lo = np.maximum(s.lower / scale - scaled, -self._step_limit / scale).ravel()
        hi = np.minimum(s.upper / scale - scaled, self._step_limit / scale).ravel()
        lo[: 2 * N] = hi[: 2 * N] = lo[-2 * N :] = hi[-2 * N :] = 0.0
        velocity = s.planner_velocity * h * np.sqrt(slow_down) / scale
        step = np.diff(scaled, axis=0)
        definition = -_accelerations(scaled)
        zeros, infinite = np.zeros(self.n_acceleration), np.full(self.n_acceleration, np.inf)
        return (
            np.concatenate([lo, [0.0], (-velocity - step).ravel(), definition, -infinite, zeros]),
            np.concatenate([hi, [np.inf], (velocity - step).ravel(), definition, zeros, infinite]),
        )

    def _scale(self, h: float) -> NDArray[np.float64]:
        """Radians (metres) per scaled unit of each joint's control points."""
        return self.settings.planner_acceleration * h * h

    def _sample(self, control: NDArray[np.float64]) -> NDArray[np.float64]:
        """The path at its samples (knots and segment midpoints), from control points (S+2, 6)."""
        return np.einsum("ki,kij->kj", self._weights, control[self._first[:, None] + np.arange(3)])

    # --- the refinement ----------------------------------------------------------------------------
    def refine(
        self, warm: HermitePath, pick: Channel | None, place: Channel, upright: Upright
    ) -> tuple[HermitePath, Trajectory]:
        """The fastest path found, retimed to the limits, and its trajectory sampled at the control
        period, which has passed the trajectory checks (limits, channels, upright tool); warm-started
        from `warm`. No `pick` channel: the block starts in the air (after a handover). A `PegbtError`
        saying why if a linearisation has no solution or they run out first."""
        # Control points on the warm path at the times they sit nearest to, turned upright, ends
        # doubled; the phases (the samples where the block leaves the start peg and reaches the goal
        # peg) come from them.
        h = warm.duration / self.segments
        times = np.clip((np.arange(self.points) - 0.5) / self.segments, 0.0, 1.0) * warm.duration
        control = warm.evaluate(warm.times[0] + times)[0]
        control[:2], control[-2:] = warm.positions[0], warm.positions[-1]
        control[2:-2] = upright_configurations(control[2:-2], self.settings, upright)
        tips = tip_position(self._sample(control))
        phases = self._phases(tips, pick, place)
        # In transit the block stays above the goal peg's clearing height, and above the start peg's; a goal
        # that is no floor (the block comes up onto it) sets none.
        floor = place.clear + float((place.point - tips[0]) @ place.axis) if place.floor else -np.inf
        if pick is None:  # only the start sample is "on" the start: it stays where it is
            leaving = Channel(tips[0], place.axis if place.floor else -place.axis, 0.0, place.tolerance)
        else:
            leaving, floor = pick, max(pick.clear, floor) if pick.floor else floor
        failures: list[PegbtError] = []
        best: tuple[HermitePath, Trajectory] | None = None
        for shift in PHASE_SHIFTS:
            shifted = (phases[0], max(phases[1] - shift, phases[0] + 1))
            if shift and shifted == phases:
                continue
            try:
                found = self._refine_from(control, h, shifted, pick, place, upright, leaving, floor)
            except PegbtError as error:
                failures.append(error)
                continue
            if best is None or found[1].duration < best[1].duration:
                best = found
        if best is None:
            raise failures[0]
        return best

    def _refine_from(
        self,
        control: NDArray[np.float64],
        h: float,
        phases: tuple[int, int],
        pick: Channel | None,
        place: Channel,
        upright: Upright,
        leaving: Channel,
        floor: float,
    ) -> tuple[HermitePath, Trajectory]:
        """The sequential QP from the warm `control` points with the block on the pegs' channels up to
        and from the samples `phases`: the first iterate that passes the checks."""
        scale = self._scale(h)
        acceleration = _accelerations(control / scale)
        slow_down = float(np.max(np.abs(acceleration)))
        start, goal = control[0], control[-1]
        problems: list[str] = []
        for iteration in range(1, self.sqp.max_iterations + 1):
            physical, channel_lo, channel_hi = self._linearise(
                control, phases, leaving, place, upright, floor
            )
            limits_lo, limits_hi = self._bounds(h, control / scale, slow_down)
            self._solver.update(
                Ax=self._A.data(self._constraint_values(physical * scale)),
                l=np.concatenate([limits_lo, channel_lo.ravel()]),
                u=np.concatenate([limits_hi, channel_hi.ravel()]),
            )
            if iteration == 1:
                self._forget_previous_transfer()
            self._solver.warm_start(x=np.concatenate([np.zeros(self.n_control), acceleration, [slow_down]]))
            result = self._solver.solve(raise_error=False)
            self.solves += 1
            x = result.x
            if _no_solution(result.info.status_val) or x is None or not np.all(np.isfinite(x)):
                raise PegbtError(
                    f"the SQP's linearisation {iteration} has no solution (OSQP: {result.info.status})",
                    field="sqp",
                )
            # OSQP meets bounds only to its tolerance: pin the fixed ends and clip to the joint limits
            # exactly (the path stays in the convex hull of its control points).
            control = np.clip(
                control + x[: self.n_control].reshape(-1, N) * scale, self.settings.lower, self.settings.upper
            )
            control[:2], control[-2:] = start, goal
            acceleration, slow_down = _accelerations(control / scale), max(float(x[-1]), 1e-6)
            path = fit_to_limits(
                _b_spline_path(control, h),
                self.settings.planner_velocity,
                self.settings.planner_acceleration,
                speed_up=True,
            )
            trajectory = path.sample(self.settings.control_period)
            problems = trajectory_problems(
                trajectory, self.settings, leaving=pick, arriving=place, upright=upright
            )
            if not problems:
                return path, trajectory
        raise PegbtError(
            f"after {self.sqp.max_iterations} linearisations the SQP's path still fails: "
            + "; ".join(problems),
            field="sqp",
        )

    def _forget_previous_transfer(self) -> None:
        """ADMM's step size back to its initial value, as its duals are set back to zero: a plan then
        depends on its waypoints alone, not on what the arm planned before (the same time and QPs per
        plan, measured); with the previous transfer's, whether a transfer at the edge of feasibility is
        refined would depend on the trial's history."""
        self._solver.update_settings(rho=self.sqp.rho)
        self._solver.warm_start(y=np.zeros(self._rows))

    def _phases(self, tip: NDArray, pick: Channel | None, place: Channel) -> tuple[int, int]:
        """The samples where the block leaves the start peg (0 without one) and reaches the goal peg,
        for tips at the samples of the warm start; the block leaves the start peg one sample later
        than on the warm start, as the fastest paths spend a larger share of their time lifting than
        the spline does."""
        lift = 0 if pick is None else max(int(np.argmax(pick.height(tip) >= pick.clear)) + LIFT_LATER, 1)
        lower = int(self.sample_count - 1 - np.argmax(place.height(tip)[::-1] >= place.clear))
        return lift, min(max(lower, lift + 1), self.sample_count - 2)


def _accelerations(scaled: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each segment's acceleration relative to the limits (S·6,), from scaled control points (S+2, 6)."""
    return (scaled[2:] - 2 * scaled[1:-1] + scaled[:-2]).ravel()
