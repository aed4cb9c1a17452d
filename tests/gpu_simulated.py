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


def _yielding_poll():
    """The simulator's BlockManager polls its threads' is_alive in a loop that never waits, so it
    holds the GIL for whole switch intervals while the simulated threads (the work) wait for it.
    A sleep(0) before each poll hands the GIL over; what each thread computes is unchanged (the
    poll only decides when a block's syncthreads is released and when the block is done). Measured
    on the paper's model with the tangent vectors, 6 points: 44 s before, 17 s with it."""
    import threading
    import time

    from numba.cuda.simulator import kernel as simulator

    def is_alive(self, _alive=threading.Thread.is_alive):
        time.sleep(0)
        return _alive(self)

    simulator.BlockThread.is_alive = is_alive


_yielding_poll()

from vrsweep.config import load_config  # noqa: E402
from vrsweep.config.grid import Grid  # noqa: E402
from vrsweep.execution.sweep import integration_settings  # noqa: E402
from vrsweep.numerics import kernel  # noqa: E402
from vrsweep.numerics.models import kernels_for  # noqa: E402


# The periods of the sweep and slots modes' points, 6 in all: the simulator runs each thread's
# steps in Python (the paper's model takes ~750 a period), and the chunks, slots and bit-for-bit
# values these modes test do not depend on how long each point runs.
SHORT_RUN = ["transient_periods=2", "measure_periods=4", "strobe_periods=4"]

# What the host's output arrays hold before a GPU's launch: not NaN, so that an entry the card
# left unfilled (cuda.fill_nan) shows (the CPU's are NaN-filled, as execution/sweep.py fills them).
GARBAGE, GARBAGE_STATUS = 7.0, 99


def outputs(run_lines, coefficients, initial_states, settings, lines, measure, fill=np.nan, status_fill=-1):
    n_lines, length = lines.shape
    records = np.full((n_lines, length, measure, kernel.N_RECORD), fill)
    summaries = np.full((n_lines, length, kernel.N_SUMMARY), fill)
    statuses = np.full((n_lines, length), status_fill, dtype=np.int8)
    run_lines(coefficients, initial_states, settings, lines, records, summaries, statuses)
    return {"records": records.tolist(), "summaries": summaries.tolist(), "statuses": statuses.tolist()}


def main(config_path, method, lyapunov, line_length, transient_periods=4, local_coefficients="false",
         measure_periods="16"):
    from vrsweep.numerics import cuda

    cuda.LOCAL_COEFFICIENTS = local_coefficients == "true"
    config = load_config(config_path, [f"method={method}", f"lyapunov={lyapunov}", f"transient_periods={transient_periods}",
                                       f"measure_periods={measure_periods}",
                                       f"strobe_periods={min(16, int(measure_periods))}"])
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
    gpu = outputs(kernels.gpu_lines(method, lyapunov), coefficients, initial_states, settings, local, measure,
                  GARBAGE, GARBAGE_STATUS)
    print(json.dumps({"cpu": cpu, "gpu": gpu}))


def sweep(config_path):
    """The job's loop (execution/sweep.run_sweep) on the GPU, from chunks of two points growing, and
    on the CPU: the chunks handed to on_chunk, in order, and every point's values of both."""
    from vrsweep.execution import chunks
    from vrsweep.execution.sweep import run_sweep

    chunks.GPU_FIRST_CHUNK_LINES = 2  # several chunks, so that one is in flight while another finishes
    results = {}
    for device in ("cuda", "cpu"):
        config = load_config(config_path, [f"device={device}", *SHORT_RUN])
        handed, values = [], {}

        def keep(flat, chunk, handed=handed, values=values):
            handed.append(flat.tolist())
            for name in ("R", "R_err", "status", "period", "x_final", "n_steps"):
                for k, index in enumerate(flat):
                    values.setdefault(name, {})[int(index)] = float(chunk[name][k])

        run_sweep(config, on_chunk=keep)
        results[device] = {"handed": handed, "values": values}
    print(json.dumps(results))


def slots(config_path):
    """Launches in flight at once on DeviceLines' kept slots (cuda.REUSE_DEVICE_ARRAYS): chunks of
    4 and 2 lines in flight together, then one of 6 (more rows than any slot holds) and one of 1
    (the first rows of a slot's arrays). Prints each chunk's outputs from the kept slots, from
    fresh arrays and from the CPU, the slots' count, and whether each of the last two chunks
    allocated arrays."""
    from vrsweep.numerics import cuda

    config = load_config(config_path, SHORT_RUN)
    grid = Grid.from_config(config)
    kernels = kernels_for(config.model)
    flat = np.arange(grid.n_points, dtype=np.int64)
    coefficients = np.ascontiguousarray(kernels.coefficients(grid.parameters_at(config, flat)))
    initial_states = grid.initial_states_at(config, flat)
    settings = integration_settings(config.integration)
    measure = config.integration.measure_periods
    kept = kernels.gpu_lines("rk45")
    fresh = cuda.DeviceLines(kept.kernel, reuse=False)
    cpu = kernels.run_lines("rk45")

    def arrays(rows, fill=GARBAGE, status_fill=GARBAGE_STATUS):
        n = len(rows)
        return (coefficients[rows], initial_states[rows], settings, np.arange(n, dtype=np.int64).reshape(n, 1),
                np.full((n, 1, measure, kernel.N_RECORD), fill), np.full((n, 1, kernel.N_SUMMARY), fill),
                np.full((n, 1), status_fill, dtype=np.int8))

    def listed(chunk):
        return {"records": chunk[4].tolist(), "summaries": chunk[5].tolist(), "statuses": chunk[6].tolist()}

    chunks, results = [], []
    first, second = arrays(flat[:4]), arrays(flat[4:6])
    in_flight = [kept.launch(*first), kept.launch(*second)]
    slots_in_flight = len(kept.slots)
    for launch in in_flight:
        launch.wait()
    chunks += [first, second]
    reallocated = []
    for rows in (flat[:6], flat[6:7]):
        held = [id(array) for slot in kept.slots for array in slot.arrays]
        chunk = arrays(rows)
        kept.launch(*chunk).wait()
        chunks.append(chunk)
        reallocated.append([id(array) for slot in kept.slots for array in slot.arrays] != held)
    for chunk in chunks:
        other, host = arrays(np.arange(len(chunk[0]))), arrays(np.arange(len(chunk[0])), np.nan, -1)
        other = (chunk[0], chunk[1]) + other[2:]
        host = (chunk[0], chunk[1]) + host[2:]
        fresh(*other)
        cpu(*host)
        results.append({"kept": listed(chunk), "fresh": listed(other), "cpu": listed(host)})
    print(json.dumps({"chunks": results, "slots_in_flight": slots_in_flight, "slots": len(kept.slots),
                      "reallocated": reallocated}))


def job(config_path, folder):
    """run_job on the GPU (chunks of two points growing) and on the CPU: each file's solver error
    attributes, and for each run the chunks written when the solver error's tight run started, of
    how many in all (solver_error.start)."""
    import h5py

    from vrsweep.execution import chunks, job as jobs, solver_error

    chunks.GPU_FIRST_CHUNK_LINES = 2
    written, started = [0], []
    write_points = jobs.ResultWriter.write_points
    start = solver_error.start

    def counted(self, *arguments):
        write_points(self, *arguments)
        written[0] += 1

    def noted(*arguments):
        started.append(written[0])
        return start(*arguments)

    jobs.ResultWriter.write_points = counted
    solver_error.start = noted
    results = {}
    for device in ("cuda", "cpu"):
        written[0], started[:] = 0, []
        # (a transient long enough for periodic points: the estimate needs some)
        config = load_config(config_path, [f"device={device}", "transient_periods=60", "measure_periods=16"])
        path = os.path.join(folder, f"{device}.h5")
        jobs.run_job(config, path)
        with h5py.File(path, "r") as file:
            attributes = {name: float(value) for name, value in file.attrs.items() if name.startswith("R_solver_err")}
        results[device] = {"attributes": attributes, "started_after": list(started), "chunks": written[0]}
    print(json.dumps(results))


if __name__ == "__main__":
    if sys.argv[1] == "sweep":
        sweep(sys.argv[2])
    elif sys.argv[1] == "slots":
        slots(sys.argv[2])
    elif sys.argv[1] == "job":
        job(sys.argv[2], sys.argv[3])
    else:
        main(sys.argv[1], sys.argv[2], sys.argv[3], *[int(argument) for argument in sys.argv[4:6]], *sys.argv[6:])
