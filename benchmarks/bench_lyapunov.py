"""The cost of integration.lyapunov: the tangent-vector kernels against the plain ones, same run.

Run:  python benchmarks/bench_lyapunov.py [--periods N] [--repeat K] [--no-compile]

1. Per point, one thread, N transient + N measured slow periods (default 100 + 100), rtol 1e-9:
   the calling thread's CPU time of the plain kernel and of the Lyapunov kernel of the same
   method, best of K (default 3), alternating, and their ratio. The Lyapunov kernel takes the same
   steps (its tangent vectors take no part in error control), so the ratio is the cost of the
   variational equations and the saltation matrices alone.
2. First call in a fresh process with an empty numba cache, per method and kernel (compile time).
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
sys.path.insert(0, str(ROOT))

from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector, simulate  # noqa: E402

PAPER = dict(DEFAULT_PARAMETERS, Omega=4.0)
POINTS = [
    ("original, g = 5 (chaotic)", "original", dict(PAPER, g=5.0)),
    ("original, g = 10 (period 3)", "original", dict(PAPER, g=10.0)),
    ("original, g = 30 (period 1)", "original", dict(PAPER, g=30.0)),
    ("original, g = 40 (8 impacts per period)", "original", dict(PAPER, g=40.0)),
    ("effective, g = 25 (no impacts)", "effective", dict(PAPER, g=25.0)),
]


def _coefficients(model, parameters):
    return kernel_coefficients({k: np.array([v]) for k, v in parameters.items()}, model)[0]


def _cpu_seconds(coefficients, settings, method, lyapunov):
    start = time.thread_time()
    run = simulate(coefficients, [0.99, 0.5], settings, method=method, lyapunov=lyapunov)
    return time.thread_time() - start, run


def per_point(periods, repeat):
    settings = settings_vector(rtol=1e-9, atol=1e-11, transient_periods=periods, measure_periods=periods)
    print(f"1. CPU time per point, one thread, {periods} + {periods} periods, rtol 1e-9, best of {repeat}")
    print(f"   {'point':42s} {'method':7s} {'plain ms':>9s} {'lyapunov ms':>12s} {'ratio':>6s} {'lambda':>9s}")
    ratios = {method: [] for method in kernel.METHODS}
    for label, model, parameters in POINTS:
        coefficients = _coefficients(model, parameters)
        for method in kernel.METHODS:
            for lyapunov in (False, True):  # warm: load or compile outside the timing
                _cpu_seconds(coefficients, settings_vector(transient_periods=1, measure_periods=1), method, lyapunov)
            best = {False: math.inf, True: math.inf}
            for _ in range(repeat):
                for lyapunov in (False, True):
                    seconds, run = _cpu_seconds(coefficients, settings, method, lyapunov)
                    best[lyapunov] = min(best[lyapunov], seconds)
            ratio = best[True] / best[False]
            ratios[method].append(ratio)
            print(f"   {label:42s} {method:7s} {1e3 * best[False]:9.2f} {1e3 * best[True]:12.2f} {ratio:6.2f} "
                  f"{run.summary[kernel.SUM_LYAPUNOV]:9.4f}")
    for method, values in ratios.items():
        print(f"   {method}: geometric mean lyapunov / plain = {math.exp(np.mean(np.log(values))):.2f}")


_FIRST_CALL = """
import time, numpy as np
start = time.perf_counter()
from vrsweep.numerics.trajectory import simulate, settings_vector
from vrsweep.numerics.model import kernel_coefficients, DEFAULT_PARAMETERS
p = dict(DEFAULT_PARAMETERS, Omega=4.0, g=10.0)
c = kernel_coefficients({{k: np.array([v]) for k, v in p.items()}}, "original")[0]
simulate(c, [0.99, 0.5], settings_vector(transient_periods=1, measure_periods=1), method="{method}",
         lyapunov={lyapunov})
print(time.perf_counter() - start)
"""


def compile_times():
    print("2. First call in a fresh process, empty numba cache (compile) and warm cache, wall seconds")
    for method in kernel.METHODS:
        for lyapunov in (False, True):
            with tempfile.TemporaryDirectory() as cache:
                env = dict(os.environ, NUMBA_CACHE_DIR=cache)
                code = _FIRST_CALL.format(method=method, lyapunov=lyapunov)
                cold, warm = (float(subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                                   capture_output=True, text=True).stdout) for _ in range(2))
            print(f"   {method:7s} {'lyapunov' if lyapunov else 'plain':9s} cold {cold:6.1f} s   warm {warm:5.2f} s")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-compile", action="store_true", help="leave out the compile-time part")
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    per_point(args.periods, args.repeat)
    if not args.no_compile:
        compile_times()


if __name__ == "__main__":
    main()
