"""Cost of continuation against a sweep point of the same settings, and of a whole branch.

    PYTHONPATH=. python benchmarks/bench_continuation.py [--method rk45|dop853]

The case is the README's hysteresis example (effective model, gamma = alpha = 0.05, Omega = 4)
at rtol 1e-10, atol 1e-12, continued in g from 23 over [20, 27]. Baseline, measured in the same
run: one sweep point of the same settings (100 transient + 100 measured slow periods, the
config's defaults), i.e. what `vrsweep run` spends per grid point. Times are the calling
thread's CPU time, best of 3, after a warm-up call that compiles (or loads) every kernel.
"""

import argparse
import time

from vrsweep.analysis import continuation
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.shooting import periodic_map
from vrsweep.numerics.trajectory import settings_vector, simulate

PARAMETERS = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, Omega=4.0, g=23.0)


def best_of(function, repeats=3):
    times = []
    for _ in range(repeats):
        start = time.thread_time()
        result = function()
        times.append(time.thread_time() - start)
    return min(times), result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="rk45", choices=("rk45", "dop853"))
    method = parser.parse_args().method
    settings = settings_vector(rtol=1e-10, atol=1e-12)
    coefficients = kernel_coefficients(PARAMETERS, "effective")
    problem = continuation.ContinuationProblem(PARAMETERS, "effective", "g", settings, method,
                                               dict(continuation.DEFAULTS, max_step=0.3))
    start = continuation.find_start(problem, [0.0, 0.0], 23.0, 200, 16)  # warm-up: compiles
    simulate(coefficients, [0.0, 0.0], settings, method=method)

    sweep_point, _ = best_of(lambda: simulate(coefficients, start.state, settings, method=method))
    one_map, _ = best_of(lambda: periodic_map(coefficients, start.state, settings, 1, method))
    z = start.z
    tangent = continuation.tangent_of(start)
    predicted = z + 0.1 * tangent
    one_point, (orbit, failure) = best_of(
        lambda: continuation.correct(problem, predicted, 1, tangent, predicted))
    assert failure is None, failure
    whole, (branch, bifurcations) = best_of(
        lambda: continuation.continue_branch(problem, start, 20.0, 27.0, 400), repeats=1)
    n = len(branch.orbits)
    print(f"method {method}, rtol 1e-10")
    print(f"sweep point (100 + 100 periods)          {1e3 * sweep_point:8.2f} ms   1.00x")
    print(f"P and its monodromy (1 period)           {1e3 * one_map:8.3f} ms   {one_map / sweep_point:.3f}x")
    print(f"continuation point (step 0.1, {orbit.newton_iterations} Newton)     "
          f"{1e3 * one_point:8.2f} ms   {one_point / sweep_point:.3f}x")
    print(f"whole branch: {n} points, {len(bifurcations)} bifurcations located   "
          f"{1e3 * whole:8.1f} ms   {whole / sweep_point:.2f}x  ({1e3 * whole / n:.2f} ms per point)")
    print("bifurcations:", ", ".join(f"{b.kind} g = {b.orbit.parameter:.6f}" for b in bifurcations))


if __name__ == "__main__":
    main()
