"""Cost per step and per point of the dop853 kernel, for changing one thing at a time (issue 23).

Run:  python benchmarks/kernel_cost.py [--repeats N]

Not a comparison with another solver (bench_speed.py does that): it prints, for two of
bench_speed's points at the rtol it finds for dop853 (original g = 10 and effective g = 25,
rtol 1e-4, start (0.99, 0.5)), the calling thread's CPU time (best of N) of
- the kernel called directly with the arrays a sweep passes (no logs), at 1 + 1 and 100 + 100
  periods: ns per step and per RHS evaluation, and the fixed part per point (by the two lengths);
- trajectory.simulate as bench_speed calls it (impact_capacity 100 000), at 1 + 1 and 100 + 100;
- the step and RHS counts and R, which must not change for a change that keeps results bit for bit.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402

PAPER = dict(DEFAULT_PARAMETERS, Omega=4.0)
POINTS = [("original g = 10", "original", dict(PAPER, g=10.0)),
          ("effective g = 25", "effective", dict(PAPER, g=25.0))]


def best(run, repeats):
    times = []
    for _ in range(repeats):
        start = time.thread_time()
        run()
        times.append(time.thread_time() - start)
    return min(times)


def direct(method, coefficients, settings):
    n_periods = int(settings[kernel.TRANSIENT_PERIODS] + settings[kernel.MEASURE_PERIODS])
    integrate = kernel.integrator(method)
    initial = np.array([0.99, 0.5])
    summary = np.full(kernel.N_SUMMARY, np.nan)
    empty1 = np.empty(0)
    empty2 = np.empty((0, 2))
    empty3 = np.empty((0, 3))

    def run():
        records = np.empty((int(settings[kernel.MEASURE_PERIODS]), kernel.N_RECORD))
        integrate(coefficients, initial, settings, records, summary, empty1, empty2, empty3, empty2)
        return summary
    return run


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--method", default="dop853")
    args = parser.parse_args()
    for label, model, parameters in POINTS:
        coefficients = kernel_coefficients(parameters, model)
        figures = {}
        for periods in (1, 100):
            settings = settings_vector(rtol=1e-4, atol=1e-6, transient_periods=periods, measure_periods=periods)
            run = direct(args.method, coefficients, settings)
            summary = run().copy()
            figures[periods] = (best(run, args.repeats),
                                best(lambda: simulate(coefficients, [0.99, 0.5], settings, impact_capacity=100_000,
                                                      method=args.method), args.repeats),
                                summary)
        (k1, s1, sum1), (k100, s100, sum100) = figures[1], figures[100]
        steps = sum100[kernel.SUM_STEPS] - sum1[kernel.SUM_STEPS]
        rhs = sum100[kernel.SUM_RHS] - sum1[kernel.SUM_RHS]
        per_step = (k100 - k1) / steps
        fixed = k1 - per_step * sum1[kernel.SUM_STEPS]
        print(f"{label}: {int(sum100[kernel.SUM_STEPS])} steps, {int(sum100[kernel.SUM_RHS])} RHS, "
              f"R = {sum100[kernel.SUM_R]!r}")
        print(f"  kernel: {k100 * 1e3:.3f} ms (100 + 100), {k1 * 1e3:.4f} ms (1 + 1); "
              f"{per_step * 1e9:.0f} ns/step, {(k100 - k1) / rhs * 1e9:.1f} ns/RHS, fixed {fixed * 1e3:.4f} ms")
        print(f"  simulate: {s100 * 1e3:.3f} ms (100 + 100), {s1 * 1e3:.4f} ms (1 + 1): "
              f"{(s100 - k100) * 1e3:+.4f} / {(s1 - k1) * 1e3:+.4f} ms over the kernel")


if __name__ == "__main__":
    main()
