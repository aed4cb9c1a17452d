"""A written model against the built-in one: the paper's system written out (configs/paper_written.yaml)
against ``model: original``, in one run, on the same points and settings.

    python benchmarks/bench_written.py [--repeats 3]

For the original-model points of bench_speed.py, each method at rtol 1e-9 (100 + 100 periods):
the CPU time per point of each (best of N, benchmarks/_timing.py), their ratio (built-in time /
written time: 1 is the same speed, above 1 the written model is faster), and R of both (equal to
the tolerance: the steps differ only where the built-in's dop853 rotates the forcing phases). Then
the compile time of the written model's kernel, cold (an empty numba cache, in a fresh process)
and cached (a second fresh process), against the built-in's, for rk45.

    python benchmarks/bench_written.py --kinked [--repeats 3]

The cost of locating a written model's switching surfaces instead: a bilinear spring (a kink at
x = d, tests/test_written_kinks.py's) and the same spring with friction (-mu*sign(v), a jump at
v = 0), each run by the loop as the GPU composes it (kernel.METHOD_PARTS: the library's cosines
at every stage) twice in one process, with its switching functions located (the model's
switch_signs, frozen mode included) and stepped over (rhs.no_switches), 100 + 100 periods: the
CPU time per point of each, their ratio (stepped over / located: above 1 locating is faster),
the steps and R's error against the located dop853 run at rtol 1e-13.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
if os.environ.get("PYTHONPATH") is None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
from _timing import best_of  # noqa: E402
from bench_speed import POINTS, V0  # noqa: E402

from vrsweep.config import load_config  # noqa: E402
from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "vrsweep" / "examples" / "paper_written.yaml"
SETTINGS = dict(rtol=1e-9, atol=1e-11, transient_periods=100, measure_periods=100)

_COMPILE = """
import time
start = time.perf_counter()
from vrsweep.config import load_config
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.trajectory import settings_vector, simulate
config = load_config({example!r}, ["g=30"])
model = config.model if {written} else "original"
kernels = kernels_for(model)
simulate(kernels.coefficients(config.parameters), [0.99, 0.5], settings_vector(transient_periods=0,
         measure_periods=1), model=model)
print(time.perf_counter() - start)
"""


def compile_seconds(written, cache):
    """Wall time of a fresh process that loads the config, makes (or loads) the rk45 kernel and runs
    one period, with numba's cache in ``cache``."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=cache)
    script = _COMPILE.format(example=str(EXAMPLE), written=written)
    out = subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True,
                         check=True)
    return float(out.stdout.split()[-1])


KINKED = """
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0) - mu*sign(v) + F*cos(omega*t)"
  parameters: {zeta: 0.05, k: 3.0, d: 0.5, mu: 0.0, F: 1.0, omega: 0.8}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
"""


def kinked(repeats):
    """The cost of locating the switching surfaces (module doc, --kinked)."""
    import numba

    from vrsweep.config import parse_config
    from vrsweep.numerics import codegen, rhs
    from vrsweep.numerics.impact import N_BRACKET
    from vrsweep.numerics.state import N_STATE

    config = parse_config(KINKED, "kinked.yaml")
    module = codegen.compiled(config.model)
    integrate = numba.njit(kernel._integrate.py_func)
    kernels = kernels_for(config.model)

    def run(method, located, coefficients, settings):
        rules, step, error, dense_output, accepted, growth, rejected, k_rows, dense_order = kernel.METHOD_PARTS[method]
        n_periods = int(settings[kernel.TRANSIENT_PERIODS] + settings[kernel.MEASURE_PERIODS])
        records = np.full((n_periods, kernel.N_RECORD), np.nan)
        summary = np.full(kernel.N_SUMMARY, np.nan)
        switches = module.switch_signs if located else rhs.no_switches
        status = integrate(module.rhs, module.rhs, module.tangent, module.barrier_force, switches,
                           module.switch_saltation if located else rhs.no_saltation,
                           module.sliding_surface if located else rhs.no_sliding, rhs.no_preparations, rules,
                           step, error, dense_output, accepted, growth, rejected, False,
                           (np.empty((k_rows, N_STATE)), np.empty((N_STATE, dense_order)),
                            np.empty((kernel.N_VECTORS, N_STATE)), np.empty(N_BRACKET)), np.empty(1), coefficients,
                           np.array([0.0, 0.0]), settings, records, summary, np.empty(0), np.empty((0, 2)),
                           np.empty((0, 3)), np.empty((0, 2)), np.empty((0, 4)), kernel.lanes_apart)
        return status, summary

    print(f"CPU seconds per point, best of {repeats}, 100 + 100 periods; ratio = stepped over / located")
    print(f"{'model':<22} {'method':<7} {'rtol':>6} {'located':>8} {'over':>8} {'ratio':>6} {'steps':>7} "
          f"{'over':>7} {'R err located':>13} {'over':>9}")
    ratios = {}
    for label, mu in (("bilinear spring", 0.0), ("... with friction", 0.1)):
        coefficients = kernels.coefficients({**config.parameters, "mu": mu})
        reference = run("dop853", True, coefficients, settings_vector(rtol=1e-13, atol=1e-15, transient_periods=100,
                                                                      measure_periods=100))[1][kernel.SUM_R]
        for method in ("rk45", "dop853"):
            for rtol in (1e-6, 1e-8, 1e-10):
                settings = settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=100, measure_periods=100)
                results = {}
                for located in (True, False):
                    results[located] = best_of(lambda: run(method, located, coefficients, settings), repeats,
                                               warm_up=True)
                (time_located, (status_a, a)), (time_over, (status_b, b)) = results[True], results[False]
                ratio = time_over / time_located
                ratios.setdefault((label, method), []).append(ratio)
                print(f"{label:<22} {method:<7} {rtol:6.0e} {time_located:8.4f} {time_over:8.4f} {ratio:6.2f} "
                      f"{int(a[kernel.SUM_STEPS]):7d} {int(b[kernel.SUM_STEPS]):7d} "
                      f"{abs(a[kernel.SUM_R] - reference):13.1e} {abs(b[kernel.SUM_R] - reference):9.1e}"
                      + ("" if status_a == status_b == 0 else f"  statuses {status_a} {status_b}"))
    for (label, method), values in ratios.items():
        print(f"{label}, {method}: stepped over / located time, geometric mean over the rtols: "
              f"{float(np.exp(np.mean(np.log(values)))):.2f}x")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--kinked", action="store_true", help="the cost of locating a written model's kinks")
    args = parser.parse_args()
    if args.kinked:
        kinked(args.repeats)
        return
    vector = settings_vector(**SETTINGS)
    print(f"rtol {SETTINGS['rtol']:g}, {SETTINGS['transient_periods']} + {SETTINGS['measure_periods']} periods; "
          f"CPU seconds per point, best of {args.repeats}")
    print(f"{'point':<52} {'method':<7} {'built-in':>9} {'written':>9} {'ratio':>6}  {'R built-in':>12} "
          f"{'R written':>12}")
    ratios = {}
    for label, model, parameters, x0, _ in POINTS:
        if model != "original":
            continue
        written = load_config(EXAMPLE, [f"{name}={value}" for name, value in parameters.items()]
                              + [f"initial.x={x0}", f"initial.v={V0}"])
        for method in ("rk45", "dop853"):
            builtin_vector = kernels_for("original").coefficients(parameters)
            written_vector = kernels_for(written.model).coefficients(written.parameters)
            builtin_time, a = best_of(lambda: simulate(builtin_vector, [x0, V0], vector, method=method),
                                      args.repeats, warm_up=True)
            written_time, b = best_of(lambda: simulate(written_vector, [x0, V0], vector, method=method,
                                                       model=written.model), args.repeats, warm_up=True)
            ratio = builtin_time / written_time
            ratios.setdefault(method, []).append(ratio)
            print(f"{label:<52} {method:<7} {builtin_time:9.3f} {written_time:9.3f} {ratio:6.2f}  "
                  f"{a.summary[kernel.SUM_R]:12.8g} {b.summary[kernel.SUM_R]:12.8g}")
    for method, values in ratios.items():
        print(f"{method}: written / built-in speed, geometric mean over the points: "
              f"{float(np.exp(np.mean(np.log(values)))):.2f}x "
              f"(worst {min(values):.2f}x)")
    with tempfile.TemporaryDirectory() as cache:
        cold_builtin = compile_seconds(False, cache)
        cold_written = compile_seconds(True, cache)
        cached_builtin = compile_seconds(False, cache)
        cached_written = compile_seconds(True, cache)
    print(f"compile, rk45, a fresh process: built-in cold {cold_builtin:.1f} s, cached {cached_builtin:.1f} s; "
          f"written cold {cold_written:.1f} s (sympy, the module, numba), cached {cached_written:.1f} s")


if __name__ == "__main__":
    started = time.perf_counter()
    main()
    print(f"({time.perf_counter() - started:.0f} s)")
