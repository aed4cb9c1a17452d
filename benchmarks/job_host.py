"""The host's side of a GPU's run through the job, without the card: what a GPU's run waits for.

    python benchmarks/job_host.py [--compare fill|writes] [--side 512] [--rounds 2]

On a GPU the card computes one chunk while the host computes the last one's diagnostics and
writes it; when the host is slower, the card waits (the effective model on an H100:
benchmarks/README.md, "GPU"). This runs vrsweep.sweep(device="cuda") on a side x side (g, Omega)
map of the effective model (dop853, rtol 1e-9, 100 + 100 periods) with the device replaced by a
stand-in whose launch hands back 2,048 points' precomputed outputs (copied into the chunk's
arrays, as the card's copy back), in chunks of a GPU's sizes (32,768 points, doubling to
131,072), so that everything measured is the host's: the chunks' arrays, the diagnostics on
every core numba has, the writer, one chunk in flight as on a card. Two ways of one step, run
alternately, each run's seconds and their ratio printed:

- fill: the host fills the chunk's outputs with NaN and copies them in (up to 0.6.3; the copy in
  stood for by a copy on the host), or leaves them unfilled for the card to fill (cuda.fill_nan);
- writes: every chunk written as an HDF5 point selection (up to 0.6.2), or as slabs where its
  points fill a sixteenth of their rows (store/writer.py, SLAB_WRITE_SHARE).
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
from vrsweep.execution import device, sweep  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402
from vrsweep.store import writer  # noqa: E402


class StandInLaunch:
    def __init__(self, outputs, arrays):
        self.outputs, self.arrays = outputs, arrays

    def wait(self):
        records, summaries, statuses = self.outputs
        period_records, summary, status = self.arrays[4:]
        take = np.arange(period_records.shape[0]) % len(statuses)
        period_records[:, 0], summary[:, 0], status[:, 0] = records[take], summaries[take], statuses[take]
        return None


class StandInLines:
    """cuda.DeviceLines' launch and wait, without a card: the outputs copied back are precomputed.
    copy_in: the host's outputs are copied first, as DeviceLines did up to 0.6.3."""

    def __init__(self, outputs):
        self.outputs = outputs
        self.copy_in = False

    def launch(self, *arrays):
        if self.copy_in:
            for host in arrays[4:]:
                np.copy(host)
        return StandInLaunch(self.outputs, arrays)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--compare", choices=("fill", "writes"), default="fill")
    parser.add_argument("--side", type=int, default=512)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    kernels = kernels_for("effective")
    _, records, summaries, statuses = run(kernels.run_lines("dop853"),
                                          coefficients_of(kernels, grid(1_000_000)[:2048]),
                                          settings_vector(**INTEGRATION), INTEGRATION["measure_periods"])
    lines = StandInLines((records, summaries, statuses))
    device.check_device = lambda name: None
    device.gpu_lines = lambda kernels, method, lyapunov: lines
    sweep.gpu_memory_bytes = lambda: 80 * 2**30
    sweep.gpu_first_chunk_lines = lambda line_length: 32768
    sweep.max_chunk_lines = lambda *arguments, **options: 131072
    spent = {}
    write_points = writer.ResultWriter.write_points

    def timed(self, *arguments):
        began = time.perf_counter()
        write_points(self, *arguments)
        spent["write"] += time.perf_counter() - began

    writer.ResultWriter.write_points = timed
    unfilled = sweep._outputs

    def filled(shape, fill, dtype, filled_by_kernel):
        return unfilled(shape, fill, dtype, False)

    arms = {"fill": (("host fills, copies in (0.6.3)", {"_outputs": filled, "copy_in": True, "share": 1 / 16}),
                     ("card fills (0.6.4)", {"_outputs": unfilled, "copy_in": False, "share": 1 / 16})),
            "writes": (("writes as points (0.6.2)", {"_outputs": unfilled, "copy_in": False, "share": np.inf}),
                       ("writes as slabs (0.6.3)", {"_outputs": unfilled, "copy_in": False, "share": 1 / 16}))}
    config = {"model": "effective",
              "sweep": {"g": {"start": 5.0, "stop": 35.0, "num": args.side},
                        "Omega": {"start": 3.0, "stop": 6.0, "num": args.side}},
              "integration": {**{key: INTEGRATION[key] for key in
                                 ("rtol", "atol", "transient_periods", "measure_periods")}, "device": "cuda"}}
    times = {name: [] for name, _ in arms[args.compare]}
    for _ in range(args.rounds):
        for name, arm in arms[args.compare]:
            sweep._outputs = arm["_outputs"]
            lines.copy_in = arm["copy_in"]
            writer.SLAB_WRITE_SHARE = arm["share"]
            spent["write"] = 0.0
            with tempfile.TemporaryDirectory() as folder:
                began = time.perf_counter()
                vrsweep.sweep(config, output=Path(folder) / "map.h5", progress=False, method="dop853",
                              allow_large=True)
                elapsed = time.perf_counter() - began
            times[name].append((elapsed, spent["write"]))
            print(f"{args.side}x{args.side}, {name:30s}: the run {elapsed:6.2f} s, of it writing "
                  f"{spent['write']:5.2f} s", flush=True)
    (before, _), (after, _) = arms[args.compare]
    print(f"{before} / {after}, best of {args.rounds}: the run "
          f"{min(times[before])[0] / min(times[after])[0]:.2f}x, writing "
          f"{min(w for _, w in times[before]) / min(w for _, w in times[after]):.2f}x")


if __name__ == "__main__":
    main()
