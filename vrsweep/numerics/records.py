"""What the kernel observes: the per-slow-period record, the run's summary, and the logs.

One record row per slow period T = 2 pi / omega (the caller chooses how many of the last periods
are kept: a trajectory keeps all, transient included; a sweep only the measurement window): impacts, the Fourier
quadratures of eq3.1-eq3.2, the stroboscopic state at t = nT, the period's extremes of x, time
stuck, and the tangent vectors' log growth. The summary reduces the measurement window's rows
to eq3.1-eq3.3 (R), the mean impacts per period and the Lyapunov exponents, and counts the work.
Samples, impacts and sticking intervals go to logs a trajectory passes in (length 0 in a sweep).
"""

import math

import numpy as np

from vrsweep.numerics.impact import BERNSTEIN_FROM_POWER, BERNSTEIN_ROUNDING, locate_root
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.rk45 import dense_value
from vrsweep.numerics.state import QC_INTEGRAL, QS_INTEGRAL, V, X
from vrsweep.numerics.tangent import collapse_tangents, renormalise_tangents
from vrsweep.results import Status

# --- per-slow-period record, one row per kept period (kernel.py: the last rows) ---
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
# The period's impacts (record_impact): speeds into the barrier before eq2.2 (|v-|), and the phase
# omega t of each at the response frequency, summed as cos and sin (circular statistics).
REC_IMPACT_SPEED_MIN = 10  # slowest impact of the period, inf without one
REC_IMPACT_SPEED_MAX = 11  # fastest impact of the period, 0 without one
REC_IMPACT_SPEED_SUM = 12  # sum of the period's impact speeds
REC_IMPACT_COS = 13        # sum of cos(omega t) over the period's impacts
REC_IMPACT_SIN = 14        # sum of sin(omega t) over the period's impacts
N_RECORD = 15

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
SUM_WINDOW_X_MAX = 15        # largest x in the transparent window (settings.TRANSPARENT_FROM), -inf without one
# The largest smooth maximum of x (v turns from + to -, no impact) and when (the *_monodromy
# kernels only, -inf and NaN in the others): how close an impacting orbit is to gaining an impact.
SUM_FREE_X_MAX = 16
SUM_FREE_X_MAX_TIME = 17
N_SUMMARY = 18


@kernel_jit
def emit_samples(sample_times, samples, next_sample, t0, h, y, dense, t_end):
    """Write the dense output at every sample time in (.., t_end] of the step [t0, t0 + h]."""
    while next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_end:
        theta = (sample_times[next_sample] - t0) / h if h > 0.0 else 1.0
        samples[next_sample, 0] = dense_value(dense, y, h, theta, X)
        samples[next_sample, 1] = dense_value(dense, y, h, theta, V)
        next_sample += 1
    return next_sample


@kernel_jit
def update_extremes(record, dense, y, y_new, h, theta_turn):
    """Fold the step's end and any turning point of x inside it into the period's min/max.

    theta_turn: the turning point if find_crossing located it on this dense output, else NaN.
    """
    x_end = y_new[X]
    if x_end < record[REC_X_MIN]:
        record[REC_X_MIN] = x_end
    if x_end > record[REC_X_MAX]:
        record[REC_X_MAX] = x_end
    if y[V] * y_new[V] < 0.0:
        if theta_turn != theta_turn and _inside_extremes(record, dense, y, h):
            return  # no value of the step's x can pass the period's extremes: nothing to locate
        theta = theta_turn if theta_turn == theta_turn else locate_root(dense, y, h, V, 0.0, 0.0, 1.0)
        x_turn = dense_value(dense, y, h, theta, X)
        if x_turn < record[REC_X_MIN]:
            record[REC_X_MIN] = x_turn
        if x_turn > record[REC_X_MAX]:
            record[REC_X_MAX] = x_turn


@kernel_jit
def window_top(top, dense, y, y_new, h):
    """max(top, the step's largest x): its ends, and the maximum of x inside it when v turns
    from + to - (dense holds the step's dense output then: the kernel computes it for every
    turning point)."""
    top = max(top, max(y[X], y_new[X]))
    if y[V] > 0.0 and y_new[V] < 0.0:
        theta = locate_root(dense, y, h, V, 0.0, 0.0, 1.0)
        top = max(top, dense_value(dense, y, h, theta, X))
    return top


# Rounding of the Bernstein coefficients and of dense_value, relative to the size of x's terms:
# four times impact.py's bound for the coefficients alone, so that a skipped turning point is one
# whose computed value could not have changed the record either.
EXTREMES_ROUNDING = 4.0 * BERNSTEIN_ROUNDING


@kernel_jit
def _inside_extremes(record, dense, y, h):
    """True when the step's x(theta) stays strictly inside (REC_X_MIN, REC_X_MAX), proven on its
    Bernstein coefficients (a polynomial lies within their range), with a margin for rounding.

    Most turning points of a period are not its extremes (the fast forcing's wiggles): locating
    them (locate_root, about 100 ns) would change nothing. dense (n_state, order) as dense_value's.
    """
    n = dense.shape[1]
    size = abs(y[X])
    for k in range(n):
        size += abs(h * dense[X, k])
    slack = EXTREMES_ROUNDING * size
    low = record[REC_X_MIN] + slack
    high = record[REC_X_MAX] - slack
    for i in range(n + 1):
        coefficient = y[X]
        for k in range(1, i + 1):
            coefficient += BERNSTEIN_FROM_POWER[n, i, k] * (h * dense[X, k - 1])
        if not (low < coefficient < high):
            return False
    return True


@kernel_jit
def start_period(record, x, tangents):
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
    record[REC_IMPACT_SPEED_MIN] = math.inf
    record[REC_IMPACT_SPEED_MAX] = 0.0
    record[REC_IMPACT_SPEED_SUM] = 0.0
    record[REC_IMPACT_COS] = 0.0
    record[REC_IMPACT_SIN] = 0.0


@kernel_jit
def record_impact(record, speed, phase):
    """An impact of the period: its speed into the barrier (|v-| before eq2.2) and its phase
    (response frequency x t; a grazing line on a map is where the slowest speed falls to zero)."""
    record[REC_IMPACT_SPEED_MIN] = min(record[REC_IMPACT_SPEED_MIN], speed)
    record[REC_IMPACT_SPEED_MAX] = max(record[REC_IMPACT_SPEED_MAX], speed)
    record[REC_IMPACT_SPEED_SUM] += speed
    record[REC_IMPACT_COS] += math.cos(phase)
    record[REC_IMPACT_SIN] += math.sin(phase)


@kernel_jit
def log_impact(impact_log, n_impacts, t, v_before, v_after):
    """The n_impacts-th impact into the log, while it has room."""
    if n_impacts - 1 < impact_log.shape[0]:
        impact_log[n_impacts - 1, 0] = t
        impact_log[n_impacts - 1, 1] = v_before
        impact_log[n_impacts - 1, 2] = v_after


@kernel_jit
def log_stick_start(stick_log, n_sticks, t):
    """A sticking interval starting at t into the log (its end is written at release). Returns the count."""
    if n_sticks < stick_log.shape[0]:
        stick_log[n_sticks, 0] = t
        stick_log[n_sticks, 1] = np.nan
    return n_sticks + 1


@kernel_jit(inline="always")
def close_period(record, t, y, f, tangent, coefficients, tangents, stuck):
    """At t = nT: record the period's quadratures and stroboscopic state, reset the quadratures,
    and renormalise the tangent vectors (tangent.py), recording their growth."""
    record[REC_QS] = y[QS_INTEGRAL]
    record[REC_QC] = y[QC_INTEGRAL]
    record[REC_X] = y[X]
    record[REC_V] = y[V]
    y[QS_INTEGRAL] = 0.0
    y[QC_INTEGRAL] = 0.0
    if tangents:
        add_tangent_growth(record, y)
        if stuck:
            collapse_tangents(y)  # still on the barrier: the next period starts from zero
        else:
            tangent(t, y, coefficients, f)  # f of the renormalised vectors


@kernel_jit
def add_tangent_growth(record, y):
    """Renormalise the tangent vectors and add their log growth to the period's record."""
    log_stretch, log_area = renormalise_tangents(y)
    record[REC_LOG_STRETCH] += log_stretch
    record[REC_LOG_AREA] += log_area


@kernel_jit
def emit_state(sample_times, samples, next_sample, t_end, x, v):
    """The state (x, v), constant up to t_end (a start, or a stick), at every sample time <= t_end."""
    while next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_end:
        samples[next_sample, 0] = x
        samples[next_sample, 1] = v
        next_sample += 1
    return next_sample


@kernel_jit
def summarize(period_records, n_transient, n_periods, slow_period, c, status, summary):
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
