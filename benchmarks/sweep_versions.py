"""This version's sweep against another checkout's, in one run, alternating: the lines on every
thread, through vrsweep.sweep, with the kernels already compiled.

    python benchmarks/sweep_versions.py /path/to/old/checkout [--rounds 3] [--repeats 3] [--cases WORD ...]

versions.py times one point's kernel on the calling thread; this times what runs the kernel on a
grid: the loop over lines and its threads (numerics/lines.py), the chunks, the diagnostics, in
wall time (the threads' work is what is measured). Each case runs in a fresh process per version
and round (old, new, old, new ...), each version with its own cache folder, after a warm-up sweep
of two points that compiles or loads every kernel the case uses; best of --repeats sweeps. The
cases: (g, Omega) maps of the original model with each method and with the tangent vectors; the
effective model with one period each at 20,000 points, where the cost of handing out lines to
threads would show; and continuation lines of 50 points up and down. Prints old and new seconds,
old / new per case and the geometric mean, and whether both versions gave the same bytes of R,
the status and the Lyapunov exponent.
"""

import argparse
import math
import os
import tempfile
from pathlib import Path

from _timing import checkout_child  # python benchmarks/NAME.py puts this folder first on sys.path

NEW = Path(__file__).resolve().parent.parent

MAP = "sweep:\n  g: {start: 5, stop: 35, num: 20}\n  Omega: {start: 3, stop: 6, num: 20}\n"
CASES = {
    "original, rk45, 400-point map": (
        "model: original\n" + MAP, "method: rk45, transient_periods: 50, measure_periods: 50"),
    "original, dop853, 400-point map": (
        "model: original\n" + MAP, "method: dop853, transient_periods: 50, measure_periods: 50"),
    "original, dop853, Lyapunov, 400-point map": (
        "model: original\n" + MAP, "method: dop853, lyapunov: true, transient_periods: 50, measure_periods: 50"),
    "effective, rk45, 20,000 points of 1 + 1 periods": (
        "model: effective\nsweep:\n  g: {start: 0, stop: 40, num: 200}\n  Omega: {start: 3, stop: 6, num: 100}\n",
        "method: rk45, transient_periods: 1, measure_periods: 1, strobe_periods: 1"),
    "effective, dop853, continuation lines (2 x 8 lines of 50)": (
        "model: effective\nparameters: {gamma: 0.05, alpha: 0.05}\n"
        "sweep:\n  g: {start: 21, stop: 27, num: 50, continuation: both}\n  Omega: {start: 3.5, stop: 4.5, num: 8}\n",
        "method: dop853, transient_periods: 50, measure_periods: 50"),
}

CHILD = r"""
import hashlib, json, sys, time
sys.path.insert(0, sys.argv[4])  # the checkout first: before '' (the working folder), which python -c puts first
import numpy as np
import vrsweep
text, options, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3])
config = text + "initial: {x: 0.1, v: 0.0}\n" + f"integration: {{{options}}}\n"
vrsweep.sweep(text.split("sweep:")[0] + "initial: {x: 0.1, v: 0.0}\nsweep: {g: [29.0, 30.0]}\n"
              + f"integration: {{{options}}}\n", progress=False)
best = float("inf")
for _ in range(repeats):
    began = time.perf_counter()
    result = vrsweep.sweep(config, progress=False)
    best = min(best, time.perf_counter() - began)
digest = hashlib.sha1()
for name in ("R", "status", "lyapunov"):
    if name in result:
        digest.update(np.ascontiguousarray(result[name].values).tobytes())
print(json.dumps({"vrsweep": vrsweep.__file__, "seconds": best, "digest": digest.hexdigest()[:12]}))
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cases", nargs="*", default=[], help="only the cases whose name holds one of these words")
    args = parser.parse_args()
    ratios = []
    with tempfile.TemporaryDirectory() as old_cache, tempfile.TemporaryDirectory() as new_cache:
        for name, (text, options) in CASES.items():
            if args.cases and not any(word in name for word in args.cases):
                continue
            seconds = {"old": math.inf, "new": math.inf}
            digests = {}
            for _ in range(args.rounds):
                for version, checkout, cache in (("old", args.old, old_cache), ("new", str(NEW), new_cache)):
                    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
                    env["XDG_CACHE_HOME"] = cache
                    result = checkout_child(checkout, CHILD, [text, options, str(args.repeats)], env=env)
                    seconds[version] = min(seconds[version], result["seconds"])
                    digests.setdefault(version, result["digest"])
            ratios.append(seconds["old"] / seconds["new"])
            same = "same results" if digests["old"] == digests["new"] else f"DIFFERENT results {digests}"
            print(f"{name:58s} old {seconds['old']:6.2f} s   new {seconds['new']:6.2f} s   "
                  f"old/new {ratios[-1]:.3f}   {same}", flush=True)
    mean = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
    print(f"old/new sweep time, geometric mean {mean:.3f} (range {min(ratios):.3f} to {max(ratios):.3f})")


if __name__ == "__main__":
    main()
