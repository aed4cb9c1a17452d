"""One grid point: the integration loop of the impact oscillator with its observers.

The loop advances Runge-Kutta steps of the configured method (integration.method: rk45, the
Dormand-Prince 5(4) pair of rk45.py, or dop853, Hairer's 8(5,3) of dop853.py), stops
every step at the slow-period boundaries t = nT (T = 2 pi / omega) so that every period is
measured exactly, locates
impacts on the dense output (impact.py), applies the restitution law (eq2.2), and holds the
mass on the barrier while chatter has died out and the force presses it there (sticking).

Observers are plain arrays the caller passes in, so one kernel serves a sweep (which only
needs the per-period records) and a trajectory (samples, impact and sticking logs): an
observer with zero length costs nothing. The kernel knows nothing of files or configs.

Fourier sums (eq3.1, eq3.2) are quadrature states integrated with the motion, so they are
as accurate as x itself; while stuck they are added in closed form. With integration.lyapunov
the state also carries two tangent vectors (tangent.py) and every period records their growth.

Array layouts: the state vector is state.py's; the settings vector is this module's (below);
the per-period record, the summary and the logs are records.py's (re-exported here as
kernel.REC_*, kernel.SUM_*); the coefficient vector is model.py's. The right-hand sides and the
forcing-phase rotations are rhs.py's.

``_integrate`` stays one function on purpose: it is the algorithm read top to bottom, and every
piece it calls is inlined by numba; splitting its loop into functions that return several
values would cost tuple packing in the hottest path for no gain in clarity.
"""

import math

import numpy as np

from vrsweep.numerics import dop853
from vrsweep.numerics.dop853 import (
    dop853_accepted_step_factor, dop853_certain_growth, dop853_dense, dop853_error_norm, dop853_rejected_step_factor,
    dop853_step,
)
from vrsweep.numerics.impact import (
    IMPACT, N_BRACKET, TURNING_POINT, UNRESOLVED, find_crossing, force_at_barrier, hermite_reach, locate_root,
    release_time,
)
from vrsweep.numerics.rk45 import (
    DENSE_ORDER, DP54_C, N_DYNAMIC, N_STAGES, ORDER, accepted_step_factor, certain_growth, dense_value, dp54_dense,
    dp54_step, error_norm, initial_step, rejected_step_factor,
)
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.model import ALPHA, BIG_OMEGA, C, DELTA, E, G, GAMMA, MU, OMEGA, STIFFNESS  # noqa: F401 - read as kernel.ALPHA ...
from vrsweep.results import Status
from vrsweep.numerics.records import (  # noqa: F401 - the layouts, read as kernel.REC_*, kernel.SUM_*
    N_RECORD, N_SUMMARY, REC_IMPACTS, REC_LOG_AREA, REC_LOG_STRETCH, REC_QC, REC_QS, REC_STUCK_TIME,
    REC_V, REC_X, REC_X_MAX, REC_X_MIN, SUM_IMPACTS, SUM_IMPACTS_PER_PERIOD, SUM_LYAPUNOV,
    SUM_LYAPUNOV_SUM, SUM_QC, SUM_QS, SUM_Q_AMPLITUDE, SUM_R, SUM_REJECTED, SUM_RHS, SUM_STEPS,
    SUM_FREE_X_MAX, SUM_FREE_X_MAX_TIME, SUM_STICKS, SUM_T_FINAL, SUM_V_FINAL, SUM_WINDOW_X_MAX, SUM_X_FINAL, add_tangent_growth, close_period,
    emit_samples, emit_state, log_impact, log_stick_start, start_period, summarize, update_extremes, window_top,
)
from vrsweep.numerics.rhs import (  # noqa: F401 - the rotation layout, read as kernel.* by tests
    COS_FAST, COS_SLOW, FULL_STEP_NODE, LEVEL_READY, LEVEL_ROTATIONS, MAX_NODES, NODES,
    N_ROTATION_SCRATCH, N_STEP_LEVELS, PHASE_STEP, PHASE_TIME, RESYNC_STEPS, ROTATED_STEPS, ROTATION,
    ROTATION_VALUES, SIN_FAST, SIN_SLOW, STEP_GRID, STEP_LEVELS_PER_OCTAVE, grid_step, no_preparation,
    no_scratch, oscillator_rhs, oscillator_rhs_rotated, oscillator_tangent_rhs,
    oscillator_tangent_rhs_rotated, prepare_rotations, prepare_step_rotations, rotation_scratch,
)
from vrsweep.numerics.settings import (  # noqa: F401 - the settings layout, read as kernel.*
    ATOL, DEFAULT_METHOD, DIVERGENCE_BOUND, MAX_IMPACTS_PER_PERIOD, MAX_STEPS, MEASURE_PERIODS, N_SETTINGS,
    RTOL, SETTING_DEFAULTS, SETTING_NAMES, STICK_VELOCITY, TRANSIENT_PERIODS, TRANSPARENT_FROM, TRANSPARENT_TO,
)
from vrsweep.numerics.state import N_STATE, N_STATE_WITH_TANGENTS, QC_INTEGRAL, QS_INTEGRAL, V, X
from vrsweep.numerics.tangent import (
    apply_saltation, collapse_tangents, record_monodromy, seed_tangents, tangent_derivative,
    tangents_out_of_range,
)

# Impacts are decided on each step's dense output in Bernstein form (impact.find_crossing), which
# sees a graze between a step's ends however long the step: events need no step cap (up to version
# 0.1 a step was capped at 1/8 of the shortest forcing period so that a graze showed as one turning
# point). The caps that stay are for accuracy (benchmarks/README.md, "Steps without the cap"):
# without them the controller lets local errors grow to the tolerance, and R, a Fourier component
# about 1e-3 of x's size at g = 30, then needed rtol 1e-6 to 1e-7 and more steps than the capped
# run at rtol 1e-4. With the fast forcing (g != 0): 1/8 of its period (1/6 left R 1.7e-3 off at
# g = 30, rtol 1e-4). Without it (the effective model): 1/6 of the slow period (none left R 1.5e-5
# off at g = 25, rtol 1e-4; 1/6 took 1404 steps for R within 8.5e-7, 1/8 1606).
FAST_STEP_FRACTION = 1.0 / 8.0
SLOW_STEP_FRACTION = 1.0 / 6.0
# Sticking: the force at the barrier is scanned in steps of this fraction of the shortest period.
STICK_SCAN_FRACTION = 1.0 / 64.0
# The exact step to an impact is Newton-refined until x is this close to Delta (relative).
IMPACT_POSITION_TOLERANCE = 1e-13
IMPACT_NEWTON_ITERATIONS = 3
# After a slow rebound, the first step covers at most this fraction of the predicted flight.
REBOUND_STEP_FRACTION = 0.25
# A step too long to resolve a departure from the barrier and return is retried this much shorter.
UNRESOLVED_STEP_FACTOR = 0.125


@kernel_jit
def _smallest_step(t, slow_period):
    """A step this short no longer moves t by more than a few units of its last place."""
    return 4.0 * 2.2e-16 * max(abs(t), slow_period)


@kernel_jit
def integrate_rk45(coefficients, initial_state, settings, period_records, summary,
                   sample_times, samples, impact_log, stick_log):
    """Integrate one point over transient + measurement slow periods. Returns a Status code.

    coefficients    (N_COEFFICIENTS,)        model.kernel_coefficients
    initial_state   (2,)                      x(0), v(0)
    settings        (N_SETTINGS,)            layout above
    period_records  (n_rows, N_RECORD)       the last n_rows periods' records, measure_periods <= n_rows
                                             <= n_periods (a sweep: measure_periods, a trajectory: all)
    summary         (N_SUMMARY,)             filled at the end; R, Qs, Qc NaN unless status OK
    sample_times    (n_samples,)             sorted times for dense samples (may be empty)
    samples         (n_samples, 2)           x, v at sample_times
    impact_log      (n_impact_log, 3)        t, v before, v after, for the first impacts
    stick_log       (n_stick_log, 2)         start and end of the first sticking intervals

    With Dormand-Prince 5(4) steps (integration.method: rk45, integrator.py), the library's
    cosines at every evaluation. Since version 0.2 steps are no longer capped at 1/8 of the
    shortest forcing period, so results differ from those of 0.1 (no longer bit for bit).
    """
    return _integrate(oscillator_rhs, oscillator_rhs, no_preparation, no_preparation, no_scratch, False, DP54_C,
                      dp54_step, error_norm, dp54_dense, accepted_step_factor, certain_growth,
                      rejected_step_factor, False,
                      ORDER, N_STAGES, False, N_DYNAMIC,
                      np.empty((N_STAGES + 1, N_STATE)), np.empty((N_STATE, DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)))


@kernel_jit
def integrate_dop853(coefficients, initial_state, settings, period_records, summary,
                     sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with DOP853 steps (integration.method: dop853, dop853.py).

    Its stages evaluate the forcing by rotating the phases of the step's start (prepare_rotations,
    oscillator_rhs_rotated), on step sizes rounded down to their grid; other evaluations call the
    library (oscillator_rhs).
    """
    return _integrate(oscillator_rhs, oscillator_rhs_rotated, prepare_step_rotations, prepare_rotations,
                      rotation_scratch, True,
                      dop853.C_STAGES, dop853_step, dop853_error_norm, dop853_dense, dop853_accepted_step_factor,
                      dop853_certain_growth, dop853_rejected_step_factor, True, dop853.ERROR_ESTIMATOR_ORDER + 1,
                      dop853.N_STAGES, False, N_DYNAMIC,
                      np.empty((dop853.N_STAGES_EXTENDED, N_STATE)), np.empty((N_STATE, dop853.DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)))


@kernel_jit
def integrate_rk45_lyapunov(coefficients, initial_state, settings, period_records, summary,
                            sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with the tangent vectors (integration.lyapunov: true; tangent.py).

    The same steps, impacts and records as integrate_rk45 (the tangent vectors take no part in
    error control), plus REC_LOG_STRETCH, REC_LOG_AREA per period and SUM_LYAPUNOV, SUM_LYAPUNOV_SUM.
    """
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs, no_preparation, no_preparation, no_scratch,
                      False, DP54_C,
                      dp54_step, error_norm, dp54_dense, accepted_step_factor, certain_growth,
                      rejected_step_factor, False,
                      ORDER, N_STAGES, True, N_STATE_WITH_TANGENTS,
                      np.empty((N_STAGES + 1, N_STATE_WITH_TANGENTS)),
                      np.empty((N_STATE_WITH_TANGENTS, DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)))


@kernel_jit
def integrate_dop853_lyapunov(coefficients, initial_state, settings, period_records, summary,
                              sample_times, samples, impact_log, stick_log):
    """integrate_dop853 with the tangent vectors (integration.lyapunov: true; tangent.py)."""
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs_rotated, prepare_step_rotations,
                      prepare_rotations,
                      rotation_scratch, True, dop853.C_STAGES, dop853_step, dop853_error_norm, dop853_dense,
                      dop853_accepted_step_factor, dop853_certain_growth, dop853_rejected_step_factor, True,
                      dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES, True, N_STATE_WITH_TANGENTS,
                      np.empty((dop853.N_STAGES_EXTENDED, N_STATE_WITH_TANGENTS)),
                      np.empty((N_STATE_WITH_TANGENTS, dop853.DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)))


@kernel_jit
def integrate_rk45_monodromy(coefficients, initial_state, settings, period_records, summary,
                             sample_times, samples, impact_log, stick_log, monodromy_log):
    """integrate_rk45_lyapunov that also returns each period's tangent map (continuation).

    monodromy_log (n_periods, 4): row k is the 2x2 matrix d y((k+1)T) / d y(kT) of period k,
    row-major (tangent.record_monodromy); the saltation matrix at every impact is in it, a sticking
    interval makes it zero. No renormalisation: one period's map stays far inside double range
    for the model's damping (tangent.py's TANGENT_RANGE is for runs of many periods).
    """
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs, no_preparation, no_preparation, no_scratch,
                      False, DP54_C,
                      dp54_step, error_norm, dp54_dense, accepted_step_factor, certain_growth,
                      rejected_step_factor, False,
                      ORDER, N_STAGES, True, N_STATE_WITH_TANGENTS,
                      np.empty((N_STAGES + 1, N_STATE_WITH_TANGENTS)),
                      np.empty((N_STATE_WITH_TANGENTS, DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, monodromy_log)


@kernel_jit
def integrate_dop853_monodromy(coefficients, initial_state, settings, period_records, summary,
                               sample_times, samples, impact_log, stick_log, monodromy_log):
    """integrate_rk45_monodromy with DOP853 steps."""
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs_rotated, prepare_step_rotations,
                      prepare_rotations,
                      rotation_scratch, True, dop853.C_STAGES, dop853_step, dop853_error_norm, dop853_dense,
                      dop853_accepted_step_factor, dop853_certain_growth, dop853_rejected_step_factor, True,
                      dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES, True, N_STATE_WITH_TANGENTS,
                      np.empty((dop853.N_STAGES_EXTENDED, N_STATE_WITH_TANGENTS)),
                      np.empty((N_STATE_WITH_TANGENTS, dop853.DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, monodromy_log)


# integration.method -> the kernel. Each is compiled (or loaded from the cache) on its first call,
# so a run compiles only the method it uses.
INTEGRATORS = {"rk45": integrate_rk45, "dop853": integrate_dop853}
METHODS = tuple(INTEGRATORS)
# The same with the tangent vectors (integration.lyapunov: true).
LYAPUNOV_INTEGRATORS = {"rk45": integrate_rk45_lyapunov, "dop853": integrate_dop853_lyapunov}
# With each period's raw tangent map (continuation, numerics/shooting.py).
MONODROMY_INTEGRATORS = {"rk45": integrate_rk45_monodromy, "dop853": integrate_dop853_monodromy}


def integrator(method, lyapunov=False):
    """The kernel for an integration method, with or without the tangent vectors."""
    return (LYAPUNOV_INTEGRATORS if lyapunov else INTEGRATORS)[method]


# Inlined into each method's kernel above, so that the method's functions become direct calls
# (a function passed as a runtime value would be a "dynamic global" and could not be cached).
@kernel_jit(inline="always")
def _integrate(rhs, stage_rhs, prepare_step, prepare_dense, make_scratch, grid_steps, nodes, step, step_error,
               dense_output, accepted_factor, certain_growth, rejected_factor, hold_after_reject, initial_order,
               n_stages, tangents, n_dynamic, K, dense, coefficients, initial_state, settings, period_records, summary,
               sample_times, samples, impact_log, stick_log, monodromy_log):
    """The integration loop of every method; see integrate_rk45 for the arguments.

    rhs(t, h, node, c, y, coefficients, dydt, scratch) is the oscillator at t + c h; stage_rhs the
    same at a step's stages, after prepare_step(t, h, coefficients, scratch) (before a dense output:
    prepare_dense, which also prepares the dense output's extra stages), with scratch =
    make_scratch(h_max, nodes); grid_steps rounds each step size down to grid_step's grid.
    step(stage_rhs, t, y, f, h, coefficients, K, y_new, stage, scratch, n_dynamic) fills K
    (K[n_stages] = f(t + h, y_new)) and y_new; step_error(K, h, y, y_new, rtol, atol) is the scaled
    error norm; certain_growth(err, err_previous) is True only where accepted_factor's result is
    certainly >= 1; dense_output(stage_rhs, t, y, h, coefficients, K, y_new, dense, stage, scratch,
    n_dynamic) fills dense and returns its extra RHS count. tangents: the state carries the
    tangent vectors (state.py) and the right-hand sides integrate them; n_dynamic is the number of
    state components the right-hand sides read. K (rows, n_state) and dense (n_state, order) are
    the method's work arrays, their width the state's size.

    Each pass of the loop is one of: hold the mass on the barrier up to its release or the period's
    end; or attempt a step, and if it is accepted, resolve an impact inside it (reach it with an
    exact step), feed the observers, and apply the restitution law or start sticking. A pass that
    reaches the period's end closes the period.

    monodromy_log (n, 4): with tangents, the raw one-period tangent map of each of the first n
    periods (record_monodromy); the tangent vectors then restart from the unit vectors every period
    instead of being renormalised. Length 0 (every kernel but the *_monodromy ones): unused.
    """
    rtol = settings[RTOL]
    atol = settings[ATOL]
    n_transient = int(settings[TRANSIENT_PERIODS])
    n_periods = n_transient + int(settings[MEASURE_PERIODS])
    # period_records may hold only the last rows (a sweep keeps the measurement window's, so its
    # memory does not grow with the transient): period k is row max(k - first_row, 0), and the
    # transient's periods before the kept rows all reuse row 0 (start_period resets it).
    first_row = n_periods - period_records.shape[0]
    max_steps = settings[MAX_STEPS]
    max_impacts_per_period = settings[MAX_IMPACTS_PER_PERIOD]
    divergence_bound = settings[DIVERGENCE_BOUND]
    stick_velocity = settings[STICK_VELOCITY]
    delta = coefficients[DELTA]
    restitution = coefficients[E]
    # The transparent window (grazing.py; NaN: none, and every comparison with it is False).
    transparent_from = settings[TRANSPARENT_FROM]
    transparent_to = settings[TRANSPARENT_TO]
    has_window = transparent_from == transparent_from and transparent_to == transparent_to
    transparent = False
    window_x_max = -np.inf
    # Continuation (the *_monodromy kernels) also wants the orbit's highest smooth maximum.
    track_free_maxima = monodromy_log.shape[0] > 0
    free_x_max = -np.inf
    free_x_max_time = np.nan

    slow_period = 2.0 * math.pi / coefficients[OMEGA]
    shortest_period = slow_period
    if coefficients[G] != 0.0:
        shortest_period = min(shortest_period, 2.0 * math.pi / coefficients[BIG_OMEGA])
    h_max = SLOW_STEP_FRACTION * slow_period
    if coefficients[G] != 0.0:
        h_max = min(h_max, FAST_STEP_FRACTION * 2.0 * math.pi / coefficients[BIG_OMEGA])
    stick_scan_step = STICK_SCAN_FRACTION * shortest_period

    n_state = K.shape[1]
    y = np.zeros(n_state)
    y_new = np.empty(n_state)
    stage = np.empty(n_state)
    f = np.empty(n_state)
    bracket = np.empty(N_BRACKET)
    scratch = make_scratch(h_max, nodes)  # the stage right-hand side's own

    y[X] = initial_state[0]
    y[V] = initial_state[1]
    if tangents:
        seed_tangents(y)
    t = 0.0
    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
    n_rhs = 1
    h = initial_step(rhs, t, y, f, coefficients, rtol, atol, h_max, initial_order, scratch)
    n_rhs += 1
    err_previous = 1.0
    n_steps = 0
    n_rejected = 0
    n_impacts = 0
    n_sticks = 0
    n_scans = 0
    retrying = False
    stuck = False
    status = Status.OK

    period = 0
    t_boundary = slow_period
    start_period(period_records[0], y[X], tangents)
    next_sample = emit_state(sample_times, samples, 0, 0.0, y[X], y[V])

    while True:
        record = period_records[max(period - first_row, 0)]
        if stuck:
            # --- held at (Delta, 0) until the force lets go or the period ends ---
            t_release, scans = release_time(t, t_boundary, coefficients, stick_scan_step, max_steps - n_scans)
            n_scans += scans
            if t_release != t_release:
                status = Status.MAX_STEPS  # the force scan has a budget of max_steps intervals too
                break
            t_end = min(t_release, t_boundary)
            _add_stuck_quadratures(y, delta, coefficients[OMEGA], t, t_end)
            next_sample = emit_state(sample_times, samples, next_sample, t_end, delta, 0.0)
            record[REC_STUCK_TIME] += t_end - t
            t = t_end
            if t_release <= t_boundary:
                stuck = False
                if n_sticks - 1 < stick_log.shape[0]:
                    stick_log[n_sticks - 1, 1] = t
                rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                n_rhs += 1
                err_previous = 1.0
        else:
            # --- attempt a step ---
            if n_steps >= max_steps:
                status = Status.MAX_STEPS
                break
            if not (h > _smallest_step(t, slow_period)):
                # An overflowing start (g = 1e200: the first step estimate is 0 or NaN) would
                # otherwise take zero-length steps up to the step cap.
                status = Status.STEP_TOO_SMALL if h == h else Status.NON_FINITE
                break
            h_try = min(h, h_max)
            if grid_steps:
                h_try = grid_step(h_try, scratch)  # a step size whose rotations are tabulated
            if has_window:
                # A step ends on each edge of the transparent window, so that each step is wholly
                # inside it or outside (a sliver left before an edge is judged by its midpoint).
                if t < transparent_from - _smallest_step(t, slow_period) and t + h_try > transparent_from:
                    h_try = transparent_from - t
                elif t < transparent_to - _smallest_step(t, slow_period) and t + h_try > transparent_to:
                    h_try = transparent_to - t
                transparent = transparent_from <= t + 0.5 * h_try < transparent_to
            clipped = False
            if t + 1.01 * h_try >= t_boundary:  # land on the boundary, no sliver step after it
                h_try = t_boundary - t
                clipped = True
            prepare_step(t, h_try, coefficients, scratch)
            step(stage_rhs, t, y, f, h_try, coefficients, K, y_new, stage, scratch, n_dynamic)
            n_steps += 1
            n_rhs += n_stages
            err = step_error(K, h_try, y, y_new, rtol, atol)
            if not (err <= 1.0):  # also catches NaN from an overflowing trial step
                n_rejected += 1
                retrying = True
                h = h_try * (rejected_factor(err) if err == err else 0.2)
                if h <= _smallest_step(t, slow_period):
                    status = Status.STEP_TOO_SMALL if err == err else Status.NON_FINITE
                    break
                continue
            # The next step is at the cap whenever h >= h_max, whatever h's value: so the factor
            # (two pow calls) is computed only where it can matter, with bit for bit the same steps.
            if clipped and h >= h_max:
                h_next = h  # h = max(h_next, h) below stays >= h_max whatever the factor
            elif h_try >= h_max and certain_growth(err, err_previous):
                h_next = h_try  # the factor is >= 1: h_try * factor >= h_max
            else:
                h_next = h_try * accepted_factor(err, err_previous)
            if retrying and hold_after_reject:
                h_next = min(h_next, h_try)  # Hairer's DOP853: no growth right after a rejection
            retrying = False
            err_previous = err
            h = max(h_next, h) if clipped else h_next

            # --- does the step cross the barrier? ---
            impact = False
            dense_ready = False
            theta_turn = np.nan
            # Every step that the ends alone cannot place far below the barrier gets its dense
            # output and the exact test on it (find_crossing: Bernstein form).
            if not transparent and (
                    y_new[X] >= delta or y[X] >= delta
                    or hermite_reach(y[X], y[V], f[V], y_new[X], y_new[V], K[n_stages, V], h_try, delta) >= 0.0):
                prepare_dense(t, h_try, coefficients, scratch)
                n_rhs += dense_output(stage_rhs, t, y, h_try, coefficients, K, y_new, dense, stage, scratch,
                                      n_dynamic)
                dense_ready = True
                pushed = y[X] >= delta and force_at_barrier(t, coefficients) > 0.0
                verdict = find_crossing(dense, y, y_new, h_try, delta, pushed, bracket)
                if verdict == UNRESOLVED:
                    # Off the barrier and back within the first scan interval: look closer.
                    h = h_try * UNRESOLVED_STEP_FACTOR
                    if h <= _smallest_step(t, slow_period):
                        status = Status.STEP_TOO_SMALL
                        break
                    continue
                impact = verdict == IMPACT
                if not impact:
                    theta_turn = bracket[TURNING_POINT]
            h_taken = h_try
            if impact:
                h_taken, spent = _reach_impact(stage_rhs, prepare_step, prepare_dense, step, dense_output, n_stages,
                                               n_dynamic, t, y, f, h_try, delta, bracket, coefficients, K, y_new, dense,
                                               stage, scratch)
                n_rhs += spent
                dense_ready = True

            # --- observers: samples and the period's extremes, on the step's dense output ---
            t_new = t_boundary if (clipped and not impact) else t + h_taken
            if next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_new:
                if not dense_ready:
                    prepare_dense(t, h_taken, coefficients, scratch)
                    n_rhs += dense_output(stage_rhs, t, y, h_taken, coefficients, K, y_new, dense, stage, scratch,
                                          n_dynamic)
                    dense_ready = True
                next_sample = emit_samples(sample_times, samples, next_sample, t, h_taken, y, dense, t_new)
            if y[V] * y_new[V] < 0.0 and not dense_ready:
                prepare_dense(t, h_taken, coefficients, scratch)
                n_rhs += dense_output(stage_rhs, t, y, h_taken, coefficients, K, y_new, dense, stage, scratch,
                                      n_dynamic)
            update_extremes(record, dense, y, y_new, h_taken, theta_turn)
            if transparent:
                window_x_max = window_top(window_x_max, dense, y, y_new, h_taken)
            elif track_free_maxima and y[V] > 0.0 and y_new[V] < 0.0:  # dense is ready: see above
                theta = locate_root(dense, y, h_taken, V, 0.0, 0.0, 1.0)
                x_turn = dense_value(dense, y, h_taken, theta, X)
                if x_turn > free_x_max:
                    free_x_max = x_turn
                    free_x_max_time = t + theta * h_taken

            # --- advance ---
            t = t_new
            for j in range(n_state):
                y[j] = y_new[j]
                f[j] = K[n_stages, j]

            # --- the impact: restitution (eq2.2), or the start of sticking ---
            if impact:
                y[X] = delta  # the exact step left it within IMPACT_POSITION_TOLERANCE
                n_impacts += 1
                record[REC_IMPACTS] += 1.0
                record[REC_X_MAX] = delta
                if record[REC_IMPACTS] > max_impacts_per_period:
                    status = Status.CHATTER_LIMIT
                    break
                acceleration_before = f[V]
                v_before, v_after, stuck = _restitution(y, t, coefficients, stick_velocity)
                log_impact(impact_log, n_impacts, t, v_before, v_after)
                if stuck:
                    n_sticks = log_stick_start(stick_log, n_sticks, t)
                    if tangents:
                        collapse_tangents(y)
                else:
                    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                    n_rhs += 1
                    if tangents:
                        apply_saltation(y, v_before, acceleration_before, f[V], restitution)
                        tangent_derivative(y, coefficients, f)  # f of the jumped tangent vectors
                    h = _rebound_step(h, t, v_after, coefficients)
                err_previous = 1.0

            if tangents and monodromy_log.shape[0] == 0 and tangents_out_of_range(y):
                # A strongly damped or stretched period would underflow or overflow them before
                # its end: renormalise now, the period's record sums the logs.
                add_tangent_growth(record, y)
                tangent_derivative(y, coefficients, f)

            if not (math.isfinite(y[X]) and math.isfinite(y[V])):
                status = Status.NON_FINITE
                break
            if abs(y[X]) > divergence_bound or abs(y[V]) > divergence_bound:
                status = Status.DIVERGED
                break

        if t >= t_boundary:
            raw = tangents and period < monodromy_log.shape[0]
            if raw:
                record_monodromy(monodromy_log[period], y)
            close_period(record, y, f, coefficients, tangents, stuck)
            if raw and not stuck:
                seed_tangents(y)  # the next period's map starts from the identity, not from Q
                tangent_derivative(y, coefficients, f)
            period += 1
            if period == n_periods:
                break
            t_boundary = (period + 1) * slow_period
            start_period(period_records[max(period - first_row, 0)], y[X], tangents)

    if stuck and n_sticks - 1 < stick_log.shape[0]:
        stick_log[n_sticks - 1, 1] = t
    status = summarize(period_records, n_transient - first_row, n_periods - first_row, slow_period, coefficients[C],
                       status, summary)
    summary[SUM_STEPS] = n_steps
    summary[SUM_REJECTED] = n_rejected
    summary[SUM_RHS] = n_rhs
    summary[SUM_X_FINAL] = y[X]
    summary[SUM_V_FINAL] = y[V]
    summary[SUM_T_FINAL] = t
    summary[SUM_IMPACTS] = n_impacts
    summary[SUM_STICKS] = n_sticks
    summary[SUM_WINDOW_X_MAX] = window_x_max
    summary[SUM_FREE_X_MAX] = free_x_max
    summary[SUM_FREE_X_MAX_TIME] = free_x_max_time
    return status


@kernel_jit(inline="always")
def _reach_impact(stage_rhs, prepare_step, prepare_dense, step, dense_output, n_stages, n_dynamic, t, y, f, h_try,
                  delta, bracket, coefficients, K, y_new, dense, stage, scratch):
    """Step exactly to the impact that find_crossing bracketed in the step [t, t + h_try].

    Locates it on the dense output, then reaches it with a step of the method's own order (not
    the interpolant's), Newton-corrected onto x = Delta; leaves y_new, K and dense for that step.
    Returns (its size, the RHS evaluations spent).
    """
    n_rhs = 0
    if bracket[0] < bracket[1]:
        theta = locate_root(dense, y, h_try, X, delta, bracket[0], bracket[1])
    else:
        theta = bracket[1]
    h_taken = theta * h_try
    for _ in range(IMPACT_NEWTON_ITERATIONS):
        prepare_step(t, h_taken, coefficients, scratch)
        step(stage_rhs, t, y, f, h_taken, coefficients, K, y_new, stage, scratch, n_dynamic)
        n_rhs += n_stages
        miss = y_new[X] - delta
        if abs(miss) <= IMPACT_POSITION_TOLERANCE * max(1.0, abs(delta)) or y_new[V] <= 0.0:
            break
        h_corrected = h_taken - miss / y_new[V]
        if not (0.0 < h_corrected <= h_try):
            break
        h_taken = h_corrected
    prepare_dense(t, h_taken, coefficients, scratch)
    n_rhs += dense_output(stage_rhs, t, y, h_taken, coefficients, K, y_new, dense, stage, scratch, n_dynamic)
    return h_taken, n_rhs


@kernel_jit(inline="always")
def _restitution(y, t, coefficients, stick_velocity):
    """The impact law at x = Delta: v -> -e v (eq2.2), or sticking. Returns (v_before, v_after, stuck).

    The mass sticks when chatter has died out (the rebound is slower than stick_velocity) and the
    force at rest on the barrier presses it there.
    """
    v_before = max(y[V], 0.0)
    v_after = -coefficients[E] * v_before  # eq2.2
    stuck = -v_after < stick_velocity and force_at_barrier(t, coefficients) > 0.0
    if stuck:
        v_after = 0.0
    y[V] = v_after
    return v_before, v_after, stuck


@kernel_jit(inline="always")
def _rebound_step(h, t, v_after, coefficients):
    """The next step size after a rebound: a slow rebound against a force pushing back returns
    after about 2 |v| / a, so the step stays well inside that flight and its return is seen."""
    push = force_at_barrier(t, coefficients)
    if push > 0.0:
        return min(h, REBOUND_STEP_FRACTION * 2.0 * -v_after / push)
    return h


@kernel_jit
def _add_stuck_quadratures(y, delta, omega, t_start, t_end):
    """eq3.1, eq3.2 integrands over [t_start, t_end] with x = Delta held: in closed form."""
    y[QS_INTEGRAL] += delta * (math.cos(omega * t_start) - math.cos(omega * t_end)) / omega
    y[QC_INTEGRAL] += delta * (math.sin(omega * t_end) - math.sin(omega * t_start)) / omega
