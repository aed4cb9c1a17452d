"""What kind of motion a point settled into, and R where the motion is quasi-periodic.

R (eq3.3) is the time average of x e^{-i omega t} over the measurement window. On a periodic
orbit the plain average over whole cycles is exact; on a chaotic one it is a random draw whose
spread R_err measures (diagnostics.py). Between them lies quasi-periodic motion: the original
model at Omega/omega irrational (a natural grid such as Omega = linspace(3, 6, 60) is almost
nowhere commensurate), a torus born at a Neimark-Sacker point. There the per-period integrals
beat on the scale 1/frac(Omega/omega) and the plain average converges like 1/m: after 100
periods R is off by 2e-3 to 2e-2 relative.

Weighted Birkhoff averages (Das, Sander, Saiki, Yorke, Nonlinearity 30, 2017) replace the plain
mean by one with the smooth bump w(s) = exp(-1/(s(1-s))) over the window, s in (0, 1). For a
quasi-periodic sequence f_n = F(theta + n rho), F smooth and rho Diophantine, the weighted mean
converges faster than any power of m (the bump's Fourier transform decays like
exp(-2 sqrt(2 pi xi))): at g = 40, Omega = 5 + 0.37 sqrt(3) the error after 100 periods falls
from 2.3e-3 to 2.7e-5 relative, against a 1000-period reference. On a chaotic sequence it is an
average like any other, with kappa = m sum w_n^2 = 1.96 times the plain mean's variance; so it
is used only where it helps.

The same averages tell the kinds apart. Over each half of the window, the weighted means of three
per-period observables (the two quadratures and the period's smallest x) agree to far better than
their spread on quasi-periodic motion and to about their spread on chaotic motion: for independent values the halves differ by sqrt(4 kappa / m) standard
deviations (rms). ``convergence`` is the rms over the observables of that difference in units of
the spread, divided by sqrt(4 kappa / m), so independent values give about 1 whatever m is;
the first and last three quarters are compared likewise, and the larger of the two is kept
(about 1.4 on independent values).

The observables are continuous functions of the phases on a torus; the stroboscopic x and v are
not (they jump where an impact crosses the strobe time: a weighted mean of a jump converges like
1/m), and the period's largest x is pinned at the barrier.

Measured on 275 points of the original model (g 0.5..60 x Omega 3..6 on a natural grid, 100 +
100 periods, with Lyapunov exponents): 98 have no period. The 48 of them with lambda1 > 0 beyond
its error bar all have convergence of 0.167 or more; the 36 below 0.01 all have lambda1 <= 0
within its error bar (35 of them lambda1 < 0 beyond it: a response locked to a quasi-periodic
forcing has lambda1 < 0, the forcing's phases not being state variables). QUASI_PERIODIC_LIMIT
is set low in that gap on purpose: a window shorter than the motion's slowest time scale can look
converged. On the effective model just below its Neimark-Sacker point (gamma = alpha = 0.05,
Omega = 4, g = 21.0 and 21.2), where the torus's slow modulation spans most of 100 periods,
convergence is 0.014 while R (about 9.5) differs from a 1000-period run's by 5e-4 and 3.2e-3
(the partial windows would say 2.4e-4 and 2.9e-4). Calling such a point chaotic costs a wide R_err; calling it
quasi-periodic would cost an R_err that lies.

Classes (``Motion``, stored as ``motion``):
  periodic        a period p was detected (diagnostics.detect_period): R is the plain average
                  over the window's last whole cycles (the last m - m mod p periods), the
                  orbit's own R (continuation's). Over the whole window it would be off by a
                  fixed amount: 1.6e-2 relative at g = 10, Omega = 4 (period 3, 100 periods).
                  impacts_per_period likewise (whole_cycle_impacts), as lyapunov
                  (diagnostics.whole_cycle_exponent).
  quasi_periodic  no period, not dying away, lambda1 not positive beyond its error bar, and
                  either convergence < QUASI_PERIODIC_LIMIT or lambda1 < 0 beyond its error bar
                  (where computed): R is the weighted average, R_err the largest of its
                  distances from the weighted averages of the window's halves and first and
                  last three quarters (each converged far less than the whole window, so this
                  bounds the whole window's error).
  chaotic         no period, and neither converged averages nor a negative lambda1 say
                  otherwise; lambda1 > 0 beyond its error bar makes any point without a period
                  chaotic. R and R_err as in diagnostics.py.
  not_settled     no period and dying away: the last quarter of the window varies less than
                  SETTLING_RATIO of the first quarter (measured quasi-periodic and chaotic points
                  give 0.65 to 1.12). A longer transient would tell what it settles into. R and
                  R_err as in diagnostics.py.
  none            the point failed (its status says why) or was not computed.

Why a negative lambda1 suffices: a response locked to a quasi-periodic forcing is attracted to a
torus parameterised by the forcing's phases, which are not state variables, so lambda1 < 0, and
the partial windows bound R's error whatever the convergence. Measured on 150 points of the
original model at Omega values of linspace(3, 6, 60) (Omega/omega = p/59: no period within 50),
100 periods against 1000: at all 122 points with lambda1 < 0 beyond its error bar R's error was
at most 0.79 times that R_err (convergence from 0.0006 to 2.5: a slow beat, when Omega/omega lies
near a whole number, is seen as a wide R_err, not hidden); at the 27 with lambda1 > 0 the same
bound was exceeded up to 3 times, which is why chaos keeps the plain average and its jackknife.
Without exponents, only convergence can say it, and the limit stays low (above).
"""

import warnings

import numpy as np

from vrsweep.analysis.diagnostics import gain_cycles, whole_cycles
from vrsweep.numerics import kernel
from vrsweep.numerics.coefficients import PERIOD, RESPONSE_SCALE
from vrsweep.results import Motion, Status


# Convergence (module doc) below which a point without a period is quasi-periodic: chaos gives
# about 1, measured chaotic points 0.167 or more; quasi-periodic ones mostly under 0.01 (the module
# doc says why the limit is not higher).
QUASI_PERIODIC_LIMIT = 0.01
# The last quarter's spread under this fraction of the first quarter's: the motion is dying away.
SETTLING_RATIO = 0.25
# The per-period observables whose averages decide the kind: continuous on a torus (module doc).
OBSERVABLES = (kernel.REC_QS, kernel.REC_QC, kernel.REC_X_MIN)


def bump_weights(n):
    """The weights of a weighted Birkhoff average over n consecutive values, summing to 1:
    w(s) = exp(-1/(s(1-s))) at the midpoints s = (k + 1/2)/n (each value stands for one period)."""
    s = (np.arange(n) + 0.5) / n
    w = np.exp(-1.0 / (s * (1.0 - s)))
    return w / w.sum()


# kappa = n sum w^2: the weighted mean's variance over the plain mean's for independent values
# (1.96 for every n from 20 on).
def _kappa(n):
    w = bump_weights(n)
    return n * float(np.sum(w * w))


def weighted_mean(values):
    """The weighted Birkhoff average of ``values`` (..., n) along the last axis.

    Summed term by term in a fixed order, not by a matrix product: BLAS picks its blocking by the
    array's shape, so a point's R would depend on how many points share its chunk, and a resumed
    or sharded run would not reproduce an uninterrupted one bit for bit."""
    values = np.asarray(values, dtype=np.float64)
    weights = bump_weights(values.shape[-1])
    total = np.zeros(values.shape[:-1])
    for k, weight in enumerate(weights):
        total += weight * values[..., k]
    return total


def convergence(measured):
    """The convergence measure (module doc) of each point; (n_points,) from the measurement
    window's records (n_points, m, N_RECORD). The larger of two comparisons: the two halves, and
    the first and last three quarters (a modulation whose period divides half the window gives
    equal halves, not equal three-quarter windows). An observable constant to rounding counts as
    converged; NaN where fewer than 8 periods leave nothing to compare."""
    n_points, m, _ = measured.shape
    if m < 8:
        return np.full(n_points, np.nan)
    values = measured[:, :, OBSERVABLES]                          # (n_points, m, n_obs)
    with np.errstate(invalid="ignore", divide="ignore"):
        spread = np.std(values, axis=1)
        size = np.maximum(1.0, np.max(np.abs(values), axis=1))
        worst = np.zeros(n_points)
        for length in (m // 2, (3 * m) // 4):
            first = weighted_mean(np.swapaxes(values[:, :length], 1, 2))  # (n_points, n_obs)
            last = weighted_mean(np.swapaxes(values[:, m - length:], 1, 2))
            ratio = np.abs(first - last) / spread
            ratio = np.where(spread <= 1e-12 * size, 0.0, ratio)  # constant to rounding: converged
            rms = np.sqrt(np.mean(ratio * ratio, axis=1))
            # for independent values the two windows' means differ by sqrt(2 kappa (m - length)) / length
            # standard deviations (rms): their overlap is common to both
            worst = np.maximum(worst, rms / (np.sqrt(2.0 * _kappa(length) * (m - length)) / length))
    return worst


def settling(measured):
    """The last quarter's spread over the first quarter's (rms over the observables, each in
    units of its spread over the window): about 1 on a stationary motion, far below on one that
    is dying away. (n_points,); NaN for windows under 8 periods."""
    n_points, m, _ = measured.shape
    quarter = m // 4
    if quarter < 2:
        return np.full(n_points, np.nan)
    values = measured[:, :, OBSERVABLES]
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        # A failed point's window is all NaN: its NaN is the answer, not a warning to the user.
        warnings.simplefilter("ignore", RuntimeWarning)
        spread = np.std(values, axis=1)
        early = np.std(values[:, :quarter], axis=1) / spread
        late = np.std(values[:, m - quarter:], axis=1) / spread
        return np.sqrt(np.nanmean(late * late, axis=1) / np.nanmean(early * early, axis=1))


def classify(measured, ok, period, lyapunov=None, lyapunov_err=None):
    """``Motion`` of each point (int8 (n_points,)), by the rules of the module doc.

    measured: (n_points, m, N_RECORD), the window's records; ok: bool (n_points,); period: the
    detected periods; lyapunov, lyapunov_err: (n_points,) where computed, else None."""
    n_points = len(period)
    with np.errstate(invalid="ignore"):
        converged = convergence(measured) < QUASI_PERIODIC_LIMIT
        dying = settling(measured) < SETTLING_RATIO
        if lyapunov is not None:
            positive = lyapunov - lyapunov_err > 0.0
            negative = lyapunov + lyapunov_err < 0.0
        else:
            positive = negative = np.zeros(n_points, dtype=bool)
    aperiodic = ok & (period == 0)
    motion = np.full(n_points, Motion.CHAOTIC, dtype=np.int8)
    motion[aperiodic & ~positive & (converged | negative)] = Motion.QUASI_PERIODIC
    motion[aperiodic & ~positive & dying] = Motion.NOT_SETTLED
    motion[ok & (period > 0)] = Motion.PERIODIC
    motion[~ok] = Motion.NONE
    return motion


def quasi_periodic_gain(measured, coefficients):
    """R (eq3.3) by weighted Birkhoff averages, with its error bar, for each point:
    {"R", "Qs", "Qc", "Q_amplitude", "R_err"} (n_points,) each. The quadratures are 2/T times
    the weighted mean of the per-period integrals (eq3.1, eq3.2); R_err is the largest distance
    of R from the weighted R of either half of the window or of its first or last three quarters."""
    slow_period = coefficients[:, PERIOD]
    c = coefficients[:, RESPONSE_SCALE]
    m = measured.shape[1]

    def gain(rows):
        qs = 2.0 * weighted_mean(measured[:, rows, kernel.REC_QS]) / slow_period  # eq3.1
        qc = 2.0 * weighted_mean(measured[:, rows, kernel.REC_QC]) / slow_period  # eq3.2
        amplitude = np.hypot(qs, qc)
        with np.errstate(invalid="ignore", divide="ignore"):
            return qs, qc, amplitude, np.where(c == 0.0, np.nan, amplitude / c)  # eq3.3

    qs, qc, amplitude, r = gain(slice(0, m))
    r_err = np.zeros_like(r)
    for length in (m // 2, (3 * m) // 4):  # the halves, and the first and last three quarters
        for rows in (slice(0, length), slice(m - length, m)):
            r_err = np.maximum(r_err, np.abs(r - gain(rows)[3]))
    return {"R": r, "Qs": qs, "Qc": qc, "Q_amplitude": amplitude, "R_err": r_err}


def whole_cycle_gain(measured, coefficients, period):
    """R (eq3.3) over the last whole cycles of each point's window, with Qs, Qc, Q_amplitude:
    {"R", "Qs", "Qc", "Q_amplitude"} (n_points,) each; period (n_points,) > 0, the cycle of R
    (diagnostics.gain_cycles: the motion's period, or a multiple of it). The integrals are
    summed period by period in order, as the kernel sums the window (records.py)."""
    slow_period = coefficients[:, PERIOD]
    c = coefficients[:, RESPONSE_SCALE]
    n_points, m, _ = measured.shape
    whole = whole_cycles(m, period)
    sin_integral = np.zeros(n_points)
    cos_integral = np.zeros(n_points)
    for k in range(m):
        inside = k >= m - whole
        sin_integral += np.where(inside, measured[:, k, kernel.REC_QS], 0.0)
        cos_integral += np.where(inside, measured[:, k, kernel.REC_QC], 0.0)
    window = whole * slow_period
    qs = 2.0 * sin_integral / window  # eq3.1
    qc = 2.0 * cos_integral / window  # eq3.2
    amplitude = np.hypot(qs, qc)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(c == 0.0, np.nan, amplitude / c)  # eq3.3
    return {"R": r, "Qs": qs, "Qc": qc, "Q_amplitude": amplitude}


def whole_cycle_impacts(measured, period):
    """Impacts per slow period over the last whole cycles of each point's window (period > 0):
    the orbit's impacts_per_cycle / period, over the window R is measured on (whole_cycle_gain).
    Over the whole window a period-p orbit counts part of a cycle once more: at g = 10, Omega = 4
    (period 3, 8 impacts a cycle) 2.67 a period over 100 periods, against the orbit's 8/3."""
    n_points, m, _ = measured.shape
    whole = whole_cycles(m, period)
    inside = np.arange(m)[None, :] >= (m - whole)[:, None]
    return np.where(inside, measured[:, :, kernel.REC_IMPACTS], 0.0).sum(axis=1) / whole


def _replace(values, where, estimates):
    for name, estimate in estimates.items():
        column = np.array(values[name], dtype=np.float64, copy=True)
        column[where] = estimate
        values[name] = column


def motion_values(values, measured, statuses, coefficients, lyapunov=None):
    """``values`` (point_values' dict) with ``motion`` added; at periodic points whose window is
    no whole number of cycles, R, Qs, Qc, Q_amplitude and impacts_per_period over the last whole
    cycles; at
    quasi-periodic points, R, Qs, Qc, Q_amplitude and R_err by weighted Birkhoff averages.
    lyapunov: the dict of diagnostics.lyapunov_values, or None."""
    ok = statuses == Status.OK
    exponents = (lyapunov["lyapunov"], lyapunov["lyapunov_err"]) if lyapunov is not None else (None, None)
    period = np.asarray(values["period"])
    motion = classify(measured, ok, period, *exponents)
    m = measured.shape[1]
    periodic = motion == Motion.PERIODIC
    # a cycle dividing m: the window is whole cycles, and the kernel's value is already theirs.
    # R's cycle spans whole cycles of the response's e^{iwt} too (diagnostics.gain_cycles).
    cycles = gain_cycles(coefficients, period, m)
    cut = periodic & (m % np.maximum(cycles, 1) != 0)
    if cut.any():
        _replace(values, cut, whole_cycle_gain(measured[cut], coefficients[cut], cycles[cut]))
    cut = periodic & (m % np.maximum(period, 1) != 0)
    if cut.any():
        _replace(values, cut, {"impacts_per_period": whole_cycle_impacts(measured[cut], period[cut])})
    quasi = motion == Motion.QUASI_PERIODIC
    if quasi.any():
        _replace(values, quasi, quasi_periodic_gain(measured[quasi], coefficients[quasi]))
    values["motion"] = motion
    return values
