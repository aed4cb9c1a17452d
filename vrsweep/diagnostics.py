"""Can R be trusted? Per-point diagnostics from the kernel's per-slow-period records.

All vectorised numpy over the points of a chunk; arrays are (n_points, n_periods, N_RECORD).

- Stroboscopic (Poincare) samples: x and v at t = nT for the last `strobe_periods` periods.
- `period`: the smallest p <= max_period for which those samples repeat with period p
  (to period_tolerance, relative to the orbit's size); 0 when none does (quasi-periodic,
  chaotic, or still transient).
- `R_err`: standard error of R by batch means. The measurement window's m slow periods are
  cut into B = N_BATCHES batches of whole periods (a multiple of `period` when one was found,
  so a periodic orbit gives identical batches); R is computed per batch and
  R_err = t_{0.975, B-1} * std(R_batch, ddof=1) / sqrt(B), a 95% half-width. Consecutive
  batches of a chaotic orbit are nearly independent once a batch spans many periods.
"""

import numpy as np

from vrsweep import kernel
from vrsweep.model import C, OMEGA
from vrsweep.results import Status

N_BATCHES = 10
# 97.5% quantiles of Student's t for B - 1 = 1..9 degrees of freedom (no scipy at run time).
_T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}


def detect_period(strobe_x, strobe_v, max_period, tolerance):
    """Smallest p in 1..max_period with x[k + p] == x[k] and v[k + p] == v[k] to tolerance.

    strobe_x, strobe_v: (n_points, n_strobe). Needs at least 2p samples to call p a period.
    Returns int64 (n_points,), 0 where none.
    """
    n_points, n_strobe = strobe_x.shape
    scale_x = np.maximum(1.0, np.nanmax(np.abs(strobe_x), axis=1, initial=0.0))
    scale_v = np.maximum(1.0, np.nanmax(np.abs(strobe_v), axis=1, initial=0.0))
    period = np.zeros(n_points, dtype=np.int64)
    for p in range(1, min(max_period, n_strobe // 2) + 1):
        dx = np.max(np.abs(strobe_x[:, p:] - strobe_x[:, :-p]), axis=1) / scale_x
        dv = np.max(np.abs(strobe_v[:, p:] - strobe_v[:, :-p]), axis=1) / scale_v
        repeats = (dx <= tolerance) & (dv <= tolerance) & (period == 0)
        period[repeats] = p
    return period


def batch_error(records, n_transient, slow_period, c, period):
    """95% half-width of R from batch means over the measurement window (see module doc)."""
    n_points, n_periods, _ = records.shape
    n_measured = n_periods - n_transient
    r_err = np.full(n_points, np.nan)
    sin_part = records[:, n_transient:, kernel.REC_QS]
    cos_part = records[:, n_transient:, kernel.REC_QC]
    for i in range(n_points):
        unit = int(period[i]) if period[i] > 0 else 1
        batch_length = (n_measured // N_BATCHES // unit) * unit
        n_batches = N_BATCHES
        if batch_length == 0:  # short window: batches of one cycle each
            batch_length = unit
            n_batches = n_measured // unit
        if n_batches < 2:
            continue
        used = n_batches * batch_length
        # The last `used` periods: the end of the window is the most settled part.
        qs = sin_part[i, n_measured - used:].reshape(n_batches, batch_length).sum(axis=1)
        qc = cos_part[i, n_measured - used:].reshape(n_batches, batch_length).sum(axis=1)
        window = batch_length * slow_period[i]
        r_batch = 2.0 * np.hypot(qs, qc) / window / c[i]  # eq3.1-eq3.3 per batch
        t_quantile = _T975.get(n_batches - 1, 1.96)
        r_err[i] = t_quantile * np.std(r_batch, ddof=1) / np.sqrt(n_batches)
    return r_err


def point_diagnostics(records, statuses, coefficients, integration):
    """R_err, stroboscopic samples, period, impacts per cycle, x_min, x_max (NaN/-1 if failed)."""
    n_transient = integration.transient_periods
    n_strobe = integration.strobe_periods
    ok = statuses == Status.OK
    strobe_x = records[:, -n_strobe:, kernel.REC_X].copy()
    strobe_v = records[:, -n_strobe:, kernel.REC_V].copy()
    strobe_x[~ok] = np.nan
    strobe_v[~ok] = np.nan
    period = detect_period(strobe_x, strobe_v, integration.max_period, integration.period_tolerance)
    period[~ok] = 0
    slow_period = 2.0 * np.pi / coefficients[:, OMEGA]
    r_err = batch_error(records, n_transient, slow_period, coefficients[:, C], period)
    impacts_last = records[:, :, kernel.REC_IMPACTS]
    impacts_per_cycle = np.full(len(period), -1, dtype=np.int64)
    for p in np.unique(period[period > 0]):
        rows = period == p
        impacts_per_cycle[rows] = impacts_last[rows, -p:].sum(axis=1).astype(np.int64)
    measured = records[:, n_transient:]
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
    }
