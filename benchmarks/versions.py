"""This version's kernel speed against another checkout's, in one run, alternating.

    python benchmarks/versions.py /path/to/old/checkout [--rounds 2] [--repeats 5] [--lyapunov]

For each of bench_speed.py's nine points and both methods, rtol 1e-9 (atol 1e-11), 100 + 100
periods: the calling thread's CPU time of trajectory.simulate, best of --repeats, in a fresh process
per version and round (old, new, old, new ...), after a warm-up call that compiles or loads.
--lyapunov: with the tangent vectors (integration.lyapunov), the kernels of a Lyapunov map.
Prints new/old speed per point and the geometric mean per method.
"""

import argparse
import math
from pathlib import Path

from _timing import checkout_child  # python benchmarks/NAME.py puts this folder first on sys.path

HERE = Path(__file__).resolve().parent
NEW = HERE.parent

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
sys.path.insert(0, sys.argv[4])  # the checkout first: before '' (the working folder), which python -c puts first
import vrsweep
from bench_speed import POINTS, V0
from vrsweep.numerics.model import kernel_coefficients
from vrsweep.numerics.trajectory import settings_vector, simulate

repeats = int(sys.argv[2])
lyapunov = sys.argv[3] == "lyapunov"
settings = settings_vector(rtol=1e-9, atol=1e-11, transient_periods=100, measure_periods=100)
out = {}
for method in ("rk45", "dop853"):
    for label, model, parameters, x0, _ in POINTS:
        c = kernel_coefficients(parameters, model)
        simulate(c, [x0, V0], settings, method=method, lyapunov=lyapunov)
        best = float("inf")
        for _ in range(repeats):
            began = time.thread_time()
            simulate(c, [x0, V0], settings, method=method, lyapunov=lyapunov)
            best = min(best, time.thread_time() - began)
        out[f"{method}|{label}"] = best
print(json.dumps({"vrsweep": vrsweep.__file__, "times": out}))
"""


def timings(checkout, repeats, lyapunov=False):
    """The child's times, from the checkout's own vrsweep (_timing.checkout_child)."""
    return checkout_child(checkout, CHILD, [str(HERE), str(repeats), "lyapunov" if lyapunov else "state"])["times"]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("old")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--lyapunov", action="store_true", help="with the tangent vectors")
    args = parser.parse_args()
    old, new = {}, {}
    for _ in range(args.rounds):
        for store, checkout in ((old, args.old), (new, NEW)):
            for key, value in timings(checkout, args.repeats, args.lyapunov).items():
                store[key] = min(store.get(key, math.inf), value)
    for method in ("rk45", "dop853"):
        ratios = []
        for key in sorted(k for k in new if k.startswith(method)):
            ratios.append(old[key] / new[key])
            print(f"{key:70s} old {1e3 * old[key]:8.2f} ms  new {1e3 * new[key]:8.2f} ms  new/old speed {ratios[-1]:.3f}")
        mean = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
        print(f"{method}: new/old speed, geometric mean {mean:.3f} (range {min(ratios):.3f} to {max(ratios):.3f})")


if __name__ == "__main__":
    main()
