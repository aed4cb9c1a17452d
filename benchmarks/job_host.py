"""The host's side of a run through the job, without the kernel: what a GPU's run waits for.

    python benchmarks/job_host.py [--side 512] [--rounds 2]

On a GPU the card computes one chunk while the host computes the last one's diagnostics and
writes it; when the host is slower, the card waits (the effective model on an H100:
benchmarks/README.md, "GPU"). This runs vrsweep.sweep on a side x side (g, Omega) map of the
effective model (dop853, rtol 1e-9, 100 + 100 periods) with the kernel replaced by a copy of
2,048 points' precomputed outputs, in chunks of a GPU's sizes (32,768 points, doubling to
131,072), so that everything measured is the host's: the records' allocation, the diagnostics on
every core numba has, the writer. It times the writer's two ways (store/writer.py,
SLAB_WRITE_SHARE: every chunk as an HDF5 point selection, then as slabs where the points fill a
sixteenth of their rows), alternating, and prints each run's seconds and the ratio.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gpu import INTEGRATION, coefficients_of, grid, run  # noqa: E402

import vrsweep  # noqa: E402
from vrsweep.execution import sweep  # noqa: E402
from vrsweep.numerics.models import PaperKernels, kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402
from vrsweep.store import writer  # noqa: E402


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--side", type=int, default=512)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    kernels = kernels_for("effective")
    _, records, summaries, statuses = run(kernels.run_lines("dop853"),
                                          coefficients_of(kernels, grid(1_000_000)[:2048]),
                                          settings_vector(**INTEGRATION), INTEGRATION["measure_periods"])

    def copied(coefficients, initial_states, settings, lines, period_records, summary, status):
        take = np.arange(lines.shape[0]) % len(statuses)
        period_records[:, 0], summary[:, 0], status[:, 0] = records[take], summaries[take], statuses[take]

    PaperKernels.run_lines = lambda self, method, lyapunov=False: copied
    sweep.default_chunk_lines = lambda threads, line_length: 32768
    sweep.max_chunk_lines = lambda *arguments, **options: 131072
    spent = {}
    write_points = writer.ResultWriter.write_points

    def timed(self, *arguments):
        began = time.perf_counter()
        write_points(self, *arguments)
        spent["write"] += time.perf_counter() - began

    writer.ResultWriter.write_points = timed
    config = {"model": "effective",
              "sweep": {"g": {"start": 5.0, "stop": 35.0, "num": args.side},
                        "Omega": {"start": 3.0, "stop": 6.0, "num": args.side}},
              "integration": {key: INTEGRATION[key] for key in
                              ("rtol", "atol", "transient_periods", "measure_periods")}}
    times = {"points": [], "slabs": []}
    for _ in range(args.rounds):
        for name, share in (("points", np.inf), ("slabs", 1 / 16)):
            writer.SLAB_WRITE_SHARE = share
            spent["write"] = 0.0
            with tempfile.TemporaryDirectory() as folder:
                began = time.perf_counter()
                vrsweep.sweep(config, output=Path(folder) / "map.h5", progress=False, method="dop853",
                              allow_large=True)
                elapsed = time.perf_counter() - began
            times[name].append((elapsed, spent["write"]))
            print(f"{args.side}x{args.side}, writes as {name:6s}: the run {elapsed:6.2f} s, of it writing "
                  f"{spent['write']:5.2f} s", flush=True)
    best = {name: min(runs) for name, runs in times.items()}
    print(f"points / slabs, best of {args.rounds}: the run {best['points'][0] / best['slabs'][0]:.2f}x, "
          f"writing {min(w for _, w in times['points']) / min(w for _, w in times['slabs']):.2f}x")


if __name__ == "__main__":
    main()
