"""Run by tests/test_gpu.py in a process of its own with NUMBA_ENABLE_CUDASIM=1: a few points of
each case through the GPU's line kernel (numerics/cuda.py, in numba's CUDA simulator) and through
the CPU's (lines.py). Prints one JSON line per case: the outputs of both, for the test to compare.

The simulator reads NUMBA_ENABLE_CUDASIM when numba's CUDA target is first imported, which is why
this runs apart from the test process (where the real target, or none, is loaded).
"""

import json
import os
import sys

import numpy as np

assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"

from vrsweep.config import load_config  # noqa: E402
from vrsweep.config.grid import Grid  # noqa: E402
from vrsweep.execution.sweep import integration_settings  # noqa: E402
from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402


def outputs(run_lines, coefficients, initial_states, settings, lines, measure):
    n_lines, length = lines.shape
    records = np.full((n_lines, length, measure, kernel.N_RECORD), np.nan)
    summaries = np.full((n_lines, length, kernel.N_SUMMARY), np.nan)
    statuses = np.full((n_lines, length), -1, dtype=np.int8)
    run_lines(coefficients, initial_states, settings, lines, records, summaries, statuses)
    return {"records": records.tolist(), "summaries": summaries.tolist(), "statuses": statuses.tolist()}


def main(config_path, method, lyapunov, line_length, transient_periods=4):
    config = load_config(config_path, [f"method={method}", f"lyapunov={lyapunov}", f"transient_periods={transient_periods}",
                                       "measure_periods=16"])
    grid = Grid.from_config(config)
    kernels = kernels_for(config.model)
    flat = np.arange(grid.n_points, dtype=np.int64)
    coefficients = np.ascontiguousarray(kernels.coefficients(grid.parameters_at(config, flat)))
    lines = flat.reshape(-1, line_length)
    initial_states = grid.initial_states_at(config, lines[:, 0])
    settings = integration_settings(config.integration)
    lyapunov = lyapunov == "true"
    measure = config.integration.measure_periods
    local = np.arange(lines.size, dtype=np.int64).reshape(lines.shape)
    cpu = outputs(kernels.run_lines(method, lyapunov), coefficients, initial_states, settings, local, measure)
    gpu = outputs(kernels.gpu_lines(method, lyapunov), coefficients, initial_states, settings, local, measure)
    print(json.dumps({"cpu": cpu, "gpu": gpu}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], *[int(argument) for argument in sys.argv[4:]])
