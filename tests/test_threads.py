"""One thread count for the whole program (vrsweep.execution.threads), as numba computes its own."""

import os
import subprocess
import sys

import pytest

from vrsweep.execution.threads import available_threads


def test_numba_num_threads_when_it_is_a_whole_number(monkeypatch):
    monkeypatch.setenv("NUMBA_NUM_THREADS", "3")
    assert available_threads() == 3


@pytest.mark.parametrize("value", ["", "abc", "0", "-2", "1.5"])
def test_otherwise_the_cpus_this_process_may_run_on(monkeypatch, value):
    monkeypatch.setenv("NUMBA_NUM_THREADS", value)
    assert available_threads() == len(os.sched_getaffinity(0))


def test_it_is_numbas_own_count_in_a_fresh_process(tmp_path):
    for value in ("1", "abc"):
        code = ("import warnings; warnings.simplefilter('ignore'); import numba; "
                "from vrsweep.execution.threads import available_threads; "
                "print(numba.config.NUMBA_NUM_THREADS, available_threads())")
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=dict(os.environ, NUMBA_NUM_THREADS=value), timeout=120)
        assert done.returncode == 0, done.stderr
        numba_count, ours = done.stdout.split()
        assert numba_count == ours, (value, done.stdout)


def test_an_unreadable_numba_num_threads_is_no_traceback(tmp_path, write_config):
    config = write_config(tmp_path, """\
        model: effective
        integration: {transient_periods: 1, measure_periods: 1, strobe_periods: 1}
        """)
    env = dict(os.environ, NUMBA_NUM_THREADS="abc")
    for command in (["run", config, "-o", tmp_path / "out.h5"], ["validate", config]):
        done = subprocess.run([sys.executable, "-m", "vrsweep", *map(str, command)], capture_output=True,
                              text=True, env=env, timeout=300)
        assert done.returncode == 0, done.stderr
        assert "Traceback" not in done.stderr, done.stderr
        assert done.stderr.startswith(f"vrsweep: NUMBA_NUM_THREADS='abc' is not a whole number >= 1: "
                                      f"ignored, using the {len(os.sched_getaffinity(0))} CPUs"), done.stderr


def test_sweeps_from_several_threads_at_once_under_numbas_workqueue_layer():
    # numba's workqueue layer (its fallback where OpenMP and TBB do not load) aborted the process on
    # concurrent parallel launches: two vrsweep.sweep calls from a notebook's threads killed it. The
    # lines now run on Python's threads (numerics/lines.py) and numba's layer is never started.
    code = """
import threading, numpy as np, vrsweep
from numba.np.ufunc import parallel
config = {"model": "effective", "sweep": {"g": np.linspace(0, 40, 9)},
          "integration": {"transient_periods": 20, "measure_periods": 16}}
reference = vrsweep.sweep(config, progress=False)
start = threading.Barrier(3)
results = []
def work():
    start.wait()
    results.append(vrsweep.sweep(config, progress=False))
threads = [threading.Thread(target=work) for _ in range(3)]
[thread.start() for thread in threads]
[thread.join() for thread in threads]
assert len(results) == 3
for result in results:
    assert (result.R.fillna(-1).values == reference.R.fillna(-1).values).all()
print(parallel._is_initialized)
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, NUMBA_THREADING_LAYER="workqueue", NUMBA_NUM_THREADS="2"), timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["False"]


def test_threads_may_be_a_numpy_integer(tmp_path):
    import numpy as np

    import vrsweep
    from vrsweep.errors import UsageError

    config = {"model": "effective", "integration": {"transient_periods": 1, "measure_periods": 1, "strobe_periods": 1}}
    one = vrsweep.sweep(config, threads=np.int64(1), progress=False)
    assert int(one.status) == 0
    for value in (np.bool_(True), np.int64(0), np.float64(1.0)):
        with pytest.raises(UsageError, match=r"^threads must be a whole number of at least 1, got "):
            vrsweep.sweep(config, threads=value, progress=False)


def test_a_sweep_on_fewer_threads_leaves_the_callers_numba_count_as_it_was():
    """numba keeps its thread count per Python thread: vrsweep.sweep(cfg, threads=1) left the
    notebook's own parallel numba code on one thread for the rest of the session."""
    code = ("import warnings; warnings.simplefilter('ignore'); import numba, vrsweep; "
            "config = {'model': 'effective', 'integration': {'transient_periods': 1, 'measure_periods': 1, "
            "'strobe_periods': 1}, 'sweep': {'g': {'start': 5, 'stop': 6, 'num': 4}}}; "
            "vrsweep.sweep(config, threads=1, progress=False); print(numba.get_num_threads())")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, NUMBA_NUM_THREADS="2"), timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["2"], done.stdout
