"""The GPU against all of the same machine's CPU cores, one run: speed, compile time, agreement.

    python benchmarks/gpu.py [--points 1000000] [--budget 420] [--out DIR]

On a (g, Omega) map of g in [5, 35] x Omega in [3, 6], rtol 1e-9, 100 + 100 periods (the issue's
map), for each model (original: eq2.1, effective: eq2.10):

- CPU: vrsweep's sweep lines (lines.py, a thread on every core numba has) with each method, on a
  random sample of the map's points (the whole map would take the CPU hours): points per second.
- GPU: the same lines on the card (numerics/cuda.py, a thread per point) with each method, on the
  whole map where the time budget allows, else on as many points as it does: points per second,
  and the first launch's compile time.
- Agreement on the CPU's sample: statuses equal, R relative difference at points with a period
  (analysis.diagnostics), for rk45 (the same steps but for the GPU's fused multiply-adds) and
  dop853 (the GPU's evaluates the forcing by the library, the CPU's by rotation).
- A Lyapunov map: lambda_1 from GPU and CPU (rk45) on a sample; the GPU's speed.
- The kernels' registers and local memory per thread (numba-cuda's report).
- Through the job (--job-points, each model's fastest GPU method): vrsweep.sweep(device="cuda")
  writing its HDF5 file, with the chunks, diagnostics and writing a user's run has, against the
  bare launches above: what a user gets (--job-fresh-arrays: also with fresh device arrays per
  launch, as up to 0.6.2, in the same process). Each chunk's size and seconds on the card are
  printed as it finishes, so that a call cut short still tells.
- --divergence N: gpu_divergence.py's one point per warp against 32 (what divergence costs).

Prints a table as it goes and writes everything to OUT/gpu.json. Ratios compare runs of this one
process on this one machine; the card's name and the CPU's core count are printed with them.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numba  # noqa: E402

from vrsweep.analysis.diagnostics import point_diagnostics  # noqa: E402
from vrsweep.config.schema import INTEGRATION_DEFAULTS, Integration  # noqa: E402
from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.model import DEFAULT_PARAMETERS  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402
from vrsweep.results import Status  # noqa: E402

INTEGRATION = dict(INTEGRATION_DEFAULTS, rtol=1e-9, atol=1e-11, transient_periods=100, measure_periods=100)
CPU_SAMPLE = {"original": 3000, "effective": 12000}  # points the CPU runs per method
AGREEMENT_SAMPLE = 2000                              # of those, compared with the GPU
LYAPUNOV_SAMPLE = 1000
FIRST_LAUNCH = 65536                                 # GPU points timed before the rest of a map
X0, V0 = 0.99, 0.5


def log(*items):
    print(*items, flush=True)


def grid(n_points, seed=0):
    """(n, 2) of (g, Omega): the square map of about n points, in a shuffled order."""
    side = int(round(np.sqrt(n_points)))
    g, omega = np.meshgrid(np.linspace(5.0, 35.0, side), np.linspace(3.0, 6.0, side), indexing="ij")
    points = np.stack([g.ravel(), omega.ravel()], axis=1)
    return points[np.random.default_rng(seed).permutation(len(points))]


def coefficients_of(kernels, points):
    parameters = {name: np.full(len(points), value) for name, value in DEFAULT_PARAMETERS.items()}
    parameters["g"] = points[:, 0]
    parameters["Omega"] = points[:, 1]
    return np.ascontiguousarray(kernels.coefficients(parameters))


def run(run_lines, coefficients, settings, measure):
    n = len(coefficients)
    records = np.full((n, 1, measure, kernel.N_RECORD), np.nan)
    summaries = np.full((n, 1, kernel.N_SUMMARY), np.nan)
    statuses = np.full((n, 1), Status.NOT_COMPUTED, dtype=np.int8)
    began = time.perf_counter()
    run_lines(coefficients, np.tile([X0, V0], (n, 1)), settings, np.arange(n, dtype=np.int64).reshape(n, 1),
              records, summaries, statuses)
    return time.perf_counter() - began, records[:, 0], summaries[:, 0], statuses[:, 0]


def compare(cpu, gpu, kernels, coefficients, integration):
    """Statuses equal (fraction), and R's relative difference where both have a period."""
    _, records_c, summaries_c, statuses_c = cpu
    _, records_g, summaries_g, statuses_g = gpu
    frequencies = kernels.forcing_frequencies(coefficients)
    period_c = point_diagnostics(records_c, statuses_c, coefficients, frequencies, integration)["period"]
    period_g = point_diagnostics(records_g, statuses_g, coefficients, frequencies, integration)["period"]
    both = (period_c > 0) & (period_g > 0) & (statuses_c == Status.OK) & (statuses_g == Status.OK)
    r_c, r_g = summaries_c[both, kernel.SUM_R], summaries_g[both, kernel.SUM_R]
    relative = np.abs(r_g - r_c) / np.maximum(np.abs(r_c), 1e-300)
    return {
        "statuses_equal": float(np.mean(statuses_c == statuses_g)),
        "periodic_points": int(both.sum()),
        "periods_equal": float(np.mean(period_c[both] == period_g[both])) if both.any() else None,
        "R_relative_max": float(relative.max()) if both.any() else None,
        "R_relative_median": float(np.median(relative)) if both.any() else None,
        "R_relative_p99": float(np.quantile(relative, 0.99)) if both.any() else None,
    }


def resources(device_lines):
    """Registers and local memory per thread of the kernel's compiled specialisation(s)."""
    report = {}
    try:
        dispatcher = device_lines.kernel
        report["registers"] = {str(k): v for k, v in dispatcher.get_regs_per_thread().items()}
        report["local_bytes"] = {str(k): v for k, v in dispatcher.get_local_mem_per_thread().items()}
    except Exception as error:  # noqa: BLE001 -- a report, not the measurement
        report["error"] = repr(error)
    return report


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--budget", type=float, default=420.0, help="seconds of GPU map time in all")
    parser.add_argument("--out", default=os.environ.get("OUT", "."))
    parser.add_argument("--models", default="effective,original")
    parser.add_argument("--quick", action="store_true", help="tiny samples: a smoke test (CUDA simulator)")
    parser.add_argument("--job-points", type=int, default=262144,
                        help="points of the map run through the job per model (0: none)")
    parser.add_argument("--job-only", action="store_true", help="only the runs through the job")
    parser.add_argument("--divergence", type=int, default=0, metavar="DISTINCT",
                        help="then gpu_divergence.py's measurement on DISTINCT points x 32 (0: none)")
    parser.add_argument("--job-fresh-arrays", action="store_true",
                        help="run each job's map twice: fresh device arrays per launch (0.6.2), then kept slots")
    parser.add_argument("--hold", type=int, default=None, metavar="LANES",
                        help="cuda.HOLD_LANES for every kernel of this run (default: the package's)")
    args = parser.parse_args()
    global AGREEMENT_SAMPLE, LYAPUNOV_SAMPLE, FIRST_LAUNCH
    if args.hold is not None:
        from vrsweep.numerics import cuda as vrsweep_cuda

        vrsweep_cuda.HOLD_LANES = args.hold
    if args.quick:
        CPU_SAMPLE.update(original=48, effective=48)
        AGREEMENT_SAMPLE = LYAPUNOV_SAMPLE = FIRST_LAUNCH = 32
        args.job_points = min(args.job_points, 16)
    from numba import cuda

    import numba_cuda

    device = cuda.get_current_device()
    name = getattr(device, "name", "CUDA simulator")
    card = name.decode() if isinstance(name, bytes) else str(name)
    results = {"card": card, "cpu_threads": numba.config.NUMBA_NUM_THREADS, "numba": numba.__version__,
               "numba_cuda": getattr(numba_cuda, "__version__", "?"), "points_asked": args.points, "models": {},
               "hold_lanes": args.hold}
    log(f"card {card}, {results['cpu_threads']} CPU threads, numba {numba.__version__}, "
        f"numba-cuda {results['numba_cuda']}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    integration = Integration(**INTEGRATION)
    settings = settings_vector(**INTEGRATION)
    measure = INTEGRATION["measure_periods"]
    started = time.perf_counter()

    def save():
        (out / "gpu.json").write_text(json.dumps(results, indent=1))

    models = args.models.split(",")
    for model in [] if args.job_only else models:
        kernels = kernels_for(model)
        entry = results["models"][model] = {}
        sample = grid(args.points)[:CPU_SAMPLE[model]]
        sample_coefficients = coefficients_of(kernels, sample)
        for method in ("rk45", "dop853"):
            row = entry[method] = {}
            # CPU: compile on a few points, then the sample.
            began = time.perf_counter()
            run(kernels.run_lines(method), sample_coefficients[:16], settings, measure)
            row["cpu_compile_s"] = time.perf_counter() - began
            cpu = run(kernels.run_lines(method), sample_coefficients, settings, measure)
            row["cpu_points_per_s"] = len(sample) / cpu[0]
            # GPU: compile and first launch on a few points, then the sample, then the map.
            gpu_lines = kernels.gpu_lines(method)
            began = time.perf_counter()
            run(gpu_lines, sample_coefficients[:16], settings, measure)
            row["gpu_compile_s"] = time.perf_counter() - began
            row.update(resources(gpu_lines))
            n = AGREEMENT_SAMPLE
            gpu = run(gpu_lines, sample_coefficients[:n], settings, measure)
            cpu_part = tuple(part[:n] for part in cpu[1:])
            row["agreement"] = compare((cpu[0],) + cpu_part, gpu, kernels, sample_coefficients[:n], integration)
            # The map: a first launch of 2^16 points says how many the budget allows.
            left = args.budget / (2 * len(models)) - 0  # this model and method's share
            points = grid(args.points)
            first = min(len(points), FIRST_LAUNCH)
            elapsed, _, _, statuses = run(gpu_lines, coefficients_of(kernels, points[:first]), settings, measure)
            rate = first / elapsed
            row["gpu_first_launch_points_per_s"] = rate  # gpu_variants.py's workload: its figures compare
            n_map = first
            if len(points) > first and (len(points) - first) / rate < left:
                rest = coefficients_of(kernels, points[first:])
                more, _, _, _ = run(gpu_lines, rest, settings, measure)
                elapsed += more
                n_map = len(points)
            row["gpu_map_points"] = n_map
            row["gpu_map_s"] = elapsed
            row["gpu_points_per_s"] = n_map / elapsed
            row["gpu_ok_fraction"] = float(np.mean(statuses == Status.OK))
            save()
            log(f"{model:9s} {method:6s} CPU {row['cpu_points_per_s']:9.0f} pts/s (compile {row['cpu_compile_s']:.1f} s) | "
                f"GPU {row['gpu_points_per_s']:9.0f} pts/s on {n_map} points (compile {row['gpu_compile_s']:.1f} s, "
                f"regs {row.get('registers')}, local {row.get('local_bytes')}) | "
                f"statuses equal {row['agreement']['statuses_equal']:.4f}, R rel max {row['agreement']['R_relative_max']}"
                f" median {row['agreement']['R_relative_median']} on {row['agreement']['periodic_points']} periodic "
                f"| t={time.perf_counter() - started:.0f}s")
        best_cpu = max(entry[m]["cpu_points_per_s"] for m in ("rk45", "dop853"))
        best_gpu = max(entry[m]["gpu_points_per_s"] for m in ("rk45", "dop853"))
        entry["gpu_over_best_cpu"] = best_gpu / best_cpu
        log(f"{model}: best GPU / best CPU = {entry['gpu_over_best_cpu']:.2f}x")
        save()

    if not args.job_only:
        lyapunov_map(args, results, settings, measure)
        save()
    if args.job_points:
        results["job"] = {}
        for model in models:
            for reuse in (False, True) if args.job_fresh_arrays else (True,):
                key = model if reuse else f"{model}, fresh arrays"
                results["job"][key] = row = through_the_job(model, JOB_METHOD[model], args.job_points, reuse)
                save()
                log(f"{key:9s} {JOB_METHOD[model]:6s} through the job: {row['points_per_s']:.0f} pts/s on "
                    f"{row['points']} points ({row['seconds']:.1f} s, compile included: {row['first_seconds']:.1f} s "
                    f"for the first {row['first_points']}; GPU chunks {row['chunks']})")
    if args.divergence:
        from gpu_divergence import measure as divergence  # this folder's

        results["divergence"] = divergence(args.divergence, out=out)
        save()
    log(json.dumps(results))


JOB_METHOD = {"effective": "dop853", "original": "rk45"}  # each model's fastest on the GPU


def through_the_job(model, method, n_points, reuse=True):
    """vrsweep.sweep on the GPU, with its file, as a user's run: a small run first (it compiles the
    kernel, so the timed run's figure is of the computing), then the map of about n_points.
    reuse: numerics/cuda.REUSE_DEVICE_ARRAYS for the run (False: 0.6.2's fresh arrays per launch).
    Also records the GPU chunks' sizes and kernel seconds (sweep.LineRunner.finish's)."""
    import tempfile

    import vrsweep
    from vrsweep.execution import sweep
    from vrsweep.numerics import cuda

    side = int(round(np.sqrt(n_points)))
    row = {"method": method, "reuse_device_arrays": reuse, "chunks": []}
    cuda.REUSE_DEVICE_ARRAYS = reuse
    finish = sweep.LineRunner.finish

    def timed_finish(runner, chunk):
        done = finish(runner, chunk)
        row["chunks"].append([len(chunk.flat), round(chunk.seconds, 2)])
        if len(chunk.flat) > 64:  # (the map's, not the compiling run's: a call cut short still tells)
            log(f"  chunk of {len(chunk.flat)} points: {chunk.seconds:.2f} s on the card, "
                f"{len(chunk.flat) / chunk.seconds:.0f} pts/s")
        return done

    sweep.LineRunner.finish = timed_finish
    with tempfile.TemporaryDirectory() as folder:
        for name, num in (("first", 8), ("map", side)):
            config = {"model": model,
                      "sweep": {"g": {"start": 5.0, "stop": 35.0, "num": num},
                                "Omega": {"start": 3.0, "stop": 6.0, "num": num}},
                      "integration": {key: INTEGRATION[key] for key in
                                      ("rtol", "atol", "transient_periods", "measure_periods")}}
            began = time.perf_counter()
            vrsweep.sweep(config, output=Path(folder) / f"{name}.h5", progress=False, method=method, device="cuda",
                          allow_large=True)
            elapsed = time.perf_counter() - began
            if name == "first":
                row["first_seconds"], row["first_points"] = elapsed, num * num
                row["chunks"].clear()
            else:
                row["seconds"], row["points"] = elapsed, num * num
    sweep.LineRunner.finish = finish
    cuda.REUSE_DEVICE_ARRAYS = True
    row["points_per_s"] = row["points"] / row["seconds"]
    return row


def lyapunov_map(args, results, settings, measure):
    """lambda_1 from GPU and CPU (rk45, original model) on a sample; the GPU's speed on a launch."""
    kernels = kernels_for("original")
    sample_coefficients = coefficients_of(kernels, grid(args.points)[:LYAPUNOV_SAMPLE])
    row = results["lyapunov"] = {}
    began = time.perf_counter()
    cpu = run(kernels.run_lines("rk45", True), sample_coefficients, settings, measure)
    row["cpu_s_with_compile"] = time.perf_counter() - began
    cpu = run(kernels.run_lines("rk45", True), sample_coefficients, settings, measure)
    row["cpu_points_per_s"] = LYAPUNOV_SAMPLE / cpu[0]
    gpu_lines = kernels.gpu_lines("rk45", True)
    began = time.perf_counter()
    run(gpu_lines, sample_coefficients[:16], settings, measure)
    row["gpu_compile_s"] = time.perf_counter() - began
    gpu = run(gpu_lines, sample_coefficients, settings, measure)
    both = (cpu[3] == Status.OK) & (gpu[3] == Status.OK)
    difference = np.abs(gpu[2][both, kernel.SUM_LYAPUNOV] - cpu[2][both, kernel.SUM_LYAPUNOV])
    row["lambda1_abs_max"] = float(difference.max()) if both.any() else None
    row["lambda1_abs_median"] = float(np.median(difference)) if both.any() else None
    row["statuses_equal"] = float(np.mean(cpu[3] == gpu[3]))
    big = coefficients_of(kernels, grid(args.points)[:FIRST_LAUNCH])
    elapsed, _, _, _ = run(gpu_lines, big, settings, measure)
    row["gpu_points_per_s"] = len(big) / elapsed
    row.update(resources(gpu_lines))
    log(f"lyapunov rk45 original: CPU {row['cpu_points_per_s']:.0f} pts/s, GPU {row['gpu_points_per_s']:.0f} pts/s "
        f"({row['gpu_points_per_s'] / row['cpu_points_per_s']:.1f}x), lambda1 |diff| max {row['lambda1_abs_max']} "
        f"median {row['lambda1_abs_median']}, statuses equal {row['statuses_equal']:.4f}")


if __name__ == "__main__":
    main()
