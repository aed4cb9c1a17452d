"""A grid of points -> chunks -> the kernel in parallel (numba prange), with progress.

The unit of parallel work is a *line*: a sequence of grid points run one after the other,
each starting from the previous point's final state. An ordinary sweep has lines of one
point; a continuation (hysteresis) sweep has one line per setting of the other axes, running
along the continuation axis. Lines are shuffled with a fixed seed before being cut into
chunks, so costly regions of the grid (many impacts) spread evenly over threads, chunks and
shards; each line writes only its own output slots, so the result is independent of the
order, the chunking and the thread count, bit for bit.

This module knows nothing of files: finished chunks are handed to a callback.
"""

import time
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from vrsweep import kernel
from vrsweep.diagnostics import lyapunov_values, point_diagnostics
from vrsweep.jit import kernel_jit
from vrsweep.model import INITIAL_STATE_KEYS, kernel_coefficients
from vrsweep.results import Status
from vrsweep.trajectory import settings_vector

SHUFFLE_SEED = 20240607  # fixed: the same grid always gives the same chunks and shards
DIRECTION_VALUES = {"up": 1, "down": -1}


def integration_settings(integration):
    """The kernel's settings vector from a config's integration section."""
    return settings_vector(**vars(integration))


@dataclass(frozen=True)
class Grid:
    """The output grid of a config: its axes (plus `direction` for two-way continuation)."""

    axis_names: tuple
    axis_values: tuple
    continuation_axis: int | None
    directions: tuple

    @classmethod
    def from_config(cls, config):
        names = [axis.name for axis in config.axes]
        values = [np.asarray(axis.values, dtype=np.float64) for axis in config.axes]
        continuation_axis = None
        directions = ("up",)
        for index, axis in enumerate(config.axes):
            if axis.continuation:
                continuation_axis = index
                directions = ("up", "down") if axis.continuation == "both" else (axis.continuation,)
        if len(directions) == 2:
            names.append("direction")
            values.append(np.array([DIRECTION_VALUES[d] for d in directions], dtype=np.float64))
        return cls(tuple(names), tuple(values), continuation_axis, directions)

    @property
    def shape(self):
        return tuple(len(v) for v in self.axis_values)

    @property
    def n_points(self):
        return int(np.prod(self.shape, dtype=np.int64))

    def lines(self):
        """(n_lines, line_length) flat indices into the output grid, each row in run order.

        Without continuation every point is its own line. With it, a line runs along the
        continuation axis at one setting of the other axes: `up` in increasing parameter value,
        `down` in decreasing value (whatever order the config lists the values in; the stored
        axis keeps the config's order). With `both`, the up lines fill direction index 0
        (+1) and the down lines index 1 (-1).
        """
        flat = np.arange(self.n_points, dtype=np.int64).reshape(self.shape)
        if self.continuation_axis is None:
            return flat.reshape(-1, 1)
        # A stable sort, so equal values keep their config order (and up is exactly down reversed).
        ascending = np.argsort(self.axis_values[self.continuation_axis], kind="stable")
        rows = []
        for direction_index, direction in enumerate(self.directions):
            block = flat[..., direction_index] if len(self.directions) == 2 else flat
            block = np.moveaxis(block, self.continuation_axis, -1)[..., ascending]
            if direction == "down":
                block = block[..., ::-1]
            rows.append(block.reshape(-1, block.shape[-1]))
        return np.concatenate(rows)

    def parameters_at(self, config, flat_indices):
        """Every parameter at the given flat grid indices: name -> (n,) float64.

        Built from the axes alone, so a chunk never needs a whole-grid table (memory stays flat
        as the grid grows).
        """
        flat_indices = np.asarray(flat_indices, dtype=np.int64).reshape(-1)
        table = {name: np.full(flat_indices.size, float(value)) for name, value in config.parameters.items()}
        if self.shape:  # a single point (no axes) is just the fixed parameters
            position = np.unravel_index(flat_indices, self.shape)
            for axis, (name, values) in enumerate(zip(self.axis_names, self.axis_values)):
                if name in table:  # not direction, x0, v0
                    table[name] = values[position[axis]]
        return table

    def initial_states_at(self, config, flat_indices):
        """(n, 2) starting state (x, v) at the given flat grid indices: ``initial``, or the point's
        own x0 / v0 where those are axes (basins of attraction)."""
        flat_indices = np.asarray(flat_indices, dtype=np.int64).reshape(-1)
        states = np.empty((flat_indices.size, 2), dtype=np.float64)
        states[:, 0] = config.initial["x"]
        states[:, 1] = config.initial["v"]
        if self.shape:
            position = np.unravel_index(flat_indices, self.shape)
            for axis, (name, values) in enumerate(zip(self.axis_names, self.axis_values)):
                if name in INITIAL_STATE_KEYS:
                    states[:, "xv".index(INITIAL_STATE_KEYS[name])] = values[position[axis]]
        return states


def shuffled_lines(grid, shard_index=0, shard_count=1):
    """The lines this process runs, in run order: shuffled, then every shard_count-th."""
    lines = grid.lines()
    order = np.random.default_rng(SHUFFLE_SEED).permutation(len(lines))
    return lines[order[shard_index::shard_count]]


def shard_of_points(grid, shard_count):
    """For every grid point (over grid.shape), the shard 0..shard_count-1 that runs it.

    The inverse of shuffled_lines: the line at place p of the shuffled order goes to shard
    p mod shard_count. Used to say which shard file a missing point belongs to.
    """
    lines = grid.lines()
    order = np.random.default_rng(SHUFFLE_SEED).permutation(len(lines))
    shard = np.empty(grid.n_points, dtype=np.int64)
    shard[lines[order]] = (np.arange(len(lines)) % shard_count)[:, None]
    return shard.reshape(grid.shape)


@kernel_jit(inline="always")
def _run_line(integrate, coefficients, initial_state, settings, line_points, records, summaries, statuses):
    """One line's points in order, each starting from the previous point's final state
    (the first from initial_state, (2,))."""
    state = initial_state.copy()
    no_samples = np.empty(0)
    no_sample_out = np.empty((0, 2))
    no_impacts = np.empty((0, 3))
    no_sticks = np.empty((0, 2))
    for slot in range(line_points.shape[0]):
        status = integrate(coefficients[line_points[slot]], state, settings, records[slot], summaries[slot],
                           no_samples, no_sample_out, no_impacts, no_sticks)
        statuses[slot] = status
        # The next point starts at its own t = 0 from this one's state at t = n T: in phase
        # with the slow force (omega n T = 2 pi n), and with the fast one when n Omega / omega
        # is a whole number (Omega = 4, omega = 0.5: 8 n); otherwise the fast phase restarts.
        if status == Status.OK:
            state[0] = summaries[slot, kernel.SUM_X_FINAL]
            state[1] = summaries[slot, kernel.SUM_V_FINAL]
        else:
            # A failed point says nothing about where the next one starts: restart.
            state[0] = initial_state[0]
            state[1] = initial_state[1]


@kernel_jit(parallel=True)
def run_lines_rk45(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """Run each line's points in order; lines in parallel.

    coefficients    (n_points, N_COEFFICIENTS)         for every point the lines name
    initial_states  (n_lines, 2)                        state of each line's first point
    settings        (N_SETTINGS,)
    lines           (n_lines, line_length)             indices into coefficients
    period_records  (n_lines, line_length, n_periods, N_RECORD)   outputs, per line slot
    summaries       (n_lines, line_length, N_SUMMARY)
    statuses        (n_lines, line_length) int8
    """
    for line in prange(lines.shape[0]):
        _run_line(kernel.integrate_rk45, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


@kernel_jit(parallel=True)
def run_lines_dop853(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """run_lines_rk45 with the DOP853 kernel."""
    for line in prange(lines.shape[0]):
        _run_line(kernel.integrate_dop853, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


@kernel_jit(parallel=True)
def run_lines_rk45_lyapunov(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """run_lines_rk45 with the tangent vectors (integration.lyapunov)."""
    for line in prange(lines.shape[0]):
        _run_line(kernel.integrate_rk45_lyapunov, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


@kernel_jit(parallel=True)
def run_lines_dop853_lyapunov(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """run_lines_dop853 with the tangent vectors (integration.lyapunov)."""
    for line in prange(lines.shape[0]):
        _run_line(kernel.integrate_dop853_lyapunov, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


# (integration.method, integration.lyapunov) -> the parallel loop; each is compiled (or loaded)
# only when a run uses it.
RUN_LINES = {("rk45", False): run_lines_rk45, ("dop853", False): run_lines_dop853,
             ("rk45", True): run_lines_rk45_lyapunov, ("dop853", True): run_lines_dop853_lyapunov}


# A chunk is the unit of checkpointing and of progress: long enough that writing it is a small
# part of computing it, short enough that a kill loses little. Chunks of cheap points (short
# windows, the effective model) double while they last less than this.
GROW_CHUNK_BELOW_SECONDS = 0.25
MAX_CHUNK_LINES = 8192


def default_chunk_lines(threads, line_length):
    """Enough lines per chunk to keep every thread busy and the progress bar moving."""
    return max(threads, (16 * threads) // max(1, line_length))


class LineRunner:
    """Runs given lines of a config's grid: the one code path of local and Dask sweeps alike."""

    def __init__(self, config):
        self.config = config
        self.grid = Grid.from_config(config)
        self.settings = integration_settings(config.integration)
        self.method = config.integration.method
        self.lyapunov = bool(getattr(config.integration, "lyapunov", False))
        self.n_periods = config.integration.transient_periods + config.integration.measure_periods

    def run(self, lines, threads=None):
        """lines (n_lines, line_length) flat indices -> (flat_indices, values) for on_chunk."""
        threads = threads or numba.config.NUMBA_NUM_THREADS
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        n_lines, line_length = lines.shape
        flat = np.ascontiguousarray(lines, dtype=np.int64).reshape(-1)
        coefficients = np.ascontiguousarray(
            kernel_coefficients(self.grid.parameters_at(self.config, flat), self.config.model))
        local_lines = np.arange(flat.size, dtype=np.int64).reshape(n_lines, line_length)
        # A line runs along a parameter axis only (continuation along x0 / v0 is refused), so
        # its first point's x0 / v0 is the whole line's.
        initial_states = self.grid.initial_states_at(self.config, lines[:, 0])
        records = np.full((n_lines, line_length, self.n_periods, kernel.N_RECORD), np.nan)
        summaries = np.full((n_lines, line_length, kernel.N_SUMMARY), np.nan)
        statuses = np.full((n_lines, line_length), Status.NOT_COMPUTED, dtype=np.int8)
        with numba.parallel_chunksize(1):  # dynamic scheduling: point costs differ tenfold
            RUN_LINES[self.method, self.lyapunov](coefficients, initial_states, self.settings, local_lines, records,
                                   summaries, statuses)
        values = point_values(
            records.reshape(-1, self.n_periods, kernel.N_RECORD), summaries.reshape(-1, kernel.N_SUMMARY),
            statuses.reshape(-1), coefficients, self.config.integration)
        return flat, values


def run_sweep(config, *, threads=None, shard=(0, 1), done=None, on_chunk=None,
              progress=None, chunk_lines=None):
    """Run the config's grid (or one shard of it), chunk by chunk.

    done:      optional flat bool mask over the grid; lines whose points are all done are skipped.
    on_chunk:  callback(flat_indices (n,), values: dict name -> (n, ...)) after every chunk.
    progress:  callback(points_done_now, points_total) or None.
    Returns a dict of status counts {Status: n} over the points run.
    """
    runner = LineRunner(config)
    threads = threads or numba.config.NUMBA_NUM_THREADS
    lines = shuffled_lines(runner.grid, *shard)
    # A continuation line is the unit of work: its points depend on each other, so a line with
    # any point missing is run again from its start (the points already done come out the same).
    not_done = np.ones(runner.grid.n_points, dtype=bool) if done is None else ~done.reshape(-1)
    lines = lines[np.any(not_done[lines], axis=1)]
    line_length = lines.shape[1] if lines.size else 1
    adaptive = chunk_lines is None
    chunk_lines = chunk_lines or default_chunk_lines(threads, line_length)
    counts = {}
    total = int(np.count_nonzero(not_done[lines]))  # progress counts points newly done, not redone
    start = 0
    while start < len(lines):
        began = time.perf_counter()
        flat, values = runner.run(lines[start:start + chunk_lines], threads)
        start += chunk_lines
        if adaptive and time.perf_counter() - began < GROW_CHUNK_BELOW_SECONDS:
            chunk_lines = min(2 * chunk_lines, MAX_CHUNK_LINES)
        for code, n in zip(*np.unique(values["status"], return_counts=True)):
            counts[Status(int(code))] = counts.get(Status(int(code)), 0) + int(n)
        if on_chunk is not None:
            on_chunk(flat, values)
        if progress is not None:
            progress(int(np.count_nonzero(not_done[flat])), total)
    return counts


def point_values(records, summaries, statuses, coefficients, integration):
    """Per-point output variables (the HDF5 contract's names, docs/design.md) from the kernel's raw outputs."""
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
    values.update(point_diagnostics(records, statuses, coefficients, integration))
    if getattr(integration, "lyapunov", False):
        values.update(lyapunov_values(records, summaries, statuses, coefficients, integration, values["period"]))
    return values
