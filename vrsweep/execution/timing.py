"""How long a run will take, measured: a sample of the grid's own lines run on this machine
(``vrsweep run --dry-run``), where estimate.py's cost model only guesses from constants.

The sample is the first lines of the sweep's own shuffled order (config/grid.py), so it is spread
over the grid as the run's chunks are, and the same config always samples the same points. Lines
run in chunks of one line per thread (the run's parallel loop, or a launch on the GPU), chunk after
chunk, until SAMPLE_SECONDS have passed or SAMPLE_LINES lines have run. The estimate is the
sample's points per second carried to the whole grid; its range comes from the chunks' spread,
because points differ tenfold in cost (impacts, chatter).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

# The sample: at least SAMPLE_MIN_CHUNKS chunks, then more until SAMPLE_SECONDS or SAMPLE_LINES.
SAMPLE_SECONDS = 3.0
SAMPLE_LINES = 512
SAMPLE_MIN_CHUNKS = 3


@dataclass(frozen=True)
class Timing:
    n_points: int          # points of the whole run (its shard's)
    sampled_points: int
    sample_seconds: float
    compile_seconds: float  # the first chunk's time, compilation or loading from the cache included
    chunk_rates: tuple      # points per second of each timed chunk

    @property
    def points_per_second(self) -> float:
        return self.sampled_points / self.sample_seconds

    @property
    def seconds(self) -> float:
        return self.n_points / self.points_per_second

    @property
    def seconds_range(self) -> tuple[float, float]:
        """The estimate at the slowest and the fastest chunk's rate."""
        return self.n_points / max(self.chunk_rates), self.n_points / min(self.chunk_rates)


def measure(config, threads=None, shard=(0, 1), seconds=SAMPLE_SECONDS, max_lines=SAMPLE_LINES) -> Timing:
    """Run a sample of ``config``'s lines (nothing is written) and time it; see the module doc."""
    import numba

    from vrsweep.config.grid import Grid, shuffled_lines
    from vrsweep.execution.device import check_device
    from vrsweep.execution.sweep import LineRunner

    check_device(config.integration.device)
    threads = max(1, int(threads or numba.config.NUMBA_NUM_THREADS))
    grid = Grid.from_config(config)
    lines = shuffled_lines(grid, *shard)
    n_points = int(lines.size)
    runner = LineRunner(config)
    per_chunk = max(1, min(threads, len(lines))) if runner.device == "cpu" else min(len(lines), 4096)
    began = time.perf_counter()
    runner.run(lines[:1], threads)  # compiles the kernel, or loads it from the cache
    compile_seconds = time.perf_counter() - began
    rates, sampled, spent, start = [], 0, 0.0, 1
    while start < len(lines) and (len(rates) < SAMPLE_MIN_CHUNKS or (spent < seconds and start - 1 < max_lines)):
        chunk = lines[start:start + per_chunk]
        began = time.perf_counter()
        runner.run(chunk, threads)
        elapsed = max(time.perf_counter() - began, 1e-9)
        rates.append(chunk.size / elapsed)
        sampled += chunk.size
        spent += elapsed
        start += per_chunk
    if not rates:  # a grid of one line: its only line was the compiling one
        rates, sampled, spent = [lines[:1].size / compile_seconds], int(lines[:1].size), compile_seconds
    return Timing(n_points=n_points, sampled_points=int(sampled), sample_seconds=spent,
                  compile_seconds=compile_seconds, chunk_rates=tuple(float(rate) for rate in rates))


def describe(timing: Timing, threads: int, device: str = "cpu") -> str:
    """One line for the user: the estimate, its range and what it was measured on."""
    from vrsweep.execution.estimate import format_duration

    low, high = timing.seconds_range
    where = "the GPU" if device == "cuda" else f"{threads} thread{'s' if threads != 1 else ''}"
    return (f"about {format_duration(timing.seconds)} on {where} ({format_duration(low)} to "
            f"{format_duration(high)} at the fastest and slowest sampled chunk's pace); measured on "
            f"{timing.sampled_points} of {timing.n_points} points in {timing.sample_seconds:.1f} s, "
            f"{timing.points_per_second:.3g} points/s; compile or load: {timing.compile_seconds:.1f} s")


def rough_and_measured_agree(rough_seconds: float, timing: Timing) -> bool:
    """Whether the cost model's guess is within 2x of the measured estimate (said if not)."""
    return abs(math.log(max(rough_seconds, 1e-9) / timing.seconds)) <= math.log(2.0)

