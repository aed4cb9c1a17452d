"""The sweep's lines on the CPU: a compiled loop over a range of lines, run by Python threads.

A *line* is a sequence of grid points run one after the other, each starting from the previous
point's final state (vrsweep.execution.sweep plans them). Each line writes only its own slots of
the output arrays, so the result does not depend on the thread count or the schedule.

The threads are Python's, not numba's ``prange``: ``run_lines_*`` is compiled with ``nogil`` (it
leaves Python's lock while it computes), and ThreadedLines calls it from several threads at once,
each call on lines that no other call touches. A ``prange`` loop compiled its parallel wrapper
anew for every kernel, 2.5 s of a cold rk45 sweep's compile and 4.8 s of a dop853 one's; the
plain loop compiles in about a second, and runs as fast (benchmarks/README.md, "Python's threads
over the lines"). No numba threading layer is started, so none can fail to load or abort on two
sweeps at once.
"""

import threading

import numba
import numpy as np

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


@kernel_jit(nogil=True)
def run_lines_rk45(coefficients, initial_states, settings, lines, period_records, summaries, statuses, first, stop):
    """Run lines first..stop-1, each line's points in order (ThreadedLines runs ranges at once).

    coefficients    (n_points, N_COEFFICIENTS)         for every point the lines name
    initial_states  (n_lines, 2)                        state of each line's first point
    settings        (N_SETTINGS,)
    lines           (n_lines, line_length)             indices into coefficients
    period_records  (n_lines, line_length, n_periods, N_RECORD)   outputs, per line slot
    summaries       (n_lines, line_length, N_SUMMARY)
    statuses        (n_lines, line_length) int8
    """
    for line in range(first, stop):
        run_line(kernel.integrate_rk45, coefficients, initial_states[line], settings, lines[line],
                 period_records[line], summaries[line], statuses[line])


@kernel_jit(nogil=True)
def run_lines_dop853(coefficients, initial_states, settings, lines, period_records, summaries, statuses, first, stop):
    """run_lines_rk45 with the DOP853 kernel."""
    for line in range(first, stop):
        run_line(kernel.integrate_dop853, coefficients, initial_states[line], settings, lines[line],
                 period_records[line], summaries[line], statuses[line])


@kernel_jit(nogil=True)
def run_lines_rk45_lyapunov(coefficients, initial_states, settings, lines, period_records, summaries, statuses,
                            first, stop):
    """run_lines_rk45 with the tangent vectors (integration.lyapunov)."""
    for line in range(first, stop):
        run_line(kernel.integrate_rk45_lyapunov, coefficients, initial_states[line], settings, lines[line],
                 period_records[line], summaries[line], statuses[line])


@kernel_jit(nogil=True)
def run_lines_dop853_lyapunov(coefficients, initial_states, settings, lines, period_records, summaries, statuses,
                              first, stop):
    """run_lines_dop853 with the tangent vectors (integration.lyapunov)."""
    for line in range(first, stop):
        run_line(kernel.integrate_dop853_lyapunov, coefficients, initial_states[line], settings, lines[line],
                 period_records[line], summaries[line], statuses[line])


class GuidedSchedule:
    """Hands out ranges of lines [first, stop) to threads, each once, until all are handed out or
    stop() is called: a quarter of a thread's share of what is left, at least one line (OpenMP's
    "guided" schedule). Few calls while much is left, single lines at the end: a point may cost
    ten times another, and the last ranges decide when the chunk ends."""

    SHARE = 4  # ranges per thread's share of the lines left

    def __init__(self, n_lines, threads):
        self.n_lines, self.threads = int(n_lines), max(1, int(threads))
        self.next = 0
        self._lock = threading.Lock()

    def take(self):
        """The next range, or None when every line is handed out (or the schedule was stopped)."""
        with self._lock:
            first = self.next
            if first >= self.n_lines:
                return None
            size = max(1, (self.n_lines - first) // (self.SHARE * self.threads))
            self.next = first + size
            return first, first + size

    def stop(self):
        """Hand out nothing more: the ranges already taken are finished, no other is started."""
        with self._lock:
            self.next = self.n_lines


class ThreadedLines:
    """A sweep's lines on ``threads`` threads: ``kernel`` (a run_lines_* above, or a written
    model's) called with the ranges of a GuidedSchedule, from the calling thread and threads - 1
    others. Called as ``prange`` loops were: ``(coefficients, initial_states, settings, lines,
    period_records, summaries, statuses, threads=None)``, at most numba's thread count.

    An exception in a thread, or KeyboardInterrupt (or any exception) in the calling one, stops
    the schedule; the ranges in flight finish (a compiled call cannot be stopped halfway) and the
    first exception is raised in the caller, once every thread is done.
    """

    def __init__(self, kernel):
        self.kernel = kernel

    def __call__(self, coefficients, initial_states, settings, lines, period_records, summaries, statuses,
                 threads=None):
        arrays = (coefficients, initial_states, settings, lines, period_records, summaries, statuses)
        n_lines = lines.shape[0]
        threads = min(int(threads or numba.config.NUMBA_NUM_THREADS), numba.config.NUMBA_NUM_THREADS, max(1, n_lines))
        schedule = GuidedSchedule(n_lines, threads)
        failures = []

        def work():
            try:
                while (taken := schedule.take()) is not None:
                    self.kernel(*arrays, *taken)
            except BaseException as error:  # noqa: BLE001 - handed to the caller
                schedule.stop()
                failures.append(error)

        others = [threading.Thread(target=work, name=f"vrsweep-lines-{k}", daemon=True) for k in range(1, threads)]
        for thread in others:
            thread.start()
        try:
            work()
        finally:
            schedule.stop()
            for thread in others:
                thread.join()
        if failures:
            raise failures[0]


# (integration.method, integration.lyapunov) -> the lines on threads; each kernel is compiled (or
# loaded) only when a run uses it.
RUN_LINES = {("rk45", False): ThreadedLines(run_lines_rk45), ("dop853", False): ThreadedLines(run_lines_dop853),
             ("rk45", True): ThreadedLines(run_lines_rk45_lyapunov),
             ("dop853", True): ThreadedLines(run_lines_dop853_lyapunov)}


def kernel_is_cached(method: str = "rk45", lyapunov: bool = False) -> bool:
    """Whether the sweep kernel of ``method`` (RUN_LINES[method, lyapunov]) has been compiled
    into the cache already (numba_cache.is_compiled: a hint for the user, not a promise)."""
    return numba_cache.is_compiled(RUN_LINES[method, lyapunov].kernel)
