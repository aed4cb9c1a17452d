"""How big and how long a run will be, before anything is compiled or run.

Rough on purpose: the point is to catch a grid that is out of proportion (a typo'd ``num``, an
extra axis) before it fills a disk or a week, not to predict the finish time. Must not import
numba: ``vrsweep validate`` uses it and promises to compile nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vrsweep.config.schema import INTEGRATION_DEFAULTS
from vrsweep.errors import ConfigError
from vrsweep.execution.threads import available_threads
# format_bytes: the store's, imported from here by callers written before it moved.
from vrsweep.store.fileio import format_bytes  # noqa: F401

# Wall time of one grid point over one slow period 2 pi/omega, on one thread, at rtol = 1e-9.
# The original model resolves the fast forcing Omega, so it takes several times more steps.
# Calibrated with `vrsweep run configs/fig1.yaml --threads 1` (81 points x 200 periods at
# rtol 1e-9, 2-core workstation): 5.7 s user for the original model, 2.2 s for the effective one,
# less ~1.5 s of start-up. Points with many impacts cost several times the mean.
SECONDS_PER_POINT_PERIOD = {"original": 2.6e-4, "effective": 4e-5}
REFERENCE_RTOL = 1e-9
# integration.method: cost relative to rk45 at REFERENCE_RTOL, and the order that sets how the
# step count grows as rtol tightens (about rtol^(-1/order)). dop853 took 0.35x the time of rk45 at
# rtol 1e-9 on the original model and 0.2x on the effective one (paper points, one thread).
METHOD_COST = {"rk45": 1.0, "dop853": 0.35}
METHOD_ORDER = {"rk45": 5, "dop853": 8}
# integration.lyapunov: cost of the tangent vectors relative to a plain run of the same method
# (benchmarks/README.md, "Lyapunov exponents": geometric means over five points, one thread).
LYAPUNOV_COST = {"rk45": 1.15, "dop853": 1.85}

# HDF5's own bytes, measured on vrsweep's files (h5py 3, HDF5 1.14): each dataset's object header
# and attributes take ~2.5 kB whatever its size, plus ~0.45 kB per grid dimension for the
# dimension-scale links (a 9-point sweep's 25 datasets: 77 kB on disk, 3.9 kB of it
# data); each chunk of a chunked dataset adds a B-tree entry and a checksum (~48 B per chunk of
# store.CHUNK_TARGET_BYTES).
BYTES_PER_DATASET = 2500
BYTES_PER_DATASET_DIMENSION = 450
BYTES_PER_CHUNK = 48
# Coordinates (axes, strobe...) are single chunks with a checksum: each adds a chunk index
# (a B-tree node, HDF5 1.8 format) of ~3 kB (measured: 3032 B per coordinate, h5py 3, HDF5 1.14).
BYTES_PER_COORDINATE_CHUNK_INDEX = 3000
CHUNK_BYTES = 4 * 1024  # store.CHUNK_TARGET_BYTES (not imported: store imports h5py)

# Beyond either, `run` wants --allow-large.
MAX_OUTPUT_BYTES = 2e9
MAX_SECONDS = 24 * 3600.0


@dataclass(frozen=True)
class Estimate:
    n_points: int
    output_bytes: int
    seconds: float
    memory_bytes: int = 0  # the per-period records the run holds at once (memory_bytes below)


def memory_bytes(config, threads=None) -> int:
    """Bytes of per-period records a run of ``config`` holds at once, per process: one chunk's
    (chunks.default_chunk_lines within chunks.max_chunk_lines: at most CHUNK_RECORD_BYTES, at least one
    line); on a GPU two chunks' (one computing while the host finishes the other)."""
    from vrsweep.config.grid import Grid
    from vrsweep.execution.chunks import GPU_CHUNKS_IN_FLIGHT, default_chunk_lines, max_chunk_lines, point_record_bytes

    threads = max(1, int(threads or available_threads()))
    grid = Grid.from_config(config)
    line_length = len(grid.axis_values[grid.continuation_axis]) if grid.continuation_axis is not None else 1
    n_lines = max(1, config.n_runs // line_length)
    if config.integration.device == "cuda":  # a GPU's chunks grow to their bound, two at once (chunks.py)
        lines = min(n_lines, max_chunk_lines(config.integration, line_length, gpu=True, memory=memory_limit()))
        return GPU_CHUNKS_IN_FLIGHT * lines * line_length * point_record_bytes(config.integration)
    lines = min(n_lines, default_chunk_lines(threads, line_length), max_chunk_lines(config.integration, line_length))
    return lines * line_length * point_record_bytes(config.integration)


def memory_limit() -> int:
    """The most a run may hold (bytes): memory_allowance's."""
    return memory_allowance()[0]


def memory_allowance() -> tuple[int, str]:
    """(the most a run may hold, in bytes; whose limit that is, in words): half of the smallest of
    the machine's physical memory, the process's resource limits (``ulimit -v``, ``ulimit -d``) and
    its cgroup's memory limit (a container's, a batch job's). The other half is the system's,
    numba's and the output's. 4 GiB where none of them can be told."""
    import os

    found = []
    try:
        found.append((os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"), "this machine allows a run (half its memory)"))
    except (ValueError, OSError, AttributeError):
        pass
    try:
        import resource

        for limit, words in ((resource.RLIMIT_AS, "ulimit -v"), (resource.RLIMIT_DATA, "ulimit -d")):
            soft = resource.getrlimit(limit)[0]
            if soft != resource.RLIM_INFINITY and soft > 0:
                found.append((soft, f"this process may use (half its {words} limit)"))
    except (ImportError, ValueError, OSError, AttributeError):
        pass
    cgroup = _cgroup_memory_limit()
    if cgroup is not None:
        found.append((cgroup, "this process's cgroup allows (half its memory limit)"))
    if not found:
        return 4 * 2 ** 30, "vrsweep allows a run where the memory cannot be told"
    total, words = min(found, key=lambda item: item[0])
    return total // 2, words


def _cgroup_memory_limit():
    """The memory limit of this process's cgroup (v2 memory.max, v1 memory.limit_in_bytes, the
    smallest along its ancestors), or None where there is none or it cannot be read."""
    import os

    try:
        with open("/proc/self/cgroup", encoding="utf-8") as handle:
            lines = handle.read().splitlines()
    except OSError:
        return None
    limits = []
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, path = parts
        if controllers == "":
            base, name = "/sys/fs/cgroup", "memory.max"
        elif "memory" in controllers.split(","):
            base, name = "/sys/fs/cgroup/memory", "memory.limit_in_bytes"
        else:
            continue
        folder = path.strip("/")
        for _ in range(64):  # up to the root, at most as deep as any cgroup tree
            try:
                with open(os.path.join(base, folder, name), encoding="ascii") as handle:
                    text = handle.read().strip()
                if text.isdigit() and int(text) < 2 ** 60:  # v1 says "no limit" with a huge number
                    limits.append(int(text))
            except (OSError, UnicodeDecodeError):
                pass
            if not folder:
                break
            folder = os.path.dirname(folder)
    return min(limits) if limits else None


# A point's index and a file's offset are int64: a grid past either cannot be run at all, allowed
# or not (three axes of 10^7 values, 10^21 points, ended in numpy's "array is too big" traceback
# under --dry-run and in posix_fallocate's "Python int too large to convert to C long" otherwise).
INT64_MAX = 2**63 - 1


def beyond_int64_problem(config) -> str | None:
    """Why no run of ``config`` is possible (one line), or None: its points or its file's bytes do not
    fit in int64. Not a matter of --allow-large."""
    n_points, size = config.n_runs, stored_bytes(config)
    if n_points <= INT64_MAX and size <= INT64_MAX:
        return None
    return (f"{config.source_name}: a grid of {n_points} points ({format_bytes(size)}) is past what a "
            f"point's index or a file's size can be ({INT64_MAX}, int64): use fewer values on the axes")


# Bytes a grid point costs to order before any is run, in every process, shard or not
# (config/grid.py shuffled_lines): its flat index, the shuffled copy, the permutation of lines.
ORDERING_BYTES_PER_POINT = 24


def memory_problem(config, threads=None) -> str | None:
    """Why the run cannot fit in the memory this process may use (one line), or None. Not a
    matter of --allow-large: a run past it would end in an allocation failure. What it holds: one
    chunk's per-period records (memory_bytes) and the ordering of the whole grid's points."""
    records = memory_bytes(config, threads)
    ordering = ORDERING_BYTES_PER_POINT * config.n_runs
    limit, whose = memory_allowance()
    if records + ordering <= limit:
        return None
    if ordering >= records:  # three axes of 3000 values: 27e9 points ended "out of memory", exit 1
        return (f"{config.source_name}: a grid of {config.n_runs} points needs {format_bytes(ordering)} "
                f"to order its points ({ORDERING_BYTES_PER_POINT} bytes a point, in every shard), more than "
                f"the {format_bytes(limit)} {whose}: use fewer values on the axes")
    return (f"{config.source_name}: measure_periods = {config.integration.measure_periods} needs "
            f"{format_bytes(records)} of per-period records at once, more than the {format_bytes(limit)} "
            f"{whose}: lower integration.measure_periods")


def estimate(config, threads=None) -> Estimate:
    """Output size and wall time of running ``config`` on ``threads`` threads (default: all)."""
    threads = max(1, int(threads or available_threads()))
    integration = config.integration
    n_points = config.n_runs  # a two-way continuation stores and runs every point twice
    output_bytes = stored_bytes(config)
    periods = integration.transient_periods + integration.measure_periods
    # A method of order p takes about rtol^(-1/p) steps per unit time: DP5 (1e-9/rtol)^(1/5).
    method = getattr(integration, "method", INTEGRATION_DEFAULTS["method"])
    steps_factor = METHOD_COST[method] * (REFERENCE_RTOL / integration.rtol) ** (1.0 / METHOD_ORDER[method])
    if integration.lyapunov:
        steps_factor *= LYAPUNOV_COST[method]
    # A written model is costed as the original one (the steps a model takes depend on its time
    # scales, which only a run measures): a rough guide, as any estimate before a run.
    cost = SECONDS_PER_POINT_PERIOD.get(config.model if isinstance(config.model, str) else "original")
    seconds = n_points * periods * cost * steps_factor / threads
    return Estimate(n_points=n_points, output_bytes=output_bytes, seconds=seconds,
                    memory_bytes=memory_bytes(config, threads))


def compiles_first(config) -> bool | None:
    """Whether a run of ``config`` compiles its sweep kernel before its first point (a hint, as
    numba_cache.is_compiled), found without importing numba (validate imports none): the paper's
    run_lines_* in numerics/lines.py, or a written model's in its generated module, which a first
    run also has to write (sympy). None on a GPU, whose kernel's cache only numba-cuda reads.
    The run's time estimate is the integration's alone: a first run adds about 30 s to it."""
    from pathlib import Path

    from vrsweep.numerics import codegen, numba_cache

    integration = config.integration
    if integration.device == "cuda":
        return None
    name = f"run_lines_{integration.method}{'_lyapunov' if integration.lyapunov else ''}"
    if config.written:
        source = codegen.module_path(codegen.module_name(config.model))
        if not source.exists():
            return True
    else:
        source = Path(numba_cache.__file__).with_name("lines.py")
    return not numba_cache.is_cached_function(source, name)


def stored_arrays(config):
    """(name, bytes per grid point, dimension names beyond the grid) of every array a run stores:
    the point variables (vrsweep.store.variables), the done mask and the analytic columns
    (theory.analytic_columns, evaluated at one point to learn their shapes)."""
    from vrsweep.analysis import theory
    from vrsweep.store.variables import point_variables

    arrays = [(name, np.dtype(dtype).itemsize * math.prod(n for _, n in extra), [dim for dim, _ in extra])
              for name, dtype, extra, _ in point_variables(config.integration)]
    arrays.append(("done", 1, []))
    one_point = {name: np.array([value], dtype=np.float64) for name, value in config.parameters.items()}
    columns = {} if config.written else theory.analytic_columns(one_point)  # the paper's theory only
    for name, (array, dims_suffix, _) in columns.items():
        array = np.asarray(array)
        if name == "g_res":  # stored once per value of Omega (job._reduce_constant_axes), ~nothing
            continue
        arrays.append((name, array.nbytes // max(1, array.shape[0]) if array.ndim else array.nbytes,
                       list(dims_suffix)))
    return arrays


def stored_bytes(config) -> int:
    """Size of the result file: the arrays' bytes plus HDF5's per-dataset and per-chunk overhead."""
    n_points = config.n_runs
    arrays = stored_arrays(config)
    data = sum(per_point * n_points for _, per_point, _ in arrays)
    chunks = sum(math.ceil(per_point * n_points / CHUNK_BYTES) for _, per_point, _ in arrays)
    # Datasets: the arrays, g_res, the axes and the extra dimensions' coordinates (strobe, root, ...).
    extra_dims = {dim for _, _, dims in arrays for dim in dims}
    grid_dims = len(config.axes) + (config.n_runs != config.n_points)  # + direction
    n_datasets = len(arrays) + 1 + grid_dims + len(extra_dims)
    coordinates = 8 * (sum(len(axis.values) for axis in config.axes) + 64)
    headers = (n_datasets * BYTES_PER_DATASET + len(arrays) * grid_dims * BYTES_PER_DATASET_DIMENSION
               + (grid_dims + len(extra_dims)) * BYTES_PER_COORDINATE_CHUNK_INDEX)
    return int(data + coordinates + chunks * BYTES_PER_CHUNK + headers
               + 2 * len(config.to_yaml()))  # the config is kept as text (root attribute and done's)


def size_problem(config, threads=None, allow="allow_large=True") -> str | None:
    """The message `check_size` would raise, or None when the run is of reasonable size.

    ``allow``: how the caller allows a large run (the command line says --allow-large)."""
    threads = max(1, int(threads or available_threads()))
    guess = estimate(config, threads)
    if guess.output_bytes <= MAX_OUTPUT_BYTES and guess.seconds <= MAX_SECONDS:
        return None
    return (f"{config.source_name}: grid of {guess.n_points} points, estimated "
            f"{format_bytes(guess.output_bytes)} / {format_duration(guess.seconds)} on {threads} "
            f"thread{'s' if threads != 1 else ''}; pass {allow} to run it anyway")


def check_size(config, threads=None, allow_large: bool = False, allow="allow_large=True") -> Estimate:
    """Raise ConfigError if the run cannot fit in memory (memory_problem), or is out of proportion
    (> 2 GB or > 24 h) and not allowed (``allow``: how the caller allows it, as in size_problem)."""
    beyond = beyond_int64_problem(config)
    if beyond is not None:  # whatever allow_large says
        raise ConfigError([beyond], source=config.source_name)
    memory = memory_problem(config, threads)
    if memory is not None:  # whatever allow_large says
        raise ConfigError([memory], source=config.source_name)
    problem = size_problem(config, threads, allow)
    if problem is not None and not allow_large:
        raise ConfigError([problem], source=config.source_name)
    return estimate(config, threads)


def format_duration(seconds: float) -> str:
    """0.01 -> '< 0.1 s', 3.2 -> '3.2 s', 200 -> '3.3 min', 90000 -> '25.0 h', 2e6 -> '23.1 days'."""
    if seconds < 0.1:
        return "< 0.1 s"
    if seconds < 60:
        return f"{seconds:.1f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"
