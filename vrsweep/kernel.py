"""One grid point: the integration loop of the impact oscillator with its observers.

The loop advances Runge-Kutta steps of the configured method (integration.method: rk45, the
Dormand-Prince 5(4) pair of integrator.py, or dop853, Hairer's 8(5,3) of dop853.py), stops every step at the slow-period
boundaries t = nT (T = 2 pi / omega) so that every period is measured exactly, locates
impacts on the dense output (impact.py), applies the restitution law (eq2.2), and holds the
mass on the barrier while chatter has died out and the force presses it there (sticking).

Observers are plain arrays the caller passes in, so one kernel serves a sweep (which only
needs the per-period records) and a trajectory (samples, impact and sticking logs): an
observer with zero length costs nothing. The kernel knows nothing of files or configs.

Fourier sums (eq3.1, eq3.2) are quadrature states integrated with the motion, so they are
as accurate as x itself; while stuck they are added in closed form.
"""

import math

import numpy as np

from vrsweep import dop853
from vrsweep.dop853 import (
    dop853_accepted_step_factor, dop853_dense, dop853_error_norm, dop853_rejected_step_factor, dop853_step,
)
from vrsweep.impact import (
    IMPACT, UNRESOLVED, X, V, find_crossing, force_at_barrier, locate_root, release_time,
)
from vrsweep.integrator import (
    DENSE_ORDER, N_STAGES, ORDER, accepted_step_factor, dense_value, dp54_dense, dp54_step, error_norm,
    initial_step, rejected_step_factor,
)
from vrsweep.jit import kernel_jit
from vrsweep.model import ALPHA, BIG_OMEGA, C, DELTA, E, G, GAMMA, MU, OMEGA, STIFFNESS
from vrsweep.results import Status

# --- state: position, velocity, and the two Fourier quadratures of the current slow period ---
N_STATE = 4
QS_INTEGRAL, QC_INTEGRAL = 2, 3

# --- settings vector layout (float64), filled by sweep.integration_settings ---
RTOL, ATOL, TRANSIENT_PERIODS, MEASURE_PERIODS, MAX_STEPS, MAX_IMPACTS_PER_PERIOD, \
    DIVERGENCE_BOUND, STICK_VELOCITY = range(8)
N_SETTINGS = 8

# --- per-slow-period record, one row per period, transient included ---
REC_IMPACTS = 0     # impacts in the period
REC_QS = 1          # integral of x sin(omega t) over the period
REC_QC = 2          # integral of x cos(omega t) over the period
REC_X = 3           # stroboscopic x at the period's end, t = (n + 1) T
REC_V = 4           # stroboscopic v at the period's end
REC_X_MIN = 5       # smallest x in the period
REC_X_MAX = 6       # largest x in the period
REC_STUCK_TIME = 7  # time spent stuck on the barrier in the period
N_RECORD = 8

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
N_SUMMARY = 13

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
def oscillator_rhs(t, y, coefficients, dydt):
    """x'' + gamma (x^2 - mu) x' + k x + alpha x^3 = c cos(omega t) + g cos(Omega t).

    eq2.1 (mu = 1, k = -omega0^2) and eq2.10 (mu = K, k = wt2, g = 0) alike; the last two
    components accumulate the integrands of eq3.1 and eq3.2.
    """
    x = y[X]
    v = y[V]
    omega_t = coefficients[OMEGA] * t
    forcing = coefficients[C] * math.cos(omega_t) + coefficients[G] * math.cos(coefficients[BIG_OMEGA] * t)
    dydt[X] = v
    dydt[V] = (forcing - coefficients[GAMMA] * (x * x - coefficients[MU]) * v
               - coefficients[STIFFNESS] * x - coefficients[ALPHA] * x * x * x)
    dydt[QS_INTEGRAL] = x * math.sin(omega_t)
    dydt[QC_INTEGRAL] = x * math.cos(omega_t)


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
def _update_extremes(record, dense, y, y_new, h):
    """Fold the step's end and any turning point of x inside it into the period's min/max."""
    x_end = y_new[X]
    if x_end < record[REC_X_MIN]:
        record[REC_X_MIN] = x_end
    if x_end > record[REC_X_MAX]:
        record[REC_X_MAX] = x_end
    if y[V] * y_new[V] < 0.0:
        theta = locate_root(dense, y, h, V, 0.0, 0.0, 1.0)
        x_turn = dense_value(dense, y, h, theta, X)
        if x_turn < record[REC_X_MIN]:
            record[REC_X_MIN] = x_turn
        if x_turn > record[REC_X_MAX]:
            record[REC_X_MAX] = x_turn


@kernel_jit
def _start_period(record, x):
    record[REC_IMPACTS] = 0.0
    record[REC_QS] = 0.0
    record[REC_QC] = 0.0
    record[REC_X] = np.nan
    record[REC_V] = np.nan
    record[REC_X_MIN] = x
    record[REC_X_MAX] = x
    record[REC_STUCK_TIME] = 0.0


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
    """
    return _integrate(dp54_step, error_norm, dp54_dense, accepted_step_factor, rejected_step_factor, False,
                      ORDER, N_STAGES, np.empty((N_STAGES + 1, N_STATE)), np.empty((N_STATE, DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log)


@kernel_jit
def integrate_dop853(coefficients, initial_state, settings, period_records, summary,
                     sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with DOP853 steps (integration.method: dop853, dop853.py)."""
    return _integrate(dop853_step, dop853_error_norm, dop853_dense, dop853_accepted_step_factor,
                      dop853_rejected_step_factor, True, dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES,
                      np.empty((dop853.N_STAGES_EXTENDED, N_STATE)), np.empty((N_STATE, dop853.DENSE_ORDER)),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log)


# integration.method -> the kernel. Each is compiled (or loaded from the cache) on its first call,
# so a run compiles only the method it uses.
INTEGRATORS = {"rk45": integrate_rk45, "dop853": integrate_dop853}
METHODS = tuple(INTEGRATORS)


# Inlined into each method's kernel above, so that the method's functions become direct calls
# (a function passed as a runtime value would be a "dynamic global" and could not be cached).
@kernel_jit(inline="always")
def _integrate(step, step_error, dense_output, accepted_factor, rejected_factor, hold_after_reject,
               initial_order, n_stages, K, dense, coefficients, initial_state, settings, period_records, summary,
               sample_times, samples, impact_log, stick_log):
    """The integration loop of every method; see integrate_rk45 for the arguments.

    step(rhs, t, y, f, h, coefficients, K, y_new, stage) fills K (K[n_stages] = f(t + h, y_new))
    and y_new; step_error(K, h, y, y_new, rtol, atol) is the scaled error norm; dense_output(rhs,
    t, y, h, coefficients, K, y_new, dense, stage) fills dense and returns its extra RHS count.
    """
    rhs = oscillator_rhs
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
    omega = coefficients[OMEGA]

    slow_period = 2.0 * math.pi / omega
    shortest_period = slow_period
    if coefficients[G] != 0.0:
        shortest_period = min(shortest_period, 2.0 * math.pi / coefficients[BIG_OMEGA])
    h_max = MAX_STEP_FRACTION * shortest_period
    stick_scan_step = STICK_SCAN_FRACTION * shortest_period

    y = np.zeros(N_STATE)
    y_new = np.empty(N_STATE)
    stage = np.empty(N_STATE)
    f = np.empty(N_STATE)
    bracket = np.empty(2)

    y[X] = initial_state[0]
    y[V] = initial_state[1]
    t = 0.0
    rhs(t, y, coefficients, f)
    n_rhs = 1
    h = initial_step(rhs, t, y, f, coefficients, rtol, atol, h_max, initial_order)
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
    _start_period(period_records[0], y[X])
    next_sample = 0
    while next_sample < sample_times.shape[0] and sample_times[next_sample] <= 0.0:
        samples[next_sample, 0] = y[X]
        samples[next_sample, 1] = y[V]
        next_sample += 1

    while True:
        record = period_records[period]
        if stuck:
            # Held at (Delta, 0) until the force lets go or the period ends.
            t_release, scans = release_time(t, t_boundary, coefficients, stick_scan_step, max_steps - n_scans)
            n_scans += scans
            if t_release != t_release:
                status = Status.MAX_STEPS  # the force scan has a budget of max_steps intervals too
                break
            t_end = min(t_release, t_boundary)
            y[QS_INTEGRAL] += delta * (math.cos(omega * t) - math.cos(omega * t_end)) / omega
            y[QC_INTEGRAL] += delta * (math.sin(omega * t_end) - math.sin(omega * t)) / omega
            while next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_end:
                samples[next_sample, 0] = delta
                samples[next_sample, 1] = 0.0
                next_sample += 1
            record[REC_STUCK_TIME] += t_end - t
            t = t_end
            if t_release <= t_boundary:
                stuck = False
                if n_sticks - 1 < stick_log.shape[0]:
                    stick_log[n_sticks - 1, 1] = t
                rhs(t, y, coefficients, f)
                n_rhs += 1
                err_previous = 1.0
        else:
            if n_steps >= max_steps:
                status = Status.MAX_STEPS
                break
            if not (h > _smallest_step(t, slow_period)):
                # An overflowing start (g = 1e200: the first step estimate is 0 or NaN) would
                # otherwise take zero-length steps up to the step cap.
                status = Status.STEP_TOO_SMALL if h == h else Status.NON_FINITE
                break
            h_try = min(h, h_max)
            clipped = False
            if t + 1.01 * h_try >= t_boundary:  # land on the boundary, no sliver step after it
                h_try = t_boundary - t
                clipped = True
            step(rhs, t, y, f, h_try, coefficients, K, y_new, stage)
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

            impact = False
            dense_ready = False
            if y_new[X] >= delta or y[X] >= delta or (y[V] > 0.0 and y_new[V] < 0.0):
                n_rhs += dense_output(rhs, t, y, h_try, coefficients, K, y_new, dense, stage)
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
            h_taken = h_try
            if impact:
                # Locate on the dense output, then reach the impact with an exact step
                # (the step's order, not the interpolant's), Newton-corrected onto Delta.
                if bracket[0] < bracket[1]:
                    theta = locate_root(dense, y, h_try, X, delta, bracket[0], bracket[1])
                else:
                    theta = bracket[1]
                h_taken = theta * h_try
                for _ in range(IMPACT_NEWTON_ITERATIONS):
                    step(rhs, t, y, f, h_taken, coefficients, K, y_new, stage)
                    n_rhs += n_stages
                    miss = y_new[X] - delta
                    if abs(miss) <= IMPACT_POSITION_TOLERANCE * max(1.0, abs(delta)) or y_new[V] <= 0.0:
                        break
                    h_corrected = h_taken - miss / y_new[V]
                    if not (0.0 < h_corrected <= h_try):
                        break
                    h_taken = h_corrected
                n_rhs += dense_output(rhs, t, y, h_taken, coefficients, K, y_new, dense, stage)
                dense_ready = True

            t_new = t_boundary if (clipped and not impact) else t + h_taken
            if next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_new:
                if not dense_ready:
                    n_rhs += dense_output(rhs, t, y, h_taken, coefficients, K, y_new, dense, stage)
                    dense_ready = True
                next_sample = _emit_samples(sample_times, samples, next_sample, t, h_taken, y, dense, t_new)
            if y[V] * y_new[V] < 0.0 and not dense_ready:
                n_rhs += dense_output(rhs, t, y, h_taken, coefficients, K, y_new, dense, stage)
            _update_extremes(record, dense, y, y_new, h_taken)

            t = t_new
            for j in range(N_STATE):
                y[j] = y_new[j]
                f[j] = K[n_stages, j]

            if impact:
                v_before = max(y[V], 0.0)
                y[X] = delta
                n_impacts += 1
                record[REC_IMPACTS] += 1.0
                record[REC_X_MAX] = delta
                if record[REC_IMPACTS] > max_impacts_per_period:
                    status = Status.CHATTER_LIMIT
                    break
                v_after = -restitution * v_before  # eq2.2
                if -v_after < stick_velocity and force_at_barrier(t, coefficients) > 0.0:
                    # Chatter has died out and the force holds the mass on the barrier.
                    v_after = 0.0
                    stuck = True
                    if n_sticks < stick_log.shape[0]:
                        stick_log[n_sticks, 0] = t
                        stick_log[n_sticks, 1] = np.nan
                    n_sticks += 1
                y[V] = v_after
                if n_impacts - 1 < impact_log.shape[0]:
                    impact_log[n_impacts - 1, 0] = t
                    impact_log[n_impacts - 1, 1] = v_before
                    impact_log[n_impacts - 1, 2] = v_after
                if not stuck:
                    rhs(t, y, coefficients, f)
                    n_rhs += 1
                    # A slow rebound against a force pushing back returns after about
                    # 2 |v| / a: step well inside that flight, so its return is seen.
                    push = force_at_barrier(t, coefficients)
                    if push > 0.0:
                        h = min(h, REBOUND_STEP_FRACTION * 2.0 * -v_after / push)
                err_previous = 1.0

            if not (math.isfinite(y[X]) and math.isfinite(y[V])):
                status = Status.NON_FINITE
                break
            if abs(y[X]) > divergence_bound or abs(y[V]) > divergence_bound:
                status = Status.DIVERGED
                break

        if t >= t_boundary:
            record[REC_QS] = y[QS_INTEGRAL]
            record[REC_QC] = y[QC_INTEGRAL]
            record[REC_X] = y[X]
            record[REC_V] = y[V]
            y[QS_INTEGRAL] = 0.0
            y[QC_INTEGRAL] = 0.0
            period += 1
            if period == n_periods:
                break
            t_boundary = (period + 1) * slow_period
            _start_period(period_records[period], y[X])

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
        for k in (SUM_R, SUM_QS, SUM_QC, SUM_Q_AMPLITUDE, SUM_IMPACTS_PER_PERIOD):
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
    if c == 0.0:
        summary[SUM_R] = np.nan  # eq3.3 is a gain: undefined without a drive
        return Status.OK
    summary[SUM_R] = amplitude / c  # eq3.3
    for k in (SUM_R, SUM_QS, SUM_QC):
        if not math.isfinite(summary[k]):
            return Status.NON_FINITE
    return Status.OK
