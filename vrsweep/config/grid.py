"""The grid a config spans: its axes in config order (plus ``direction`` for two-way continuation),
its continuation lines, and every parameter and initial state at given grid points.

The one place the grid is expanded: the sweep runs it (vrsweep.execution.sweep), the job lays out the
file from it, and ``Config.grid_parameters`` reads it. Pure numpy: no kernel, no files.
"""

from dataclasses import dataclass

import numpy as np

from vrsweep.numerics.model import INITIAL_STATE_KEYS

DIRECTION_VALUES = {"up": 1, "down": -1}


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


# --- the grid's lines shuffled, and divided into shards ----------------------------------------
# Lines are shuffled with a fixed seed so that costly regions spread over threads, chunks and
# shards, and the same grid always gives the same shards (merge relies on it).
SHUFFLE_SEED = 20240607  # fixed: the same grid always gives the same chunks and shards


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
