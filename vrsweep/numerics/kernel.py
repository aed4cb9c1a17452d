"""One grid point: the integration loop of the impact oscillator with its observers.

The loop advances Runge-Kutta steps of the configured method (integration.method: rk45, the
Dormand-Prince 5(4) pair of integrator.py, or dop853, Hairer's 8(5,3) of dop853.py), stops
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

Array layouts: the state vector is state.py's; the settings vector, the per-period record and
the summary are this module's (below); the coefficient vector is model.py's.
"""

import math

import numpy as np

from vrsweep.numerics import dop853
from vrsweep.numerics.dop853 import (
    dop853_accepted_step_factor, dop853_dense, dop853_error_norm, dop853_rejected_step_factor, dop853_step,
)
from vrsweep.numerics.impact import (
    IMPACT, N_BRACKET, TURNING_POINT, UNRESOLVED, find_crossing, force_at_barrier, locate_root, release_time,
)
from vrsweep.numerics.rk45 import (
    DENSE_ORDER, DP54_C, N_DYNAMIC, N_STAGES, ORDER, accepted_step_factor, dense_value, dp54_dense, dp54_step,
    error_norm, initial_step, rejected_step_factor,
)
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.model import ALPHA, BIG_OMEGA, C, DELTA, E, G, GAMMA, MU, OMEGA, STIFFNESS
from vrsweep.results import Status
from vrsweep.numerics.state import N_STATE, N_STATE_WITH_TANGENTS, QC_INTEGRAL, QS_INTEGRAL, V, X
from vrsweep.numerics.tangent import (
    apply_saltation, collapse_tangents, renormalise_tangents, seed_tangents, tangent_derivative,
    tangents_out_of_range,
)

# --- settings vector layout (float64), filled by sweep.integration_settings ---
RTOL, ATOL, TRANSIENT_PERIODS, MEASURE_PERIODS, MAX_STEPS, MAX_IMPACTS_PER_PERIOD, \
    DIVERGENCE_BOUND, STICK_VELOCITY = range(8)
N_SETTINGS = 8
# Their config names (the config's integration section), in index order, and their defaults:
# the config schema takes its defaults of these from here (config -> numerics, never back).
SETTING_DEFAULTS = {
    "rtol": 1e-9, "atol": 1e-11, "transient_periods": 100, "measure_periods": 100,
    "max_steps": 20_000_000, "max_impacts_per_period": 100_000, "divergence_bound": 1.0e6,
    "stick_velocity": 1.0e-7,
}
SETTING_NAMES = tuple(SETTING_DEFAULTS)

# --- per-slow-period record, one row per period, transient included ---
REC_IMPACTS = 0     # impacts in the period
REC_QS = 1          # integral of x sin(omega t) over the period
REC_QC = 2          # integral of x cos(omega t) over the period
REC_X = 3           # stroboscopic x at the period's end, t = (n + 1) T
REC_V = 4           # stroboscopic v at the period's end
REC_X_MIN = 5       # smallest x in the period
REC_X_MAX = 6       # largest x in the period
REC_STUCK_TIME = 7  # time spent stuck on the barrier in the period
REC_LOG_STRETCH = 8  # log growth of the leading tangent vector over the period (NaN without tangents)
REC_LOG_AREA = 9     # log growth of the tangent parallelogram's area (both exponents' sum)
N_RECORD = 10

# --- summary of a run ---
SUM_R = 0                   # gain |Q| / c, eq3.3
SUM_QS = 1                  # eq3.1
SUM_QC = 2                  # eq3.2
SUM_Q_AMPLITUDE = 3         # |Q| = sqrt(Qs^2 + Qc^2), the amplitude comparable with theory
SUM_IMPACTS_PER_PERIOD = 4  # mean over the measurement window
SUM_STEPS = 5               # step attempts
SUM_REJECTED = 6
SUM_RHS = 7                 # right-hand-side evaluations
SUM_X_FINAL = 8
SUM_V_FINAL = 9
SUM_T_FINAL = 10
SUM_IMPACTS = 11            # all impacts, transient included
SUM_STICKS = 12             # sticking intervals
SUM_LYAPUNOV = 13           # largest Lyapunov exponent over the window, per unit time (tangent.py)
SUM_LYAPUNOV_SUM = 14       # sum of both exponents over the window, per unit time
N_SUMMARY = 15

# Largest step as a fraction of the shortest forcing period: a longer step could carry the
# mass to the barrier and back between its ends with no sign change the event test can see.
MAX_STEP_FRACTION = 1.0 / 8.0
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
def oscillator_rhs(t, h, node, c, y, coefficients, dydt, scratch):
    """x'' + gamma (x^2 - mu) x' + k x + alpha x^3 = c cos(omega t) + g cos(Omega t), at t + c h.

    eq2.1 (mu = 1, k = -omega0^2) and eq2.10 (mu = K, k = wt2, g = 0) alike; the last two
    components accumulate the integrands of eq3.1 and eq3.2. The cosines are the library's at
    every evaluation (``node`` and ``scratch`` are unused): the rk45 kernel's stages, and every
    evaluation outside a step.
    """
    time = t + c * h
    omega_t = coefficients[OMEGA] * time
    # Without the fast forcing (the effective model) Omega may be anything, even overflow Omega t.
    cos_fast = math.cos(coefficients[BIG_OMEGA] * time) if coefficients[G] != 0.0 else 0.0
    _oscillator_derivative(y, coefficients, math.cos(omega_t), math.sin(omega_t), cos_fast, dydt)


@kernel_jit(inline="always")
def _oscillator_derivative(y, coefficients, cos_slow, sin_slow, cos_fast, dydt):
    x = y[X]
    v = y[V]
    forcing = coefficients[C] * cos_slow + coefficients[G] * cos_fast
    dydt[X] = v
    dydt[V] = (forcing - coefficients[GAMMA] * (x * x - coefficients[MU]) * v
               - coefficients[STIFFNESS] * x - coefficients[ALPHA] * x * x * x)
    dydt[QS_INTEGRAL] = x * sin_slow
    dydt[QC_INTEGRAL] = x * cos_slow


@kernel_jit
def oscillator_tangent_rhs(t, h, node, c, y, coefficients, dydt, scratch):
    """oscillator_rhs and the variational equations of the tangent vectors (tangent.py)."""
    oscillator_rhs(t, h, node, c, y, coefficients, dydt, scratch)
    tangent_derivative(y, coefficients, dydt)


@kernel_jit
def no_scratch(h_max, nodes):
    return np.empty(0)


@kernel_jit
def no_preparation(t, h, coefficients, scratch):
    return


# --- the forcing's phases rotated to the stage times (the dop853 kernel) ------------------------
# At a stage time t + c h, cos(a + d) = cos a cos d - sin a sin d and sin(a + d) = sin a cos d
# + cos a sin d, with a = omega t (Omega t) at the step's start and d = omega c h (Omega c h).
# prepare_rotations computes the phases at t (library calls once per step) and the rotations of
# every node for the step size h; oscillator_rhs_rotated then costs a few multiplications where
# oscillator_rhs makes three library calls. Step sizes are rounded down to the grid
# h_max 2^(-k / STEP_LEVELS_PER_OCTAVE) (grid_step), whose rotations are tabulated once per point.
STEP_LEVELS_PER_OCTAVE = 16
N_STEP_LEVELS = 128
MAX_NODES = 16
ROTATION_VALUES = 4 * MAX_NODES  # cos, sin of omega c h and of Omega c h, per node
# The phases at the next step's start are the last step's rotated by its full step (a node c = 1),
# recomputed by the library every RESYNC_STEPS steps so that rounding cannot accumulate.
RESYNC_STEPS = 16
# scratch layout
PHASE_TIME, PHASE_STEP, COS_SLOW, SIN_SLOW, COS_FAST, SIN_FAST, FULL_STEP_NODE, ROTATED_STEPS = range(8)
ROTATION = 8                                         # the current step's rotations, per node
NODES = ROTATION + ROTATION_VALUES                   # the method's nodes c
STEP_GRID = NODES + MAX_NODES                        # the grid of step sizes
LEVEL_READY = STEP_GRID + N_STEP_LEVELS              # 1 once a grid step's rotations are tabulated
LEVEL_ROTATIONS = LEVEL_READY + N_STEP_LEVELS        # N_STEP_LEVELS x ROTATION_VALUES
N_ROTATION_SCRATCH = LEVEL_ROTATIONS + N_STEP_LEVELS * ROTATION_VALUES


@kernel_jit
def rotation_scratch(h_max, nodes):
    """oscillator_rhs_rotated's scratch for steps up to h_max of a method with these nodes."""
    scratch = np.empty(N_ROTATION_SCRATCH)  # 68 kB: only what is read before it is written is set
    scratch[:ROTATION] = 0.0
    scratch[PHASE_TIME] = np.nan
    scratch[PHASE_STEP] = np.nan
    scratch[NODES:STEP_GRID] = 0.0
    scratch[LEVEL_READY:LEVEL_ROTATIONS] = 0.0
    scratch[FULL_STEP_NODE] = -1.0
    for node in range(nodes.shape[0]):
        scratch[NODES + node] = nodes[node]
        if nodes[node] == 1.0 and scratch[FULL_STEP_NODE] < 0.0:
            scratch[FULL_STEP_NODE] = node
    for k in range(N_STEP_LEVELS):
        scratch[STEP_GRID + k] = h_max * 2.0 ** (-k / STEP_LEVELS_PER_OCTAVE)
    return scratch


@kernel_jit
def grid_step(h, scratch):
    """The largest step size of the grid that is <= h; h itself below the grid (or if NaN)."""
    if not (h >= scratch[STEP_GRID + N_STEP_LEVELS - 1]):
        return h
    k = int(math.ceil(STEP_LEVELS_PER_OCTAVE * math.log2(scratch[STEP_GRID] / h)))
    k = min(max(k, 0), N_STEP_LEVELS - 1)
    while k > 0 and scratch[STEP_GRID + k - 1] <= h:  # log2's rounding: take the largest <= h
        k -= 1
    while k < N_STEP_LEVELS - 1 and scratch[STEP_GRID + k] > h:
        k += 1
    return scratch[STEP_GRID + k]


@kernel_jit
def _grid_level(h, scratch):
    """k with h equal to the grid's k-th step size, or -1."""
    if not (scratch[STEP_GRID + N_STEP_LEVELS - 1] <= h <= scratch[STEP_GRID]):
        return -1
    k = int(round(STEP_LEVELS_PER_OCTAVE * math.log2(scratch[STEP_GRID] / h)))
    for j in (k, k - 1, k + 1):
        if 0 <= j < N_STEP_LEVELS and scratch[STEP_GRID + j] == h:
            return j
    return -1


@kernel_jit
def _rotations(h, coefficients, scratch, out):
    """cos and sin of omega c h and Omega c h for every node c, into scratch[out:out + 64]."""
    omega = coefficients[OMEGA]
    big_omega = coefficients[BIG_OMEGA]
    fast = coefficients[G] != 0.0  # without the fast forcing Omega may be anything: leave it out
    for node in range(MAX_NODES):
        dt = scratch[NODES + node] * h
        scratch[out + 4 * node] = math.cos(omega * dt)
        scratch[out + 4 * node + 1] = math.sin(omega * dt)
        scratch[out + 4 * node + 2] = math.cos(big_omega * dt) if fast else 0.0
        scratch[out + 4 * node + 3] = math.sin(big_omega * dt) if fast else 0.0


@kernel_jit
def prepare_rotations(t, h, coefficients, scratch):
    """Make scratch hold the phases at t and the rotations for a step of size h."""
    if t != scratch[PHASE_TIME]:
        full = int(scratch[FULL_STEP_NODE])
        if (t == scratch[PHASE_TIME] + scratch[PHASE_STEP] and full >= 0
                and scratch[ROTATED_STEPS] < RESYNC_STEPS):
            # The step just taken ended at t: rotate its start's phases by the whole step.
            r = ROTATION + 4 * full
            cos_slow = scratch[COS_SLOW] * scratch[r] - scratch[SIN_SLOW] * scratch[r + 1]
            sin_slow = scratch[SIN_SLOW] * scratch[r] + scratch[COS_SLOW] * scratch[r + 1]
            cos_fast = scratch[COS_FAST] * scratch[r + 2] - scratch[SIN_FAST] * scratch[r + 3]
            sin_fast = scratch[SIN_FAST] * scratch[r + 2] + scratch[COS_FAST] * scratch[r + 3]
            scratch[COS_SLOW] = cos_slow
            scratch[SIN_SLOW] = sin_slow
            scratch[COS_FAST] = cos_fast
            scratch[SIN_FAST] = sin_fast
            scratch[ROTATED_STEPS] += 1.0
        else:
            omega_t = coefficients[OMEGA] * t
            scratch[COS_SLOW] = math.cos(omega_t)
            scratch[SIN_SLOW] = math.sin(omega_t)
            if coefficients[G] != 0.0:
                scratch[COS_FAST] = math.cos(coefficients[BIG_OMEGA] * t)
                scratch[SIN_FAST] = math.sin(coefficients[BIG_OMEGA] * t)
            scratch[ROTATED_STEPS] = 0.0
        scratch[PHASE_TIME] = t
    if h != scratch[PHASE_STEP]:
        level = _grid_level(h, scratch)
        if level < 0:  # a step clipped to a period's end, or to an impact
            _rotations(h, coefficients, scratch, ROTATION)
        else:
            table = LEVEL_ROTATIONS + level * ROTATION_VALUES
            if scratch[LEVEL_READY + level] == 0.0:
                _rotations(h, coefficients, scratch, table)
                scratch[LEVEL_READY + level] = 1.0
            scratch[ROTATION:ROTATION + ROTATION_VALUES] = scratch[table:table + ROTATION_VALUES]
        scratch[PHASE_STEP] = h


@kernel_jit
def oscillator_rhs_rotated(t, h, node, c, y, coefficients, dydt, scratch):
    """oscillator_rhs at a stage node of a step prepared by prepare_rotations (t and h unused).

    No branch and no library call: with either, an evaluation cost as much as oscillator_rhs.
    """
    r = ROTATION + 4 * node
    cos_d = scratch[r]
    sin_d = scratch[r + 1]
    _oscillator_derivative(y, coefficients,
                           scratch[COS_SLOW] * cos_d - scratch[SIN_SLOW] * sin_d,
                           scratch[SIN_SLOW] * cos_d + scratch[COS_SLOW] * sin_d,
                           scratch[COS_FAST] * scratch[r + 2] - scratch[SIN_FAST] * scratch[r + 3],
                           dydt)


@kernel_jit
def oscillator_tangent_rhs_rotated(t, h, node, c, y, coefficients, dydt, scratch):
    """oscillator_rhs_rotated and the variational equations of the tangent vectors (tangent.py)."""
    oscillator_rhs_rotated(t, h, node, c, y, coefficients, dydt, scratch)
    tangent_derivative(y, coefficients, dydt)


@kernel_jit
def _smallest_step(t, slow_period):
    """A step this short no longer moves t by more than a few units of its last place."""
    return 4.0 * 2.2e-16 * max(abs(t), slow_period)


@kernel_jit
def _emit_samples(sample_times, samples, next_sample, t0, h, y, dense, t_end):
    """Write the dense output at every sample time in (.., t_end] of the step [t0, t0 + h]."""
    while next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_end:
        theta = (sample_times[next_sample] - t0) / h if h > 0.0 else 1.0
        samples[next_sample, 0] = dense_value(dense, y, h, theta, X)
        samples[next_sample, 1] = dense_value(dense, y, h, theta, V)
        next_sample += 1
    return next_sample


@kernel_jit
def _update_extremes(record, dense, y, y_new, h, theta_turn):
    """Fold the step's end and any turning point of x inside it into the period's min/max.

    theta_turn: the turning point if find_crossing located it on this dense output, else NaN.
    """
    x_end = y_new[X]
    if x_end < record[REC_X_MIN]:
        record[REC_X_MIN] = x_end
    if x_end > record[REC_X_MAX]:
        record[REC_X_MAX] = x_end
    if y[V] * y_new[V] < 0.0:
        theta = theta_turn if theta_turn == theta_turn else locate_root(dense, y, h, V, 0.0, 0.0, 1.0)
        x_turn = dense_value(dense, y, h, theta, X)
        if x_turn < record[REC_X_MIN]:
            record[REC_X_MIN] = x_turn
        if x_turn > record[REC_X_MAX]:
            record[REC_X_MAX] = x_turn


@kernel_jit
def _start_period(record, x, tangents):
    record[REC_IMPACTS] = 0.0
    record[REC_QS] = 0.0
    record[REC_QC] = 0.0
    record[REC_X] = np.nan
    record[REC_V] = np.nan
    record[REC_X_MIN] = x
    record[REC_X_MAX] = x
    record[REC_STUCK_TIME] = 0.0
    # Summed over the period's renormalisations (tangent.py); NaN in a run without tangent vectors.
    record[REC_LOG_STRETCH] = 0.0 if tangents else np.nan
    record[REC_LOG_AREA] = 0.0 if tangents else np.nan


@kernel_jit
def integrate_rk45(coefficients, initial_state, settings, period_records, summary,
                   sample_times, samples, impact_log, stick_log):
    """Integrate one point over transient + measurement slow periods. Returns a Status code.

    coefficients    (N_COEFFICIENTS,)        model.kernel_coefficients
    initial_state   (2,)                      x(0), v(0)
    settings        (N_SETTINGS,)            layout above
    period_records  (n_periods, N_RECORD)    filled for every completed period
    summary         (N_SUMMARY,)             filled at the end; R, Qs, Qc NaN unless status OK
    sample_times    (n_samples,)             sorted times for dense samples (may be empty)
    samples         (n_samples, 2)           x, v at sample_times
    impact_log      (n_impact_log, 3)        t, v before, v after, for the first impacts
    stick_log       (n_stick_log, 2)         start and end of the first sticking intervals

    With Dormand-Prince 5(4) steps (integration.method: rk45, integrator.py).
    The library's cosines at every evaluation, so results are those of earlier versions bit for bit.
    """
    return _integrate(oscillator_rhs, oscillator_rhs, no_preparation, no_scratch, False, DP54_C,
                      dp54_step, error_norm, dp54_dense, accepted_step_factor, rejected_step_factor, False,
                      ORDER, N_STAGES, False, N_DYNAMIC,
                      np.empty((N_STAGES + 1, N_STATE)), np.empty((N_STATE, DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log)


@kernel_jit
def integrate_dop853(coefficients, initial_state, settings, period_records, summary,
                     sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with DOP853 steps (integration.method: dop853, dop853.py).

    Its stages evaluate the forcing by rotating the phases of the step's start (prepare_rotations,
    oscillator_rhs_rotated), on step sizes rounded down to their grid; other evaluations call the
    library (oscillator_rhs).
    """
    return _integrate(oscillator_rhs, oscillator_rhs_rotated, prepare_rotations, rotation_scratch, True,
                      dop853.C_STAGES, dop853_step, dop853_error_norm, dop853_dense, dop853_accepted_step_factor,
                      dop853_rejected_step_factor, True, dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES,
                      False, N_DYNAMIC,
                      np.empty((dop853.N_STAGES_EXTENDED, N_STATE)), np.empty((N_STATE, dop853.DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log)


@kernel_jit
def integrate_rk45_lyapunov(coefficients, initial_state, settings, period_records, summary,
                            sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with the tangent vectors (integration.lyapunov: true; tangent.py).

    The same steps, impacts and records as integrate_rk45 (the tangent vectors take no part in
    error control), plus REC_LOG_STRETCH, REC_LOG_AREA per period and SUM_LYAPUNOV, SUM_LYAPUNOV_SUM.
    """
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs, no_preparation, no_scratch, False, DP54_C,
                      dp54_step, error_norm, dp54_dense, accepted_step_factor, rejected_step_factor, False,
                      ORDER, N_STAGES, True, N_STATE_WITH_TANGENTS,
                      np.empty((N_STAGES + 1, N_STATE_WITH_TANGENTS)),
                      np.empty((N_STATE_WITH_TANGENTS, DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log)


@kernel_jit
def integrate_dop853_lyapunov(coefficients, initial_state, settings, period_records, summary,
                              sample_times, samples, impact_log, stick_log):
    """integrate_dop853 with the tangent vectors (integration.lyapunov: true; tangent.py)."""
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs_rotated, prepare_rotations,
                      rotation_scratch, True, dop853.C_STAGES, dop853_step, dop853_error_norm, dop853_dense,
                      dop853_accepted_step_factor, dop853_rejected_step_factor, True,
                      dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES, True, N_STATE_WITH_TANGENTS,
                      np.empty((dop853.N_STAGES_EXTENDED, N_STATE_WITH_TANGENTS)),
                      np.empty((N_STATE_WITH_TANGENTS, dop853.DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log)


# integration.method -> the kernel. Each is compiled (or loaded from the cache) on its first call,
# so a run compiles only the method it uses.
INTEGRATORS = {"rk45": integrate_rk45, "dop853": integrate_dop853}
METHODS = tuple(INTEGRATORS)
DEFAULT_METHOD = "rk45"  # the config schema's default of integration.method
# The same with the tangent vectors (integration.lyapunov: true).
LYAPUNOV_INTEGRATORS = {"rk45": integrate_rk45_lyapunov, "dop853": integrate_dop853_lyapunov}


def integrator(method, lyapunov=False):
    """The kernel for an integration method, with or without the tangent vectors."""
    return (LYAPUNOV_INTEGRATORS if lyapunov else INTEGRATORS)[method]


# Inlined into each method's kernel above, so that the method's functions become direct calls
# (a function passed as a runtime value would be a "dynamic global" and could not be cached).
@kernel_jit(inline="always")
def _integrate(rhs, stage_rhs, prepare_step, make_scratch, grid_steps, nodes, step, step_error, dense_output,
               accepted_factor, rejected_factor, hold_after_reject, initial_order, n_stages, tangents, n_dynamic,
               K, dense, coefficients, initial_state, settings, period_records, summary, sample_times, samples,
               impact_log, stick_log):
    """The integration loop of every method; see integrate_rk45 for the arguments.

    rhs(t, h, node, c, y, coefficients, dydt, scratch) is the oscillator at t + c h; stage_rhs the
    same at a step's stages, after prepare_step(t, h, coefficients, scratch), with scratch =
    make_scratch(h_max, nodes); grid_steps rounds each step size down to grid_step's grid.
    step(stage_rhs, t, y, f, h, coefficients, K, y_new, stage, scratch, n_dynamic) fills K
    (K[n_stages] = f(t + h, y_new)) and y_new; step_error(K, h, y, y_new, rtol, atol) is the scaled
    error norm; dense_output(stage_rhs, t, y, h, coefficients, K, y_new, dense, stage, scratch,
    n_dynamic) fills dense and returns its extra RHS count. tangents: the state carries the
    tangent vectors (state.py) and the right-hand sides integrate them; n_dynamic is the number of
    state components the right-hand sides read. K (rows, n_state) and dense (n_state, order) are
    the method's work arrays, their width the state's size.

    Each pass of the loop is one of: hold the mass on the barrier up to its release or the period's
    end; or attempt a step, and if it is accepted, resolve an impact inside it (reach it with an
    exact step), feed the observers, and apply the restitution law or start sticking. A pass that
    reaches the period's end closes the period.
    """
    rtol = settings[RTOL]
    atol = settings[ATOL]
    n_transient = int(settings[TRANSIENT_PERIODS])
    n_periods = n_transient + int(settings[MEASURE_PERIODS])
    max_steps = settings[MAX_STEPS]
    max_impacts_per_period = settings[MAX_IMPACTS_PER_PERIOD]
    divergence_bound = settings[DIVERGENCE_BOUND]
    stick_velocity = settings[STICK_VELOCITY]
    delta = coefficients[DELTA]
    restitution = coefficients[E]

    slow_period = 2.0 * math.pi / coefficients[OMEGA]
    shortest_period = slow_period
    if coefficients[G] != 0.0:
        shortest_period = min(shortest_period, 2.0 * math.pi / coefficients[BIG_OMEGA])
    h_max = MAX_STEP_FRACTION * shortest_period
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
    _start_period(period_records[0], y[X], tangents)
    next_sample = _emit_state(sample_times, samples, 0, 0.0, y[X], y[V])

    while True:
        record = period_records[period]
        if stuck:
            # --- held at (Delta, 0) until the force lets go or the period ends ---
            t_release, scans = release_time(t, t_boundary, coefficients, stick_scan_step, max_steps - n_scans)
            n_scans += scans
            if t_release != t_release:
                status = Status.MAX_STEPS  # the force scan has a budget of max_steps intervals too
                break
            t_end = min(t_release, t_boundary)
            _add_stuck_quadratures(y, delta, coefficients[OMEGA], t, t_end)
            next_sample = _emit_state(sample_times, samples, next_sample, t_end, delta, 0.0)
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
            if y_new[X] >= delta or y[X] >= delta or (y[V] > 0.0 and y_new[V] < 0.0):
                prepare_step(t, h_try, coefficients, scratch)
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
                h_taken, spent = _reach_impact(stage_rhs, prepare_step, step, dense_output, n_stages, n_dynamic,
                                               t, y, f, h_try, delta, bracket, coefficients, K, y_new, dense,
                                               stage, scratch)
                n_rhs += spent
                dense_ready = True

            # --- observers: samples and the period's extremes, on the step's dense output ---
            t_new = t_boundary if (clipped and not impact) else t + h_taken
            if next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_new:
                if not dense_ready:
                    prepare_step(t, h_taken, coefficients, scratch)
                    n_rhs += dense_output(stage_rhs, t, y, h_taken, coefficients, K, y_new, dense, stage, scratch,
                                          n_dynamic)
                    dense_ready = True
                next_sample = _emit_samples(sample_times, samples, next_sample, t, h_taken, y, dense, t_new)
            if y[V] * y_new[V] < 0.0 and not dense_ready:
                prepare_step(t, h_taken, coefficients, scratch)
                n_rhs += dense_output(stage_rhs, t, y, h_taken, coefficients, K, y_new, dense, stage, scratch,
                                      n_dynamic)
            _update_extremes(record, dense, y, y_new, h_taken, theta_turn)

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
                _log_impact(impact_log, n_impacts, t, v_before, v_after)
                if stuck:
                    n_sticks = _log_stick_start(stick_log, n_sticks, t)
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

            if tangents and tangents_out_of_range(y):
                # A strongly damped or stretched period would underflow or overflow them before
                # its end: renormalise now, the period's record sums the logs.
                _add_tangent_growth(record, y)
                tangent_derivative(y, coefficients, f)

            if not (math.isfinite(y[X]) and math.isfinite(y[V])):
                status = Status.NON_FINITE
                break
            if abs(y[X]) > divergence_bound or abs(y[V]) > divergence_bound:
                status = Status.DIVERGED
                break

        if t >= t_boundary:
            _close_period(record, y, f, coefficients, tangents, stuck)
            period += 1
            if period == n_periods:
                break
            t_boundary = (period + 1) * slow_period
            _start_period(period_records[period], y[X], tangents)

    if stuck and n_sticks - 1 < stick_log.shape[0]:
        stick_log[n_sticks - 1, 1] = t
    status = _summarize(period_records, n_transient, n_periods, slow_period, coefficients[C], status, summary)
    summary[SUM_STEPS] = n_steps
    summary[SUM_REJECTED] = n_rejected
    summary[SUM_RHS] = n_rhs
    summary[SUM_X_FINAL] = y[X]
    summary[SUM_V_FINAL] = y[V]
    summary[SUM_T_FINAL] = t
    summary[SUM_IMPACTS] = n_impacts
    summary[SUM_STICKS] = n_sticks
    return status


@kernel_jit(inline="always")
def _reach_impact(stage_rhs, prepare_step, step, dense_output, n_stages, n_dynamic, t, y, f, h_try, delta,
                  bracket, coefficients, K, y_new, dense, stage, scratch):
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
    prepare_step(t, h_taken, coefficients, scratch)
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


@kernel_jit(inline="always")
def _log_impact(impact_log, n_impacts, t, v_before, v_after):
    """The n_impacts-th impact into the log, while it has room."""
    if n_impacts - 1 < impact_log.shape[0]:
        impact_log[n_impacts - 1, 0] = t
        impact_log[n_impacts - 1, 1] = v_before
        impact_log[n_impacts - 1, 2] = v_after


@kernel_jit(inline="always")
def _log_stick_start(stick_log, n_sticks, t):
    """A sticking interval starting at t into the log (its end is written at release). Returns the count."""
    if n_sticks < stick_log.shape[0]:
        stick_log[n_sticks, 0] = t
        stick_log[n_sticks, 1] = np.nan
    return n_sticks + 1


@kernel_jit(inline="always")
def _close_period(record, y, f, coefficients, tangents, stuck):
    """At t = nT: record the period's quadratures and stroboscopic state, reset the quadratures,
    and renormalise the tangent vectors (tangent.py), recording their growth."""
    record[REC_QS] = y[QS_INTEGRAL]
    record[REC_QC] = y[QC_INTEGRAL]
    record[REC_X] = y[X]
    record[REC_V] = y[V]
    y[QS_INTEGRAL] = 0.0
    y[QC_INTEGRAL] = 0.0
    if tangents:
        _add_tangent_growth(record, y)
        if stuck:
            collapse_tangents(y)  # still on the barrier: the next period starts from zero
        else:
            tangent_derivative(y, coefficients, f)  # f of the renormalised vectors


@kernel_jit(inline="always")
def _add_tangent_growth(record, y):
    """Renormalise the tangent vectors and add their log growth to the period's record."""
    log_stretch, log_area = renormalise_tangents(y)
    record[REC_LOG_STRETCH] += log_stretch
    record[REC_LOG_AREA] += log_area


@kernel_jit
def _add_stuck_quadratures(y, delta, omega, t_start, t_end):
    """eq3.1, eq3.2 integrands over [t_start, t_end] with x = Delta held: in closed form."""
    y[QS_INTEGRAL] += delta * (math.cos(omega * t_start) - math.cos(omega * t_end)) / omega
    y[QC_INTEGRAL] += delta * (math.sin(omega * t_end) - math.sin(omega * t_start)) / omega


@kernel_jit
def _emit_state(sample_times, samples, next_sample, t_end, x, v):
    """The state (x, v), constant up to t_end (a start, or a stick), at every sample time <= t_end."""
    while next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_end:
        samples[next_sample, 0] = x
        samples[next_sample, 1] = v
        next_sample += 1
    return next_sample


@kernel_jit
def _summarize(period_records, n_transient, n_periods, slow_period, c, status, summary):
    """eq3.1-eq3.3 over the measurement window, and the mean impacts per slow period.

    Returns the status, turned into NON_FINITE if a result overflows (e.g. a subnormal c), so a
    point marked ok holds finite numbers. Only c = 0 exactly (no drive, which configs refuse)
    leaves the gain R undefined: NaN, with the trajectory itself ok.
    """
    if status == Status.OK:
        status = _measure(period_records, n_transient, n_periods, slow_period, c, summary)
    if status != Status.OK:
        for k in (SUM_R, SUM_QS, SUM_QC, SUM_Q_AMPLITUDE, SUM_IMPACTS_PER_PERIOD, SUM_LYAPUNOV, SUM_LYAPUNOV_SUM):
            summary[k] = np.nan
    return status


@kernel_jit
def _measure(period_records, n_transient, n_periods, slow_period, c, summary):
    n_measured = n_periods - n_transient
    sin_integral = 0.0
    cos_integral = 0.0
    impacts = 0.0
    for k in range(n_transient, n_periods):
        sin_integral += period_records[k, REC_QS]
        cos_integral += period_records[k, REC_QC]
        impacts += period_records[k, REC_IMPACTS]
    window = n_measured * slow_period
    qs = 2.0 * sin_integral / window  # eq3.1
    qc = 2.0 * cos_integral / window  # eq3.2
    amplitude = math.sqrt(qs * qs + qc * qc)
    summary[SUM_QS] = qs
    summary[SUM_QC] = qc
    summary[SUM_Q_AMPLITUDE] = amplitude
    summary[SUM_IMPACTS_PER_PERIOD] = impacts / n_measured
    _lyapunov_exponents(period_records, n_transient, n_periods, window, summary)
    if c == 0.0:
        summary[SUM_R] = np.nan  # eq3.3 is a gain: undefined without a drive
        return Status.OK
    summary[SUM_R] = amplitude / c  # eq3.3
    for k in (SUM_R, SUM_QS, SUM_QC):
        if not math.isfinite(summary[k]):
            return Status.NON_FINITE
    return Status.OK


@kernel_jit
def _lyapunov_exponents(period_records, n_transient, n_periods, window, summary):
    """The largest exponent and the sum of both: the window's log growths per unit time.

    NaN without tangent vectors (their records are NaN); -inf when the mass stuck in the window
    (tangent.py: the tangent map of a sticking interval is zero).
    """
    stretch = 0.0
    area = 0.0
    for k in range(n_transient, n_periods):
        stretch += period_records[k, REC_LOG_STRETCH]
        area += period_records[k, REC_LOG_AREA]
    summary[SUM_LYAPUNOV] = stretch / window
    summary[SUM_LYAPUNOV_SUM] = area / window
