"""How far apart a warp's points lie on the map, and what it costs the GPU: one run, the same work.

    python benchmarks/gpu_spacing.py [--cases original:rk45,original:dop853,effective:dop853]
                                     [--side 1000] [--rows 32] [--spacings 1,8,32] [--rounds 2] [--out DIR]

A warp's 32 lanes run in step, and wait for each other where their points take different paths
through the integrator's loop (gpu_divergence.py: 6 to 11x between one point per warp and 32 random
points). Do neighbouring points of a map take the same path? A GPU run's chunks are random subsets
of the grid (the sweep's shuffle, made for the CPU's threads), sorted by their parameters: a warp's
lanes hold points as many cells apart as the chunk is sparse in the grid (a 1,000 x 1,000 map: 32
cells in its first chunk of 32,768 points, 8 in a chunk of 131,072). Chunks that were regions of
the grid would put them on adjacent cells.

This runs one set of points, ROWS rows of gpu.py's (g, Omega) map at SIDE x SIDE (rows spread
evenly over g, every Omega: the map's mix of motions), on the GPU's default kernel, once for each
spacing s: the lines in the order (column mod s, row, column div s), so that a warp's neighbouring
lanes hold points s cells apart along Omega. The same points and work for every s; prints points
per second and each spacing's speed over the largest's, and checks that every order gives every
point the same statuses and summaries, bit for bit (the order changes nothing in a point).

Measured on an H100 (2026-11-27, benchmarks/README.md): adjacent points ran no faster than points
32 cells apart (0.96x with rk45, 0.93x with dop853, the original model), so chunks stay shuffled.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gpu import INTEGRATION, coefficients_of, log, run  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402

CASES = "original:rk45,original:dop853,effective:dop853"


def map_rows(side, rows):
    """(rows * side, 2) of (g, Omega) and each point's (row, column) on the side x side map."""
    g = np.linspace(5.0, 35.0, side)[np.unique(np.linspace(0, side - 1, rows).round().astype(int))]
    omega = np.linspace(3.0, 6.0, side)
    row, column = np.meshgrid(np.arange(len(g)), np.arange(side), indexing="ij")
    points = np.stack([g[row.ravel()], omega[column.ravel()]], axis=1)
    return points, row.ravel(), column.ravel()


def spaced_order(row, column, spacing):
    """The points' order that puts neighbouring lanes ``spacing`` columns apart."""
    return np.lexsort((column // spacing, row, column % spacing))


def measure(cases, side, rows, spacings, rounds, out=None):
    from vrsweep.numerics import cuda

    settings = settings_vector(**INTEGRATION)
    measure_periods = INTEGRATION["measure_periods"]
    points, row, column = map_rows(side, rows)
    results = {"side": side, "rows": rows, "points": len(points), "cases": {}}
    for case in cases:
        model, method = case.split(":")
        kernels = kernels_for(model)
        coefficients = coefficients_of(kernels, points)
        device_lines = cuda.DeviceLines(kernels.gpu_lines(method).kernel, sort=False)
        run(device_lines, coefficients[:64], settings, measure_periods)  # compile or load
        entry = results["cases"][case] = {"seconds": {str(s): [] for s in spacings}}
        reference = None
        same = True
        for _ in range(rounds):
            for spacing in spacings:
                order = spaced_order(row, column, spacing)
                seconds, _, summaries, statuses = run(device_lines, coefficients[order], settings, measure_periods)
                entry["seconds"][str(spacing)].append(seconds)
                back = np.empty_like(order)
                back[order] = np.arange(len(order))
                if reference is None:
                    reference = (summaries[back], statuses[back])
                else:
                    same &= bool(np.array_equal(reference[1], statuses[back])
                                 and np.array_equal(reference[0], summaries[back], equal_nan=True))
        best = {s: min(entry["seconds"][str(s)]) for s in spacings}
        entry["points_per_s"] = {str(s): len(points) / best[s] for s in spacings}
        widest = max(spacings)
        entry["over_widest"] = {str(s): best[widest] / best[s] for s in spacings}
        entry["bit_for_bit"] = same
        log(f"{model:9s} {method:6s} " + ", ".join(
            f"spacing {s}: {entry['points_per_s'][str(s)]:8.0f} pts/s ({entry['over_widest'][str(s)]:.2f}x)"
            for s in spacings) + f"; {len(points)} points, best of {rounds}; same results: {same}")
        if out is not None:
            (Path(out) / "gpu_spacing.json").write_text(json.dumps(results, indent=1))
    return results


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--cases", default=CASES)
    parser.add_argument("--side", type=int, default=1000)
    parser.add_argument("--rows", type=int, default=32)
    parser.add_argument("--spacings", default="1,8,32")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--out", default=os.environ.get("OUT", "."))
    args = parser.parse_args()
    Path(args.out).mkdir(parents=True, exist_ok=True)
    spacings = [int(s) for s in args.spacings.split(",")]
    log(json.dumps(measure(args.cases.split(","), args.side, args.rows, spacings, args.rounds, out=args.out)))


if __name__ == "__main__":
    main()
