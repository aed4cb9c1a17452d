"""The host's per-point diagnostics (execution/sweep.point_values) against another checkout's, in
one run: the part of a sweep that 0.7.0 changed (lyapunov and impacts_per_period over the last
whole cycles, every forcing frequency of a written model), the kernel being the same.

    python benchmarks/diagnostics_versions.py /path/to/old/checkout [--rounds 3]

The original model's kernel outputs with Lyapunov exponents, 100 + 100 periods, on a 40 x 10
(g, Omega) map (computed once, by this checkout), then each version's point_values on them, one
thread, best of 5, in a fresh process per version and round (old, new, old, new ...). Prints
new/old time.
"""

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
NEW = HERE.parent

CHILD = r"""
import inspect, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from vrsweep.config import parse_config
from vrsweep.execution.sweep import point_values
from vrsweep.numerics.models import kernels_for
data = np.load(sys.argv[2])
config = parse_config("model: original\nintegration: {lyapunov: true, transient_periods: 100, measure_periods: 100}")
arguments = [data["records"], data["summaries"], data["statuses"], data["coefficients"]]
if "frequencies" in inspect.signature(point_values).parameters:
    arguments.append(kernels_for("original").forcing_frequencies(data["coefficients"]))
best = float("inf")
for _ in range(5):
    began = time.perf_counter()
    values = point_values(*arguments, config.integration, threads=1)
    best = min(best, time.perf_counter() - began)
np.savez(sys.argv[3], **{name: np.asarray(value) for name, value in values.items()})
print(best)
"""


def differences(old_path, new_path):
    """Per variable of point_values: the points whose values differ (NaN equal to NaN), and by how much."""
    old, new = np.load(old_path), np.load(new_path)
    lines = []
    for name in sorted(set(old.files) | set(new.files)):
        if name not in old.files or name not in new.files:
            lines.append(f"  {name}: only in {'new' if name in new.files else 'old'}")
            continue
        a, b = old[name], new[name]
        if a.shape != b.shape:
            lines.append(f"  {name}: shape {a.shape} -> {b.shape}")
            continue
        differ = ~((a == b) | (np.isnan(a) & np.isnan(b))) if a.dtype.kind == "f" else a != b
        differ = differ.reshape(len(a), -1).any(axis=1) if differ.ndim > 1 else differ
        if differ.any():
            largest = np.nanmax(np.abs(a[differ].astype(float) - b[differ].astype(float)))
            lines.append(f"  {name}: {int(differ.sum())} of {len(a)} points differ, by up to {largest:.3g}")
    return lines or ["  every variable bit for bit"]


def outputs(path):
    """The kernel's records, summaries and statuses of the map, by this checkout."""
    from vrsweep.numerics import kernel
    from vrsweep.numerics.lines import RUN_LINES
    from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
    from vrsweep.numerics.trajectory import settings_vector

    g, omega = np.meshgrid(np.linspace(2, 40, 40), np.linspace(3, 6, 10), indexing="ij")
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=g.ravel(), Omega=omega.ravel()), "original")
    n = len(coefficients)
    settings = settings_vector(rtol=1e-9, atol=1e-11, transient_periods=100, measure_periods=100, lyapunov=True)
    records = np.full((n, 1, 100, kernel.N_RECORD), np.nan)
    summaries = np.full((n, 1, kernel.N_SUMMARY), np.nan)
    statuses = np.zeros((n, 1), dtype=np.int8)
    RUN_LINES["rk45", True](coefficients, np.tile([0.99, 0.5], (n, 1)), settings,
                            np.arange(n, dtype=np.int64).reshape(n, 1), records, summaries, statuses)
    np.savez(path, records=records[:, 0], summaries=summaries[:, 0], statuses=statuses[:, 0],
             coefficients=coefficients)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "outputs.npz"
        outputs(path)
        times = {"old": [], "new": []}
        for _ in range(args.rounds):
            for name, checkout in (("old", args.old), ("new", str(NEW))):
                run = subprocess.run([sys.executable, "-c", CHILD, checkout, str(path),
                                      str(Path(folder) / f"{name}.npz")], capture_output=True, text=True, check=True)
                times[name].append(float(run.stdout.split()[-1]))
        changed = differences(Path(folder) / "old.npz", Path(folder) / "new.npz")
    old, new = min(times["old"]), min(times["new"])
    print(f"point_values, 400 points with exponents: old {old * 1e3:.1f} ms, new {new * 1e3:.1f} ms, "
          f"new/old time {new / old:.3f}")
    print("values, new against old:")
    print("\n".join(changed))


if __name__ == "__main__":
    main()
