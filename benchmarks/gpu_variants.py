"""The GPU kernel's launch shapes against each other and against the CPU, one run, one machine.

    python benchmarks/gpu_variants.py [--points 65536] [--variants A,C,D,E] [--cases original:rk45,...]
                                      [--source DIR] [--no-cpu] [--out DIR]

numerics/cuda.py has six levers (its QUEUE, SORT, MAX_REGISTERS, GATHER_LANES, LOCAL_COEFFICIENTS
and HOLD_LANES): a work queue, lines handed out in parameter order, a register cap, a warp barrier
at every pass of the loop, a thread's coefficients read from its own copy, and the loop's rare
branches held back until several lanes of a warp take them together. This script times, on the
first POINTS points of gpu.py's shuffled (g, Omega) map (rtol 1e-9, 100 + 100 periods):

    A  one thread per line, shuffled order, the compiler's registers   (the first version)
    C  the queue, parameter order, the compiler's registers             (the default up to 0.6.2)
    D  C with at most 128 registers a thread
    E  C with the lanes of a warp gathered at every pass                (the default)
    F  E with each thread's coefficients copied to its local memory    (cuda.LOCAL_COEFFICIENTS)
    G  E with at most 168 registers a thread: 12 warps a multiprocessor instead of 8, more to hide
       the latency of a branch's serial arithmetic, for spills (benchmarks/README.md, 0.6.7)
    H  E with a step's rare branches held until 8 lanes of the warp wait (cuda.HOLD_LANES = 8)
    I  the same until 16 wait (benchmarks/warp_defer.py: the better if the card weighs the
       branches 10x as the CPU does, the worse if it weighs them as the CPU does)

for the original model with rk45 and dop853 and the effective model with dop853, and the CPU's
best method (dop853, every core) on a sample, so that every ratio is of this one process. Checks
that every variant gives the same statuses and R as the first bit for bit (neither the order of
the lines nor a barrier changes anything in a line's arithmetic).

--source DIR times another checkout's vrsweep (its package folder's parent, e.g. an old version
unpacked with `git archive REV | tar -x -C DIR`): two calls, one with it and one without, compare
two versions on one card; --variants C times only the default shape.
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
if "--source" in sys.argv[:-1]:  # another checkout's package, imported before gpu.py's path puts this one first
    sys.path.insert(0, str(Path(sys.argv[sys.argv.index("--source") + 1]).resolve()))
import vrsweep  # noqa: E402,F401

from gpu import INTEGRATION, coefficients_of, grid, log, run  # noqa: E402
from vrsweep.numerics import cuda, rhs  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402
from vrsweep.numerics.trajectory import settings_vector  # noqa: E402

VARIANTS = {"A": dict(queue=False, sort=False, max_registers=None, gather=False),
            "C": dict(queue=True, sort=True, max_registers=None, gather=False),
            "D": dict(queue=True, sort=True, max_registers=128, gather=False),
            "E": dict(queue=True, sort=True, max_registers=None, gather=True),
            "F": dict(queue=True, sort=True, max_registers=None, gather=True, local_coefficients=True),
            "G": dict(queue=True, sort=True, max_registers=168, gather=True),
            "H": dict(queue=True, sort=True, max_registers=None, gather=True, hold=8),
            "I": dict(queue=True, sort=True, max_registers=None, gather=True, hold=16)}
CASES = [("original", "rk45", 2000), ("effective", "dop853", 8000), ("original", "dop853", 2000)]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=65536)
    parser.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated, of " + ", ".join(VARIANTS))
    parser.add_argument("--source", help="the folder holding the vrsweep package to time (default: this one)")
    parser.add_argument("--out", default=os.environ.get("OUT", "."))
    parser.add_argument("--cases", help="comma-separated model:method, of " + ",".join(
        f"{model}:{method}" for model, method, _ in CASES) + " (default: all)")
    parser.add_argument("--no-cpu", action="store_true",
                        help="leave out the CPU's sample (when another run in the same call times it)")
    args = parser.parse_args()
    chosen = [name.strip() for name in args.variants.split(",")]
    unknown = sorted(set(chosen) - set(VARIANTS))
    if unknown:
        parser.error(f"--variants: unknown {', '.join(unknown)} (known: {', '.join(VARIANTS)})")
    cases = CASES
    if args.cases:
        asked = [case.strip() for case in args.cases.split(",")]
        cases = [case for name in asked for case in CASES if f"{case[0]}:{case[1]}" == name]
        if len(cases) != len(asked):
            parser.error(f"--cases: {args.cases} (known: {', '.join(f'{m}:{k}' for m, k, _ in CASES)})")
    settings = settings_vector(**INTEGRATION)
    measure = INTEGRATION["measure_periods"]
    results = {"card": str(getattr(cuda.cuda.get_current_device(), "name", "CUDA simulator")), "points": args.points,
               "vrsweep": f"{vrsweep.__version__} from {Path(vrsweep.__file__).parent}"}
    log(f"vrsweep {results['vrsweep']}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for model, method, cpu_sample in cases:
        kernels = kernels_for(model)
        points = grid(1_000_000)[:args.points]
        coefficients = coefficients_of(kernels, points)
        row = results[f"{model} {method}"] = {}
        row["cpu_dop853_points_per_s"] = float("nan")
        if not args.no_cpu:
            cpu_lines = kernels.run_lines("dop853")
            run(cpu_lines, coefficients[:16], settings, measure)  # compile
            sample = coefficients[:cpu_sample]
            elapsed, *_ = run(cpu_lines, sample, settings, measure)
            row["cpu_dop853_points_per_s"] = len(sample) / elapsed
        reference = None
        # (up to 0.6.7 the helper was cuda's: an old version's, --source, has it there)
        functions = getattr(rhs, "paper_functions", None) or cuda.paper_functions
        functions = functions(False)
        for name in chosen:
            variant = VARIANTS[name]
            known = inspect.signature(cuda.line_kernel).parameters  # (an old version's, --source, has fewer)
            options = {key: variant[key] for key in ("queue", "max_registers", "gather", "local_coefficients", "hold")
                       if key in known and key in variant}
            compiled = cuda.line_kernel(method, False, *functions, **options)
            lines = cuda.DeviceLines(compiled, sort=variant["sort"])
            began = time.perf_counter()
            run(lines, coefficients[:16], settings, measure)
            compile_s = time.perf_counter() - began
            elapsed, _, summaries, statuses = run(lines, coefficients, settings, measure)
            try:
                registers = list(compiled.get_regs_per_thread().values())
                local = list(compiled.get_local_mem_per_thread().values())
            except AttributeError:  # the CUDA simulator
                registers = local = None
            same = None
            if reference is None:  # the first variant timed (A unless --variants leaves it out)
                reference = (summaries, statuses)
            else:
                same = bool(np.array_equal(statuses, reference[1])
                            and np.array_equal(summaries, reference[0], equal_nan=True))
            # (a digest of the outputs, so that two calls, --source and not, compare bit for bit too)
            digest = hashlib.sha1(summaries.tobytes() + statuses.tobytes()).hexdigest()[:16]
            row[name] = {"points_per_s": args.points / elapsed, "seconds": elapsed, "compile_s": compile_s,
                         "registers": registers, "local_bytes": local, "same_as_first": same,
                         "outputs_sha1": digest}
            row[name]["over_cpu_best"] = row[name]["points_per_s"] / row["cpu_dop853_points_per_s"]
            log(f"{model:9s} {method:6s} {name}: {row[name]['points_per_s']:8.0f} pts/s "
                f"({row[name]['over_cpu_best']:.2f}x CPU dop853 {row['cpu_dop853_points_per_s']:.0f}), "
                f"regs {registers}, local {local}, compile {compile_s:.1f} s, same as {chosen[0]}: {same}, "
                f"outputs {digest}")
            (out / "gpu_variants.json").write_text(json.dumps(results, indent=1))
    log(json.dumps(results))


if __name__ == "__main__":
    main()
