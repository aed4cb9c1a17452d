"""R's error against the window's length N: the plain average, the weighted Birkhoff average and
what vrsweep stores (analysis/motion.py), for a periodic, a quasi-periodic and a chaotic point of
the original model, against a 10x longer reference run (docs/accuracy.md, "R's error against the
window").

    python benchmarks/birkhoff.py          (about half a minute on one core)

Each point runs once: 100 transient periods, then 10 x 400 measured ones (rk45, rtol 1e-9). The
windows of N periods are the first N measured ones. The reference is the estimator that suits
the point over all 4000 periods: the whole-cycle plain average for the periodic point, the
weighted average for the quasi-periodic one, the plain average for the chaotic one (whose R is a
random draw at any N: its "error" is the distance between two draws, to compare with R_err).
Prints one table per point: N, the motion vrsweep calls it, the error of each estimator, R_err.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vrsweep.analysis import motion  # noqa: E402
from vrsweep.analysis.diagnostics import detect_period, r_error  # noqa: E402
from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.coefficients import PERIOD, RESPONSE_SCALE  # noqa: E402
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402

TRANSIENT = 100
LONGEST = 400
POINTS = {
    "periodic (Omega = 4, g = 10: period 3)": {"Omega": 4.0, "g": 10.0},
    "quasi-periodic (Omega = 3 + sqrt(2)/2, g = 25)": {"Omega": 3.0 + 0.5 * math.sqrt(2.0), "g": 25.0},
    "chaotic (Omega = 4, g = 5)": {"Omega": 4.0, "g": 5.0},
}
WINDOWS = (25, 50, 100, 200, 400)


def records_of(parameters):
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, **parameters), "original")
    settings = settings_vector(rtol=1e-9, atol=1e-11, transient_periods=TRANSIENT,
                               measure_periods=10 * LONGEST, max_steps=10**9)
    result = simulate(coefficients, np.array([0.1, 0.0]), settings)
    return result.period_records[TRANSIENT:], coefficients


def plain_gain(rows, slow_period, c):
    return 2.0 * math.hypot(rows[:, kernel.REC_QS].mean(), rows[:, kernel.REC_QC].mean()) / slow_period / c


def stored(rows, coefficients):
    """R, R_err and the motion vrsweep stores for a window ``rows`` (m, N_RECORD)."""
    measured = rows[np.newaxis]
    period = detect_period(rows[np.newaxis, -16:, kernel.REC_X], rows[np.newaxis, -16:, kernel.REC_V], 8, 1e-6)
    slow_period, c = coefficients[PERIOD], coefficients[RESPONSE_SCALE]
    values = {"R": np.array([plain_gain(rows, slow_period, c)]),
              "R_err": np.array([r_error(rows[:, kernel.REC_QS], rows[:, kernel.REC_QC], slow_period, c, period[0])]),
              "Qs": np.zeros(1), "Qc": np.zeros(1), "Q_amplitude": np.zeros(1), "period": period}
    values = motion.motion_values(values, measured, np.zeros(1, dtype=np.int8), coefficients[np.newaxis])
    return values["R"][0], values["R_err"][0], motion.Motion(int(values["motion"][0])).name.lower()


def main():
    for name, parameters in POINTS.items():
        records, coefficients = records_of(parameters)
        slow_period, c = coefficients[PERIOD], coefficients[RESPONSE_SCALE]
        if name.startswith("periodic"):
            whole = (len(records) // 3) * 3
            reference = plain_gain(records[:whole], slow_period, c)
        elif name.startswith("quasi"):
            reference = motion.quasi_periodic_gain(records[np.newaxis], coefficients[np.newaxis])["R"][0]
        else:
            reference = plain_gain(records, slow_period, c)
        print(f"\n{name}: reference R = {reference:.10g} over {len(records)} periods")
        print(f"{'N':>5} {'motion':>15} {'plain':>9} {'weighted':>9} {'stored':>9} {'R_err':>9}   (|R - reference| / reference)")
        for n in WINDOWS:
            rows = records[:n]
            weighted = motion.quasi_periodic_gain(rows[np.newaxis], coefficients[np.newaxis])["R"][0]
            r, r_err, kind = stored(rows, coefficients)
            relative = lambda value: abs(value - reference) / reference  # noqa: E731
            print(f"{n:>5} {kind:>15} {relative(plain_gain(rows, slow_period, c)):9.1e} {relative(weighted):9.1e} "
                  f"{relative(r):9.1e} {r_err / reference:9.1e}")


if __name__ == "__main__":
    main()
