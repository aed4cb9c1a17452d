"""The benchmarks' one way of timing a call: the calling thread's CPU time, best of N.

CPU time (time.thread_time), not wall time: the machine may be shared, and other jobs disturb a
thread's CPU time less than the clock. Imported by the scripts beside it, which are run as
``python benchmarks/NAME.py`` (this folder first on sys.path) or as modules of the package.
"""

import json
import os
import subprocess
import sys
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


def checkout_child(checkout, child, arguments, env=None, timeout=None):
    """The JSON a child process prints last, ``python -c child *arguments checkout``, run with the
    checkout's own vrsweep: the child puts its last argument first on sys.path and prints
    ``{"vrsweep": vrsweep.__file__, ...}``, checked here to lie in the checkout. Up to 0.7.8 the
    children of versions.py found vrsweep on PYTHONPATH, after '' (the working folder): run from
    a checkout's root, as its usage shows, both children imported that checkout's vrsweep, and
    every ratio compared it with itself."""
    checkout = os.path.realpath(checkout)
    env = dict(os.environ if env is None else env, PYTHONPATH=checkout)
    done = subprocess.run([sys.executable, "-c", child, *arguments, checkout], env=env, capture_output=True, text=True,
                          check=True, timeout=timeout)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    imported = os.path.realpath(result["vrsweep"])
    if not imported.startswith(checkout + os.sep):
        raise SystemExit(f"the child imported {imported}, not the checkout {checkout}")
    return result
