"""Impacts with the barrier at x = Delta: event location on the dense output, sticking.

Roots are located on the step's continuous extension (integrator.dense_value) in the step
fraction theta in [0, 1]; the kernel then reaches the impact state with an exact step.
"""

import numpy as np

from vrsweep.numerics.rk45 import dense_value
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.model import ALPHA, BIG_OMEGA, C, DELTA, G, OMEGA, STIFFNESS
from vrsweep.numerics.state import V, X


# Step fraction to which roots are located: the impact time is then known to ~1e-15 h.
THETA_TOLERANCE = 1e-15
MAX_ROOT_ITERATIONS = 200
# A step that starts on the barrier is scanned at this many interior points for a return to it:
# a slow rebound can leave and come back within one step, with x(t + h) < Delta (a graze).
BARRIER_SCAN_POINTS = 8
NO_CROSSING = -1.0
# find_crossing's bracket: (theta_low, theta_high, the turning point it located)
N_BRACKET = 3
TURNING_POINT = 2
# find_crossing's verdicts.
NO_IMPACT = 0
IMPACT = 1
UNRESOLVED = 2  # left the barrier and came back between scan points: retry with a shorter step


@kernel_jit
def locate_root(dense, y, h, component, level, theta_low, theta_high):
    """theta in [theta_low, theta_high] where the interpolant's component crosses ``level``.

    Requires value(theta_low) < level <= value(theta_high) or the reverse; the Illinois
    variant of regula falsi keeps the bracket and converges superlinearly.
    Returns the upper end of the final bracket, so the located state is on the far side.
    """
    f_low = dense_value(dense, y, h, theta_low, component) - level
    f_high = dense_value(dense, y, h, theta_high, component) - level
    if f_high == 0.0:
        return theta_high
    side = 0
    for _ in range(MAX_ROOT_ITERATIONS):
        if theta_high - theta_low <= THETA_TOLERANCE:
            break
        theta = (theta_low * f_high - theta_high * f_low) / (f_high - f_low)
        if not (theta_low < theta < theta_high):
            theta = 0.5 * (theta_low + theta_high)
        f_mid = dense_value(dense, y, h, theta, component) - level
        if f_mid == 0.0:
            return theta
        if (f_mid < 0.0) == (f_low < 0.0):
            theta_low, f_low = theta, f_mid
            if side == -1:
                f_high *= 0.5
            side = -1
        else:
            theta_high, f_high = theta, f_mid
            if side == 1:
                f_low *= 0.5
            side = 1
    return theta_high


@kernel_jit
def _crossing_after_turning_point(dense, y, h, delta, theta_a, theta_b):
    """Upper bracket end for an excursion past Delta around a maximum of x.

    Called with v(theta_a) > 0 > v(theta_b) and x(theta_a) < Delta: locates the maximum of x
    and returns it as the upper end of a crossing bracket if it reaches Delta, else NO_CROSSING.
    """
    theta_turn = locate_root(dense, y, h, V, 0.0, theta_a, theta_b)
    if dense_value(dense, y, h, theta_turn, X) >= delta:
        return theta_turn
    return NO_CROSSING


@kernel_jit
def find_crossing(dense, y, y_new, h, delta, pushed_into_barrier, bracket):
    """Does x reach Delta within the step? If so, fill bracket = (theta_low, theta_high, .).

    bracket[TURNING_POINT] is the located maximum of x inside a step that starts below the
    barrier with v > 0 and ends with v < 0 (NaN if none was located).

    Cases (the state can never be above Delta at a step's start):
    - started below the barrier: x(t + h) >= Delta, or a grazing excursion past Delta that
      returns below it within the step (a velocity sign change from + to -);
    - started on the barrier (after a rebound or a release): scan interior points for the
      first return to Delta after leaving it.
    Returns IMPACT (bracket[0] has x < Delta), NO_IMPACT, or UNRESOLVED when the step is too
    long to see the mass leave the barrier before it is back past it.
    ``pushed_into_barrier``: the force at (Delta, 0) at the step's start points into the barrier.
    """
    bracket[TURNING_POINT] = np.nan
    if y[X] < delta:
        if y_new[X] >= delta:
            bracket[0] = 0.0
            bracket[1] = 1.0
            return IMPACT
        if y[V] > 0.0 and y_new[V] < 0.0:
            # A maximum of x inside the step: an impact if it reaches Delta. Kept in the bracket,
            # so the step's extremes (records.update_extremes) need not locate it again.
            theta_turn = locate_root(dense, y, h, V, 0.0, 0.0, 1.0)
            bracket[TURNING_POINT] = theta_turn
            if dense_value(dense, y, h, theta_turn, X) >= delta:
                bracket[0] = 0.0
                bracket[1] = theta_turn
                return IMPACT
        return NO_IMPACT

    # On the barrier: find where the mass has left it, then where it first comes back.
    theta_prev = 0.0
    v_prev = y[V]
    left = False
    for k in range(1, BARRIER_SCAN_POINTS + 1):
        theta = k / BARRIER_SCAN_POINTS
        x_k = y_new[X] if k == BARRIER_SCAN_POINTS else dense_value(dense, y, h, theta, X)
        v_k = y_new[V] if k == BARRIER_SCAN_POINTS else dense_value(dense, y, h, theta, V)
        if not left:
            if x_k < delta:
                left = True
        elif x_k >= delta:
            bracket[0] = theta_prev
            bracket[1] = theta
            return IMPACT
        elif v_prev > 0.0 and v_k < 0.0:
            theta_high = _crossing_after_turning_point(dense, y, h, delta, theta_prev, theta)
            if theta_high != NO_CROSSING:
                bracket[0] = theta_prev
                bracket[1] = theta_high
                return IMPACT
        theta_prev = theta
        v_prev = v_k
    if not left and y_new[X] > delta:
        if y[V] >= 0.0 and pushed_into_barrier:
            # Resting (or creeping) on the barrier and pressed into it: an impact at the
            # step's start with no speed, which the kernel turns into sticking.
            bracket[0] = 0.0
            bracket[1] = 0.0
            return IMPACT
        return UNRESOLVED
    # x == Delta to rounding (a release where the force has only just turned) is no impact.
    return NO_IMPACT


@kernel_jit
def force_at_barrier(t, coefficients):
    """Acceleration of a mass resting at (Delta, 0): positive pushes it into the barrier.

    The damping term vanishes with the velocity, so only stiffness and forcing remain.
    """
    delta = coefficients[DELTA]
    return (coefficients[C] * np.cos(coefficients[OMEGA] * t)
            + coefficients[G] * np.cos(coefficients[BIG_OMEGA] * t)
            - coefficients[STIFFNESS] * delta - coefficients[ALPHA] * delta ** 3)


@kernel_jit
def release_time(t_start, t_limit, coefficients, scan_step, max_scans):
    """First t in (t_start, t_limit] where the force at the barrier stops pushing into it.

    The force is an explicit function of t, so it is scanned in steps of ``scan_step``
    (a fraction of the shortest forcing period, so no sign change is stepped over) and the
    sign change is bisected to rounding. Returns (t, scans): t = t_limit + 1 if the mass stays
    stuck, NaN if ``max_scans`` scan intervals did not reach either (a fast forcing period
    so short that the scan would never end, e.g. Omega = 1e12).
    """
    t_a = t_start
    scans = 0
    while t_a < t_limit:
        if scans >= max_scans:
            return np.nan, scans
        scans += 1
        t_b = min(t_a + scan_step, t_limit)
        if force_at_barrier(t_b, coefficients) <= 0.0:
            for _ in range(MAX_ROOT_ITERATIONS):
                t_mid = 0.5 * (t_a + t_b)
                if t_mid <= t_a or t_mid >= t_b:
                    break
                if force_at_barrier(t_mid, coefficients) <= 0.0:
                    t_b = t_mid
                else:
                    t_a = t_mid
            return t_b, scans
        t_a = t_b
    return t_limit + 1.0, scans
