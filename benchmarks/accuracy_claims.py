"""R's error against rtol, per method and model, over a spread of points: the worst case, which is
what docs/accuracy.md claims.

    python benchmarks/accuracy_claims.py            (about a minute on one core)

Points: bench_speed.py's nine (the paper's Fig. 1 and 2 parameters, the effective model,
off-paper parameters), the two points where a user found the claim "dop853 at rtol 1e-6 gives five
digits" wrong (original model, Omega = 5, g = 45, period 6; Omega = 4, g = 35, period 1), a
long-period point and a chaotic one. 100 + 100 periods each, atol = rtol / 100.

The converged R of a point is vrsweep's dop853 at rtol 1e-13; rk45 at 1e-12 is printed beside it
(their difference bounds the reference's own error). A point is *periodic* when its stroboscopic
state repeats to 1e-6 in the last 16 periods (analysis.diagnostics.detect_period) in the reference
run; on a chaotic point no tolerance converges R (docs/trust.md), and it is listed but left out of
the worst case.

Prints, per model and method: the worst relative error of R over the periodic points at each rtol,
and the loosest rtol from which every periodic point has R within 1e-5 (five digits) at that and
every tighter rtol. CHECKS below are the claims of docs/accuracy.md; the script fails (exit 1) if a
measured number breaks one.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_speed import PAPER, POINTS, V0  # noqa: E402
from vrsweep.analysis.diagnostics import detect_period  # noqa: E402
from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.model import kernel_coefficients  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402
from vrsweep.results import Status  # noqa: E402

EXTRA_POINTS = [
    ("original, g = 45, Omega = 5 (period 6; the issue's)", "original", dict(PAPER, g=45.0, Omega=5.0), 0.99),
    ("original, g = 35, Omega = 4 (period 1; the issue's)", "original", dict(PAPER, g=35.0), 0.99),
    ("original, g = 17.85, Omega = 4 (period 7)", "original", dict(PAPER, g=17.85), 0.99),
    ("original, g = 5, Omega = 4 (chaotic)", "original", dict(PAPER, g=5.0), 0.99),
]
RTOLS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]
FIVE_DIGITS = 1e-5
PERIODS = 100
# The claims docs/accuracy.md makes, checked against this run: (model, method, rtol) -> the worst
# relative error of R over the periodic points must not exceed the bound.
CHECKS = {
    ("original", "dop853", 1e-8): FIVE_DIGITS,
    ("effective", "dop853", 1e-6): FIVE_DIGITS,
    ("original", "rk45", 1e-9): FIVE_DIGITS,
    ("effective", "rk45", 1e-6): FIVE_DIGITS,
}


def r_of(model, parameters, x0, method, rtol):
    coefficients = kernel_coefficients(parameters, model)
    settings = settings_vector(rtol=rtol, atol=rtol / 100, transient_periods=PERIODS, measure_periods=PERIODS)
    run = simulate(coefficients, [x0, V0], settings, method=method)
    return run


def main():
    points = [(label, model, parameters, x0) for label, model, parameters, x0, _ in POINTS] + EXTRA_POINTS
    errors = {}  # (model, method) -> {rtol: [relative errors over periodic points]}
    times = {}   # (model, method) -> {rtol: [CPU seconds of the calling thread per point]}
    rows = []
    for label, model, parameters, x0 in points:
        reference = r_of(model, parameters, x0, "dop853", 1e-13)
        check = r_of(model, parameters, x0, "rk45", 1e-12)
        strobe = reference.period_records[-16:]
        period = int(detect_period(strobe[None, :, kernel.REC_X], strobe[None, :, kernel.REC_V], 8, 1e-6)[0])
        r_ref = reference.summary[kernel.SUM_R]
        periodic = reference.status == Status.OK and period > 0
        line = {"label": label, "period": period, "R": r_ref,
                "reference_spread": abs(check.summary[kernel.SUM_R] - r_ref) / abs(r_ref)}
        for method in ("rk45", "dop853"):
            for rtol in RTOLS:
                began = time.thread_time()
                run = r_of(model, parameters, x0, method, rtol)
                spent = time.thread_time() - began
                error = abs(run.summary[kernel.SUM_R] - r_ref) / abs(r_ref) if run.status == Status.OK else math.inf
                line[method, rtol] = error
                if periodic:
                    errors.setdefault((model, method), {}).setdefault(rtol, []).append(error)
                    times.setdefault((model, method), {}).setdefault(rtol, []).append(spent)
        rows.append(line)
        print(f"{label:58s} period {period}  R = {r_ref:.8g}  (rk45 1e-12 differs by {line['reference_spread']:.1e})",
              flush=True)
        for method in ("rk45", "dop853"):
            print(f"    {method:6s} " + "  ".join(f"{rtol:.0e}: {line[method, rtol]:.1e}" for rtol in RTOLS), flush=True)

    print("\nWorst relative error of R over the periodic points, by rtol (five digits: <= 1e-5)")
    print(f"{'model, method':22s} " + " ".join(f"{rtol:>8.0e}" for rtol in RTOLS) + "   loosest rtol for 5 digits")
    failures = []
    for (model, method), by_rtol in sorted(errors.items()):
        worst = [max(by_rtol[rtol]) for rtol in RTOLS]
        loosest = None
        for index in range(len(RTOLS)):
            if all(w <= FIVE_DIGITS for w in worst[index:]):
                loosest = RTOLS[index]
                break
        print(f"{model + ', ' + method:22s} " + " ".join(f"{w:8.1e}" for w in worst)
              + f"   {loosest if loosest is not None else 'none'}  ({len(by_rtol[RTOLS[0]])} points)")
        mean_ms = [1e3 * math.exp(np.mean(np.log(times[model, method][rtol]))) for rtol in RTOLS]
        print(f"{'  ms per point (geo.)':22s} " + " ".join(f"{t:8.1f}" for t in mean_ms))
        for (c_model, c_method, rtol), bound in CHECKS.items():
            if (c_model, c_method) == (model, method) and max(by_rtol[rtol]) > bound:
                failures.append(f"{model} {method} rtol {rtol:g}: worst {max(by_rtol[rtol]):.2e} > {bound:g}")
    if failures:
        print("\nCLAIMS BROKEN:\n  " + "\n  ".join(failures))
        return 1
    print("\nEvery claim of docs/accuracy.md (CHECKS) holds.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
