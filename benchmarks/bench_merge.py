"""Peak memory of `vrsweep merge` against the number of shards, the result size and start-up.

    python benchmarks/bench_merge.py [--points 100000] [--strobe 64] [--shards 2 4 8]
                                     [--baseline REV] [--repeat 2]

The shard files are made synthetically, with the library's own writer and the layout of a real run
(vrsweep.execution.job: axes, variables, root attributes, owned masks and the analytic columns of a real
config), filled with values that are a function of the point: a merge does not look at what the
values mean, and computing 10^5 real points would take this machine many minutes. The default,
10^5 points with 64 stroboscopic samples, gives the 116 MiB result of the issue that asked for a
streaming merge (8 shards of it peaked at 1.19 GB).

Each merge is a fresh subprocess, `python -m vrsweep merge SHARDS -o OUT -q`; its peak resident set
size is its own ru_maxrss from os.wait4, taken by a small launcher process (see LAUNCHER). Start-up is the same command merging 2 shards of a
10-point grid of the same config. The baseline is the merge of revision REV (default 5bae00a, the
last one that read each shard whole): its vrsweep package, taken with `git archive`, is imported
by the same kind of subprocess and its store's merge_results called on the same files, with its own start-up
measured the same way. Each merge runs --repeat times; the lowest peak is kept (the noise of a
shared machine only adds).

Prints a Markdown table and the ratios (benchmarks/README.md, section "Merge", records them).
"""

import argparse
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

REPOSITORY = Path(__file__).resolve().parent.parent


def config_text(n_points, strobe):
    """Effective model on a g x Omega grid of n_points (100 Omega values from 1000 points on)."""
    n_omega = 100 if n_points >= 1000 else 2
    n_g = n_points // n_omega
    assert n_g * n_omega == n_points and n_g >= 2, n_points
    return textwrap.dedent(f"""\
        model: effective
        sweep:
          g: {{start: 0.0, stop: 40.0, num: {n_g}}}
          Omega: {{start: 4.0, stop: 5.0, num: {n_omega}}}
        integration: {{transient_periods: 1, measure_periods: {strobe}, strobe_periods: {strobe}}}
        output: merged.h5
        """)


def make_shards(directory, text, n_shards, extras_cache):
    """Shard files of ``text`` for shards 0..n_shards-1, every owned point done, finished as a
    run finishes them. Returns their paths."""
    from vrsweep.execution import job
    from vrsweep.config import parse_config
    from vrsweep.store import ResultWriter
    from vrsweep.execution.sweep import Grid

    config = parse_config(text)
    grid = Grid.from_config(config)
    if text not in extras_cache:  # the analytic columns: the same for every shard
        extras_cache[text] = job.analytic_extras(config, grid)
    specs = job._variable_specs(config)
    paths = []
    for index in range(n_shards):
        shard = (index, n_shards)
        path = job.shard_output_path(Path(directory) / "map.h5", shard)
        owned = job.owned_mask(grid, shard)
        writer = ResultWriter.create(path, job._axes(grid), specs, job.root_attributes(config, shard),
                                     overwrite=True, owned_mask=owned)
        points = np.flatnonzero(owned)
        for chunk in np.array_split(points, max(1, points.size // 4096)):
            writer.write_points(chunk, synthetic_values(specs, chunk))
        writer.finish(extra=extras_cache[text])
        paths.append(path)
    return paths


def synthetic_values(specs, points):
    """Values that differ from point to point and from variable to variable."""
    values = {}
    for k, spec in enumerate(specs):
        shape = (points.size,) + spec.extra_shape
        base = points.reshape((-1,) + (1,) * len(spec.extra_shape)).astype(np.float64)
        ramp = np.arange(int(np.prod(spec.extra_shape, dtype=np.int64))).reshape(spec.extra_shape or ())
        if spec.dtype.kind == "f":
            values[spec.name] = np.broadcast_to(np.sin(base + k + ramp), shape).astype(spec.dtype)
        elif spec.name == "status":
            values[spec.name] = np.zeros(shape, dtype=spec.dtype)  # ok
        else:
            values[spec.name] = np.broadcast_to(base.astype(np.int64) + k, shape).astype(spec.dtype)
    return values


BASELINE_LAUNCHER = """\
import sys
sys.path.insert(0, sys.argv[1])  # the revision's own package: its store imported its own modules
from vrsweep.store import merge_results
merge_results(sys.argv[3:], sys.argv[2], overwrite=True)
"""


def merge_command(shards, out, baseline_store=None):
    if baseline_store is None:
        return [sys.executable, "-m", "vrsweep", "merge", *map(str, shards), "-o", str(out),
                "--overwrite", "--quiet"]
    return [sys.executable, "-c", BASELINE_LAUNCHER, str(baseline_store), str(out), *map(str, shards)]


# A process's peak RSS on Linux includes the memory of the process it was forked from until it
# called exec (the parent's pages count as its own): measured straight from this process, which
# holds numba and the shards' analytic columns, every merge would look as large as this process.
# So each merge is started by a small launcher (a bare Python, about 10 MiB, the same for every
# measurement, start-up included) that reports its child's own rusage.
LAUNCHER = """\
import os, subprocess, sys
child = subprocess.Popen(sys.argv[1:], stderr=subprocess.PIPE)
_, status, usage = os.wait4(child.pid, 0)
sys.stderr.write(child.stderr.read().decode())
print(usage.ru_maxrss, os.waitstatus_to_exitcode(status))
"""


def measure(command, repeat):
    """(lowest peak RSS in MiB, fastest wall time in s) of ``command`` run ``repeat`` times."""
    peaks, walls = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        launched = subprocess.run([sys.executable, "-c", LAUNCHER, *command], capture_output=True, text=True)
        walls.append(time.perf_counter() - start)
        maxrss, code = (int(word) for word in launched.stdout.split())
        if code != 0:
            raise SystemExit(f"{' '.join(command[:4])} ... failed:\n{launched.stderr}")
        peaks.append(maxrss / 1024)  # KiB on Linux
    return min(peaks), min(walls)


def baseline_store(directory, revision):
    """The folder holding ``revision``'s vrsweep package (git archive), or None if git cannot give it.
    The whole package, not its store.py alone: that imported modules (vrsweep.model) which the
    current package no longer has, and the baseline failed in ModuleNotFoundError."""
    folder = Path(directory) / "baseline"
    folder.mkdir()
    try:
        archive = subprocess.run(["git", "-C", str(REPOSITORY), "archive", revision, "vrsweep"],
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    except (OSError, subprocess.CalledProcessError) as error:
        print(f"no baseline: git archive {revision} vrsweep failed ({error})")
        return None
    return folder


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=100_000, help="grid points (a multiple of 100)")
    parser.add_argument("--strobe", type=int, default=64, help="strobe_periods: sets the bytes per point")
    parser.add_argument("--shards", type=int, nargs="+", default=[2, 4, 8])
    parser.add_argument("--baseline", default="5bae00a", help="git revision of the old merge ('' for none)")
    parser.add_argument("--repeat", type=int, default=2, help="runs per merge; the lowest peak is kept")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="vrsweep-bench-merge-") as directory:
        directory = Path(directory)
        old_store = baseline_store(directory, args.baseline) if args.baseline else None
        extras = {}

        tiny = directory / "tiny"
        tiny.mkdir()
        tiny_shards = make_shards(tiny, config_text(10, args.strobe), 2, extras)
        start_new, _ = measure(merge_command(tiny_shards, tiny / "out.h5"), args.repeat)
        start_old = (measure(merge_command(tiny_shards, tiny / "out_old.h5", old_store), args.repeat)[0]
                     if old_store else None)
        print(f"start-up (2 shards of 10 points): {start_new:.0f} MiB"
              + (f"; baseline {start_old:.0f} MiB" if old_store else ""))

        rows = []
        for n_shards in args.shards:
            where = directory / f"shards{n_shards}"
            where.mkdir()
            t0 = time.perf_counter()
            shards = make_shards(where, config_text(args.points, args.strobe), n_shards, extras)
            print(f"made {n_shards} shards of {args.points} points in {time.perf_counter() - t0:.0f} s",
                  flush=True)
            out = where / "merged.h5"
            peak, wall = measure(merge_command(shards, out), args.repeat)
            result = out.stat().st_size / 2**20
            old = measure(merge_command(shards, where / "old.h5", old_store), args.repeat) if old_store else None
            rows.append((n_shards, result, peak, wall, old))
            for path in shards:
                path.unlink()

    print(f"\n{args.points} points, strobe_periods {args.strobe}; peak RSS of the merge process (MiB)\n")
    print("| shards | result (MiB) | start-up | peak | peak − start-up | (peak − start-up) / result "
          "| peak / (start-up + 2 × result) | wall (s) |" + (" baseline peak | baseline wall (s) | peak: baseline / new |" if old_store else ""))
    print("|---:|---:|---:|---:|---:|---:|---:|---:|" + ("---:|---:|---:|" if old_store else ""))
    for n_shards, result, peak, wall, old in rows:
        line = (f"| {n_shards} | {result:.0f} | {start_new:.0f} | {peak:.0f} | {peak - start_new:.0f} | "
                f"{(peak - start_new) / result:.2f} | {peak / (start_new + 2 * result):.2f} | {wall:.1f} |")
        if old:
            line += f" {old[0]:.0f} | {old[1]:.1f} | {old[0] / peak:.1f}x |"
        print(line)
    print("\nratios against the fewest shards:")
    n0, _, p0, _, o0 = rows[0]
    for n_shards, _, peak, _, old in rows[1:]:
        text = f"  {n_shards}/{n0} shards: peak x{peak / p0:.2f} ({peak - p0:+.0f} MiB)"
        if old and o0:
            text += f"; baseline x{old[0] / o0[0]:.2f} ({old[0] - o0[0]:+.0f} MiB)"
        print(text)


if __name__ == "__main__":
    main()
