"""The process's environment made hostile: HOME, XDG_CONFIG_HOME, XDG_CACHE_HOME, MPLCONFIGDIR
naming a file or nothing. Each command works, falling back and saying so once, or says one line.

numba's cache folder has its own tests (test_numba_cache.py); these are the folders vrsweep does
not own but uses through matplotlib.
"""

import os
import subprocess
import sys

import pytest

import vrsweep

# The package under test, wherever it is (a worktree's, not only the one installed).
SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(vrsweep.__file__)))

SWEEP = """\
    model: effective
    sweep: {g: {start: 20, stop: 21, num: 2}}
    integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}
    """


def _vrsweep(*args, cwd, **env):
    """``python -m vrsweep ARGS`` in ``cwd`` with ``env`` over this process's environment (a
    value None removes the variable); the finished process."""
    environment = {**os.environ, "TMPDIR": str(cwd), "PYTHONPATH": SOURCE}  # fallback folders under tmp_path
    for name, value in env.items():
        if value is None:
            environment.pop(name, None)
        else:
            environment[name] = value
    return subprocess.run([sys.executable, "-m", "vrsweep", *map(str, args)], cwd=cwd, env=environment,
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, sweep_file):
    return sweep_file(tmp_path_factory.mktemp("environment"), SWEEP)[1]


@pytest.mark.parametrize("variable", ["HOME", "XDG_CONFIG_HOME", "XDG_CACHE_HOME", "MPLCONFIGDIR"])
def test_matplotlib_folder_that_is_a_file(variable, tmp_path, sweep):
    """HOME (or an XDG folder, or MPLCONFIGDIR) naming a file: matplotlib logged "mkdir -p failed
    for path ..." and "Matplotlib created a temporary cache directory ..." (several lines, in
    matplotlib's words) ahead of plot's and info's output, and rebuilt its font cache in a new
    temporary folder on every command. Now vrsweep's private fallback folder, which persists, and
    one note from plot; info, which draws nothing, says nothing."""
    afile = tmp_path / "a-file"
    afile.write_text("not a folder")
    env = {variable: str(afile)}
    if variable != "MPLCONFIGDIR":
        env["MPLCONFIGDIR"] = None
    if variable not in ("HOME", "MPLCONFIGDIR"):
        env["HOME"] = str(tmp_path)
    fallback = tmp_path / f"vrsweep-cache-{os.getuid()}" / "matplotlib"
    for _ in range(2):  # the second finds the fallback's font cache and says the same
        drawn = _vrsweep("plot", sweep, "-o", "figure.png", "--overwrite", cwd=tmp_path, **env)
        assert drawn.returncode == 0, drawn.stderr
        assert len(drawn.stderr.splitlines()) == 2, drawn.stderr
        note, written = drawn.stderr.splitlines()
        assert note.startswith("Note: matplotlib's folder ") and f"not writable" in note, note
        assert note.endswith(f"its settings and font cache are in {fallback} instead"), note
        assert written == "-> figure.png"
    assert (tmp_path / "figure.png").stat().st_size > 0
    assert any(fallback.iterdir())  # matplotlib's font cache, kept for the next command
    assert not list(tmp_path.glob("matplotlib-*"))  # no temporary folder of matplotlib's own
    described = _vrsweep("info", sweep, cwd=tmp_path, **env)
    assert described.returncode == 0 and described.stderr == "", described.stderr


def test_a_usable_matplotlib_folder_is_left_alone(tmp_path, sweep):
    home = tmp_path / "home"
    drawn = _vrsweep("plot", sweep, "-o", "figure.png", cwd=tmp_path, HOME=str(home), MPLCONFIGDIR=None,
                     XDG_CONFIG_HOME=None, XDG_CACHE_HOME=None)
    assert drawn.returncode == 0 and drawn.stderr == "-> figure.png\n", drawn.stderr
    assert (home / ".cache" / "matplotlib").is_dir()  # matplotlib's own choice
    assert not (tmp_path / f"vrsweep-cache-{os.getuid()}" / "matplotlib").exists()
