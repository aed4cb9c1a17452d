"""The parallel loops over grid lines (numba prange): everything of a sweep that numba compiles.

A *line* is a sequence of grid points run one after the other, each starting from the previous
point's final state (vrsweep.execution.sweep plans them). Each line writes only its own slots of
the output arrays, so the result does not depend on the thread count or the schedule.
"""

import numpy as np
from numba import prange

from vrsweep.numerics import kernel, numba_cache
from vrsweep.numerics.jit import kernel_jit
from vrsweep.results import Status


@kernel_jit(inline="always")
def run_line(integrate, coefficients, initial_state, settings, line_points, records, summaries, statuses):
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
        next_start(status, summaries[slot], initial_state, state)


@kernel_jit
def next_start(status, summary, initial_state, state):
    """Where a line's next point starts (state, (2,)), after a point that ended with status and
    summary: the CPU's lines (run_line) and the GPU's (cuda.py) alike.

    The next point starts at its own t = 0 from this one's state at t = n T: in phase with the
    slow force (omega n T = 2 pi n), and with the fast one when n Omega / omega is a whole number
    (Omega = 4, omega = 0.5: 8 n); otherwise the fast phase restarts.
    """
    if status == Status.OK:
        state[0] = summary[kernel.SUM_X_FINAL]
        state[1] = summary[kernel.SUM_V_FINAL]
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
        run_line(kernel.integrate_rk45, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


@kernel_jit(parallel=True)
def run_lines_dop853(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """run_lines_rk45 with the DOP853 kernel."""
    for line in prange(lines.shape[0]):
        run_line(kernel.integrate_dop853, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


@kernel_jit(parallel=True)
def run_lines_rk45_lyapunov(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """run_lines_rk45 with the tangent vectors (integration.lyapunov)."""
    for line in prange(lines.shape[0]):
        run_line(kernel.integrate_rk45_lyapunov, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


@kernel_jit(parallel=True)
def run_lines_dop853_lyapunov(coefficients, initial_states, settings, lines, period_records, summaries, statuses):
    """run_lines_dop853 with the tangent vectors (integration.lyapunov)."""
    for line in prange(lines.shape[0]):
        run_line(kernel.integrate_dop853_lyapunov, coefficients, initial_states[line], settings, lines[line],
                  period_records[line], summaries[line], statuses[line])


# (integration.method, integration.lyapunov) -> the parallel loop; each is compiled (or loaded)
# only when a run uses it.
RUN_LINES = {("rk45", False): run_lines_rk45, ("dop853", False): run_lines_dop853,
             ("rk45", True): run_lines_rk45_lyapunov, ("dop853", True): run_lines_dop853_lyapunov}


def kernel_is_cached(method: str = "rk45", lyapunov: bool = False) -> bool:
    """Whether the sweep kernel of ``method`` (RUN_LINES[method, lyapunov]) has been compiled
    into the cache already (numba_cache.is_compiled: a hint for the user, not a promise)."""
    return numba_cache.is_compiled(RUN_LINES[method, lyapunov])
