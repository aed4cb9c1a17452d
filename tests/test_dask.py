"""``vrsweep run --dask``: chunks on dask.distributed workers, one writer, same file as a local run."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

pytest.importorskip("dask.distributed")

TINY = """\
    sweep:
      g: {start: 0.0, stop: 30.0, num: 9}
      Omega: [4.0, 5.0]
    integration: {transient_periods: 5, measure_periods: 5, strobe_periods: 4}
    """


@pytest.fixture(scope="module")
def single(tmp_path_factory, invoke, write_config):
    directory = tmp_path_factory.mktemp("dask")
    config = write_config(directory, TINY)
    out = directory / "single.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    return config, out


def test_a_local_cluster_of_two_workers_equals_a_single_run(single, tmp_path, assert_same_result, invoke):
    config, expected = single
    out = tmp_path / "dask.h5"
    result = invoke("run", config, "-o", out, "--dask", "local:2", "--threads", 1)
    assert result.exit_code == 0, result.output
    assert "18 of 18 points computed" in result.output
    assert_same_result(out, expected)


def test_dask_resumes_a_local_run_through_a_scheduler_address(single, tmp_path, assert_same_result, done_count, invoke):
    """Resumable as a local run: the client writes; a partial file is completed on a cluster."""
    from dask.distributed import LocalCluster

    from vrsweep.config import load_config
    from vrsweep.execution.job import GracefulStop, Interrupted, run_job
    from vrsweep.execution.sweep import run_sweep

    config, expected = single
    out = tmp_path / "partial.h5"
    stop = GracefulStop()
    stop.signum = signal.SIGINT  # stop after the first chunk
    with pytest.raises(Interrupted):
        run_job(load_config(config), out, threads=1, stop=stop,
                executor=lambda c, **kw: run_sweep(c, chunk_lines=4, **kw))
    assert done_count(out) == 4

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        result = invoke("run", config, "-o", out, "--resume", "--dask", cluster.scheduler_address)
    assert result.exit_code == 0, result.output
    assert "14 of 18 points computed" in result.output
    assert_same_result(out, expected)


def test_run_without_dask_never_imports_it(single, tmp_path):
    config, _ = single
    script = textwrap.dedent(f"""
        import sys
        from vrsweep.cli import main
        import vrsweep.execution.distributed  # the module itself imports dask lazily too
        try:
            main(["run", {str(config)!r}, "-o", {str(tmp_path / "plain.h5")!r}, "-q"])
        except SystemExit as exit:
            assert not exit.code, exit.code
        print(sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed")))
    """)
    output = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert output.stdout.strip() == "[]", output


def test_ctrl_c_in_a_terminal_stops_a_local_cluster_run_cleanly(tmp_path, assert_same_result, done_count, invoke, vrsweep_process, write_config):
    """A terminal's Ctrl-C goes to the whole process group, local workers included: the workers
    must leave it to the client, which saves the chunk in flight, shuts the cluster down and
    prints the resume command (a worker killed by it used to leave the client waiting forever)."""
    config = write_config(tmp_path, """\
        sweep:
          g: {start: 0.0, stop: 40.0, num: 96}
        integration: {transient_periods: 60, measure_periods: 60, strobe_periods: 8}
        """)
    out = tmp_path / "out.h5"
    child = vrsweep_process("run", config, "-o", out, "--dask", "local:2", "--threads", 1,
                            cwd=tmp_path, start_new_session=True)  # its own group, as in a terminal
    try:
        deadline = time.monotonic() + 120
        while (done_count(out) or 0) < 16 and time.monotonic() < deadline and child.poll() is None:
            time.sleep(0.02)
        os.killpg(child.pid, signal.SIGINT)
        _, stderr = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
    assert child.returncode == 130, stderr
    assert "Traceback" not in stderr and "WARNING" not in stderr, stderr
    assert "--resume" in stderr and "--dask local:2" in stderr
    saved = done_count(out)
    assert 16 <= saved < 96

    result = invoke("run", config, "-o", out, "--resume")
    assert result.exit_code == 0 and f"{96 - saved} of 96 points computed" in result.output
    assert invoke("run", config, "-o", tmp_path / "single.h5", "-q").exit_code == 0
    assert_same_result(out, tmp_path / "single.h5")


def test_without_dask_installed_dask_is_a_usage_error(single, tmp_path, monkeypatch, invoke):
    config, _ = single
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import now fails as if absent
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--dask", "local:2")
    assert result.exit_code == 2
    assert "pip install" in result.output and "vrsweep[dask]" in result.output
    assert 'pip install -e ".[dask]"' in result.output  # and how to do it in a clone
    assert not (tmp_path / "out.h5").exists()


@pytest.mark.parametrize("threads", [None, 1])  # None: waits for a worker to size the chunks
def test_a_stop_with_no_worker_connected_takes_effect_at_once(single, tmp_path, threads, done_count):
    """SIGTERM (scancel) to a client whose SLURM worker jobs were still queued: the stop waited for
    the next chunk to be saved, which no worker would ever compute, so the client stayed until
    SIGKILL and never cancelled its worker jobs (examples/slurm/dask_slurm.py)."""
    from dask.distributed import LocalCluster

    from vrsweep.config import load_config
    from vrsweep.execution.distributed import dask_executor
    from vrsweep.execution.job import GracefulStop, Interrupted, run_job

    config, _ = single
    stop = GracefulStop()
    stop.signum = signal.SIGTERM  # asked for before any worker came
    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        executor = dask_executor(cluster.scheduler_address, threads, stop)
        began = time.monotonic()
        with pytest.raises(Interrupted) as stopped:
            run_job(load_config(config), tmp_path / "out.h5", threads=threads, stop=stop, executor=executor)
        assert time.monotonic() - began < 10
    assert stopped.value.exit_code == 143
    assert done_count(tmp_path / "out.h5") == 0  # the file is there, for --resume



# A process of its own: distributed installs its stderr handler only where the root logger has
# none (a command's process; pytest's has its own).
_DISTRIBUTED_LINES = """
import logging, sys
from distributed.comm.core import CommClosedError
from vrsweep.execution import distributed as vrsweep_distributed

vrsweep_distributed._no_tracebacks_below_warning()
vrsweep_distributed._no_tracebacks_below_warning()  # idempotent: one filter
(handler,) = logging.getLogger("distributed").handlers
assert sum(f is vrsweep_distributed._info_without_traceback for f in handler.filters) == 1
for name, level, message in (("distributed.batched", logging.INFO, "Batched Comm Closed <TCP (closed)>"),
                             ("distributed.core", logging.WARNING, "something failed")):
    try:
        raise CommClosedError()
    except CommClosedError:
        logging.getLogger(name).log(level, message, exc_info=True)
    print("@@", file=sys.stderr)
"""


def test_distributeds_info_lines_carry_no_traceback_its_warnings_do():
    """A scheduler closed with its workers still connected (after every stop of a Dask-on-SLURM
    run) logs "Batched Comm Closed" at INFO with a CommClosedError traceback: it printed beneath
    vrsweep's "Interrupted (SIGTERM)" line (test_shards' dask_slurm test, once in a CI run). The
    line stays, its traceback goes; a warning keeps its traceback."""
    done = subprocess.run([sys.executable, "-c", _DISTRIBUTED_LINES], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    info, warning, _ = done.stderr.split("@@")
    assert "Batched Comm Closed" in info and "Traceback" not in info and "CommClosedError" not in info, info
    assert "something failed" in warning and "Traceback" in warning and "CommClosedError" in warning, warning
