"""Scale of `vrsweep run`: peak memory and wall time against grid size and measured periods.

    python benchmarks/scale.py [--threads N] [--sizes 1000 10000 100000] [--periods 25 50 100 200]
                               [--repeat 3] [--hdf5-chunk-bytes B]

Each measurement is a fresh `vrsweep run` subprocess (so the numbers include start-up, the HDF5
file and the analytic columns: what a user waits for), timed with a monotonic clock; its peak
resident set size is the child's own ru_maxrss from os.wait4. The numba cache is warmed first,
so no run includes compilation. Runs shorter than a minute are repeated (--repeat) and the
fastest is kept: on a shared machine the noise only ever adds time.

--hdf5-chunk-bytes B runs the children with the store's HDF5 chunk target set to B bytes (an
experiment for store.py, not a vrsweep option): a sweep chunk's points are scattered over the grid,
and every HDF5 chunk it touches is rewritten whole at the flush, so that target sets how the cost
of a checkpoint grows with the grid.

The runs are deliberately tiny per point (effective model, transient 1 + measure 1 slow periods,
one stroboscopic sample) so that 10^5 points take minutes: what grows with the grid is then the
bookkeeping (parameter tables, the done mask, the HDF5 chunk cache, per-chunk writes), which is
what this benchmark is about. The period series uses 1000 points of the same model.

Prints a Markdown table and the ratios (benchmarks/README.md, section "Scale", records them).
"""

import argparse
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path


def config_text(n_points, transient=1, measure=1):
    """Effective model on a g x Omega grid of n_points (100 Omega values once n >= 10^4)."""
    integration = f"integration: {{transient_periods: {transient}, measure_periods: {measure}, strobe_periods: 1}}\n"
    if n_points == 1:
        return "model: effective\n" + integration
    n_omega = 100 if n_points >= 10_000 else 10
    n_g = n_points // n_omega
    assert n_g * n_omega == n_points and n_g >= 2, n_points
    return textwrap.dedent(f"""\
        model: effective
        sweep:
          g: {{start: 0.0, stop: 40.0, num: {n_g}}}
          Omega: {{start: 4.0, stop: 5.0, num: {n_omega}}}
        """) + integration


def measure(directory, name, text, threads, repeat=1, chunk_bytes=None):
    """Run one config in fresh processes: the fastest of `repeat` runs (wall seconds, peak RSS in
    MiB, file size in MiB), repeating only while a run takes under a minute."""
    best = None
    for _ in range(repeat):
        result = _measure_once(directory, name, text, threads, chunk_bytes)
        best = result if best is None or result[0] < best[0] else best
        if result[0] > 60:
            break
    return best


def _measure_once(directory, name, text, threads, chunk_bytes):
    config = Path(directory) / f"{name}.yaml"
    out = Path(directory) / f"{name}.h5"
    config.write_text(text)
    launcher = ["-m", "vrsweep"]
    if chunk_bytes:
        launcher = ["-c", "import sys, vrsweep.store.layout as s; "
                    f"s._chunk_shape.__defaults__ = ({chunk_bytes},); "
                    "from vrsweep.cli import main; sys.argv[0] = 'vrsweep'; main()"]
    command = [sys.executable, *launcher, "run", str(config), "-o", str(out), "--overwrite",
               "--quiet", "--allow-large"]
    if threads:
        command += ["--threads", str(threads)]
    start = time.perf_counter()
    child = subprocess.Popen(command, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)  # this child's own rusage, not all children's
    wall = time.perf_counter() - start
    stderr = child.stderr.read().decode()
    child.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{name} failed:\n{stderr}")
    size = out.stat().st_size / 2**20
    out.unlink()
    return wall, usage.ru_maxrss / 1024, size  # ru_maxrss is in KiB on Linux


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--threads", type=int, default=None, help="--threads of each run (default: all cores)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000])
    parser.add_argument("--periods", type=int, nargs="+", default=[25, 50, 100, 200],
                        help="measured periods of the period series (1000 points, transient 1)")
    parser.add_argument("--repeat", type=int, default=3, help="keep the fastest of this many runs")
    parser.add_argument("--hdf5-chunk-bytes", type=int, default=None,
                        help="experiment: the store's HDF5 chunk target in the children")
    args = parser.parse_args()
    options = dict(threads=args.threads, repeat=args.repeat, chunk_bytes=args.hdf5_chunk_bytes)

    with tempfile.TemporaryDirectory(prefix="vrsweep-scale-") as directory:
        print("warming the numba cache ...", flush=True)
        measure(directory, "warmup", config_text(1), args.threads)
        base_wall, base_rss, _ = measure(directory, "one_point", config_text(1), **options)
        print(f"\nstart-up (1 point): {base_wall:.2f} s, {base_rss:.0f} MiB peak RSS")

        print("\n| points | wall (s) | wall - start-up (s) | us per point | peak RSS (MiB) | file (MiB) |")
        print("|---:|---:|---:|---:|---:|---:|")
        by_size = []
        for n in args.sizes:
            wall, rss, size = measure(directory, f"points_{n}", config_text(n), **options)
            work = wall - base_wall
            by_size.append((n, wall, work, rss))
            print(f"| {n} | {wall:.2f} | {work:.2f} | {1e6 * work / n:.0f} | {rss:.0f} | {size:.1f} |", flush=True)

        print("\n| measured periods (1000 points) | wall (s) | wall - start-up (s) | peak RSS (MiB) |")
        print("|---:|---:|---:|---:|")
        by_period = []
        for m in args.periods:
            wall, rss, _ = measure(directory, f"periods_{m}", config_text(1000, 1, m), **options)
            by_period.append((m, wall, wall - base_wall, rss))
            print(f"| {m} | {wall:.2f} | {wall - base_wall:.2f} | {rss:.0f} |", flush=True)

    print("\nratios, points (each step against the previous size):")
    for (n0, _, w0, r0), (n1, _, w1, r1) in zip(by_size, by_size[1:]):
        print(f"  {n1}/{n0} = {n1 / n0:g}x points: work time x{w1 / w0:.2f}, peak RSS x{r1 / r0:.2f} "
              f"(+{r1 - r0:.0f} MiB)")
    print("ratios, measured periods:")
    for (m0, _, w0, _), (m1, _, w1, _) in zip(by_period, by_period[1:]):
        print(f"  {m1}/{m0} = {m1 / m0:g}x periods: work time x{w1 / w0:.2f}")
    if len(by_period) >= 2:
        # Least-squares line through (periods, work time): the intercept is the per-point cost
        # that does not depend on the periods (chunk writes, diagnostics, one transient period).
        xs = [m for m, *_ in by_period]
        ys = [w for _, _, w, _ in by_period]
        mean_x, mean_y = sum(xs) / len(xs), sum(ys) / len(ys)
        slope = sum((x - mean_x) * (y - mean_y) for x, y in zip(xs, ys)) / sum((x - mean_x) ** 2 for x in xs)
        intercept = mean_y - slope * mean_x
        worst = max(abs(y - (intercept + slope * x)) / y for x, y in zip(xs, ys))
        print(f"  work time = {intercept:.2f} s + {1e3 * slope:.1f} ms x periods "
              f"(largest deviation from the line {100 * worst:.1f}%)")


if __name__ == "__main__":
    main()
