"""A written model against the built-in one: the paper's system written out (configs/paper_written.yaml)
against ``model: original``, in one run, on the same points and settings.

    python benchmarks/bench_written.py [--repeats 3]

For the original-model points of bench_speed.py, each method at rtol 1e-9 (100 + 100 periods):
the CPU time per point of each (best of N, benchmarks/_timing.py), their ratio (built-in time /
written time: 1 is the same speed, above 1 the written model is faster), and R of both (equal to
the tolerance: the steps differ only where the built-in's dop853 rotates the forcing phases). Then
the compile time of the written model's kernel, cold (an empty numba cache, in a fresh process)
and cached (a second fresh process), against the built-in's, for rk45.
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
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
