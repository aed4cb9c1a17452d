"""Can R be trusted? Per-point diagnostics from the kernel's per-slow-period records.

R (eq3.3) is the gain of the time average over the m slow periods of the measurement window.
On a periodic orbit it is a property of the system; on a chaotic one it is one draw of a random
variable: another rtol, the last bit of atol or of x(0) gives another trajectory and another R
(at g = 5, Omega = 4 with the paper's parameters, R over 100 periods ranges from 0.4 to 2.6 with
the solver tolerance alone). These diagnostics say which case a point is in. All are vectorised
over the points of a chunk; records are (n_points, n_rows, N_RECORD), the last n_rows periods'
records with n_rows >= measure_periods (a sweep keeps the measurement window's only: see
window_records); only the measurement window's rows are read.

Stroboscopic (Poincare) samples
    ``strobe_x``, ``strobe_v``: x and v at t = nT, T = 2 pi/omega, for the last
    ``strobe_periods`` periods (the kernel stops a step on every t = nT, so they are exact).

``period``
    The smallest p <= max_period with x[k+p] = x[k] and v[k+p] = v[k] for every k of the
    strobe samples, to ``period_tolerance`` relative to max(1, max |x|) (resp. |v|); at least
    two cycles must be seen, so p <= strobe_periods // 2; and every smaller lag must repeat at
    least SEPARATION = 100 times worse (see detect_period: an orbit still spiralling into a
    fixed point otherwise passes for period p). 0 = none: chaotic, quasi-periodic, a period
    above max_period, or not yet converged to the tolerance, in which case R may still be
    accurate: read R_err. ``impacts_per_cycle`` is the number of impacts in the last p periods
    (-1 when period is 0).

``R_err`` (95% half-width of R)
    1. Batches. The window's m periods are cut into B = 10 consecutive batches of L whole
       periods, L a multiple of ``period`` when one was found (so a periodic orbit gives
       identical batches), using the last B*L periods. Each batch gives a gain vector
       q_b = 2/(L T c) (integral of x sin, integral of x cos), the mean of which is R's vector.
    2. Jackknife. R = |mean q_b| is a non-linear function of the batch means, so its variance is
       estimated by the delete-one-batch jackknife: R_(b) = |mean of the other B-1 batches|,
       var = (B-1)/B * sum_b (R_(b) - mean R_(.))^2, and
       R_err = t_{0.975, B-1} * sqrt(var)   (t_{0.975,9} = 2.262).
    3. Incomplete cycles. On a period-p orbit with m not a multiple of p, R over the window
       differs from the orbit's own R (its mean over whole cycles) by a fixed amount that no
       tolerance changes: at g = 10, Omega = 4 (period 3) R over 100 periods is 0.5444 and over
       the last 99 it is 0.5356. Since 0.6.0 R of a periodic point is its mean over the window's
       last whole cycles (analysis/motion.py), the orbit's own R, which continuation computes too;
       before, that offset was added to R_err instead.

    Why this estimator, from measurements (ensembles of 54 runs per point: rtol 1e-7 ... 1e-11
    times six x(0) perturbations of 1e-9, paper parameters, Omega = 4, 100 + 100 periods):
    - per-period Fourier components of a chaotic orbit are nearly uncorrelated (lag-1
      autocorrelation -0.1 to -0.2, below 0.07 from lag 2 on at g = 5), so batches of 10
      periods are close to independent and Student's t with B - 1 dof is the right factor;
    - the fraction of runs whose R lies within R_err of the ensemble mean (nominal 95%) was
      0.98 / 0.94 / 0.98 at g = 5 / 1 / 2.5 with the jackknife (the factor that would give
      exactly 95% is 1.9 / 2.2 / 1.5, against t = 2.26 used); the previous estimator
      (t * std of per-batch R / sqrt(B)) gave 0.87 at g = 5: per-batch |q_b| carries its own
      noise bias and misjudges the spread of |mean q_b|;
    - two runs at different tolerances agree within hypot(R_err1, R_err2) in 97-100% of pairs.
    What it cannot see: transient chaos. At g = 22 a chaotic transient ends, after a random
    time, on a period-4 orbit (R = 9.93); a run still chaotic at the end of its window has
    R ~ 5 +- 2 and no statistic of that window predicts the later capture. Such points have
    period 0 and R_err / R ~ 0.4, so they are flagged all the same.

``x_min``, ``x_max``
    The extremes of x over the measurement window (turning points located on the dense output).

``lyapunov_err`` (95% half-width of ``lyapunov``, with integration.lyapunov)
    The largest exponent is the mean of the per-period log stretches of the tangent vector over
    the window (tangent.py), a linear statistic: the same B = 10 batches as R_err (L whole
    periods, L a multiple of ``period``) each give an exponent lambda_b, and
    lyapunov_err = t_{0.975, B-1} std(lambda_b) / sqrt(B). A period-p orbit's ``lyapunov`` is its
    mean over the window's last whole cycles (whole_cycle_exponent), the orbit's log |mu_1| / (pT),
    as its R is; vrsweep 0.6.9 and earlier stored the window's mean and added the distance between
    the two to lyapunov_err. On an orbit whose two Floquet multipliers are a complex pair the per-period stretch oscillates with the pair's rotation and
    the window's mean carries an O(1/m) bias: there lyapunov is half the exponents' sum, from the
    exact log areas (complex_pair_exponent, since 0.7.1), and lyapunov_err the batches' of half the
    log area, the estimate stored (up to 0.7.6 the batches' of the one vector's stretch, which swing
    with the pair's rotation: 0.026 about a bilinear spring's exact -0.03). A point that stuck
    in the window has lyapunov = -inf exactly (tangent.py) and lyapunov_err = 0.
    Measured as for R_err (24 runs per point: rtol 1e-8 ... 1e-11 times six x(0) moved by up to
    5e-9, paper parameters, Omega = 4, 100 + 100 periods): the fraction of runs within
    lyapunov_err of the ensemble mean was 0.92 / 0.96 / 0.92 / 0.96 at g = 1 / 3 / 5 / 20 (means
    0.151, 0.223, 0.250, 0.034); at g = 22, where a chaotic transient ends on a period-4 orbit at a
    random time, 0.71: the same blind spot as R_err's.
"""

import numpy as np

# Omega/omega (or any forcing frequency over the response's) counts as p/q when it agrees with it
# to RATIO_TOLERANCE, relative: a grid value typed as a decimal is p/q to roundoff.
from vrsweep.analysis.commensurate import RATIO_TOLERANCE
from vrsweep.numerics import kernel
from vrsweep.numerics.coefficients import PERIOD, RESPONSE_FREQUENCY, RESPONSE_SCALE
from vrsweep.results import Status

N_BATCHES = 10
# A period's smaller lags must repeat this many times worse than the period itself (detect_period).
SEPARATION = 100.0
# 97.5% quantiles of Student's t for B - 1 = 1..9 degrees of freedom (no scipy at run time).
_T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}


def detect_period(strobe_x, strobe_v, max_period, tolerance):
    """Smallest p in 1..max_period with x[k + p] == x[k] and v[k + p] == v[k] to tolerance.

    strobe_x, strobe_v: (n_points, n_strobe). Needs at least 2p samples to call p a period.
    The residual r_p = max_k max(|x[k+p] - x[k]| / scale_x, |v[k+p] - v[k]| / scale_v), with
    scale = max(1, max |x|) (resp. |v|), so the tolerance means the same on small and large
    orbits. p is a period when r_p <= tolerance and every smaller lag q has r_q > SEPARATION * r_p:
    the p points of a cycle must be told apart far more clearly than they repeat. Without that
    rule an orbit still spiralling into a fixed point, with a Floquet rotation near 2 pi / p,
    passes as period p (measured: effective model, g = 23.25, r_5 = 8e-7 but r_1 = 4e-6; the
    genuine period-3 and period-5 orbits of the original model at Omega = 4 have r_q / r_p > 1e8).
    NaN samples (failed points) never repeat.
    Returns int64 (n_points,), 0 where none.
    """
    strobe_x = np.asarray(strobe_x, dtype=np.float64)
    strobe_v = np.asarray(strobe_v, dtype=np.float64)
    n_points, n_strobe = strobe_x.shape
    with np.errstate(invalid="ignore"):
        scale_x = np.maximum(1.0, np.max(np.abs(strobe_x), axis=1, initial=0.0))
        scale_v = np.maximum(1.0, np.max(np.abs(strobe_v), axis=1, initial=0.0))
    period = np.zeros(n_points, dtype=np.int64)
    smallest_before = np.full(n_points, np.inf)  # min over q < p of r_q
    for p in range(1, min(max_period, n_strobe // 2) + 1):
        residual = np.maximum(np.max(np.abs(strobe_x[:, p:] - strobe_x[:, :-p]), axis=1) / scale_x,
                              np.max(np.abs(strobe_v[:, p:] - strobe_v[:, :-p]), axis=1) / scale_v)
        residual = np.where(np.isnan(residual), np.inf, residual)  # NaN never repeats
        repeats = (residual <= tolerance) & (smallest_before > SEPARATION * residual) & (period == 0)
        period[repeats] = p
        smallest_before = np.minimum(smallest_before, residual)
    return period


def orbit_gain(coefficients, periods, R, Q_amplitude):
    """(R, Q_amplitude) of a period-``periods`` orbit from their integrals over one of its cycles
    (shooting.periodic_map's): those, where the response frequency w is a harmonic of the orbit's
    2 pi / (periods T); else 0, exactly. The orbit has no component at any other w, and its cycle
    is no whole number of cycles of e^{iwt} (gain_cycles, the sweep's rule). With w = omega/2, a
    period-1 branch of the linear impact oscillator stored R = 1.229 at Delta = 3 for this 0."""
    # w is a harmonic when e^{iwt} repeats after q periods T with q dividing the orbit's (forcing_periods)
    q = forcing_periods(coefficients[None, PERIOD], coefficients[None, RESPONSE_FREQUENCY:RESPONSE_FREQUENCY + 1],
                        periods)[0]
    return (R, Q_amplitude) if q > 0 and periods % q == 0 else (0.0, 0.0)


def forcing_periods(slow_period, frequencies, longest):
    """The number q of periods T after which every forcing of each point repeats: each frequency
    h (models' forcing_frequencies: omega and Omega for the paper's models, every frequency of a
    written model's sines and cosines) must make h T / (2 pi) a ratio p/q with q <= ``longest``,
    and q is the least common multiple of their q. 0 where none repeats so soon.
    slow_period: (n_points,); frequencies: (n_points, K). (n_points,) int64."""
    from fractions import Fraction
    from math import lcm

    header = np.column_stack([slow_period, frequencies])
    periods = np.zeros(len(header), dtype=np.int64)
    rows, inverse = np.unique(header, axis=0, return_inverse=True)  # a map has few distinct rows
    for k, (period, *row) in enumerate(rows):
        q = 1
        for frequency in row:
            if frequency == 0.0:
                continue
            with np.errstate(over="ignore"):
                ratio = frequency * period / (2.0 * np.pi)
            if not np.isfinite(ratio):  # Omega = 1e308 overflows to inf, which Fraction refuses
                q = 0
                break
            fraction = Fraction(ratio).limit_denominator(max(int(longest), 1))
            if not abs(ratio - fraction) <= RATIO_TOLERANCE * abs(ratio):
                q = 0
                break
            q = lcm(q, fraction.denominator)
        periods[inverse.reshape(-1) == k] = q if q <= longest else 0
    return periods


def sampling_of_forcing(model, parameter_sets, longest):
    """What samples taken once, or evenly, per period T see of each parameter set's forcing.

    model: the config's (``"original"``, ``"effective"`` or a written one); parameter_sets: a list
    of {name: value}. Returns (q, cycles), two (n,) arrays: q the periods T after which the
    forcing repeats (forcing_periods: 1 where it repeats every T, 0 where it does not within
    ``longest``), cycles the fastest forcing's cycles per period T (h T / 2 pi; 0 where nothing
    forces). A figure sampling x at t = nT draws the motion's own stroboscopic map only where q is
    1 (Omega/omega = 1/10 repeats after q = 10: a motion locked to it shows 10 dots); a figure
    sampling N times per T resolves the fastest force only with several samples per cycle (at
    Omega = 50, omega = 0.5: 100 cycles per T, 200 samples are 2 per cycle, which alias)."""
    from vrsweep.numerics.models import kernels_for

    kernels = kernels_for(model)
    names = list(parameter_sets[0]) if parameter_sets else []
    table = {name: np.array([float(values[name]) for values in parameter_sets]) for name in names}
    vectors = np.asarray(kernels.coefficients(table), dtype=np.float64).reshape(len(parameter_sets), -1)
    frequencies = np.abs(np.asarray(kernels.forcing_frequencies(vectors), dtype=np.float64))
    frequencies = frequencies.reshape(len(parameter_sets), -1)
    period = vectors[:, PERIOD]
    q = forcing_periods(period, frequencies, longest)
    with np.errstate(invalid="ignore", over="ignore"):
        cycles = np.max(frequencies, axis=1, initial=0.0) * period / (2.0 * np.pi)
    return q, cycles


def gain_cycles(coefficients, period, m):
    """The slow periods in one cycle of a point's R: the least common multiple of its motion's
    period p and the number q of periods T after which the response's e^{iwt} repeats
    (forcing_periods of w); p where w repeats after no q (or the lcm exceeds the m-period window).
    A period-p orbit has Fourier components only at multiples of 2 pi / (pT): at any other w its
    Q is 0, and an integral over whole p-cycles is that 0 only if it also spans whole cycles of
    e^{iwt}. With w = omega/2 over a period-1 orbit, R was 0.012 over 101 periods (0.059 over
    21, 0 over any even number), with an R_err of 1e-13 from batches of an even length. For the
    paper's models w T = 2 pi: q = 1, the motion's period itself.
    coefficients: (n_points, N); period: (n_points,) int, 0 where none. (n_points,) int64."""
    period = np.asarray(period, dtype=np.int64)
    response = forcing_periods(coefficients[:, PERIOD], coefficients[:, RESPONSE_FREQUENCY:RESPONSE_FREQUENCY + 1], m)
    cycle = np.lcm(period, response)
    return np.where((period > 0) & (response > 0) & (cycle <= m), cycle, period)


def forcing_period_detected(measured, period, forcing, max_period, tolerance):
    """``period`` with the forcing's period q filled in where none up to max_period was found but
    the window's stroboscopic states repeat after q (> max_period) periods: the forcing repeats
    only after q periods, so a motion locked to it has no shorter period (Omega/omega = 78/11:
    period 11, beyond the default max_period 8). Tested on the last max(2q, 16) periods of the
    window with detect_period's rules (every smaller lag 100 times worse)."""
    m = measured.shape[1]
    found = np.array(period, copy=True)
    for q in np.unique(forcing[(period == 0) & (forcing > max_period) & (2 * forcing <= m)]):
        rows = np.flatnonzero((period == 0) & (forcing == q))
        n = min(m, max(2 * int(q), 16))
        lag = detect_period(measured[rows, m - n:, kernel.REC_X], measured[rows, m - n:, kernel.REC_V], int(q), tolerance)
        found[rows[lag == q]] = q
    return found


def _amplitude(sin_integral, cos_integral, duration):
    """|Q| of eq3.1-eq3.2 from the two Fourier integrals over `duration`."""
    return 2.0 * np.hypot(sin_integral, cos_integral) / duration


def _batches(n_measured, unit):
    """(B, L): the window's last B * L periods in B batches of L, a multiple of the cycle length
    ``unit``; B = N_BATCHES unless the window is short, then batches of one cycle each."""
    batch_length = (n_measured // N_BATCHES // unit) * unit
    if batch_length == 0:
        return n_measured // unit, unit
    return N_BATCHES, batch_length


def r_error(sin_part, cos_part, slow_period, c, period):
    """R_err of one point (module doc): the jackknife half-width over batches of whole cycles.

    sin_part, cos_part: (m,) per-period Fourier integrals over the measurement window.
    Returns NaN when the window holds fewer than two cycles or c == 0 (R is then NaN too).
    """
    n_measured = len(sin_part)
    unit = int(period) if period > 0 else 1
    if c == 0.0 or n_measured < 2 * unit:
        return np.nan
    n_batches, batch_length = _batches(n_measured, unit)
    used = n_batches * batch_length
    # The last `used` periods: the end of the window is the most settled part.
    qs = sin_part[n_measured - used:].reshape(n_batches, batch_length).sum(axis=1)
    qc = cos_part[n_measured - used:].reshape(n_batches, batch_length).sum(axis=1)
    # Leave-one-out means of the batch integrals, each over (B - 1) batches.
    # The spread of |Q|, divided by |c| once at the end (R = |Q|/c, eq3.3): the squares of R's
    # own deviations overflowed where R is large (c = 1e-300: R = 1.6e298 and R_err inf).
    a_loo = _amplitude(qs.sum() - qs, qc.sum() - qc, (n_batches - 1) * batch_length * slow_period)
    variance = (n_batches - 1) / n_batches * np.sum((a_loo - a_loo.mean()) ** 2)
    return _T975.get(n_batches - 1, 1.96) * np.sqrt(variance) / abs(c)


def window_records(records, integration):
    """The measurement window's rows of records (n_points, n_rows, N_RECORD): the last
    measure_periods, whether the kernel kept the transient's rows (a trajectory) or not (a sweep)."""
    n_measure = integration.measure_periods
    if records.shape[1] < n_measure:
        raise ValueError(f"records hold {records.shape[1]} periods, fewer than the {n_measure} measured")
    return records[:, records.shape[1] - n_measure:]


def batch_error(measured, slow_period, c, period, ok):
    """R_err for every point of a chunk (see r_error and the module doc); NaN where not ok.

    measured: (n_points, measure_periods, N_RECORD), the measurement window's records.

    r_error's arithmetic on all the points of one cycle length at once: their batches have the same
    shape, and every sum runs along the last, contiguous axis of its array, as r_error's do along
    its one-point arrays, so each value is r_error's to the last bit (tests/test_diagnostics.py).
    One point at a time it was most of the host's work per chunk, which a GPU waits for."""
    n_points, n_measured = measured.shape[:2]
    r_err = np.full(n_points, np.nan)
    unit = np.where(period > 0, period, 1).astype(np.int64)
    # a failed point's records are partly NaN, and c == 0 leaves R undefined: nothing to estimate
    estimable = ok & (c != 0.0) & (n_measured >= 2 * unit)
    for length in np.unique(unit[estimable]):
        rows = np.flatnonzero(estimable & (unit == length))
        n_batches, batch_length = _batches(n_measured, int(length))
        used = n_batches * batch_length
        window = measured[rows, n_measured - used:]
        qs = np.ascontiguousarray(window[:, :, kernel.REC_QS]).reshape(len(rows), n_batches, batch_length).sum(axis=2)
        qc = np.ascontiguousarray(window[:, :, kernel.REC_QC]).reshape(len(rows), n_batches, batch_length).sum(axis=2)
        duration = (n_batches - 1) * batch_length * slow_period[rows]
        a_loo = _amplitude(qs.sum(axis=1)[:, None] - qs, qc.sum(axis=1)[:, None] - qc, duration[:, None])
        variance = (n_batches - 1) / n_batches * np.sum((a_loo - a_loo.mean(axis=1)[:, None]) ** 2, axis=1)
        with np.errstate(over="ignore"):  # past the largest double: the point is non_finite (sweep.py)
            r_err[rows] = _T975.get(n_batches - 1, 1.96) * np.sqrt(variance) / np.abs(c[rows])
    return r_err


def lyapunov_error(log_stretch, slow_period, period):
    """lyapunov_err of one point (module doc). log_stretch: (m,) per-period log stretches."""
    n_measured = len(log_stretch)
    unit = int(period) if period > 0 else 1
    if n_measured < 2 * unit:
        return np.nan
    if np.isneginf(log_stretch).any():
        return 0.0  # the tangent map collapsed (sticking): lyapunov is -inf, exactly
    n_batches, batch_length = _batches(n_measured, unit)
    used = n_batches * batch_length
    exponents = log_stretch[n_measured - used:].reshape(n_batches, batch_length).sum(axis=1) / (
        batch_length * slow_period)
    return _T975.get(n_batches - 1, 1.96) * np.std(exponents, ddof=1) / np.sqrt(n_batches)


def whole_cycles(m, period):
    """Slow periods in the last whole cycles of an m-period window of a period-p orbit, (m // p) p
    (ints or arrays): its rows m - whole_cycles .. m - 1. R, impacts_per_period and lambda_1 of a
    periodic point are all taken over these rows (motion.whole_cycle_gain, whole_cycle_impacts,
    whole_cycle_exponent), so that the three are the orbit's own and over one window."""
    return (m // period) * period


def whole_cycle_exponent(log_stretch, slow_period, period):
    """The largest exponent over the window's last whole cycles of a period-p orbit: the orbit's
    own, log |mu_1| / (p T) (mu_1 the largest Floquet multiplier of its p-period map). Over the
    whole window a period-p orbit's exponent would count the share of a cycle m mod p adds: at
    g = 10, Omega = 4 (period 3, 8 impacts a cycle, 100 periods) -0.4651 against the orbit's
    -0.4664, as R would be off by 1.6e-2 (motion.whole_cycle_gain). log_stretch: (m,)."""
    whole = whole_cycles(len(log_stretch), period)
    return log_stretch[len(log_stretch) - whole:].sum() / (whole * slow_period)


def complex_pair_exponent(log_stretch, log_area, slow_period, period):
    """A period-p orbit's largest exponent when its two Floquet multipliers are a complex pair:
    log |mu| / (pT) = half the exponents' sum, which the log areas give exactly; None when the
    multipliers are real (or the data say nothing). log_stretch, log_area: (m,) per period.

    One tangent vector rotates with a complex pair, and its mean stretch over the window carries
    a bias of order 1/m that the batches need not see: on x'' + 0.1 x' + x = cos(2.5 t), whose
    exponent is -0.05 exactly, the window's gave -0.04995985 with lyapunov_err 6.7e-6. The area
    of the parallelogram grows by |det M| every cycle, without that bias. The pair is told from
    the per-cycle stretches: against half the per-cycle log area they tend to ln|mu_1 / mu_2| / 2
    > 0 for real multipliers, and swing to both sides for a complex pair."""
    used = whole_cycles(len(log_stretch), period)
    cycles = used // period
    if cycles < 4 or not (np.isfinite(log_stretch).all() and np.isfinite(log_area).all()):
        return None
    stretch = log_stretch[len(log_stretch) - used:].reshape(cycles, period).sum(axis=1)
    area = log_area[len(log_area) - used:].reshape(cycles, period).sum(axis=1)
    swing = (stretch - area / 2)[cycles // 2:]
    rounding = 1e-9 * max(1.0, float(np.abs(area).max()))
    if swing.min() >= -rounding:
        return None  # real multipliers (or a conformal map, where the window's mean is exact too)
    return float(area.sum() / (2 * used * slow_period))


def lyapunov_values(records, summaries, statuses, coefficients, integration, period):
    """lyapunov and lyapunov_err for every point of a chunk (NaN where not ok)."""
    ok = statuses == Status.OK
    lyapunov = summaries[:, kernel.SUM_LYAPUNOV].copy()
    lyapunov_err = np.full(len(lyapunov), np.nan)
    slow_period = coefficients[:, PERIOD]
    measured = window_records(records, integration)
    m = measured.shape[1]
    for i in np.flatnonzero(ok):
        log_stretch = measured[i, :, kernel.REC_LOG_STRETCH]
        lyapunov_err[i] = lyapunov_error(log_stretch, slow_period[i], period[i])
        # a periodic point's exponent is its orbit's: over the last whole cycles, as its R
        # (motion.whole_cycle_gain); a point that stuck keeps -inf (tangent.py)
        if period[i] > 0 and m % period[i] and np.isfinite(lyapunov[i]):
            lyapunov[i] = whole_cycle_exponent(log_stretch, slow_period[i], int(period[i]))
        if period[i] > 0 and np.isfinite(lyapunov[i]):
            log_area = measured[i, :, kernel.REC_LOG_AREA]
            pair = complex_pair_exponent(log_stretch, log_area, slow_period[i], int(period[i]))
            if pair is not None:
                # its band is the batches' of the estimate it stores, half the log area: the one
                # vector's stretch swings with the pair's rotation (0.026 about an exact -0.03)
                lyapunov[i] = pair
                lyapunov_err[i] = lyapunov_error(log_area / 2, slow_period[i], period[i])
    lyapunov[~ok] = np.nan
    return {"lyapunov": lyapunov, "lyapunov_err": lyapunov_err}


def impact_observables(measured, ok, slow_period):
    """What the impacts of the measurement window were, per point (NaN where not ok; speeds and
    phases NaN where it had no impact):

    impact_speed_min, _max, _mean  speeds into the barrier before eq2.2, |v-| (a grazing line on a
                                   map: where impact_speed_min falls to zero, like a square root)
    impact_phase                   circular mean of omega t mod 2 pi over the impacts, in [0, 2 pi)
                                   (omega: the response frequency)
    impact_phase_spread            circular standard deviation sqrt(-2 ln |mean of exp(i omega t)|):
                                   0 when every impact falls at one phase
    stuck_fraction                 fraction of the window's time the mass was stuck: at rest on a
                                   barrier, or sliding on a written model's surface v = c (the
                                   kernel's REC_STUCK_TIME counts both); NaN only where not ok

    measured: (n_points, measure_periods, N_RECORD); ok: (n_points,) bool; slow_period (n_points,).
    """
    impacts = measured[:, :, kernel.REC_IMPACTS].sum(axis=1)
    hit = ok & (impacts > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        # (+ 0.0: an impact on a stop below at v- = +0.0 is logged with the speed -0.0, the kernel's
        # side * v; a speed is written +0)
        speed_min = np.min(measured[:, :, kernel.REC_IMPACT_SPEED_MIN], axis=1) + 0.0
        speed_max = np.max(measured[:, :, kernel.REC_IMPACT_SPEED_MAX], axis=1) + 0.0
        speed_mean = measured[:, :, kernel.REC_IMPACT_SPEED_SUM].sum(axis=1) / impacts + 0.0
        cos_sum = measured[:, :, kernel.REC_IMPACT_COS].sum(axis=1)
        sin_sum = measured[:, :, kernel.REC_IMPACT_SIN].sum(axis=1)
        phase = np.mod(np.arctan2(sin_sum, cos_sum), 2.0 * np.pi)
        resultant = np.minimum(np.hypot(cos_sum, sin_sum) / impacts, 1.0)
        spread = np.sqrt(-2.0 * np.log(resultant))
    stuck = measured[:, :, kernel.REC_STUCK_TIME].sum(axis=1) / (measured.shape[1] * slow_period)
    values = {"impact_speed_min": speed_min, "impact_speed_max": speed_max, "impact_speed_mean": speed_mean,
              "impact_phase": phase, "impact_phase_spread": spread}
    for array in values.values():
        array[~hit] = np.nan
    stuck[~ok] = np.nan
    values["stuck_fraction"] = stuck
    return values


def point_diagnostics(records, statuses, coefficients, frequencies, integration):
    """R_err, stroboscopic samples, period, impacts per cycle, x_min, x_max, the impact observables
    (impact_observables) (NaN/0/-1 if failed). frequencies: (n_points, K), the forcing's
    (models' forcing_frequencies)."""
    measured = window_records(records, integration)
    n_strobe = integration.strobe_periods  # <= measure_periods (config rule)
    ok = statuses == Status.OK
    strobe_x = measured[:, -n_strobe:, kernel.REC_X].copy()
    strobe_v = measured[:, -n_strobe:, kernel.REC_V].copy()
    strobe_x[~ok] = np.nan
    strobe_v[~ok] = np.nan
    period = detect_period(strobe_x, strobe_v, integration.max_period, integration.period_tolerance)
    period[~ok] = 0
    forcing = forcing_periods(coefficients[:, PERIOD], frequencies, measured.shape[1] // 2)
    period = forcing_period_detected(measured, period, forcing, integration.max_period, integration.period_tolerance)
    slow_period = coefficients[:, PERIOD]
    r_err = batch_error(measured, slow_period, coefficients[:, RESPONSE_SCALE],
                        gain_cycles(coefficients, period, measured.shape[1]), ok)
    impacts = measured[:, :, kernel.REC_IMPACTS]  # the last p <= strobe_periods // 2 periods are read
    impacts_per_cycle = np.full(len(period), -1, dtype=np.int64)
    for p in np.unique(period[period > 0]):
        rows = period == p
        impacts_per_cycle[rows] = impacts[rows, -p:].sum(axis=1).astype(np.int64)
    x_min = np.min(measured[:, :, kernel.REC_X_MIN], axis=1)
    x_max = np.max(measured[:, :, kernel.REC_X_MAX], axis=1)
    for array in (r_err, x_min, x_max):
        array[~ok] = np.nan
    return {
        "R_err": r_err,
        "strobe_x": strobe_x,
        "strobe_v": strobe_v,
        "period": period,
        "impacts_per_cycle": impacts_per_cycle,
        "x_min": x_min,
        "x_max": x_max,
        **impact_observables(measured, ok, slow_period),
    }
