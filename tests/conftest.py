"""Shared fixtures: running the CLI in this process or as a real process, tiny configs, and
comparing result files bit for bit. Each is a session fixture that hands out a plain function
(``def test_x(invoke): invoke("run", ...)``), so module-scoped fixtures can use them too."""

import os
import signal
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import settings

from vrsweep.cli import main

# The property tests draw the same examples on every run ("derandomize": each test's seed is its
# own name), so a run of the suite, CI's included, passes or fails on the code alone, never on a
# lucky draw. Searching for new failures is a deliberate run with fresh random draws:
# VRSWEEP_HYPOTHESIS=explore python -m pytest tests/test_hostile_*.py (the README says so too).
settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("VRSWEEP_HYPOTHESIS", "repeatable"))


@pytest.fixture(autouse=True)
def _signal_handlers_as_found():
    """Each test leaves this process's SIGINT and SIGTERM handling (and that of every signal that
    stops a run) as it found it. A test in the
    same worker that changed it (dask_jobqueue's runner installs its own SIGINT handler when it is
    imported; a SIG_IGN is inherited by every child process) made a later test's children start
    with SIGINT ignored: test_process_edges' 'importing vrsweep leaves SIGINT alone' failed so."""
    from vrsweep.execution.signals import STOP_SIGNALS

    found = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    yield
    for signum, handler in found.items():
        if signal.getsignal(signum) is not handler and handler is not None:
            signal.signal(signum, handler)


def _open_hdf5_files():
    return {file_id.name for file_id in h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_FILE)}


@pytest.fixture(autouse=True)
def _no_hdf5_file_left_open():
    """A test that leaves an HDF5 file open fails itself. xarray keeps a file opened through
    open_results in its own cache until the Dataset is closed or collected, so a test that forgot
    made the checks of later tests in the same worker fail (test_errors' "no HDF5 file left open"
    saw another test's results/continuation_hysteresis.h5), and only in the orders xdist happened
    to choose: CI failed on it where the same commit had passed here."""
    found = _open_hdf5_files()
    yield
    left = _open_hdf5_files() - found
    if left:  # no gc.collect() first: a Dataset in a reference cycle keeps its file open until
        # the collector happens to run, which is how the leak reached other tests
        import xarray.backends.file_manager

        for manager in list(xarray.backends.file_manager.FILE_CACHE.values()):
            manager.close()
        for file_id in h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_FILE):
            if file_id.name in left:
                file_id.close()
        pytest.fail(f"the test left HDF5 files open (close what it opened): {sorted(left)}",
                    pytrace=False)


def _write_config(tmp_path, text, name="sweep.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def _invoke(*args, env=None):
    """Run the CLI in this process; returns click's Result (output = stdout + stderr)."""
    result = CliRunner().invoke(main, [str(a) for a in args], env=env)
    assert "Traceback" not in result.output, result.output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def _sweep_file(folder, text, name="sweep"):
    """``vrsweep run -q`` on the config ``text`` (dedented), written as NAME.yaml in ``folder``:
    (the config's path, the result file's path NAME.h5)."""
    config = _write_config(folder, text, f"{name}.yaml")
    path = folder / f"{name}.h5"
    result = _invoke("run", config, "-o", path, "-q")
    assert result.exit_code == 0, result.output
    return config, path


def _vrsweep_process(*args, **kwargs):
    """``vrsweep ARGS`` as a real subprocess (for kill -9 and signals), stderr piped."""
    command = [sys.executable, "-m", "vrsweep", *[str(a) for a in args]]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ), **kwargs)


def _done_count(path):
    """Points marked done in a file another process may be writing (None if not readable yet)."""
    try:
        with h5py.File(path, "r", locking=False) as f:
            return int(f["done"][()].sum())
    except (OSError, KeyError):  # not created yet, or caught mid-write: ask again
        return None


def _describe(path):
    """Everything in a result file but its creation time and command: every dataset (bytes, type, shape,
    chunks, fill, dimension scales) and every attribute, in order."""

    def clean(attrs):
        out = []
        for key, value in attrs.items():
            # when and by which command a file was written; references: file addresses
            if key in ("created", "date_created", "history", "REFERENCE_LIST", "DIMENSION_LIST"):
                continue
            out.append((key, value.tobytes() if isinstance(value, np.ndarray) else repr(value)))
        return out

    with h5py.File(path, "r") as f:
        result = {"/": clean(f.attrs)}
        for name, ds in f.items():
            result[name] = dict(
                dtype=ds.dtype.str, shape=ds.shape, chunks=ds.chunks, fill=repr(ds.fillvalue),
                attrs=clean(ds.attrs), data=ds[()].tobytes(),
                dims=[[s.name for s in d.values()] for d in ds.dims])
        return result


def _assert_same_result(a, b):
    """Files a and b are identical bit for bit, apart from when and by which command they were
    written (``created``, ``date_created``, ``history``)."""
    da, db = _describe(a), _describe(b)
    assert list(da) == list(db), "different datasets"
    for key in da:
        if da[key] != db[key]:
            differing = [k for k in da[key] if da[key][k] != db[key][k]] if key != "/" else "attributes"
            raise AssertionError(f"{a} and {b} differ in {key!r}: {differing}")


@pytest.fixture(scope="session")
def write_config():
    """write_config(tmp_path, text, name="sweep.yaml") -> the path of a config with ``text`` (dedented)."""
    return _write_config


@pytest.fixture(scope="session")
def invoke():
    """invoke(*args, env=None) -> click's Result of ``vrsweep ARGS`` run in this process."""
    return _invoke


@pytest.fixture(scope="session")
def sweep_file():
    """sweep_file(folder, text, name="sweep") -> (config, result) paths of ``vrsweep run`` on ``text``."""
    return _sweep_file


@pytest.fixture(scope="session")
def vrsweep_process():
    """vrsweep_process(*args) -> a Popen of ``python -m vrsweep ARGS`` (for kill -9 and signals)."""
    return _vrsweep_process


@pytest.fixture(scope="session")
def done_count():
    """done_count(path) -> points marked done in a file another process may be writing, or None."""
    return _done_count


@pytest.fixture(scope="session")
def describe():
    """describe(path) -> everything in a result file but when and by which command it was written."""
    return _describe


@pytest.fixture(scope="session")
def assert_same_result():
    """assert_same_result(a, b): the two files are identical bit for bit but for when and how
    they were written."""
    return _assert_same_result
