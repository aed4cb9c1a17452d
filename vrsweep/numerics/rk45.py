"""Dormand-Prince 5(4): tableau as data, one step, error norm, PI controller, dense output.

Modelled on scipy/integrate/_ivp/rk.py: the tableau is named data, the step function is
small, and step-control constants have names. Everything here is numba-jitted and knows
nothing of impacts or of the oscillator: the right-hand side is a jitted function passed
in (numbakit-ode style), with signature ``rhs(t, h, node, c, y, coefficients, dydt, scratch)``
writing dydt, the derivative at time t + c h: a step evaluates its stage ``node`` (an index into
the method's nodes c; -1 for a time that is no node) at t + c h, so that a right-hand side may
prepare work for all the stages of a step (kernel.py: the forcing's phases). ``scratch`` belongs
to the right-hand side and is passed through.

Shapes used throughout (n = number of state components, state.py: x, v, two Fourier
quadratures, and in the Lyapunov kernels two tangent vectors; only the first ``N_CONTROLLED``
take part in error control, only the first ``n_dynamic`` are read by the right-hand side (so only
those stage values are formed) and only x and v are interpolated):

    y, y_new, dydt    (n,)
    K                 (N_STAGES + 1, n)   stage derivatives; K[-1] is f(t + h, y_new) (FSAL)
    dense             (n, DENSE_ORDER)     coefficients of the continuous extension
"""

import math

import numpy as np

from vrsweep.numerics.jit import kernel_jit

# --- Dormand & Prince (1980) RK5(4)7FM: c, A, b (5th order), e = b - b_hat (embedded 4th) ---
N_STAGES = 6
ORDER = 5
ERROR_ESTIMATOR_ORDER = 4

DP54_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
DP54_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])
DP54_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
# Applied to all seven stages (the FSAL stage included): h * E . K is the local error estimate.
DP54_E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])

# Continuous extension of order 4 (Shampine 1986, as in scipy's RK45): for theta in [0, 1],
#   y(t + theta h) = y + h * sum_j (K^T P)[:, j] * theta^(j+1).
DENSE_ORDER = 4
DP54_P = np.array([
    [1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0.0, 0.0, 0.0, 0.0],
    [0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])

# --- step-size control ---
SAFETY = 0.9
MIN_FACTOR = 0.2   # never shrink a step by more than 5x at once
MAX_FACTOR = 10.0  # never grow a step by more than 10x at once
# PI controller (Hairer, Norsett & Wanner, vol. I, II.4; the DOPRI5 code's values):
# factor = SAFETY * err^-PI_ALPHA * err_previous^PI_BETA.
PI_BETA = 0.04
PI_ALPHA = 1.0 / ORDER - 0.75 * PI_BETA
ERR_PREVIOUS_FLOOR = 1e-4  # keeps the PI memory from exploding after a near-exact step

# The first N_CONTROLLED components (x, v) are error-controlled (docs/design.md); the Fourier
# quadratures ride along: they are integrals of x, as accurate as x itself.
N_CONTROLLED = 2
# The oscillator's right-hand side reads only the first N_DYNAMIC components (x, v): the
# quadratures feed nothing back, so their stage values are never formed (half the work of a
# stage). A right-hand side that reads more (the tangent vectors) passes its own n_dynamic.
N_DYNAMIC = 2
# The continuous extension is made for x and v only: events and samples need nothing else.
N_INTERPOLATED = 2


# Inlined at numba-IR level so that the rhs argument becomes a direct call: a dispatcher passed
# as a runtime value would be a "dynamic global" and the caller could not be cached.
@kernel_jit(inline="always")
def dp54_step(rhs, t, y, f, h, coefficients, K, y_new, stage, scratch, n_dynamic=N_DYNAMIC):
    """One Dormand-Prince step of size h from (t, y) with f = rhs(t, y) already known.

    Fills K (N_STAGES + 1, n) with the stage derivatives, K[N_STAGES] = f(t + h, y_new)
    (first same as last), and y_new (n,). ``stage`` (n,) is scratch, passed in so that the
    hot loop allocates nothing; its first n_dynamic components are formed. The error estimate
    is ``error_norm``'s job.
    """
    n = y.shape[0]
    for j in range(n):
        K[0, j] = f[j]
    for s in range(1, N_STAGES):
        for j in range(n_dynamic):
            acc = 0.0
            for r in range(s):
                acc += DP54_A[s, r] * K[r, j]
            stage[j] = y[j] + h * acc
        rhs(t, h, s, DP54_C[s], stage, coefficients, K[s], scratch)
    for j in range(n):
        acc = 0.0
        for r in range(N_STAGES):
            acc += DP54_B[r] * K[r, j]
        y_new[j] = y[j] + h * acc
    rhs(t, h, N_STAGES, 1.0, y_new, coefficients, K[N_STAGES], scratch)


@kernel_jit
def error_norm(K, h, y, y_new, rtol, atol):
    """RMS over the controlled components of the local error / (atol + rtol * max(|y|, |y_new|))."""
    total = 0.0
    for j in range(N_CONTROLLED):
        err = 0.0
        for r in range(N_STAGES + 1):
            err += DP54_E[r] * K[r, j]
        scale = atol + rtol * max(abs(y[j]), abs(y_new[j]))
        ratio = h * err / scale
        total += ratio * ratio
    return math.sqrt(total / N_CONTROLLED)


@kernel_jit
def accepted_step_factor(err, err_previous):
    """Growth factor after an accepted step (err <= 1): PI control, clipped."""
    if err == 0.0:
        return MAX_FACTOR
    factor = SAFETY * err ** -PI_ALPHA * max(err_previous, ERR_PREVIOUS_FLOOR) ** PI_BETA
    return min(MAX_FACTOR, max(MIN_FACTOR, factor))


# At the step cap the factor is not needed when it is certainly >= 1: the next step is at the cap
# whatever its value (kernel.py). These are the largest errors for which SAFETY err^-alpha
# max(err_previous, floor)^beta >= 1 holds for every err_previous in a bucket (err_previous >=
# GROWTH_BUCKETS[i]), with a margin far above pow's rounding, so two pow calls (23 ns of a step)
# are skipped on most capped steps with bit for bit the same steps.
GROWTH_BUCKETS = (1e-1, 1e-2, 1e-3, ERR_PREVIOUS_FLOOR)


def growth_thresholds(alpha, beta):
    """The error below which the PI factor is >= 1, per bucket of GROWTH_BUCKETS."""
    return tuple((SAFETY * low ** beta) ** (1.0 / alpha) * (1.0 - 1e-6) for low in GROWTH_BUCKETS)


GROWTH_THRESHOLDS = growth_thresholds(PI_ALPHA, PI_BETA)


@kernel_jit
def growth_is_certain(err, err_previous, thresholds):
    """True when SAFETY err^-alpha max(err_previous, floor)^beta >= 1 is certain, without pow."""
    previous = max(err_previous, ERR_PREVIOUS_FLOOR)
    if previous >= GROWTH_BUCKETS[0]:
        return err <= thresholds[0]
    if previous >= GROWTH_BUCKETS[1]:
        return err <= thresholds[1]
    if previous >= GROWTH_BUCKETS[2]:
        return err <= thresholds[2]
    return err <= thresholds[3]


@kernel_jit
def certain_growth(err, err_previous):
    """accepted_step_factor(err, err_previous) >= 1 is certain (growth_is_certain)."""
    return growth_is_certain(err, err_previous, GROWTH_THRESHOLDS)


@kernel_jit
def rejected_step_factor(err):
    """Shrink factor after a rejected step (err > 1): plain I control, never growing."""
    return min(1.0, max(MIN_FACTOR, SAFETY * err ** (-1.0 / ORDER)))


@kernel_jit
def dense_coefficients(K, dense):
    """dense (n, DENSE_ORDER) = K^T P: the continuous extension of the last step (x and v only)."""
    for j in range(N_INTERPOLATED):
        for q in range(DENSE_ORDER):
            acc = 0.0
            for r in range(N_STAGES + 1):
                acc += K[r, j] * DP54_P[r, q]
            dense[j, q] = acc


@kernel_jit(inline="always")
def dp54_dense(rhs, t, y, h, coefficients, K, y_new, dense, stage, scratch, n_dynamic=N_DYNAMIC):
    """dense_coefficients behind the interface of dop853.dop853_dense: no extra RHS evaluation."""
    dense_coefficients(K, dense)
    return 0


@kernel_jit
def dense_value(dense, y, h, theta, component):
    """Component of the continuous extension at t + theta h (Horner in theta).

    Any method's dense output in the form y + h theta sum_q dense[component, q] theta^q; its
    degree is dense.shape[1] (4 for DP5(4), 7 for DOP853).
    """
    order = dense.shape[1]
    acc = dense[component, order - 1]
    for q in range(order - 2, -1, -1):
        acc = acc * theta + dense[component, q]
    return y[component] + h * theta * acc


@kernel_jit(inline="always")
def initial_step(rhs, t, y, f, coefficients, rtol, atol, h_max, order, scratch, y1, f1):
    """Starting step size (Hairer, Norsett & Wanner, vol. I, II.4, algorithm of 'hinit').
    y1, f1 (n,): work arrays (an Euler step's end and its derivative)."""
    n = y.shape[0]
    d0 = 0.0
    d1 = 0.0
    for j in range(N_CONTROLLED):
        scale = atol + rtol * abs(y[j])
        d0 += (y[j] / scale) ** 2
        d1 += (f[j] / scale) ** 2
    d0 = math.sqrt(d0 / N_CONTROLLED)
    d1 = math.sqrt(d1 / N_CONTROLLED)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, h_max)
    for j in range(n):
        y1[j] = y[j] + h0 * f[j]
    rhs(t, h0, -1, 1.0, y1, coefficients, f1, scratch)
    d2 = 0.0
    for j in range(N_CONTROLLED):
        scale = atol + rtol * abs(y[j])
        d2 += ((f1[j] - f[j]) / scale) ** 2
    d2 = math.sqrt(d2 / N_CONTROLLED) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / order)
    return min(100.0 * h0, h1, h_max)
