"""Checkpoint and resume end to end: a real ``vrsweep run`` killed (-9), interrupted (Ctrl-C) or
terminated (SIGTERM) mid-run resumes to the file an uninterrupted run writes, bit for bit; a file
from another config is never overwritten or mixed."""

import re
import shlex
import signal
import time

import h5py
import pytest

# Big enough to be caught mid-run: 96 points in chunks of 16 (one thread), ~0.5 s per chunk.
SLOW = """\
    sweep:
      g: {start: 0.0, stop: 40.0, num: 96}
    integration: {transient_periods: 60, measure_periods: 60, strobe_periods: 8}
    """
N_POINTS = 96
CHUNK = 16  # run_sweep's chunk on one thread


@pytest.fixture(scope="module")
def reference(tmp_path_factory, invoke, write_config):
    """The uninterrupted run (also compiles the kernel before any subprocess needs it)."""
    directory = tmp_path_factory.mktemp("reference")
    config = write_config(directory, SLOW)
    out = directory / "reference.h5"
    result = invoke("run", config, "-o", out, "-q")
    assert result.exit_code == 0, result.output
    return config, out


@pytest.fixture(scope="session")
def start_and_wait_for_progress(done_count, vrsweep_process):
    """The helper below, with the shared helpers it calls (tests/conftest.py)."""
    def start_and_wait_for_progress(tmp_path, config, out):
        """Start ``vrsweep run`` on one thread; return it once at least one chunk is on disk."""
        child = vrsweep_process("run", config, "-o", out, "--threads", 1, cwd=tmp_path)
        deadline = time.monotonic() + 120  # a cold numba cache compiles for ~30 s first
        while time.monotonic() < deadline and child.poll() is None:
            n = done_count(out)
            if n is not None and n >= CHUNK:
                return child, n
            time.sleep(0.02)
        child.kill()
        pytest.fail(f"no chunk written in time: {child.communicate()}")
    return start_and_wait_for_progress


@pytest.fixture(scope="session")
def resume(invoke):
    """The helper below, with the shared helpers it calls (tests/conftest.py)."""
    def resume(config, out):
        result = invoke("run", config, "-o", out, "--resume")
        assert result.exit_code == 0, result.output
        return result
    return resume


def n_computed(result):
    return int(re.search(r"(\d+) of (\d+) points computed", result.output).group(1))


def test_kill_9_mid_run_then_resume_is_identical_to_an_uninterrupted_run(tmp_path, reference, assert_same_result, done_count, resume, start_and_wait_for_progress):
    config, expected = reference
    out = tmp_path / "killed.h5"
    child, _ = start_and_wait_for_progress(tmp_path, config, out)
    child.send_signal(signal.SIGKILL)
    child.communicate()
    assert child.returncode == -signal.SIGKILL
    saved = done_count(out)
    assert CHUNK <= saved < N_POINTS, "killed too late to test anything"
    with h5py.File(out, "r") as f:
        assert f.attrs["vrsweep_complete"] == 0

    result = resume(config, out)
    assert n_computed(result) == N_POINTS - saved  # only what was missing
    assert_same_result(out, expected)


# SIGHUP (a closed terminal, a dropped ssh session) and SIGUSR1/SIGUSR2 (sbatch --signal=USR1@60)
# killed the run at once (exit -1, -10, -12): the chunk in flight lost, not a word in the log.
STOP_SIGNALS = [signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGUSR1, signal.SIGUSR2]


@pytest.mark.parametrize("signum", STOP_SIGNALS, ids=[signal.Signals(s).name for s in STOP_SIGNALS])
def test_a_signal_stops_cleanly_and_prints_the_resume_command(tmp_path, reference, signum, assert_same_result, done_count, invoke, start_and_wait_for_progress):
    config, expected = reference
    out = tmp_path / "stopped.h5"
    child, seen = start_and_wait_for_progress(tmp_path, config, out)
    # Signalled the moment its done flags show, the run can still be between writing them and
    # checking for a signal, with no chunk in flight (then nothing is lost either, but nothing is
    # tested): a fifth of a chunk later it computes the next one.
    time.sleep(0.1)
    child.send_signal(signum)
    _, stderr = child.communicate(timeout=60)
    assert child.returncode == 128 + signum, stderr
    assert "Traceback" not in stderr, stderr
    name = signal.Signals(signum).name
    assert f"{name}: stopping once the chunk in progress is saved" in stderr, stderr
    assert f"Interrupted ({name}): finished chunks are saved" in stderr, stderr
    saved = done_count(out)
    assert seen < saved < N_POINTS  # the chunk in flight was finished and kept
    assert saved % CHUNK == 0

    # The printed command is the way back: run it as printed.
    command = stderr.strip().splitlines()[-1].strip()
    assert command == shlex.join(["vrsweep", "run", str(config), "--resume", "-o", str(out),
                                  "--threads", "1"])
    result = invoke(*shlex.split(command)[1:])
    assert result.exit_code == 0, result.output
    assert n_computed(result) == N_POINTS - saved
    assert_same_result(out, expected)


def test_a_terminal_that_closes_stops_the_run_as_sighup_does(tmp_path, reference, assert_same_result, done_count, resume):
    """The real thing: a run whose terminal is a pseudo-terminal it controls; the terminal's
    master end closes (the window, or ssh, goes), the kernel sends SIGHUP and every later write to
    the terminal fails with EIO. The run finishes its chunk, keeps it and exits 129; the progress
    line and the message it can no longer write do not turn it into an error."""
    import fcntl
    import os
    import subprocess
    import sys
    import termios

    config, expected = reference
    out = tmp_path / "hung_up.h5"
    master, terminal = os.openpty()

    def control_the_terminal():  # a session of its own, with the pty as its controlling terminal
        os.setsid()
        fcntl.ioctl(terminal, termios.TIOCSCTTY, 0)

    child = subprocess.Popen([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(out), "--threads", "1"],
                             stdin=terminal, stdout=terminal, stderr=terminal, preexec_fn=control_the_terminal,
                             env=dict(os.environ))
    os.close(terminal)
    os.set_blocking(master, False)  # read what the run writes without waiting for it
    try:
        deadline = time.monotonic() + 120
        seen = None
        while time.monotonic() < deadline and child.poll() is None:
            try:
                os.read(master, 65536)  # keep the terminal's buffer from filling
            except OSError:
                pass
            seen = done_count(out)
            if seen is not None and seen >= CHUNK:
                break
            time.sleep(0.02)
        assert seen is not None and seen >= CHUNK, "no chunk written in time"
        time.sleep(0.1)
        os.close(master)  # the terminal hangs up
        child.wait(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 128 + signal.SIGHUP
    saved = done_count(out)
    assert seen < saved < N_POINTS and saved % CHUNK == 0  # the chunk in flight was finished and kept
    result = resume(config, out)
    assert n_computed(result) == N_POINTS - saved
    assert_same_result(out, expected)


def test_resume_of_a_finished_file_computes_nothing(tmp_path, reference, assert_same_result, resume):
    config, expected = reference
    out = tmp_path / "copy.h5"
    out.write_bytes(expected.read_bytes())
    result = resume(config, out)
    assert "0 of 96 points computed (nothing left to compute)" in result.output
    assert_same_result(out, expected)


def test_resume_without_a_file_starts_one(tmp_path, resume, write_config):
    config = write_config(tmp_path, "integration: {transient_periods: 3, measure_periods: 3, strobe_periods: 2}\n")
    result = resume(config, tmp_path / "new.h5")
    assert "1 of 1 points computed" in result.output


def test_output_of_another_config_is_never_overwritten_nor_mixed(tmp_path, invoke, write_config):
    config = write_config(tmp_path, """\
        sweep:
          g: {start: 0.0, stop: 30.0, num: 4}
        integration: {transient_periods: 3, measure_periods: 3, strobe_periods: 2}
        """)
    out = tmp_path / "out.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    before = out.read_bytes()

    plain = invoke("run", config, "-o", out, "--set", "e=0.9")
    assert plain.exit_code == 2 and "--overwrite" in plain.output

    resumed = invoke("run", config, "-o", out, "--set", "e=0.9", "--resume")
    assert resumed.exit_code == 2
    assert "different config" in resumed.output and "e: 0.9" in resumed.output
    assert "--overwrite" in resumed.output
    assert out.read_bytes() == before  # untouched by either

    replaced = invoke("run", config, "-o", out, "--set", "e=0.9", "--overwrite", "-q")
    assert replaced.exit_code == 0
    with h5py.File(out, "r") as f:
        assert "e: 0.9\n" in f.attrs["config"]
        assert f["done"][()].all()


def test_an_interrupted_run_can_be_resumed_in_process(tmp_path, monkeypatch, assert_same_result, done_count, write_config):
    """The library path: a stop asked for during a chunk raises after that chunk is written."""
    from vrsweep.config import load_config
    from vrsweep.execution.job import GracefulStop, Interrupted, run_job

    config = load_config(write_config(tmp_path, """\
        sweep:
          g: {start: 0.0, stop: 30.0, num: 6}
        integration: {transient_periods: 3, measure_periods: 3, strobe_periods: 2}
        """))
    stop = GracefulStop()
    stop.signum = signal.SIGINT  # as if Ctrl-C came during the first chunk
    out = tmp_path / "out.h5"
    with pytest.raises(Interrupted) as caught:
        run_job(config, out, threads=1, stop=stop, executor=_small_chunks)
    assert caught.value.exit_code == 130
    assert done_count(out) == 2
    report = run_job(config, out, threads=1, resume=True)
    assert report.n_run == 4
    assert_same_result(out, _fresh(config, tmp_path / "fresh.h5"))


def _small_chunks(config, **kwargs):
    from vrsweep.execution.sweep import run_sweep

    return run_sweep(config, chunk_lines=2, **kwargs)


def _fresh(config, out):
    from vrsweep.execution.job import run_job

    run_job(config, out, threads=2)
    return out


def test_signals_outside_the_main_thread_are_left_alone():
    import threading

    from vrsweep.execution.job import GracefulStop

    before = signal.getsignal(signal.SIGINT)
    seen = []

    def worker():
        with GracefulStop() as stop:
            seen.append(signal.getsignal(signal.SIGINT))
            stop.check()

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert seen == [before] and signal.getsignal(signal.SIGINT) is before
