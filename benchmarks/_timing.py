"""The benchmarks' one way of timing a call: the calling thread's CPU time, best of N.

CPU time (time.thread_time), not wall time: the machine may be shared, and other jobs disturb a
thread's CPU time less than the clock. Imported by the scripts beside it, which are run as
``python benchmarks/NAME.py`` (this folder first on sys.path) or as modules of the package.
"""

import time


def best_of(function, repeats=3, warm_up=False):
    """(the smallest CPU time in seconds of ``repeats`` calls of ``function()``, the last call's
    result). warm_up: one untimed call first, which compiles (or loads) every kernel it uses."""
    if warm_up:
        function()
    times = []
    for _ in range(repeats):
        start = time.thread_time()
        result = function()
        times.append(time.thread_time() - start)
    return min(times), result
