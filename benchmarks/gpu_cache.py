"""The GPU's kernel from numba's cache: a first process compiles it, a second loads it.

    python benchmarks/gpu_cache.py [--model original] [--method rk45] [--points 4096] [--out DIR]

Needs a CUDA GPU (numba-cuda). Up to 0.6.3 every process compiled the line kernel (20 to 65 s on
an H100's host); since 0.6.4 its source is a module file in numba's cache folder and numba-cuda
caches its compile (numerics/cuda.py, CACHE_KERNELS). This runs, in an empty cache folder of its
own (NUMBA_CACHE_DIR), the same child twice, one process after the other: the child times
cuda.ready_kernel (compiling or loading the kernel), reports numba-cuda's cache hits and misses
and any cache failure (ready_kernel then compiles without the cache), and runs a launch of
``--points`` points of the benchmark map (benchmarks/gpu.py's settings). Prints both children's
figures, the ratio of their kernel times, and whether their outputs are equal bit for bit; writes
DIR/gpu_cache.json. --cache-dir keeps the cache folder, so that later runs of a device call
(NUMBA_CACHE_DIR set to it) load the kernel rather than compile it.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def child(model, method, n_points):
    sys.path.insert(0, str(HERE))
    sys.path.insert(0, str(HERE.parent))
    from gpu import INTEGRATION, coefficients_of, grid, run

    from vrsweep.numerics import cuda
    from vrsweep.numerics.models import kernels_for
    from vrsweep.numerics.trajectory import settings_vector

    kernels = kernels_for(model)
    began = time.perf_counter()
    kernel_ = kernels.gpu_kernel(method)
    generated = time.perf_counter() - began
    was_cached = cuda.is_cached(kernel_)
    began = time.perf_counter()
    ready = cuda.ready_kernel(kernel_)
    ready_seconds = time.perf_counter() - began
    lines = kernels.gpu_lines(method)
    seconds, records, summaries, statuses = run(lines, coefficients_of(kernels, grid(1_000_000)[:n_points]),
                                                settings_vector(**INTEGRATION), INTEGRATION["measure_periods"])
    digest = hashlib.sha1(records.tobytes() + summaries.tobytes() + statuses.tobytes()).hexdigest()
    print(json.dumps({
        "source_seconds": generated, "cached_before": was_cached, "ready_seconds": ready_seconds,
        "cache_hits": sum(getattr(ready, "_cache_hits", {}).values()),
        "cache_misses": sum(getattr(ready, "_cache_misses", {}).values()),
        "cache_failure": getattr(ready, "cache_failure", None), "launch_seconds": seconds,
        "outputs_sha1": digest, "kernel_file": kernel_.py_func.__code__.co_filename}))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--model", default="original")
    parser.add_argument("--method", default="rk45")
    parser.add_argument("--points", type=int, default=4096)
    parser.add_argument("--out", default=".")
    parser.add_argument("--cache-dir", default=None,
                        help="an empty folder to cache in, kept after (default: a temporary one)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.model, args.method, args.points)
        return
    runs = []
    if args.cache_dir and any(Path(args.cache_dir).glob("*")):
        sys.exit(f"--cache-dir {args.cache_dir}: not empty")
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.cache_dir or scratch
        env = dict(os.environ, NUMBA_CACHE_DIR=folder)
        for name in ("first process (compiles)", "second process (loads)"):
            began = time.perf_counter()
            done = subprocess.run([sys.executable, __file__, "--child", "--model", args.model, "--method", args.method,
                                   "--points", str(args.points)], capture_output=True, text=True, env=env)
            wall = time.perf_counter() - began
            if done.returncode != 0:
                print(done.stderr[-3000:])
                sys.exit(done.returncode)
            result = json.loads(done.stdout.strip().splitlines()[-1])
            result["process_seconds"] = wall
            runs.append(result)
            print(f"{name}: kernel ready in {result['ready_seconds']:.1f} s (hits {result['cache_hits']}, misses "
                  f"{result['cache_misses']}, failure {result['cache_failure']}), launch of {args.points} points "
                  f"{result['launch_seconds']:.2f} s, process {wall:.1f} s", flush=True)
    first, second = runs
    summary = {"model": args.model, "method": args.method, "points": args.points, "runs": runs,
               "ready_ratio": first["ready_seconds"] / second["ready_seconds"],
               "same_outputs": first["outputs_sha1"] == second["outputs_sha1"]}
    print(f"compile / load: {summary['ready_ratio']:.1f}x; outputs equal bit for bit: {summary['same_outputs']}")
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / "gpu_cache.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
