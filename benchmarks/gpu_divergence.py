"""What the lanes of a warp cost each other on the GPU: one point per warp against 32, one run.

    python benchmarks/gpu_divergence.py [--distinct 2048] [--cases original:rk45,...] [--out DIR]

A warp's 32 threads execute one instruction at a time: where their points take different paths
through the loop (a rejected step, an impact, a dense output for an extremum), the warp runs each
path in turn while the other lanes wait. This measures what that costs, with the same work in both
runs: DISTINCT points of gpu.py's shuffled (g, Omega) map (rtol 1e-9, 100 + 100 periods), each
repeated 32 times, on the GPU's default kernel (numerics/cuda.py: the queue),

    same    the copies of a point next to each other (parameter order): a warp integrates one
            point 32 times, its lanes never diverge;
    mixed   the same lines in a random order (no sorting): a warp's lanes integrate 32 different
            points;

and prints points per second of each and same / mixed, the factor that divergence costs (an upper
bound on what any scheme keeping a warp's lanes together could gain), for the original model with
rk45 and dop853 and the effective model with dop853. Checks that both runs give every copy of a
point the same statuses and summaries, bit for bit (the order changes nothing in a line).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gpu import INTEGRATION, coefficients_of, grid, log, run  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402

WARP = 32
CASES = [("original", "rk45"), ("original", "dop853"), ("effective", "dop853")]


def measure(distinct, cases=CASES, out=None):
    """{case: {same, mixed: points/s, divergence_factor, bit_for_bit}} on DISTINCT points x 32."""
    from vrsweep.numerics import cuda

    settings = settings_vector(**INTEGRATION)
    measure_periods = INTEGRATION["measure_periods"]
    results = {}
    for model, method in cases:
        kernels = kernels_for(model)
        coefficients = np.repeat(coefficients_of(kernels, grid(1_000_000)[:distinct]), WARP, axis=0)
        shuffle = np.random.default_rng(1).permutation(len(coefficients))
        compiled = kernels.gpu_lines(method).kernel
        same_lines = cuda.DeviceLines(compiled, sort=True)
        mixed_lines = cuda.DeviceLines(compiled, sort=False)
        run(same_lines, coefficients[:16], settings, measure_periods)  # compile
        same = run(same_lines, coefficients, settings, measure_periods)
        mixed = run(mixed_lines, coefficients[shuffle], settings, measure_periods)
        unshuffled = np.empty_like(shuffle)
        unshuffled[shuffle] = np.arange(len(shuffle))
        bit_for_bit = bool(np.array_equal(same[3], mixed[3][unshuffled])
                           and np.array_equal(same[2], mixed[2][unshuffled], equal_nan=True))
        row = results[f"{model} {method}"] = {
            "points": len(coefficients), "same_points_per_s": len(coefficients) / same[0],
            "mixed_points_per_s": len(coefficients) / mixed[0], "bit_for_bit": bit_for_bit}
        row["divergence_factor"] = row["same_points_per_s"] / row["mixed_points_per_s"]
        log(f"{model:9s} {method:6s} one point per warp {row['same_points_per_s']:8.0f} pts/s, 32 points per warp "
            f"{row['mixed_points_per_s']:8.0f} pts/s: divergence costs {row['divergence_factor']:.2f}x "
            f"({len(coefficients)} lines; same results: {bit_for_bit})")
        if out is not None:
            (Path(out) / "gpu_divergence.json").write_text(json.dumps(results, indent=1))
    return results


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--distinct", type=int, default=2048, help="distinct points, each run 32 times")
    parser.add_argument("--cases", default=",".join(f"{model}:{method}" for model, method in CASES),
                        help="comma-separated model:method (each compiles a kernel)")
    parser.add_argument("--out", default=os.environ.get("OUT", "."))
    args = parser.parse_args()
    Path(args.out).mkdir(parents=True, exist_ok=True)
    cases = [tuple(case.split(":")) for case in args.cases.split(",")]
    log(json.dumps(measure(args.distinct, cases, out=args.out)))


if __name__ == "__main__":
    main()
