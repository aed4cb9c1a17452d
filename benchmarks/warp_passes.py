"""What the impact's Newton steps cost a warp: an estimate from the CPU's counts, no GPU needed.

    python benchmarks/warp_passes.py [--model original] [--method rk45] [--points 1024]

On a GPU the lanes of a warp take each pass of the loop together (the warp vote, numerics/cuda.py);
up to 0.6.5 a lane that met an impact then took the impact's exact step, IMPACT_NEWTON_ITERATIONS
steps at most, inside its pass, while the warp's other lanes waited. Turning those steps into
passes of the loop, so that they share the one step of every pass (done since, kernel._integrate),
is worth at most what they cost the warp. This runs a random sample of the benchmark map (benchmarks/gpu.py's settings) on the CPU and
counts per point its steps, impacts and right-hand sides; the Newton steps are the right-hand
sides left after the steps' own, the two of the start and the one after each rebound (rk45's
dense output costs none, so rk45 only). With p the impacts per step and m the Newton steps per
impact, a pass of a warp of 32 lanes costs 1 + (1 - (1 - p)^32) m steps if lanes meet impacts
independently: the ratio to 1 + p m (a lane alone) bounds the restructuring's gain.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gpu import INTEGRATION, coefficients_of, grid, run  # noqa: E402

from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.rk45 import N_STAGES  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402

WARP = 32


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--model", default="original")
    parser.add_argument("--points", type=int, default=1024)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    kernels = kernels_for(args.model)
    points = grid(1_000_000)
    points = points[np.random.default_rng(args.seed).choice(len(points), args.points, replace=False)]
    seconds, _, summaries, statuses = run(kernels.run_lines("rk45"), coefficients_of(kernels, points),
                                          settings_vector(**INTEGRATION), INTEGRATION["measure_periods"])
    steps = summaries[:, kernel.SUM_STEPS]
    impacts = summaries[:, kernel.SUM_IMPACTS]
    sticks = summaries[:, kernel.SUM_STICKS]
    rejected = summaries[:, kernel.SUM_REJECTED]
    newton = (summaries[:, kernel.SUM_RHS] - 2 - steps * N_STAGES - impacts) / N_STAGES
    p = impacts.sum() / steps.sum()
    m = newton.sum() / impacts.sum()
    alone, warp = 1 + p * m, 1 + (1 - (1 - p) ** WARP) * m
    print(f"{args.model}, rk45, {args.points} points of the map ({seconds:.1f} s on the CPU); statuses "
          f"{dict(zip(*[a.tolist() for a in np.unique(statuses, return_counts=True)]))}")
    print(f"steps a point: mean {steps.mean():.0f}, median {np.median(steps):.0f}, max {steps.max():.0f}")
    print(f"impacts a step {p:.4f}; Newton steps an impact {m:.2f}; rejected steps a step "
          f"{rejected.sum() / steps.sum():.4f}; sticks a point {sticks.mean():.1f}")
    print(f"a pass costs a lane alone {alone:.3f} steps, a warp of {WARP} lanes {warp:.3f}: Newton steps "
          f"taken as passes would gain at most {warp / alone:.2f}x")


if __name__ == "__main__":
    main()
