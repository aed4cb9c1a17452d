"""A digest of every result of bench_speed.py's nine points, to show two versions compute the same.

Run with each version's sources first on the path and compare the printed digests:
    PYTHONPATH=/path/to/old python benchmarks/same_results.py
    PYTHONPATH=/path/to/new python benchmarks/same_results.py

For each point, method (rk45, dop853) and rtol (1e-4, 1e-6, 1e-9), 100 + 100 periods: the bytes
of the whole summary (R, Qs, Qc, step, rejection, RHS and impact counts, the final state) and of
every period's record (impacts, quadratures, stroboscopic state, x_min, x_max). One digest for
all 54 runs, and one per point. Equal digests: bit for bit the same results.
"""

import hashlib
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
if os.environ.get("PYTHONPATH") is None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

import vrsweep  # noqa: E402
from bench_speed import POINTS, V0  # noqa: E402
from vrsweep.numerics.model import kernel_coefficients  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402


# The summary's slots compared: those of version 0.2.0 (R ... SUM_LYAPUNOV_SUM). The slots added
# since (the transparent window's and the highest smooth maximum's, continuation's observers) are
# -inf/NaN in a sweep, and comparing them would fail on the layout alone.
COMPARED_SUMMARY = 15
# Likewise the record's columns of 0.2.0 (impacts ... REC_LOG_AREA); the impact observables added
# in 0.5.0 (REC_IMPACT_SPEED_MIN ...) are new columns, not changed ones.
COMPARED_RECORD = 10


def main():
    total = hashlib.sha1()
    print(f"vrsweep from {Path(vrsweep.__file__).parent}")
    for label, model, parameters, x0, _ in POINTS:
        point = hashlib.sha1()
        coefficients = kernel_coefficients(parameters, model)
        for method in ("rk45", "dop853"):
            for rtol in (1e-4, 1e-6, 1e-9):
                settings = settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=100, measure_periods=100)
                run = simulate(coefficients, [x0, V0], settings, method=method)
                for array in (run.summary[:COMPARED_SUMMARY], np.ascontiguousarray(run.period_records[:, :COMPARED_RECORD])):
                    point.update(array.tobytes())
                    total.update(array.tobytes())
        print(f"  {point.hexdigest()[:16]}  {label}")
    print(f"all 54 runs: {total.hexdigest()}")


if __name__ == "__main__":
    main()
