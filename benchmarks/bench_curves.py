"""Cost of a bifurcation-curve point against a branch point in the same run, and of whole curves.

    PYTHONPATH=. python benchmarks/bench_curves.py [--method rk45|dop853]

The case is the README's hysteresis example (effective model, gamma = alpha = 0.05, Omega = 4) at
rtol 1e-10, atol 1e-12: its branch in g from 24 over [23.5, 25.4] gives the fold (g = 25.2675)
and the graze of the unstable orbit (g = 25.0849), each followed in Omega over [3.6, 4.4] (g
within [15, 40]) with max_step 0.3. Baseline, measured in the same run: one point of the
one-parameter continuation (arclength step 0.1), and one sweep point of the same settings (100
transient + 100 measured slow periods). Times are the calling thread's CPU time, best of 3, after
warm-up calls that compile (or load) every kernel.
"""

import argparse

import numpy as np

from vrsweep.analysis import continuation, curves
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.trajectory import settings_vector, simulate

if __package__:  # python -m benchmarks.NAME, or imported
    from ._timing import best_of
else:  # python benchmarks/NAME.py: this folder is first on sys.path
    from _timing import best_of

PARAMETERS = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, Omega=4.0, g=24.0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="rk45", choices=("rk45", "dop853"))
    method = parser.parse_args().method
    settings = settings_vector(rtol=1e-10, atol=1e-12)
    options = dict(continuation.DEFAULTS, max_step=0.3)
    problem = continuation.ContinuationProblem(PARAMETERS, "effective", "g", settings, method, options)
    start = continuation.find_start(problem, [0.0, 0.0], 24.0, 200, 16)  # warm-up: compiles
    _, bifurcations = continuation.continue_branch(problem, start, 23.5, 25.4, 60)
    found = {b.kind: b.orbit for b in bifurcations}
    coefficients = kernel_coefficients(PARAMETERS, "effective")
    simulate(coefficients, [0.0, 0.0], settings, method=method)

    sweep_point, _ = best_of(lambda: simulate(coefficients, start.state, settings, method=method))
    tangent = continuation.tangent_of(start)
    predicted = start.z + 0.1 * tangent
    branch_point, (orbit, failure) = best_of(lambda: continuation.correct(problem, predicted, 1, tangent, predicted))
    assert failure is None, failure

    print(f"method {method}, rtol 1e-10")
    print(f"sweep point (100 + 100 periods)                 {1e3 * sweep_point:8.2f} ms   {1.0:8.3f}x sweep")
    print(f"branch point (step 0.1, {orbit.newton_iterations} Newton)                 {1e3 * branch_point:8.2f} ms"
          f"   {branch_point / sweep_point:8.3f}x sweep   1.00x branch point")
    for kind in ("fold", "grazing"):
        curve_problem = curves.CurveProblem(dict(PARAMETERS), "effective", ("g", "Omega"), settings, method, options)
        bifurcation = found[kind]
        first, failure = curves.start_point(curve_problem, kind, bifurcation.state, [bifurcation.parameter, 4.0], 1)
        assert failure is None, failure
        curve_tangent = curves.tangent_of(first)
        predicted = first.z + 0.1 * curve_tangent
        one, (point, failure) = best_of(lambda: curves.correct(curve_problem, kind, predicted, 1, curve_tangent,
                                                               predicted))
        assert failure is None, failure
        whole, (curve, specials) = best_of(
            lambda: curves.continue_curve(curve_problem, kind, first, ((15.0, 40.0), (3.6, 4.4)), 400), repeats=1)
        n = len(curve.points)
        omega = np.array([p.values[1] for p in curve.points])
        print(f"{kind} curve point (step 0.1, {point.newton_iterations} Newton)        {1e3 * one:8.2f} ms"
              f"   {one / sweep_point:8.3f}x sweep   {one / branch_point:.2f}x branch point")
        print(f"whole {kind} curve: {n} points, Omega {omega.min():.3f}-{omega.max():.3f}   {1e3 * whole:8.1f} ms"
              f"   {whole / sweep_point:8.2f}x sweep   ({1e3 * whole / n:.2f} ms per point)")


if __name__ == "__main__":
    main()
