"""This version's cold compile time against another checkout's, in one run, alternating.

    python benchmarks/compile_versions.py /path/to/old/checkout [--rounds 1]

What a user waits for before a first sweep's first point: a fresh process with an empty numba
cache folder (XDG_CACHE_HOME of its own, NUMBA_CACHE_DIR unset) imports vrsweep and sweeps two
points of one period each, for the paper's original model and a written one-stop model (rk45),
the original with dop853, and the original with the tangent vectors (rk45); where numba-cuda is
installed, also the GPU's line kernel for the original model (rk45), compiled to PTX for sm_90
without a card (cuda.compile_for). Wall time of the whole process, best of --rounds; the old checkout and this one alternate per case and round. Prints
old / new time per case and the geometric mean. Sympy's derivation of the written model is
included (about a second).
"""

import argparse
import importlib.util
import math
import os
import tempfile
import time
from pathlib import Path

from _timing import checkout_child  # python benchmarks/NAME.py puts this folder first on sys.path

NEW = Path(__file__).resolve().parent.parent  # this checkout, as versions.py's

CASES = {
    "original, rk45": ("model: original\nparameters: {g: 30.0, Omega: 4.0}\n", "method: rk45"),
    "written one stop, rk45": (
        "model:\n"
        "  acceleration: \"-2*zeta*v - x + F*cos(omega*t)\"\n"
        "  parameters: {zeta: 0.1, F: 1.0, omega: 0.8, Delta: 0.5}\n"
        "  barriers:\n"
        "    - {position: Delta, side: above, restitution: 0.7}\n"
        "  period: \"2*pi/omega\"\n"
        "  response: {frequency: omega, scale: F}\n", "method: rk45"),
    "original, dop853": ("model: original\nparameters: {g: 30.0, Omega: 4.0}\n", "method: dop853"),
    "original, rk45, tangent vectors": ("model: original\nparameters: {g: 30.0, Omega: 4.0}\n",
                                        "method: rk45, lyapunov: true"),
}
if importlib.util.find_spec("numba_cuda") is not None:
    CASES["GPU kernel, original, rk45 (PTX)"] = ("ptx rk45", "")

CHILD = r"""
import json, sys
sys.path.insert(0, sys.argv[3])  # the checkout first: before '' (the working folder), which python -c puts first
import vrsweep
if sys.argv[1].startswith("ptx "):  # the GPU's kernel, compiled for a card this machine need not have
    from vrsweep.numerics import cuda, rhs
    cuda.compile_for(sys.argv[1].split()[1], False, *rhs.paper_functions(False), compute_capability=(9, 0))
else:
    axis = "F: [0.9, 1.0]" if "F:" in sys.argv[1] else "g: [29.0, 30.0]"
    vrsweep.sweep(sys.argv[1] + "initial: {x: 0.0, v: 0.0}\n" + f"sweep: {{{axis}}}\n"
                  + f"integration: {{transient_periods: 1, measure_periods: 1, strobe_periods: 1, {sys.argv[2]}}}\n",
                  progress=False)
print(json.dumps({"vrsweep": vrsweep.__file__}))
"""


def cold_seconds(checkout, text, options):
    """Wall seconds of a fresh process with an empty cache folder: import, compile, two points."""
    with tempfile.TemporaryDirectory() as cache:
        env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
        env["XDG_CACHE_HOME"] = cache
        began = time.perf_counter()
        checkout_child(checkout, CHILD, [text, options], env=env)
        return time.perf_counter() - began


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("--rounds", type=int, default=1)
    args = parser.parse_args()
    ratios = []
    for name, (text, options) in CASES.items():
        old = new = math.inf
        for _ in range(args.rounds):
            old = min(old, cold_seconds(args.old, text, options))
            new = min(new, cold_seconds(str(NEW), text, options))
        ratios.append(old / new)
        print(f"{name:34s} old {old:6.1f} s   new {new:6.1f} s   old/new {ratios[-1]:.3f}", flush=True)
    mean = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
    print(f"old/new compile time, geometric mean {mean:.3f} (range {min(ratios):.3f} to {max(ratios):.3f})")


if __name__ == "__main__":
    main()
