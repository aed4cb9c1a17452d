"""A sliding (stick-slip) written model's speed and stick count in this version against another
checkout's, in one run, alternating.

    python benchmarks/sliding_versions.py /path/to/old/checkout [--rounds 2] [--repeats 5]

The forced oscillator with friction on a belt, x'' = -2 zeta v - x - mu sign(v - belt) + F cos(omega
t) (tests/test_written_sliding.py's model), at a few (omega, mu): each method at rtol 1e-6 and 1e-9,
20 + 6 periods from (0, 0.3). For each: the calling thread's CPU time of trajectory.simulate (best
of --repeats, after a warm-up call that compiles or loads), the sticks logged and the right-hand
side evaluations, in a fresh process per version and round. Prints new/old speed per case, the
geometric mean, and where the two versions log different numbers of sticks.
"""

import argparse
import json
import math
import os

from _timing import checkout_child  # python benchmarks/NAME.py puts this folder first on sys.path

CASES = [(0.5, 0.6, 0.2), (0.3, 0.6, 0.2), (1.5, 0.72, 0.2), (1.5, 0.75, 0.2)]  # (omega, mu, belt)

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[3])  # the checkout first: before '' (the working folder), which python -c puts first
import vrsweep
from vrsweep.config import parse_config
from vrsweep.numerics import kernel
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.trajectory import settings_vector, simulate

cases, repeats = json.loads(sys.argv[1]), int(sys.argv[2])
out = {}
for omega, mu, belt in cases:
    config = parse_config(f'''
model:
  acceleration: "-2*zeta*v - x - mu*sign(v - belt) + F*cos(omega*t)"
  parameters: {{zeta: 0.05, mu: {mu}, F: 1.0, omega: {omega}, belt: {belt}}}
  period: "2*pi/omega"
  response: {{frequency: omega, scale: F}}
initial: {{x: 0.0, v: 0.3}}
''', "belt.yaml")
    c = kernels_for(config.model).coefficients(config.parameters)
    for method in ("rk45", "dop853"):
        for rtol in (1e-6, 1e-9):
            settings = settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=20, measure_periods=6)
            run = simulate(c, [0.0, 0.3], settings, method=method, model=config.model)
            best = float("inf")
            for _ in range(repeats):
                began = time.thread_time()
                simulate(c, [0.0, 0.3], settings, method=method, model=config.model)
                best = min(best, time.thread_time() - began)
            out[f"{method} rtol {rtol:.0e} omega {omega} mu {mu}"] = (
                best, int(run.summary[kernel.SUM_STICKS]), int(run.summary[kernel.SUM_RHS]))
print(json.dumps({"vrsweep": vrsweep.__file__, "cases": out}))
"""


def measure(checkout, repeats):
    """The child's cases, from the checkout's own vrsweep (_timing.checkout_child)."""
    return checkout_child(checkout, CHILD, [json.dumps(CASES), str(repeats)])["cases"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    new_checkout = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    old, new = {}, {}
    for _ in range(args.rounds):
        for store, checkout in ((old, args.old), (new, new_checkout)):
            for key, (seconds, sticks, rhs) in measure(checkout, args.repeats).items():
                best = store.get(key, (math.inf,))[0]
                store[key] = (min(best, seconds), sticks, rhs)
    ratios = []
    for key in new:
        ratios.append(old[key][0] / new[key][0])
        print(f"{key:34s} old {1e3 * old[key][0]:7.2f} ms {old[key][1]:3d} sticks {old[key][2]:7d} rhs   "
              f"new {1e3 * new[key][0]:7.2f} ms {new[key][1]:3d} sticks {new[key][2]:7d} rhs   "
              f"new/old speed {ratios[-1]:.3f}")
    mean = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
    print(f"new/old speed, geometric mean {mean:.3f} (range {min(ratios):.3f} to {max(ratios):.3f})")
    differ = [key for key in new if new[key][1] != old[key][1]]
    print(f"stick counts differ in {len(differ)} of {len(new)} cases" + (": " + "; ".join(differ) if differ else ""))


if __name__ == "__main__":
    main()
