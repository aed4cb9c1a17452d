"""Ctrl-C in any command: one line and exit 130, never click's "Aborted!" and exit 1 (issue 10).

``run`` has its own handling (stop after the chunk in progress, print the resume command; see
test_resume.py); every other command goes through the group's.
"""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from vrsweep.cli import main

FIG3 = Path(__file__).resolve().parent.parent / "configs" / "fig3.yaml"


def _interrupted(*args, **kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize("name", sorted(set(main.commands) - {"run"}))
def test_ctrl_c_in_a_command_exits_130_with_one_line(name, monkeypatch, tmp_path):
    monkeypatch.setattr(main.commands[name], "callback", _interrupted)
    monkeypatch.chdir(tmp_path)
    # Arguments that pass click's own checks, so that the command's body is reached.
    args = {"merge": ["a.h5", "-o", "out.h5"], "init": []}.get(name, ["x.yaml"])
    result = CliRunner().invoke(main, [name, *args])
    assert result.exit_code == 130, result.output
    assert result.stderr == "Interrupted (SIGINT)\n", result.stderr
    assert result.stdout == ""


def test_ctrl_c_inside_run_before_its_sweep_starts(monkeypatch, tmp_path):
    """Loading the config comes before run's own handler: the group's applies."""
    import vrsweep.config

    monkeypatch.setattr(vrsweep.config, "load_config", _interrupted)
    result = CliRunner().invoke(main, ["run", str(FIG3), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 130 and result.stderr == "Interrupted (SIGINT)\n", result.output


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc to see numba loaded")
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_real_signal_to_simulate(signum, tmp_path):
    """SIGINT or SIGTERM once the command is running (numba, which only a command loads, is in
    memory). SIGTERM ended it with exit 143 and nothing said."""
    out = tmp_path / "traj.h5"
    process = subprocess.Popen(
        [sys.executable, "-m", "vrsweep", "simulate", str(FIG3), "--set", "transient_periods=4000",
         "--samples-per-period", "1", "-o", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while "llvmlite" not in Path(f"/proc/{process.pid}/maps").read_text():
            assert process.poll() is None and time.monotonic() < deadline, "simulate never started"
            time.sleep(0.02)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 128 + signum, stderr
    assert stderr == f"Interrupted ({signal.Signals(signum).name})\n"
    assert not out.exists() and list(tmp_path.iterdir()) == []  # no output, no temporary file


def test_a_sigint_inside_code_that_exec_runs_still_exits_130(tmp_path):
    """The race behind a rare exit by SIGINT (-2) after "Interrupted (SIGINT)": a signal that lands
    while exec() runs a string (a dataclass or namedtuple being made, as numba's import does
    often) raised a bare KeyboardInterrupt there, which CPython notes as unhandled though the
    command line catches it, and `python -m` then kills itself with SIGINT at exit. Here the
    signal lands inside exec'd code every time, under the command line's own SIGINT handling."""
    process = _under_the_command_lines_sigint(tmp_path, "sigint_in_exec", (
        "try:\n"
        "    exec('import os, signal\\nos.kill(os.getpid(), signal.SIGINT)\\nwhile True: pass')\n"
        "except KeyboardInterrupt:\n"
        "    sys.exit(130)\n"))
    assert process.returncode == 130, process.stderr


def _under_the_command_lines_sigint(folder, name, code):
    """Run ``code`` as `python -m NAME` with SIGINT handled as cli.py handles it once a command
    runs (os, signal and sys imported); the finished subprocess."""
    package = folder / name
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "__main__.py").write_text(
        "import os, signal, sys\n"
        "from vrsweep.execution import signals\n"
        "signals.exit_at_once_on_sigint()\n"
        "signals.raise_on_sigint()  # as cli.py does once a command runs\n" + code)
    return subprocess.run([sys.executable, "-m", name], cwd=folder, capture_output=True, text=True, timeout=60)


def test_a_sigint_while_numba_compiles_exits_130_with_one_line(tmp_path):
    """The other rare race: SIGINT while llvmlite calls back into Python as numba compiles (or
    caches) a kernel. An exception cannot leave a ctypes callback (Python prints "Exception ignored
    ..." and goes on, the Ctrl-C lost, exit 0). Here the signal lands inside a ctypes callback
    while numba's compiler lock is held, every time."""
    process = _under_the_command_lines_sigint(tmp_path, "sigint_in_compile", (
        "import ctypes\n"
        "from numba.core.compiler_lock import global_compiler_lock\n"
        "@ctypes.CFUNCTYPE(None)\n"
        "def callback():\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "    for _ in range(10 ** 6): pass\n"
        "try:\n"
        "    with global_compiler_lock:\n"
        "        callback()\n"
        "except KeyboardInterrupt:\n"
        "    sys.exit(130)\n"
        "sys.exit(0)\n"))
    assert process.returncode == 130, process.stderr
    assert process.stderr == "Interrupted (SIGINT)\n"


def test_a_reader_that_stops_reading_is_no_error(tmp_path):
    """`vrsweep validate CONFIG | head -0`: exit 141 (SIGPIPE's code), no "Error: Broken pipe"."""
    process = subprocess.Popen([sys.executable, "-m", "vrsweep", "validate", str(FIG3)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    process.stdout.close()  # before the command has written anything
    stderr = process.stderr.read()
    assert process.wait(timeout=60) == 141, stderr
    assert stderr == ""


def test_a_sigterm_that_an_import_swallowed_still_stops_run(tmp_path):
    """The command line's SIGTERM raises Interrupted wherever Python is; C code that clears any
    error swallowed it (numpy.random's Cython module, imported with numba 0.3 s into `vrsweep run`,
    registering its classes with abc): the run went on to its end, exit 0, a scancel lost. The
    stop a run sets up asks for it, and the run stops before anything is written: exit 143, the
    line of an interrupted run."""
    import os

    from vrsweep.execution import signals

    signals.raise_on_sigint()  # as the command line does, SIGTERM's handler then raises
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal.signal(signal.SIGTERM, signals._raise_interrupted)
        try:  # C code that clears the error it meets
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
        except BaseException:  # noqa: BLE001
            pass
        result = CliRunner().invoke(main, ["run", str(FIG3), "-o", str(tmp_path / "out.h5")])
    finally:
        signal.signal(signal.SIGTERM, previous)
        getattr(signals, "_raised", []).clear()
    assert result.exit_code == 143, result.output
    assert result.stderr.startswith("\nInterrupted (SIGTERM): finished chunks are saved. Resume with:\n")
    assert not (tmp_path / "out.h5").exists()


def test_a_sigterm_while_the_command_line_starts_says_so(tmp_path):
    """SIGTERM before a command runs (its imports) ended the process killed by the signal, nothing
    said; Ctrl-C there was one line and 130. SIGTERM is now one line too, and 143."""
    code = ("import sys\nsys.argv[0] = 'vrsweep'\nimport vrsweep, os, signal, time\n"
            "os.kill(os.getpid(), signal.SIGTERM)\ntime.sleep(30)\n")
    process = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert process.returncode == 143 and process.stderr == "Interrupted (SIGTERM)\n", process


def _swallow_a_sigterm():
    """A real SIGTERM under the command line's handler, whose Interrupted C code swallows (as
    numpy.random's Cython module did while numba was imported)."""
    import os

    from vrsweep.execution import signals

    assert signal.getsignal(signal.SIGTERM) is signals._raise_interrupted  # the command line's, set by invoke
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
    except BaseException:  # noqa: BLE001
        pass


@pytest.mark.parametrize("name", ["simulate", "plot", "info", "theory", "validate", "init"])
def test_a_sigterm_an_import_swallowed_inside_any_command_still_says_so(name, monkeypatch, tmp_path):
    """0.7.5 remembered a swallowed SIGTERM for run alone (its stop asks when it starts); every
    other command swallowed it and ended with exit 0 (simulate wrote its file, plot its figure),
    a scancel lost. The command line asks after the command: exit 143, the one line of an
    interrupted command, and what was written is complete."""
    from vrsweep.execution import signals

    real = main.commands[name].callback

    def swallowing(*args, **kwargs):
        _swallow_a_sigterm()  # an import at the command's start
        return real(*args, **kwargs)

    monkeypatch.setattr(main.commands[name], "callback", swallowing)
    monkeypatch.chdir(tmp_path)
    short = ["--set", "transient_periods=2", "--set", "measure_periods=2", "--set", "strobe_periods=2"]
    sweep = tmp_path / "sweep.h5"
    if name in ("plot", "info"):
        monkeypatch.setattr(main.commands[name], "callback", real)  # made as usual
        config = tmp_path / "sweep.yaml"
        config.write_text("model: effective\nsweep: {g: {start: 20, stop: 21, num: 2}}\n")
        made = CliRunner().invoke(main, ["run", str(config), *short, "-o", str(sweep), "-q"])
        assert made.exit_code == 0, made.output
        monkeypatch.setattr(main.commands[name], "callback", swallowing)
    args = {"simulate": ["simulate", str(FIG3), *short, "-o", "traj.h5"],
            "plot": ["plot", str(sweep), "-o", "figure.png"],
            "info": ["info", str(sweep)],
            "theory": ["theory", str(FIG3)],
            "validate": ["validate", str(FIG3)],
            "init": ["init", "new.yaml"]}[name]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 143, result.output
    assert result.stderr.endswith("Interrupted (SIGTERM)\n"), result.stderr
    assert "Traceback" not in result.output
    assert not signals._raised  # taken: the next command in this process runs as usual
    written = {"simulate": "traj.h5", "plot": "figure.png", "init": "new.yaml"}.get(name)
    if written:  # complete: renamed into place whole, nothing temporary beside it
        assert (tmp_path / written).stat().st_size > 0
        assert not [p.name for p in tmp_path.iterdir() if p.name not in (written, "sweep.h5", "sweep.yaml")]
