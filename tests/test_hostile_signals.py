"""Issue 33, class 2: a signal during `vrsweep continue` keeps the branch followed so far.

SIGINT or SIGTERM stops the continuation at its next orbit (a second signal stops at once); what
it has followed is written, marked incomplete (vrsweep_complete 0, the ends not reached
"interrupted"), and info, plot and open_results read it. The exit code is the signal's (130, 143).
"""

import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

import vrsweep
from vrsweep.errors import ResultFileError

EFFECTIVE = """\
    model: effective
    parameters: {gamma: 0.05, alpha: 0.05}
    continuation: {parameter: g, from: 23.0, to: [21.0, 27.0]}
    """
# The same, followed in steps a hundred times smaller: a minute or more, long enough to be stopped.
LONG = """\
    model: effective
    parameters: {gamma: 0.05, alpha: 0.05}
    continuation: {parameter: g, from: 23.0, to: [0.0, 60.0], initial_step: 0.0005, max_step: 0.0005,
                   max_points: 200000}
    """


def _stop_after(monkeypatch, orbits, signum):
    """Make the continuation's GracefulStop see ``signum`` after ``orbits`` orbits, as if it had
    arrived then (the handler sets the flag; check() raises at the next orbit)."""
    from vrsweep.execution import signals

    calls = [0]
    real_check = signals.GracefulStop.check

    def check(self):
        calls[0] += 1
        if calls[0] == orbits:
            self.signum = signum
        return real_check(self)

    monkeypatch.setattr(signals.GracefulStop, "check", check)
    return calls


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_keeps_the_branch_followed_so_far(tmp_path, invoke, write_config, monkeypatch, signum):
    config = write_config(tmp_path, EFFECTIVE)
    out = tmp_path / "branch.h5"
    calls = _stop_after(monkeypatch, 3, signum)
    result = invoke("continue", config, "-o", out, "-q")  # -q: no compile notice; the interruption is said anyway
    name = signal.Signals(signum).name
    assert result.exit_code == 128 + signum, result.output
    lines = result.output.strip().splitlines()
    assert lines == [f"Interrupted ({name}): the 4 orbits followed so far are in {out}, marked incomplete (info and "
                     "plot read it); run vrsweep continue again for the whole branch"], result.output
    assert calls[0] == 3  # stopped at the orbit after the signal: the other way was not followed
    with h5py.File(out, "r") as f:
        assert int(f.attrs["vrsweep_complete"]) == 0
    with vrsweep.open_results(out) as ds:
        assert ds.sizes["point"] == 4  # the start and the 3 orbits below it
        assert np.all(np.diff(ds["parameter"].values) > 0)
        assert [str(ds[f"branch_end_{side}_status"].values[0]) for side in ("first", "last")] == \
               ["interrupted", "interrupted"]
        assert f"stopped by {name} at g = " in str(ds["branch_end_first_reason"].values[0])
    info = invoke("info", out)
    assert info.exit_code == 0 and "NOT complete (stopped by a signal" in info.output, info.output
    assert "interrupted: stopped by" in info.output
    figure = invoke("plot", out, "-o", tmp_path / "branch.png")
    assert figure.exit_code == 0 and "stopped by a signal: plotting what it had followed" in figure.output
    assert (tmp_path / "branch.png").exists()


HYSTERESIS = """\
    model: effective
    parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
    initial: {x: 0.0, v: 0.0}
    integration: {rtol: 1.0e-10, atol: 1.0e-12, transient_periods: 200}
    continuation: {parameter: g, from: 24.0, to: [23.5, 25.4], max_step: 0.3}
    """


@pytest.fixture(scope="module")
def hysteresis_branch(tmp_path_factory, write_config, invoke):
    folder = tmp_path_factory.mktemp("hysteresis")
    branch = folder / "branch.h5"
    assert invoke("continue", write_config(folder, HYSTERESIS), "-o", branch, "-q").exit_code == 0
    return branch


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_keeps_the_curve_followed_so_far(tmp_path, invoke, hysteresis_branch, monkeypatch, signum):
    """The fold of tests/test_cli_continue's hysteresis branch followed in Omega, stopped after 2
    points (the SIGTERM of the issue kept nothing, and once exited 0)."""
    branch = hysteresis_branch
    with vrsweep.open_results(branch) as ds:
        kinds = [str(kind) for kind in ds["bifurcation_kind"].values]
    fold, graze = kinds.index("fold"), kinds.index("grazing")
    out = tmp_path / "curve.h5"
    _stop_after(monkeypatch, 2, signum)
    result = invoke("continue", branch, "--point", fold, "--point", graze, "--along", "Omega", "--to", "3.9", "4.1",
                    "--within", "20", "30", "-o", out, "-q")
    name = signal.Signals(signum).name
    assert result.exit_code == 128 + signum, result.output
    assert result.output.strip() == (f"Interrupted ({name}): the 3 points followed so far are in {out}, marked "
                                     "incomplete (info and plot read it); run vrsweep continue again for the whole "
                                     "curves"), result.output
    with vrsweep.open_results(out) as ds:
        assert ds.sizes["point"] == 3 and ds.sizes["curve_id"] == 1  # the second --point is not followed
        assert ds.attrs["vrsweep_complete"] == 0
        assert [str(ds[f"curve_end_{side}_status"].values[0]) for side in ("first", "last")] == \
               ["interrupted", "interrupted"]
    info = invoke("info", out)
    assert info.exit_code == 0 and "NOT complete (stopped by a signal" in info.output, info.output


def test_without_a_signal_the_branch_is_complete(tmp_path, invoke, write_config):
    config = write_config(tmp_path, EFFECTIVE)
    out = tmp_path / "branch.h5"
    result = invoke("continue", config, "-o", out, "-q")
    assert result.exit_code == 0, result.output
    with h5py.File(out, "r") as f:
        assert int(f.attrs["vrsweep_complete"]) == 1
        assert b"interrupted" not in b"".join(np.asarray(f["branch_end_last_status"][()], dtype=bytes))


def test_a_signal_after_the_last_orbit_leaves_a_complete_file(tmp_path, invoke, write_config, monkeypatch):
    """The flag set once every orbit is followed: the file is complete, and says so; the exit code
    is still the signal's."""
    from vrsweep.execution import signals

    config = write_config(tmp_path, EFFECTIVE)
    out = tmp_path / "branch.h5"
    real_exit = signals.GracefulStop.__exit__

    def exit_after_a_late_signal(self, *exc):
        if exc[0] is None and self.signum is None:
            self.signum = signal.SIGTERM
        return real_exit(self, *exc)

    monkeypatch.setattr(signals.GracefulStop, "__exit__", exit_after_a_late_signal)
    result = invoke("continue", config, "-o", out, "-q")
    assert result.exit_code == 143, result.output
    assert result.output.strip() == f"Interrupted (SIGTERM) as the continuation finished: {out} is complete"
    with h5py.File(out, "r") as f:
        assert int(f.attrs["vrsweep_complete"]) == 1


def _numba_loaded(pid):
    """Whether process ``pid`` has numba's compiler in memory: the continuation's problem is being
    built, a moment before its GracefulStop is installed. (Its SIGTERM handler tells nothing: the
    command line handles SIGTERM from the start, to say "Interrupted (SIGTERM)".)"""
    try:
        with open(f"/proc/{pid}/maps") as handle:
            return "llvmlite" in handle.read()
    except OSError:
        return False


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads /proc to know when to signal")
# SIGHUP (a closed terminal) and SIGUSR1 (sbatch --signal=USR1@60) killed it at once (exit -1,
# -10), the orbits followed lost; SIGUSR2 takes the same way.
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGUSR1])
def test_a_real_signal_to_a_long_continuation(tmp_path, write_config, signum):
    config = write_config(tmp_path, LONG)
    out = tmp_path / "long.h5"
    process = subprocess.Popen([sys.executable, "-m", "vrsweep", "continue", str(config), "-o", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not _numba_loaded(process.pid) and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.05)
        time.sleep(4.0)  # GracefulStop installed, some orbits followed (or the kernels still compiling: then one)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 128 + signum, stderr
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1].startswith(f"Interrupted ({signal.Signals(signum).name}): "), stderr
    assert "marked incomplete" in stderr.strip().splitlines()[-1], stderr
    with vrsweep.open_results(out) as ds:
        assert ds.sizes["point"] >= 2 and ds.attrs["vrsweep_complete"] == 0


def _handmade_branch(path, ends, complete):
    from handmade import CONFIG, orbit

    from vrsweep.analysis.continuation import Branch
    from vrsweep.config.validate import config_from_dict
    from vrsweep.store import branch_file

    orbits = [orbit(g, True) for g in np.linspace(22.0, 23.0, 5)]
    branch = Branch(periods=1, orbits=orbits, ends=ends)
    branch_file.write_branch(path, branch_file.branch_arrays([branch], [], 1.0), config_from_dict(CONFIG), "rk45",
                             complete=complete)
    return path


def test_an_interrupted_branch_file_must_say_so_both_ways(tmp_path):
    from vrsweep.store.branch_file import check_branch

    stopped = {"down": ("interrupted", "stopped by SIGINT at g = 22"), "up": ("interrupted", "not followed")}
    whole = {"down": ("left_range", "g left"), "up": ("max_points", "enough")}
    check_branch(_handmade_branch(tmp_path / "stopped.h5", stopped, complete=False))
    check_branch(_handmade_branch(tmp_path / "whole.h5", whole, complete=True))
    with pytest.raises(ResultFileError, match="is incomplete: the run that wrote it did not finish"):
        check_branch(_handmade_branch(tmp_path / "a.h5", whole, complete=False))
    with pytest.raises(ResultFileError, match="it ends interrupted in a file marked complete"):
        check_branch(_handmade_branch(tmp_path / "b.h5", stopped, complete=True))


def test_a_stop_leaves_an_ignored_or_claimed_signal_as_it_was():
    """`nohup vrsweep run ...` ignores SIGHUP on purpose, and a program that runs vrsweep's API may
    handle SIGUSR1 itself: a run's stop takes neither; a signal left to its default it takes, and
    gives back."""
    from vrsweep.execution.signals import GracefulStop

    def mine(signum, frame):
        pass

    before = {signum: signal.getsignal(signum) for signum in (signal.SIGHUP, signal.SIGUSR1, signal.SIGUSR2)}
    try:
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        signal.signal(signal.SIGUSR1, mine)
        signal.signal(signal.SIGUSR2, signal.SIG_DFL)
        with GracefulStop(announce=False) as stop:
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            assert signal.getsignal(signal.SIGUSR1) is mine
            assert signal.getsignal(signal.SIGUSR2) == stop._handle
            os.kill(os.getpid(), signal.SIGUSR2)
            with pytest.raises(KeyboardInterrupt, match="SIGUSR2"):
                stop.check()
        assert signal.getsignal(signal.SIGUSR2) is signal.SIG_DFL
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)
