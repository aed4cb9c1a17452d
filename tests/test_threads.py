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
