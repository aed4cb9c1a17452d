"""This version's code generation of written models against another checkout's, in one run.

    python benchmarks/codegen_versions.py /path/to/old/checkout [--rounds 1] [--limit 300]

What a user waits for in sympy before numba compiles anything: `codegen.source(model)` for a few
written accelerations (the CPU time of a fresh process's call, best of --rounds, the checkouts
alternating per case and round), and whether the two write the same module text (a same text
is the same cached kernel: same numbers). A case that takes an old checkout more than --limit
seconds is stopped and shown as '>limit'. Prints old / new per case.
"""

import argparse
import subprocess
import sys
from pathlib import Path

from _timing import checkout_child  # python benchmarks/NAME.py puts this folder first on sys.path

NEW = Path(__file__).resolve().parent.parent


def _nested_max(n):
    text = "x"
    for k in range(1, n):
        text = f"max({text}, x + {k}*v)"
    return f"-x - 0.1*v + 0.01*{text} + F*cos(omega*t)"


CASES = {
    "bilinear spring (one kink)": "-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)",
    "friction sign(v)": "-2*zeta*v - x - k*sign(v) + F*cos(omega*t)",
    "Hertz max(x - d, 0)**1.5": "-2*zeta*v - x - k*max(x - d, 0)**1.5 + F*cos(omega*t)",
    "square-root spring": "-2*zeta*v - k*sqrt(abs(x))*sign(x) + F*cos(omega*t)",
    "nested max of x + k*v, 6 arguments": _nested_max(6),
    "nested max of x + k*v, 8 arguments": _nested_max(8),
    "nested max of x + k*v, 10 arguments": _nested_max(10),
}

CHILD = r"""
import hashlib, json, sys, time
sys.path.insert(0, sys.argv[2])
import vrsweep
from vrsweep.config import parse_config
from vrsweep.numerics import codegen
text = ('model:\n  acceleration: "' + sys.argv[1] + '"\n'
        '  parameters: {k: 3.0, d: 0.5, zeta: 0.05, F: 1.0, omega: 0.8}\n'
        '  period: "2*pi/omega"\n  response: {frequency: omega, scale: F}\n')
model = parse_config(text, "m.yaml").model
start = time.thread_time()
source = codegen.source(model)
seconds = time.thread_time() - start
print(json.dumps({"vrsweep": vrsweep.__file__, "seconds": seconds,
                  "digest": hashlib.sha256(source.encode()).hexdigest()[:12]}))
"""


def timed(checkout, acceleration, limit):
    try:
        return checkout_child(checkout, CHILD, [acceleration], timeout=limit)
    except subprocess.TimeoutExpired:
        return {"seconds": None, "digest": None}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("old", help="the checkout to compare with (e.g. git archive REV vrsweep | tar -x -C DIR)")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--limit", type=float, default=300.0, help="seconds before a case is stopped")
    options = parser.parse_args()
    print(f"{'case':40s} {'old s':>8s} {'new s':>8s} {'old/new':>8s}  module text")
    for name, acceleration in CASES.items():
        best = {}
        digests = {}
        for _ in range(options.rounds):
            for label, checkout in (("old", options.old), ("new", NEW)):
                result = timed(checkout, acceleration, options.limit)
                seconds = result["seconds"]
                if seconds is not None:
                    best[label] = min(best.get(label, seconds), seconds)
                digests[label] = result["digest"]
        old, new = best.get("old"), best.get("new")
        same = "same" if digests["old"] == digests["new"] else "differs"
        ratio = f"{old / new:8.1f}" if old is not None and new else "       -"
        old_text = f"{old:8.2f}" if old is not None else f">{options.limit:7.0f}"
        print(f"{name:40s} {old_text} {new:8.2f} {ratio}  {same}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
