"""Cost of continuation against a sweep point of the same settings, and of a whole branch.

    PYTHONPATH=. python benchmarks/bench_continuation.py [--method rk45|dop853]

The case is the README's hysteresis example (effective model, gamma = alpha = 0.05, Omega = 4)
at rtol 1e-10, atol 1e-12, continued in g from 23 over [20, 27]. Baseline, measured in the same
run: one sweep point of the same settings (100 transient + 100 measured slow periods, the
config's defaults), i.e. what `vrsweep run` spends per grid point. Times are the calling
thread's CPU time, best of 3, after a warm-up call that compiles (or loads) every kernel.

Then period-doubling branch switching (--switch) on the original model's cascade at Fig. 1's
parameters (Omega = 4), rtol 1e-12, atol 1e-14 (docs/continuation.md): the period-2 branch over
[17.8255, 17.87] from g = 17.86 and the period-4 branch switched at its doubling (g = 17.833),
against a sweep point of the original model at the same settings.

Last, grazes of orbits that keep other impacts (the transparent window, analysis/grazing.py):
the period-3 orbit of Fig. 1's parameters at rtol 1e-10, from g = 17.7 (10 impacts in 3 periods)
down over [17.55, 17.8] through its grazes 9 -> 10 and 8 -> 9, and locating one of them alone
(Newton on the windowed map, from the orbit next to it).
"""

import argparse

from vrsweep.analysis import continuation, grazing
from vrsweep.analysis import switching as branch_switching
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.shooting import periodic_map
from vrsweep.numerics.trajectory import settings_vector, simulate

if __package__:  # python -m benchmarks.NAME, or imported
    from ._timing import best_of
else:  # python benchmarks/NAME.py: this folder is first on sys.path
    from _timing import best_of

PARAMETERS = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, Omega=4.0, g=23.0)


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
    # Crossing the graze: from the last free orbit before it (locate on the barrier-free map,
    # probe, normal-form predictor, corrector).
    graze = next(b.orbit for b in bifurcations if b.kind == "grazing")
    near = min((o for o in branch.orbits if o.impacts_per_period == 0 and not o.stable),
               key=lambda o: abs(o.parameter - graze.parameter))
    crossing, (_, beyond, _, _, _) = best_of(lambda: continuation.cross_grazing(problem, near, continuation.tangent_of(near)))
    assert beyond is not None
    print(f"method {method}, rtol 1e-10")
    print(f"sweep point (100 + 100 periods)          {1e3 * sweep_point:8.2f} ms   1.00x")
    print(f"P and its monodromy (1 period)           {1e3 * one_map:8.3f} ms   {one_map / sweep_point:.3f}x")
    print(f"continuation point (step 0.1, {orbit.newton_iterations} Newton)     "
          f"{1e3 * one_point:8.2f} ms   {one_point / sweep_point:.3f}x")
    print(f"crossing the graze (locate, probe, correct)   {1e3 * crossing:8.2f} ms   {crossing / sweep_point:.3f}x")
    print(f"whole branch: {n} points, {len(bifurcations)} bifurcations located   "
          f"{1e3 * whole:8.1f} ms   {whole / sweep_point:.2f}x  ({1e3 * whole / n:.2f} ms per point)")
    print("bifurcations:", ", ".join(f"{b.kind} g = {b.orbit.parameter:.6f}" for b in bifurcations))
    switching(method)
    multi_impact(method)


def _original_model_at(g, rtol, max_step, max_period, method):
    """(problem, the orbit found from the paper's start at g, a sweep point's time there): the
    original model at Fig. 1's parameters (Omega = 4), continued in g."""
    parameters = dict(DEFAULT_PARAMETERS, Omega=4.0, g=g)
    settings = settings_vector(rtol=rtol, atol=rtol * 1e-2)
    coefficients = kernel_coefficients(parameters, "original")
    problem = continuation.ContinuationProblem(parameters, "original", "g", settings, method,
                                               dict(continuation.DEFAULTS, max_step=max_step))
    start = continuation.find_start(problem, [0.99, 0.5], g, 300, max_period)  # warm-up: compiles
    sweep_point, _ = best_of(lambda: simulate(coefficients, start.state, settings, method=method))
    return problem, start, sweep_point


def switching(method):
    problem, start, sweep_point = _original_model_at(17.86, 1e-12, 0.3, 16, method)
    whole, (branch, bifurcations) = best_of(
        lambda: continuation.continue_branch(problem, start, 17.8255, 17.87, 40), repeats=1)
    switched, (branches, _, failures) = best_of(
        lambda: branch_switching.switch_all(problem, branch, bifurcations, 17.8255, 17.87, 40, 4), repeats=1)
    assert len(branches) == 2 and not failures, failures
    n, m = len(branch.orbits), len(branches[1].orbits)
    print(f"original model, Omega = 4, method {method}, rtol 1e-12")
    print(f"sweep point (100 + 100 periods)          {1e3 * sweep_point:8.2f} ms   1.00x")
    print(f"period-2 branch: {n} points              {1e3 * whole:8.1f} ms   {whole / sweep_point:.2f}x  "
          f"({1e3 * whole / n:.2f} ms per point)")
    print(f"switched period-4 branch: {m} points     {1e3 * switched:8.1f} ms   {switched / sweep_point:.2f}x  "
          f"({1e3 * switched / m:.2f} ms per point)")


def multi_impact(method):
    problem, start, sweep_point = _original_model_at(17.7, 1e-10, 0.05, 8, method)
    whole, (orbits, found, _) = best_of(
        lambda: continuation.follow(problem, start, -1, 17.55, 17.8, 40), repeats=1)
    grazes = [orbit for kind, orbit in found if kind == "grazing"]
    assert len(grazes) == 2, found
    # The 9 -> 10 graze alone, from the 10-impact orbit next to it (its impact about to stop).
    side, window = grazing.graze_site(problem, continuation.evaluate(problem, orbits[0].state, orbits[0].parameter, 3),
                                      orbits[0].parameter, 3, 1.0)
    locate, graze = best_of(lambda: grazing.locate_graze(problem, orbits[0].z, 3, 1e-8, window))
    assert graze is not None
    n = len(orbits)
    print(f"original model, period-3 orbit, Omega = 4, method {method}, rtol 1e-10")
    print(f"sweep point (100 + 100 periods)          {1e3 * sweep_point:8.2f} ms   1.00x")
    print(f"branch through 2 grazes: {n} points      {1e3 * whole:8.1f} ms   {whole / sweep_point:.2f}x  "
          f"(at g = {', '.join(f'{g.parameter:.6f}' for g in grazes)})")
    print(f"one graze located ({side} side, window {window[1] - window[0]:.3f} long, {graze.iterations} Newton) "
          f"{1e3 * locate:8.2f} ms   {locate / sweep_point:.2f}x")


if __name__ == "__main__":
    main()
