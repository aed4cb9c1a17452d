"""`vrsweep run --dry-run`'s estimate against the run's real time, and the cost model's, on the
docs' sweeps and maps: the estimate should be within 2x of the measured time.

    python benchmarks/estimate_check.py [--threads N] [CONFIG ...]

For each config (default: the shipped quickstart, fig1, fig2, map_g_Omega and a 60 x 60 original
map at the issue's natural Omega grid with 20 + 20 periods), in one process: the cost model's
estimate (estimate.py), the measured estimate (timing.measure: a sample of the grid's own lines),
then the whole run through the job (written to a temporary file, the kernel already compiled by
the sample), and the ratios estimate / real. Prints a table; exits 1 if a measured estimate is
more than 2x off.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vrsweep.config import load_config  # noqa: E402
from vrsweep.execution.estimate import estimate  # noqa: E402
from vrsweep.execution.job import run_job  # noqa: E402
from vrsweep.execution.timing import measure  # noqa: E402

DEFAULT = [("quickstart", "configs/quickstart.yaml", []),
           ("fig1", "configs/fig1.yaml", []),
           ("fig2", "configs/fig2.yaml", []),
           ("map_g_Omega", "configs/map_g_Omega.yaml", []),
           ("natural 60x60 original map, 20 + 20 periods", "configs/map_g_Omega.yaml",
            ["model=original", "transient_periods=20", "measure_periods=20"])]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("configs", nargs="*")
    args = parser.parse_args()
    cases = [(path, path, []) for path in args.configs] or DEFAULT
    rows, worst = [], 1.0
    for label, path, overrides in cases:
        config = load_config(ROOT / path if not Path(path).is_absolute() else path, overrides)
        if label.startswith("natural"):
            from vrsweep.config import parse_config

            text = config.to_yaml().replace("Omega: {start: 3.0, stop: 6.0, num: 7}",
                                            "Omega: {start: 3.0, stop: 6.0, num: 60}")
            text = text.replace("g: {start: 0.0, stop: 60.0, num: 41}", "g: {start: 0.0, stop: 60.0, num: 60}")
            config = parse_config(text, "natural.yaml")
        rough = estimate(config, args.threads).seconds
        timing = measure(config, args.threads)
        with tempfile.TemporaryDirectory() as folder:
            began = time.perf_counter()
            run_job(config, Path(folder) / "out.h5", threads=args.threads)
            real = time.perf_counter() - began
        ratio = timing.seconds / real
        worst = max(worst, ratio, 1 / ratio)
        rows.append((label, config.n_runs, real, timing.seconds, ratio, rough, rough / real, timing.sampled_points))
        print(f"{label:45s} {config.n_runs:6d} points  real {real:8.1f} s  measured estimate {timing.seconds:8.1f} s "
              f"({ratio:.2f}x, {timing.sampled_points} points sampled)  cost model {rough:8.1f} s ({rough / real:.2f}x)",
              flush=True)
    print(f"\nworst measured estimate / real: {worst:.2f}x (goal: within 2x)")
    return 0 if worst <= 2.0 else 1


if __name__ == "__main__":
    sys.exit(main())
