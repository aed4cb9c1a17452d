"""Issue 24, class 6: the edges of a process. Ctrl-C while the command line starts, a --dask
address that is no scheduler, a full disk under init, merge's output folder, and a file name that
is not UTF-8 under LC_ALL=C: each ends in one line (or succeeds), never a traceback, and leaves
no file behind that was not asked for.
"""

import errno
import os
import socket
import subprocess
import sys
import threading

import h5py
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

CONFIG = """\
model: effective
sweep:
  g: {start: 0, stop: 40, num: 3}
integration: {transient_periods: 1, measure_periods: 2, strobe_periods: 1}
"""


def _python(code, *args, env=None, timeout=300):
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                          env=dict(os.environ, **(env or {})), timeout=timeout)


@pytest.mark.parametrize("command", ["validate", "info", "theory", "plot", "init", "merge"])
def test_ctrl_c_while_the_command_line_imports(command, tmp_path):
    """SIGINT lands after vrsweep's first line runs and before the command is reached: exit 130,
    one line. (os.kill delivers it at once; a real Ctrl-C in the first 0.3 s lands here.)"""
    code = ("import os, signal, sys\n"
            "sys.argv = ['vrsweep', sys.argv[1], 'x.yaml']\n"
            "import vrsweep\n"
            "os.kill(os.getpid(), signal.SIGINT)\n"
            "import vrsweep.cli\n"
            "vrsweep.cli.main()\n")
    done = _python(code, command)
    assert done.returncode == 130, done.stderr
    assert done.stderr == "Interrupted (SIGINT)\n", done.stderr


def test_importing_vrsweep_as_a_library_leaves_sigint_alone():
    # Against the handler the child started with, not Python's default: a child inherits an ignored
    # SIGINT from its parent (a pytest worker after some tests), and that is not vrsweep's doing.
    done = _python("import signal; before = signal.getsignal(signal.SIGINT); import vrsweep; "
                   "print(signal.getsignal(signal.SIGINT) is before, before)")
    assert done.stdout.split()[0] == "True", (done.stdout, done.stderr)
    # Nor any other signal a command stops on (SIGHUP, SIGUSR1, SIGUSR2: a program's own to handle).
    done = _python("import signal; names = ('SIGTERM', 'SIGHUP', 'SIGUSR1', 'SIGUSR2'); "
                   "before = [signal.getsignal(getattr(signal, n)) for n in names]; import vrsweep; "
                   "print([signal.getsignal(getattr(signal, n)) for n in names] == before)")
    assert done.stdout.split()[0] == "True", (done.stdout, done.stderr)


@pytest.fixture
def not_a_scheduler():
    """A TCP port that answers with bytes a Dask client reads as an absurd frame length."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    stop = threading.Event()

    def serve():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                connection, _ = server.accept()
            except OSError:
                continue
            with connection:
                try:
                    connection.sendall(b"\xff" * 64 + b"HTTP/1.1 400 Bad Request\r\n\r\n")
                except OSError:
                    pass

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join()
    server.close()


def test_dask_at_a_port_that_is_no_scheduler(tmp_path, invoke, write_config, not_a_scheduler):
    pytest.importorskip("distributed")
    config = write_config(tmp_path, CONFIG)
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--dask", not_a_scheduler)
    assert result.exit_code != 0
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "cannot connect to a Dask scheduler" in lines[0], result.output
    assert not (tmp_path / "out.h5").exists()


@pytest.mark.parametrize("existing", [False, True])
def test_init_on_a_full_disk_leaves_the_old_config_or_none(tmp_path, invoke, monkeypatch, existing):
    from vrsweep.store import fileio

    target = tmp_path / "start.yaml"
    if existing:
        target.write_text("model: effective\n")

    def full(path):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(fileio, "fsync_path", full)
    result = invoke("init", target, *(["--overwrite"] if existing else []))
    assert result.exit_code != 0 and "No space left" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    if existing:
        assert target.read_text() == "model: effective\n"
    else:
        assert not target.exists()
    assert [p.name for p in tmp_path.iterdir()] == ([target.name] if existing else [])


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(depth=st.integers(1, 4), problem=st.sampled_from(["missing", "not_hdf5", "empty"]))
def test_merge_checks_its_inputs_before_making_a_folder(tmp_path, invoke, depth, problem):
    shard = tmp_path / f"{problem}.h5"
    if problem == "not_hdf5":
        shard.write_text("not a result")
    elif problem == "empty":
        shard.write_bytes(b"")
    folder = tmp_path.joinpath(*[f"new{level}" for level in range(depth)])
    result = invoke("merge", shard, "-o", folder / "merged.h5")
    assert result.exit_code == 2, result.output
    assert not (tmp_path / "new0").exists()


@pytest.mark.parametrize("name,env", [
    (b"caf\xe9.h5", {"LC_ALL": "C"}),                                     # not UTF-8 at all
    ("r\u00e9sum\u00e9.h5".encode(), {"LC_ALL": "C", "PYTHONCOERCECLOCALE": "0", "PYTHONUTF8": "0"}),
])
def test_a_file_name_that_is_not_text_in_the_locale(tmp_path, invoke, write_config, name, env):
    """history records the command line: merge writes it as run does, without compiling a kernel."""
    config = write_config(tmp_path, CONFIG)
    assert invoke("run", config, "-o", tmp_path / "whole.h5", "-q").exit_code == 0
    out = os.path.join(os.fsencode(tmp_path), name)
    done = subprocess.run([sys.executable, "-m", "vrsweep", "merge", os.fsencode(tmp_path / "whole.h5"), "-o", out,
                           "-q"], capture_output=True, env={**os.environ, **env}, timeout=600)
    assert done.returncode == 0, done.stderr.decode(errors="replace")
    assert b"Traceback" not in done.stderr
    with h5py.File(out, "r") as f:
        history = f.attrs["history"]
    expected = "caf\\xe9.h5" if name == b"caf\xe9.h5" else "r\u00e9sum\u00e9.h5"
    assert expected in history, history
