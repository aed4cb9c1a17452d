"""Which lines a sweep runs, in which order and in which chunks: the one planner of the local
executor (vrsweep.execution.sweep.run_sweep) and the Dask executor (vrsweep.execution.distributed), and the one
count of the statuses they report.

A *line* is a sequence of grid points run one after the other (one point, or a continuation
line; see vrsweep.config.grid). Lines are shuffled with a fixed seed, so costly regions of the
grid spread evenly over threads, chunks and shards, and the same grid always gives the same
chunks and shards. Pure numpy: no kernel, no files.
"""

from dataclasses import dataclass

import numpy as np

from vrsweep.results import Status

# The grid's division into shuffled lines and shards is the grid's (config/grid.py); imported
# from here by the planner below and by callers written before it moved.
from vrsweep.config.grid import SHUFFLE_SEED, shard_of_points, shuffled_lines  # noqa: E402,F401


# A chunk is the unit of checkpointing and of progress: long enough that writing it is a small
# part of computing it, short enough that a kill loses little. Chunks of cheap points (short
# windows, the effective model) double while they last less than this.
GROW_CHUNK_BELOW_SECONDS = 0.25
MAX_CHUNK_LINES = 8192
# What a chunk holds in memory is its points' per-period records over the measurement window
# (numerics/records.py: N_RECORD float64s per period; not imported, as that module loads numba and
# `validate` must not): chunks never grow beyond CHUNK_RECORD_BYTES of them, and a chunk of one
# line is the least a run can hold (estimate.memory_problem refuses a run where that cannot fit).
RECORD_ROW_BYTES = 15 * 8
CHUNK_RECORD_BYTES = 256 * 2 ** 20
# On a GPU (integration.device: cuda) a chunk is one launch, a thread per line from a queue. A launch
# ends with a tail, its slowest points on a few threads while the rest of the card idles: measured
# on an H100, launch time = lines / rate + about 5.6 s (the original model; about 1.1 s for the
# effective one), so a chunk must run far longer than that (benchmarks/README.md, "GPU"). Chunks start
# at GPU_FIRST_CHUNK_LINES and double while a launch lasts less than GPU_GROW_CHUNK_BELOW_SECONDS on
# the card, up to GPU_MAX_CHUNK_LINES; their records are bounded by GPU_CHUNK_RECORD_BYTES and by a
# share of the card's and the host's memory: GPU_CHUNKS_IN_FLIGHT chunks are held at once (the
# next one computes while the host finishes the last), and the host's diagnostics take about as
# much again as a chunk's records.
GPU_FIRST_CHUNK_LINES = 2 ** 15
GPU_MAX_CHUNK_LINES = 2 ** 20
GPU_GROW_CHUNK_BELOW_SECONDS = 30.0
GPU_CHUNK_RECORD_BYTES = 4 * 2 ** 30
GPU_CHUNKS_IN_FLIGHT = 2


def point_record_bytes(integration) -> int:
    """Bytes of per-period records one grid point holds while its chunk runs (the measurement
    window's rows only: the transient's length costs no memory, see numerics/kernel.py)."""
    return int(integration.measure_periods) * RECORD_ROW_BYTES


def max_chunk_lines(integration, line_length, gpu=False, memory=None) -> int:
    """The most lines a chunk may hold: MAX_CHUNK_LINES, fewer when their records would pass
    CHUNK_RECORD_BYTES, never fewer than one (on a GPU: the GPU_* bounds, and at most a
    2 * GPU_CHUNKS_IN_FLIGHT-th of ``memory``, the bytes of the smaller of the card's memory and
    what the host allows a run, where known)."""
    line_bytes = max(1, line_length) * point_record_bytes(integration)
    if gpu:
        bound = GPU_CHUNK_RECORD_BYTES
        if memory is not None:
            bound = min(bound, int(memory) // (2 * GPU_CHUNKS_IN_FLIGHT))
        return max(1, min(GPU_MAX_CHUNK_LINES, bound // line_bytes))
    return max(1, min(MAX_CHUNK_LINES, CHUNK_RECORD_BYTES // line_bytes))


def gpu_first_chunk_lines(line_length) -> int:
    """A GPU run's first chunk: GPU_FIRST_CHUNK_LINES points' worth of lines (callers bound it by
    max_chunk_lines)."""
    return max(1, GPU_FIRST_CHUNK_LINES // max(1, line_length))


def default_chunk_lines(threads, line_length):
    """Enough lines per chunk to keep every thread busy and the progress bar moving (callers
    bound it by max_chunk_lines)."""
    return max(threads, (16 * threads) // max(1, line_length))


@dataclass(frozen=True)
class LinePlan:
    """The lines one process runs (its shard's, less those already done) and how much is new."""

    lines: np.ndarray     # (n_lines, line_length) flat grid indices, each row in run order
    not_done: np.ndarray  # (n_points,) bool over the whole grid: points not yet in the file

    @property
    def line_length(self) -> int:
        return self.lines.shape[1] if self.lines.size else 1

    @property
    def total(self) -> int:
        """Points newly done once every line has run (a point redone on its line is not new)."""
        return int(np.count_nonzero(self.not_done[self.lines]))

    def newly_done(self, flat_indices) -> int:
        """Of the points of a finished chunk, those not done before: what progress counts."""
        return int(np.count_nonzero(self.not_done[flat_indices]))


def plan_lines(grid, shard=(0, 1), done=None) -> LinePlan:
    """The shard's shuffled lines with any point not done (``done``: optional flat bool mask).

    A continuation line is the unit of work: its points depend on each other, so a line with any
    point missing is run again from its start (the points already done come out the same).
    """
    lines = shuffled_lines(grid, *shard)
    not_done = np.ones(grid.n_points, dtype=bool) if done is None else ~np.asarray(done, dtype=bool).reshape(-1)
    return LinePlan(lines[np.any(not_done[lines], axis=1)], not_done)


def count_statuses(counts, statuses) -> dict:
    """Add a chunk's point statuses to ``counts`` ({Status: n}, changed in place and returned)."""
    for code, n in zip(*np.unique(statuses, return_counts=True)):
        counts[Status(int(code))] = counts.get(Status(int(code)), 0) + int(n)
    return counts
