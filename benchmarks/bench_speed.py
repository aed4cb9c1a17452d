"""vrsweep's methods against heyoka and a SciPy solve_ivp loop; thread scaling; compile time.

Run:  python benchmarks/bench_speed.py [--quick] [--periods N] [--no-scipy]
      (heyoka is optional: pip install -e ".[bench]")

Everything is measured in this one run and printed as ratios against the baselines measured
alongside it; nothing is compared with figures from another machine.

1. Per point, one thread, N transient + N measured slow periods (default 100 + 100): each solver
   at the loosest tolerance from which R stays within 1e-5 (relative) of a converged value at
   that and every tighter tolerance of the list (so that no lucky loose tolerance counts). The
   converged value is vrsweep's dop853 at rtol 1e-13; vrsweep's rk45 at 1e-12 and heyoka at 1e-15
   are printed beside it as a check. Solvers:
   - vrsweep rk45 and dop853 (integration.method);
   - heyoka (Taylor integrator, LLVM-compiled, events on its step polynomial), a terminal event
     at x = Delta whose callback applies eq2.2 and continues; the Fourier quadratures are states
     reset at the start of the window; the integrator is built once per tolerance outside the
     timing, as a sweep would (its build time is printed);
   - SciPy DOP853 with a terminal event and a restart at every impact (tests/reference.py), on
     the paper's points only (it takes seconds per run).
   Times are the calling thread's CPU time (time.thread_time), best of 3 (SciPy: one run): the
   machine may be shared, and CPU time is less disturbed by other jobs than wall time.
2. Points per second on 1 and 2 threads over a 64-point grid (original model, g in [0, 40]), for
   each method, alternating 1- and 2-thread runs.
3. First call in a fresh process, per method: empty numba cache (compile) and warm cache.
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from reference import reference_run  # noqa: E402  (the SciPy loop)

from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.model import (  # noqa: E402
    ALPHA, BIG_OMEGA, C, DEFAULT_PARAMETERS, DELTA, E, G, GAMMA, MU, OMEGA, STIFFNESS, kernel_coefficients,
)
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402

METHODS = tuple(kernel.INTEGRATORS)
PAPER = dict(DEFAULT_PARAMETERS, Omega=4.0)
# (label, model, parameters, x(0), run SciPy too). R must be a property of the system there
# (periodic orbits: R at rtol 1e-11 and 1e-13 agrees to < 1e-9), and nothing sticks (heyoka's
# loop below has no sticking). The first five are the issue's; the last four are off the paper.
POINTS = [
    ("original, g = 10, Omega = 4 (period 3)", "original", dict(PAPER, g=10.0), 0.99, True),
    ("original, g = 30, Omega = 4 (period 1)", "original", dict(PAPER, g=30.0), 0.99, True),
    ("original, g = 28, Omega = 5 (period 3)", "original", dict(PAPER, g=28.0, Omega=5.0), 0.99, True),
    ("effective, g = 25, Omega = 4 (no impacts)", "effective", dict(PAPER, g=25.0), 0.99, False),
    ("original, g = 12, Omega = 4, Delta = 0.8, x(0) = 0.7", "original", dict(PAPER, g=12.0, Delta=0.8), 0.7, False),
    ("off-paper: original, e = 0.7, g = 10", "original", dict(PAPER, g=10.0, e=0.7), 0.99, False),
    ("off-paper: original, gamma = 0.4, g = 10", "original", dict(PAPER, g=10.0, gamma=0.4), 0.99, False),
    ("off-paper: original, Delta = 1.3, g = 30", "original", dict(PAPER, g=30.0, Delta=1.3), 0.99, False),
    ("off-paper: effective, e = 0.7, g = 15", "effective", dict(PAPER, g=15.0, e=0.7), 0.99, False),
]
RTOLS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
SCIPY_RTOLS = [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]  # tighter costs SciPy tens of seconds a run
AGREEMENT = 1e-5  # relative, on R
V0 = 0.5


def _best_cpu_time(run, repeats):
    best, result = math.inf, None
    for _ in range(repeats):
        start = time.thread_time()
        result = run()
        best = min(best, time.thread_time() - start)
    return result, best


def vrsweep_solver(method):
    def solve(model, parameters, x0, rtol, periods, repeats=3):
        settings = settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=periods, measure_periods=periods)
        coefficients = kernel_coefficients(parameters, model)
        run, seconds = _best_cpu_time(
            lambda: simulate(coefficients, [x0, V0], settings, impact_capacity=100_000, method=method), repeats)
        assert run.status == 0 and run.summary[kernel.SUM_STICKS] == 0, (parameters, rtol, run.status)
        return run.summary[kernel.SUM_R], seconds, {
            "steps": int(run.summary[kernel.SUM_STEPS]), "rhs": int(run.summary[kernel.SUM_RHS])}
    return solve


def scipy_solver(model, parameters, x0, rtol, periods, repeats=1):
    coefficients = kernel_coefficients(parameters, model)
    result, seconds = _best_cpu_time(lambda: reference_run(coefficients, x0, V0, periods, periods, rtol=rtol,
                                                           atol=rtol * 1e-2, method="DOP853"), repeats)
    return result["R"], seconds, {"rhs": int(result["n_rhs"])}


class HeyokaSolver:
    """The same loop in heyoka: eq2.1 with the eq3.1-eq3.2 integrands, eq2.2 as a terminal event."""

    def __init__(self):
        import heyoka as hy

        self.hy = hy
        x, v, qs, qc = hy.make_vars("x", "v", "qs", "qc")
        t = hy.time
        p = {index: hy.par[index] for index in (GAMMA, MU, STIFFNESS, ALPHA, C, OMEGA, G, BIG_OMEGA, DELTA)}
        acceleration = (p[C] * hy.cos(p[OMEGA] * t) + p[G] * hy.cos(p[BIG_OMEGA] * t)
                        - p[GAMMA] * (x * x - p[MU]) * v - p[STIFFNESS] * x - p[ALPHA] * x * x * x)
        self.system = [(x, v), (v, acceleration), (qs, x * hy.sin(p[OMEGA] * t)), (qc, x * hy.cos(p[OMEGA] * t))]
        self.barrier = x - p[DELTA]
        self.n_parameters = DELTA + 1  # E enters only the impact law, applied in the callback
        self.restitution = 1.0
        self.integrators = {}
        self.build_seconds = {}

    def integrator(self, tol):
        if tol not in self.integrators:
            hy = self.hy

            def impact(ta, d_sgn):
                ta.state[0] = ta.pars[DELTA]  # eq2.2, at the located root
                ta.state[1] = -self.restitution * ta.state[1]
                return True

            event = hy.t_event(self.barrier, callback=impact, direction=hy.event_direction.positive)
            start = time.perf_counter()
            self.integrators[tol] = hy.taylor_adaptive(self.system, [0.0] * 4, tol=tol, t_events=[event],
                                                       pars=[0.0] * self.n_parameters)
            self.build_seconds[tol] = time.perf_counter() - start
        return self.integrators[tol]

    def __call__(self, model, parameters, x0, rtol, periods, repeats=3):
        coefficients = kernel_coefficients(parameters, model)
        ta = self.integrator(rtol)
        slow_period = 2.0 * math.pi / coefficients[OMEGA]

        def run():
            ta.pars[:] = coefficients[:self.n_parameters]
            self.restitution = coefficients[E]
            ta.time = 0.0
            ta.state[:] = [x0, V0, 0.0, 0.0]
            ta.propagate_until(periods * slow_period)
            ta.state[2] = 0.0  # the window's quadratures start at 0
            ta.state[3] = 0.0
            ta.propagate_until(2 * periods * slow_period)
            window = periods * slow_period
            return math.hypot(2.0 * ta.state[2] / window, 2.0 * ta.state[3] / window) / coefficients[C]

        r, seconds = _best_cpu_time(run, repeats)
        return r, seconds, {"order": ta.order}


def loosest_matching(solve, model, parameters, x0, converged, periods, rtols):
    """(rtol, R, seconds, counts) at the loosest rtol from which R matches at every tighter one."""
    found = None
    for rtol in reversed(rtols):  # tight to loose: stop at the first miss
        r, seconds, counts = solve(model, parameters, x0, rtol, periods)
        if not abs(r - converged) <= AGREEMENT * abs(converged):
            break
        found = (rtol, r, seconds, counts)
    return found


def _geometric_mean(values):
    return float(np.exp(np.mean(np.log(values)))) if values else math.nan


def per_point(periods, with_scipy):
    print(f"\n1. Per point, one thread ({periods} transient + {periods} measured slow periods), "
          f"R within {AGREEMENT:g} of converged")
    import numba

    numba.set_num_threads(1)
    solvers = {f"vrsweep {method}": vrsweep_solver(method) for method in METHODS}
    for solve in solvers.values():
        solve("original", PAPER, 0.99, 1e-6, 1, repeats=1)  # compile outside the timings
    heyoka = None
    try:
        heyoka = HeyokaSolver()
        solvers["heyoka"] = heyoka
    except ImportError:
        print("  heyoka is not installed (pip install -e '.[bench]'): no heyoka baseline")
    times = {name: [] for name in solvers}
    scipy_ratio = {name: [] for name in solvers}
    for label, model, parameters, x0, scipy_too in POINTS:
        converged = vrsweep_solver("dop853")(model, parameters, x0, 1e-13, periods, repeats=1)[0]
        check = vrsweep_solver("rk45")(model, parameters, x0, 1e-12, periods, repeats=1)[0]
        line = f"  {label}: R = {converged:.10f} (rk45 at 1e-12: {check:.10f}"
        if heyoka is not None:
            line += f", heyoka at 1e-15: {heyoka(model, parameters, x0, 1e-15, periods, repeats=1)[0]:.10f}"
        print(line + ")")
        found = {}
        for name, solve in solvers.items():
            found[name] = loosest_matching(solve, model, parameters, x0, converged, periods, RTOLS)
        if with_scipy and scipy_too:
            found["SciPy DOP853"] = loosest_matching(scipy_solver, model, parameters, x0, converged, periods,
                                                     SCIPY_RTOLS)
        reference = found.get("heyoka")
        for name, result in found.items():
            if result is None:
                print(f"    {name:15s} no tolerance of the list gives R within {AGREEMENT:g}")
                continue
            rtol, r, seconds, counts = result
            extra = ""
            if "rhs" in counts:
                extra = f", {counts['rhs']:>9d} RHS"
                if "steps" in counts:
                    extra += f", {counts['steps']:>7d} steps, {seconds / counts['rhs'] * 1e9:5.1f} ns/RHS"
            if "order" in counts:
                extra = f", Taylor order {counts['order']}, built in {heyoka.build_seconds[rtol]:.2f} s"
            versus = ""
            if reference is not None and name != "heyoka":
                versus = f"   heyoka/this = {reference[2] / seconds:5.2f}"
            print(f"    {name:15s} rtol {rtol:.0e}: {seconds * 1e3:9.2f} ms{extra}{versus}")
            if name in times:
                times[name].append(seconds)
        if "SciPy DOP853" in found and found["SciPy DOP853"] is not None:
            for name in solvers:
                if found[name] is not None:
                    scipy_ratio[name].append(found["SciPy DOP853"][2] / found[name][2])
    print("  geometric means over the points:")
    for name in solvers:
        line = f"    {name:15s} {_geometric_mean(times[name]) * 1e3:8.2f} ms"
        if "heyoka" in times and name != "heyoka" and len(times[name]) == len(times["heyoka"]):
            speed = _geometric_mean([h / s for h, s in zip(times["heyoka"], times[name])])
            line += f"   speed relative to heyoka {speed:5.2f}x (goal >= 1.5, no point below 1)"
        if scipy_ratio[name]:
            line += f"   {_geometric_mean(scipy_ratio[name]):6.0f}x faster than SciPy DOP853 (goal >= 500x)"
        print(line)


class _Config:
    """A minimal config object for run_sweep (what config.load_config returns, reduced)."""

    def __init__(self, periods, n_points, method="rk45"):
        from types import SimpleNamespace

        from vrsweep.numerics.trajectory import DEFAULT_SETTINGS

        self.model = "original"
        self.parameters = dict(PAPER)
        self.initial = {"x": 0.99, "v": 0.5}
        self.axes = (SimpleNamespace(name="g", values=np.linspace(0.0, 40.0, n_points), continuation=None),)
        self.integration = SimpleNamespace(**dict(DEFAULT_SETTINGS, transient_periods=periods,
                                                  measure_periods=periods, strobe_periods=8,
                                                  max_period=4, period_tolerance=1e-6, method=method,
                                                  lyapunov=False))


def thread_scaling(periods, n_points=64, pairs=5):
    print(f"\n2. Points per second on a {n_points}-point grid ({periods} + {periods} periods, rtol 1e-9)")
    from vrsweep.execution.sweep import run_sweep

    for method in METHODS:
        config = _Config(periods, n_points, method)
        run_sweep(_Config(1, 4, method), threads=2)  # compile the parallel kernel outside the timings

        def seconds(threads):
            start = time.perf_counter()
            run_sweep(config, threads=threads, chunk_lines=n_points)
            return time.perf_counter() - start

        # The machine's speed drifts by tens of percent between runs: alternate 1- and 2-thread
        # runs and take the median of the pairwise ratios.
        timings = [(seconds(1), seconds(2)) for _ in range(pairs)]
        one = np.median([a for a, _ in timings])
        two = np.median([b for _, b in timings])
        ratios = [a / b for a, b in timings]
        print(f"  {method}: 1 thread {one:6.2f} s ({n_points / one:6.1f} points/s), 2 threads {two:6.2f} s "
              f"({n_points / two:6.1f} points/s); speed-up median {np.median(ratios):.2f}x, "
              f"range {min(ratios):.2f}-{max(ratios):.2f}x (median of {pairs} pairs)")


_FIRST_CALL = """
import sys, time
start = time.perf_counter()
from vrsweep.execution.sweep import run_sweep
import benchmarks.bench_speed as b
run_sweep(b._Config(1, 2, sys.argv[1]), threads=2)
print(time.perf_counter() - start)
"""


def compile_time():
    print("\n3. First call in a fresh process (import + compile or cache load + a 2-point sweep)")
    for method in METHODS:
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            figures = []
            for _ in ("empty cache (compiles)", "warm cache"):
                out = subprocess.run([sys.executable, "-c", _FIRST_CALL, method], env=env, cwd=ROOT, check=True,
                                     capture_output=True, text=True).stdout.split()[-1]
                figures.append(float(out))
            print(f"  {method}: empty cache (compiles) {figures[0]:6.2f} s, warm cache {figures[1]:6.2f} s")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10 + 10 periods, no SciPy (a smoke run)")
    parser.add_argument("--periods", type=int, default=100, help="transient and measured periods per point")
    parser.add_argument("--no-scipy", action="store_true", help="leave out the SciPy baseline (minutes)")
    parser.add_argument("--only", choices=["points", "threads", "compile"], help="run one part")
    args = parser.parse_args()
    periods = 10 if args.quick else args.periods
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    if args.only in (None, "points"):
        per_point(periods, with_scipy=not (args.quick or args.no_scipy))
    if args.only in (None, "threads"):
        thread_scaling(min(periods, 20))
    if args.only in (None, "compile"):
        compile_time()
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
