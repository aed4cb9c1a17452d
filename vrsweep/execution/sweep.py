"""A grid of points -> chunks -> the kernel on the CPU's threads (or a GPU), with progress.

The unit of parallel work is a *line*: a sequence of grid points run one after the other,
each starting from the previous point's final state. An ordinary sweep has lines of one
point; a continuation (hysteresis) sweep has one line per setting of the other axes, running
along the continuation axis. Lines are shuffled with a fixed seed before being cut into
chunks, so costly regions of the grid (many impacts) spread evenly over threads, chunks and
shards; each line writes only its own output slots, so the result is independent of the
order, the chunking and the thread count, bit for bit.

This module knows nothing of files: finished chunks are handed to a callback. The loops that
numba compiles, and the threads that run them, are in vrsweep/numerics/lines.py.
"""

import time

import numba
import numpy as np

from vrsweep.numerics import kernel
from vrsweep.analysis.diagnostics import lyapunov_values, point_diagnostics, window_records
from vrsweep.analysis.motion import motion_values
# RUN_LINES: imported from here by callers written before the loops moved to numerics/lines.py.
from vrsweep.numerics.lines import RUN_LINES  # noqa: F401
# Grid, the planner's names: imported from here by callers written before they moved.
from vrsweep.execution.chunks import (  # noqa: F401
    GPU_GROW_CHUNK_BELOW_SECONDS, GROW_CHUNK_BELOW_SECONDS, MAX_CHUNK_LINES, SHUFFLE_SEED, count_statuses,
    default_chunk_lines, gpu_first_chunk_lines, max_chunk_lines,
    plan_lines,
    shard_of_points, shuffled_lines,
)
from vrsweep.config.grid import DIRECTION_VALUES, Grid  # noqa: F401
from vrsweep.execution.device import gpu_memory_bytes
from vrsweep.numerics.models import kernels_for
from vrsweep.results import Status
from vrsweep.numerics.trajectory import settings_vector


def integration_settings(integration):
    """The kernel's settings vector from a config's integration section."""
    return settings_vector(**vars(integration))


class LineRunner:
    """Runs given lines of a config's grid: the one code path of local and Dask sweeps alike."""

    def __init__(self, config):
        self.config = config
        self.grid = Grid.from_config(config)
        self.settings = integration_settings(config.integration)
        self.method = config.integration.method
        self.lyapunov = config.integration.lyapunov
        self.kernels = kernels_for(config.model)
        self.device = config.integration.device
        if self.device == "cuda":
            from vrsweep.execution.device import gpu_lines

            self.run_lines = gpu_lines(self.kernels, self.method, self.lyapunov)
        else:
            self.run_lines = self.kernels.run_lines(self.method, self.lyapunov)
        # Records are kept for the measurement window only (the kernel reuses one row through the
        # transient): a point's memory does not grow with transient_periods.
        self.n_record_rows = config.integration.measure_periods

    def run(self, lines, threads=None):
        """lines (n_lines, line_length) flat indices -> (flat_indices, values) for on_chunk."""
        return self.finish(self.start(lines, threads))

    def start(self, lines, threads=None):
        """Start the lines' kernel: on the CPU it runs here, to the end; on a GPU it is launched and
        left running (finish waits for it), so that the host can meanwhile finish the chunk before."""
        threads = threads or numba.config.NUMBA_NUM_THREADS
        n_lines, line_length = lines.shape
        flat = np.ascontiguousarray(lines, dtype=np.int64).reshape(-1)
        coefficients = np.ascontiguousarray(
            self.kernels.coefficients(self.grid.parameters_at(self.config, flat)))
        local_lines = np.arange(flat.size, dtype=np.int64).reshape(n_lines, line_length)
        # A line runs along a parameter axis only (continuation along x0 / v0 is refused), so
        # its first point's x0 / v0 is the whole line's.
        initial_states = self.grid.initial_states_at(self.config, lines[:, 0])
        # NaN where the kernel computes nothing (the periods after a failure). A GPU's kernel fills
        # its outputs on the card (cuda.fill_nan) and the copy back overwrites every entry, so the
        # host neither fills nor copies in a GPU chunk's records (1.8 GB for 131,072 points of 100
        # periods).
        gpu = self.device == "cuda"
        records = _outputs((n_lines, line_length, self.n_record_rows, kernel.N_RECORD), np.nan, np.float64, gpu)
        summaries = _outputs((n_lines, line_length, kernel.N_SUMMARY), np.nan, np.float64, gpu)
        statuses = _outputs((n_lines, line_length), Status.NOT_COMPUTED, np.int8, gpu)
        chunk = ChunkRun(flat, coefficients, records, summaries, statuses, threads)
        arrays = (coefficients, initial_states, self.settings, local_lines, records, summaries, statuses)
        if self.device == "cuda":
            chunk.launch = self.run_lines.launch(*arrays)
        else:
            self.run_lines(*arrays, threads=threads)
        return chunk

    def finish(self, chunk):
        """A started chunk's (flat_indices, values), once its kernel is done."""
        if chunk.launch is not None:
            chunk.seconds = chunk.launch.wait()
        values = point_values(
            chunk.records.reshape(-1, self.n_record_rows, kernel.N_RECORD),
            chunk.summaries.reshape(-1, kernel.N_SUMMARY), chunk.statuses.reshape(-1), chunk.coefficients,
            self.kernels.forcing_frequencies(chunk.coefficients), self.config.integration, threads=chunk.threads)
        if chunk.seconds is None:
            chunk.seconds = time.perf_counter() - chunk.began
        return chunk.flat, values


def _outputs(shape, fill, dtype, filled_by_kernel):
    return np.empty(shape, dtype=dtype) if filled_by_kernel else np.full(shape, fill, dtype=dtype)


class ChunkRun:
    """A chunk between LineRunner.start and finish: its points, the kernel's output arrays, the
    launch in flight on a GPU, and after finish its time in seconds, which the chunks' growth reads:
    on the CPU the whole chunk's (kernel and diagnostics), on a GPU the kernel's on the card (the
    host's part overlaps the next chunk's kernel), or the whole chunk's where the card cannot tell."""

    def __init__(self, flat, coefficients, records, summaries, statuses, threads):
        self.flat, self.coefficients = flat, coefficients
        self.records, self.summaries, self.statuses = records, summaries, statuses
        self.threads = threads
        self.launch = None
        self.began = time.perf_counter()
        self.seconds = None


def run_sweep(config, *, threads=None, shard=(0, 1), done=None, on_chunk=None,
              progress=None, chunk_lines=None):
    """Run the config's grid (or one shard of it), chunk by chunk.

    done:      optional flat bool mask over the grid; lines whose points are all done are skipped.
    on_chunk:  callback(flat_indices (n,), values: dict name -> (n, ...)) after every chunk.
    progress:  callback(points_done_now, points_total) or None.
    Returns a dict of status counts {Status: n} over the points run.

    On a GPU the next chunk's kernel is launched before the host finishes a chunk (its diagnostics,
    on_chunk's writing): the card computes while the host works. Chunks are still handed to
    on_chunk one at a time, in order; an interrupted run loses the chunk in flight, not one written.
    """
    runner = LineRunner(config)
    threads = threads or numba.config.NUMBA_NUM_THREADS
    plan = plan_lines(runner.grid, shard, done)
    lines = plan.lines
    adaptive = chunk_lines is None
    gpu = runner.device == "cuda"
    largest_chunk = max_chunk_lines(config.integration, plan.line_length, gpu=gpu,
                                    memory=gpu_memory_bytes() if gpu else None)  # the memory bound
    first_chunk = gpu_first_chunk_lines(plan.line_length) if gpu else default_chunk_lines(threads, plan.line_length)
    chunk_lines = chunk_lines or min(first_chunk, largest_chunk)
    largest_chunk = max(chunk_lines, largest_chunk)
    grow_below = GPU_GROW_CHUNK_BELOW_SECONDS if gpu else GROW_CHUNK_BELOW_SECONDS
    counts = {}
    start = 0
    in_flight = None  # a GPU's chunk launched and not yet finished
    while start < len(lines) or in_flight is not None:
        started = None
        if start < len(lines):
            started = runner.start(lines[start:start + chunk_lines], threads)
            start += chunk_lines
        if not gpu:  # the CPU's chunk is done once started: written before the next one computes
            in_flight, started = started, None
        if in_flight is not None:
            flat, values = runner.finish(in_flight)
            if adaptive and in_flight.seconds < grow_below:
                chunk_lines = min(2 * chunk_lines, largest_chunk)
            count_statuses(counts, values["status"])
            if on_chunk is not None:
                on_chunk(flat, values)
            if progress is not None:
                progress(plan.newly_done(flat), plan.total)
        in_flight = started
    return counts


# Points per block of the diagnostics when a chunk's are shared among threads (point_values).
DIAGNOSTICS_BLOCK = 4096


def point_values(records, summaries, statuses, coefficients, frequencies, integration, threads=1):
    """Per-point output variables (the HDF5 contract's names, docs/design.md) from the kernel's raw
    outputs; ``frequencies`` (n_points, K) are the forcing's (models' forcing_frequencies).

    Every value is a function of its own point's outputs alone (a point's values do not depend on
    which points share its chunk: tests/test_threads.py), so a large chunk's points are shared
    among up to ``threads`` threads, one block of at least DIAGNOSTICS_BLOCK points each: numpy's
    array operations leave Python's lock while they work. On a GPU the host's diagnostics would
    otherwise keep the card waiting (benchmarks/README.md, "GPU")."""
    n_points = len(statuses)
    n_blocks = min(max(1, int(threads)), -(-n_points // DIAGNOSTICS_BLOCK))
    if n_blocks <= 1:
        return _point_values(records, summaries, statuses, coefficients, frequencies, integration)
    from concurrent.futures import ThreadPoolExecutor

    edges = [(n_points * k) // n_blocks for k in range(n_blocks + 1)]
    blocks = [slice(low, high) for low, high in zip(edges[:-1], edges[1:])]
    with ThreadPoolExecutor(max_workers=n_blocks) as pool:
        parts = list(pool.map(
            lambda rows: _point_values(records[rows], summaries[rows], statuses[rows], coefficients[rows],
                                       frequencies[rows], integration),
            blocks))
    return {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}


# What a point marked ok carries finite (docs/file-format.md): the kernel's summarize turns an
# overflow of R, Qs or Qc into NON_FINITE; these are the host's own values that can overflow too.
_FINITE_WHERE_OK = ("R", "Qs", "Qc", "Q_amplitude")
# The summary's columns that records.summarize sets to NaN at a failed point.
_SUMMARY_BLANKED = (kernel.SUM_R, kernel.SUM_QS, kernel.SUM_QC, kernel.SUM_Q_AMPLITUDE, kernel.SUM_IMPACTS_PER_PERIOD,
                    kernel.SUM_LYAPUNOV, kernel.SUM_LYAPUNOV_SUM)


def _point_values(records, summaries, statuses, coefficients, frequencies, integration):
    values = _values_of(records, summaries, statuses, coefficients, frequencies, integration)
    # R_err NaN is a window too short for two batches; inf (like an R overflowed by the host's
    # whole-cycle or weighted averages) is an overflow, and the point is then NON_FINITE, as the
    # kernel's summarize says of the same overflow: blanked as every failed point is.
    ok = values["status"] == Status.OK
    overflowed = ok & np.isinf(values["R_err"])
    for name in _FINITE_WHERE_OK:
        overflowed |= ok & ~np.isfinite(values[name])
    if not overflowed.any():
        return values
    # A point's values are a function of its own outputs: only the overflowed rows are redone.
    rows = np.flatnonzero(overflowed)
    blanked = np.array(summaries[rows], copy=True)
    blanked[:, list(_SUMMARY_BLANKED)] = np.nan
    redone = _values_of(records[rows], blanked, np.full(len(rows), Status.NON_FINITE, dtype=statuses.dtype),
                        coefficients[rows], frequencies[rows], integration)
    for name, column in redone.items():
        values[name] = np.array(values[name], copy=True)  # some are views of the kernel's summaries
        values[name][rows] = column
    return values


def _values_of(records, summaries, statuses, coefficients, frequencies, integration):
    values = {
        "R": summaries[:, kernel.SUM_R],
        "Qs": summaries[:, kernel.SUM_QS],
        "Qc": summaries[:, kernel.SUM_QC],
        "Q_amplitude": summaries[:, kernel.SUM_Q_AMPLITUDE],
        "impacts_per_period": summaries[:, kernel.SUM_IMPACTS_PER_PERIOD],
        "status": statuses.astype(np.int8),
        "n_steps": summaries[:, kernel.SUM_STEPS].astype(np.int64),
        "n_rhs": summaries[:, kernel.SUM_RHS].astype(np.int64),
        "x_final": summaries[:, kernel.SUM_X_FINAL],
        "v_final": summaries[:, kernel.SUM_V_FINAL],
    }
    values.update(point_diagnostics(records, statuses, coefficients, frequencies, integration))
    lyapunov = None
    if integration.lyapunov:
        lyapunov = lyapunov_values(records, summaries, statuses, coefficients, integration, values["period"])
        values.update(lyapunov)
    # The kind of motion; R by weighted averages where it is quasi-periodic (analysis/motion.py).
    return motion_values(values, window_records(records, integration), statuses, coefficients, lyapunov)
