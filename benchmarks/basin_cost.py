"""Cost of a basin sweep (x0 / v0 axes) per point, against a parameter sweep of as many points.

    python benchmarks/basin_cost.py [--points 900] [--threads 1] [--repeat 3]

Both sweeps use the bistable hysteresis example (effective model, gamma = alpha = 0.05, Omega = 4,
300 transient + 100 measured slow periods, as configs/basins_g23.yaml): the basin sweep over a
square x0 x v0 grid at g = 23, the baseline over a g axis from 22.5 to 23.5 started from
configs/basins_g23.yaml's default `initial`. Each run is `job.run_job` in this process (numba
cache warmed first: no compilation timed), file writing and finishing included, so the basin
sweep's extra work shows: reading the points back and labelling them (timed on its own too, as
`attractors.label_grid`). Runs alternate and the fastest of --repeat is kept (noise on a shared
machine only adds time). Prints seconds per point and the ratio basin / parameter sweep.
"""

import argparse
import math
import tempfile
import time
from pathlib import Path

import numba

from vrsweep.analysis import attractors
from vrsweep.config import parse_config
from vrsweep.execution.job import run_job
from vrsweep.store.reading import load_results, point_variables

COMMON = """\
model: effective
parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0, g: 23.0}
integration: {transient_periods: 300, measure_periods: 100}
"""


def configs(n_points):
    side = int(round(math.sqrt(n_points)))
    basin = parse_config(COMMON + f"sweep: {{x0: {{start: -2.5, stop: 0.95, num: {side}}}, "
                                  f"v0: {{start: -2.5, stop: 2.5, num: {side}}}}}\n", "basin.yaml")
    parameter = parse_config(COMMON + f"sweep: {{g: {{start: 22.5, stop: 23.5, num: {side * side}}}}}\n",
                             "parameter.yaml")
    return basin, parameter


def timed_run(config, path, threads):
    began = time.perf_counter()
    run_job(config, path, threads=threads, overwrite=True)
    return time.perf_counter() - began


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=900)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    numba.set_num_threads(args.threads)
    basin, parameter = configs(args.points)
    n = basin.n_points
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        warm = parse_config(COMMON + "sweep: {x0: [0.0, 0.5]}\n")
        run_job(warm, folder / "warm.h5", threads=args.threads, overwrite=True)  # compile / load the cache
        best = {"basin": math.inf, "parameter": math.inf}
        for _ in range(args.repeat):
            best["parameter"] = min(best["parameter"], timed_run(parameter, folder / "p.h5", args.threads))
            best["basin"] = min(best["basin"], timed_run(basin, folder / "b.h5", args.threads))
        results = load_results(folder / "b.h5")
        labelling = math.inf
        for _ in range(args.repeat):
            began = time.perf_counter()
            attractors.label_grid({name: results[name].values for name in results.done.dims},
                                  {name: results[name].values for name in point_variables(results)},
                                  basin.integration.period_tolerance)
            labelling = min(labelling, time.perf_counter() - began)
        count = int(results["attractor_count"])
    print(f"{n} points, {args.threads} thread(s), 300 + 100 slow periods, effective model")
    print(f"| sweep | seconds | ms per point |\n|---|---:|---:|")
    print(f"| g axis ({n} values) | {best['parameter']:.2f} | {1e3 * best['parameter'] / n:.2f} |")
    print(f"| x0 x v0 at g = 23 ({n} points, {count} attractors) | {best['basin']:.2f} | "
          f"{1e3 * best['basin'] / n:.2f} |")
    print(f"| of which labelling (attractors.label_grid) | {labelling:.4f} | {1e3 * labelling / n:.4f} |")
    print(f"basin / parameter sweep: {best['basin'] / best['parameter']:.2f}x")


if __name__ == "__main__":
    main()
