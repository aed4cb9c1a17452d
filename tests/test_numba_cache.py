"""Where compiled kernels go: never into the installed package (a read-only install must work,
and a cache left in site-packages once broke the next install)."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vrsweep
from vrsweep.numerics.numba_cache import folder_name

PACKAGE = Path(vrsweep.__file__).resolve().parent


def _run(code, env_changes, cwd):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(env_changes)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=300)


def test_default_is_a_per_user_folder_per_version_and_sources(tmp_path):
    code = ("import vrsweep, os, numba.core.config as c; "
            "print(os.environ['NUMBA_CACHE_DIR']); print(c.CACHE_DIR); print(vrsweep.numerics.numba_cache.cache_dir())")
    done = _run(code, {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.returncode == 0, done.stderr
    expected = str(tmp_path / "xdg" / "vrsweep" / folder_name())
    assert folder_name().startswith(f"vrsweep-{vrsweep.__version__}-")
    assert done.stdout.split() == [expected] * 3


def test_numba_cache_dir_is_the_root_and_a_subprocess_keeps_the_folder(tmp_path):
    code = ("import os, subprocess, sys, vrsweep, numba.core.config as c; print(c.CACHE_DIR); "
            "print(subprocess.run([sys.executable, '-c', 'import vrsweep, numba.core.config as c; "
            "print(c.CACHE_DIR)'], capture_output=True, text=True, env=os.environ).stdout.strip())")
    done = _run(code, {"NUMBA_CACHE_DIR": str(tmp_path / "mine")}, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(tmp_path / "mine" / folder_name())] * 2


def test_numba_imported_first_still_gets_the_folder(tmp_path):
    code = "import numba, vrsweep, numba.core.config as c; print(c.CACHE_DIR)"
    done = _run(code, {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(tmp_path / "xdg" / "vrsweep" / folder_name())


# The package's smallest kernel that calls a kernel of another module (records.emit_samples calls
# rk45.dense_value): numba picks a process's cache folder once (numba.core.config.CACHE_DIR), for
# every kernel alike, so it shows where any kernel goes, in under a second where a sweep's kernel
# takes 30 s to compile cold. Printed: the samples written, and x, v at theta = 1/2 of a step from
# y = (1, 2) with every dense coefficient 1: y + h theta (1 + theta + theta^2 + theta^3).
TINY_KERNEL = ("import numpy as np\n"
               "from vrsweep.numerics.records import emit_samples\n"
               "samples = np.zeros((1, 2))\n"
               "done = emit_samples(np.array([0.5]), samples, 0, 0.0, 1.0, np.array([1.0, 2.0]), np.ones((2, 4)), 1.0)\n"
               "print(done, *samples[0])\n")
TINY_KERNEL_SAYS = f"1 {1.0 + 0.5 * 1.875} {2.0 + 0.5 * 1.875}"


def test_a_compiled_kernel_lands_in_the_user_folder_not_in_the_package(tmp_path):
    before = {p for p in PACKAGE.rglob("*.nbi")}
    done = _run("import vrsweep.numerics.numba_cache as n; print(n.is_empty())",
                {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.stdout.strip() == "True", done.stderr
    done = _run(TINY_KERNEL, {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == TINY_KERNEL_SAYS
    folder = tmp_path / "xdg" / "vrsweep" / folder_name()
    assert {p.name.split(".")[0] for p in folder.rglob("*.nbi")} == {"records", "rk45"}, \
        "the kernel (and the one it calls) were not cached in the per-user folder"
    assert {p for p in PACKAGE.rglob("*.nbi")} == before, "a kernel was cached inside the package"
    done = _run("import vrsweep.numerics.numba_cache as n; print(n.is_empty())",
                {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.stdout.strip() == "False"


def test_an_edit_of_any_module_gives_a_new_folder(tmp_path):
    """numba checks a cached loop against its own file only: sweep.py's loops carry kernel.py's
    code, so an edit of kernel.py alone must not load them from the old folder."""
    import shutil

    copy = tmp_path / "site" / "vrsweep"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "examples"))
    code = (f"import sys; sys.path.insert(0, {str(copy.parent)!r}); import vrsweep.numerics.numba_cache as n; "
            "print(n.__file__); print(n.folder_name())")
    before = _run(code, {}, tmp_path)
    assert before.returncode == 0, before.stderr
    assert before.stdout.split() == [str(copy / "numerics" / "numba_cache.py"), folder_name()]
    with open(copy / "numerics" / "kernel.py", "a") as kernel:
        kernel.write("\n# an edit\n")
    after = _run(code, {}, tmp_path)
    assert after.stdout.split()[1] != folder_name()


# Class 1 of the hostile-environment faults: numba, refused the folder vrsweep names, falls back to
# __pycache__ beside the sources, keyed by each file's own timestamp, and a later edit of the kernel
# left a parallel loop compiled from the old one in use. vrsweep tests the folder first.

def _blocked(tmp_path):
    """A path no one, root included, can create a folder under: its parent is a regular file."""
    blocker = tmp_path / "a-file-not-a-folder"
    blocker.write_text("")
    return blocker


def test_an_unwritable_cache_folder_gives_vrsweeps_own_fallback_and_a_notice(tmp_path):
    (tmp_path / "tmp").mkdir()
    code = ("import vrsweep.numerics.numba_cache as n, os; print(n.cache_dir()); print(n.enabled()); "
            "print(os.environ['NUMBA_CACHE_DIR']); print(n.notice())")
    done = _run(code, {"XDG_CACHE_HOME": str(_blocked(tmp_path)), "TMPDIR": str(tmp_path / "tmp")}, tmp_path)
    assert done.returncode == 0, done.stderr
    folder, enabled, variable, notice = done.stdout.splitlines()
    expected = tmp_path / "tmp" / f"vrsweep-cache-{os.getuid()}" / folder_name()
    assert folder == variable == str(expected)
    assert enabled == "True"
    assert str(_blocked(tmp_path)) in notice and str(expected) in notice and "not writable" in notice
    assert (expected.parent.stat().st_mode & 0o777) == 0o700
    # A command says it once, before its work (NUMBA_DISABLE_JIT: the point in Python, nothing compiled).
    config = tmp_path / "one.yaml"
    config.write_text("model: effective\nparameters: {g: 5}\n"
                      "integration: {transient_periods: 0, measure_periods: 1, strobe_periods: 1}\n")
    env = {**{k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}, "NUMBA_DISABLE_JIT": "1",
           "XDG_CACHE_HOME": str(_blocked(tmp_path)), "TMPDIR": str(tmp_path / "tmp")}
    done = subprocess.run([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(tmp_path / "one.h5")],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert [line for line in done.stderr.splitlines() if "numba cache" in line] == [f"Note: {notice}"], done.stderr


def test_a_fallback_folder_another_user_could_write_is_refused(tmp_path, monkeypatch):
    from vrsweep.numerics import numba_cache

    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setattr(numba_cache, "_choice", None)
    monkeypatch.setattr(numba_cache, "preferred_dir", lambda: _blocked(tmp_path) / "x")
    monkeypatch.setattr(numba_cache, "fallback_dir", lambda: shared / numba_cache.folder_name())
    assert not numba_cache.enabled()
    assert "writable by other users" in str(numba_cache._choose().unusable)


def test_no_writable_folder_compiles_without_caching_and_says_so(tmp_path, monkeypatch):
    from vrsweep.numerics import jit
    from vrsweep.numerics import numba_cache

    monkeypatch.setattr(numba_cache, "_choice", None)
    monkeypatch.setattr(numba_cache, "preferred_dir", lambda: _blocked(tmp_path) / "a")
    monkeypatch.setattr(numba_cache, "fallback_dir", lambda: _blocked(tmp_path) / "b" / "c")
    assert not numba_cache.enabled()
    assert "compiled on every run" in numba_cache.notice()
    from vrsweep.numerics.lines import kernel_is_cached

    assert not kernel_is_cached() and numba_cache.is_empty()

    def twice(x):
        return 2.0 * x

    kernel = jit.kernel_jit(twice)
    assert kernel(1.5) == 3.0
    assert type(kernel._cache).__name__ == "NullCache"  # numba's "no cache": nothing written anywhere


def test_an_edited_kernel_is_never_loaded_stale_with_the_cache_folder_unwritable(tmp_path):
    """The fault as reported: read-only cache folder, run, edit the kernel, run again. The second
    run must compute with the edited code, and nothing may be cached inside the package. The
    reported run's sweep loop (lines.py) carried kernel.py's code; here records.emit_samples
    carries rk45.dense_value's, the same fault (numba keys a cached kernel by its own file only)
    with a kernel that compiles in a second instead of 30 s."""
    import shutil

    site = tmp_path / "site"
    copy = site / "vrsweep"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "tmp").mkdir()
    changes = {"XDG_CACHE_HOME": str(_blocked(tmp_path)), "TMPDIR": str(tmp_path / "tmp"), "PYTHONPATH": str(site)}
    code = TINY_KERNEL + "import vrsweep.numerics.numba_cache as n; print(n.notice())\n"

    def response():
        done = _run(code, changes, tmp_path)
        assert done.returncode == 0, done.stderr
        says, notice = done.stdout.splitlines()
        assert "not writable" in notice
        return says

    assert response() == TINY_KERNEL_SAYS
    horner = "return y[component] + h * theta * acc"
    source = copy / "numerics" / "rk45.py"
    assert horner in source.read_text()
    source.write_text(source.read_text().replace(horner, "return y[component] + 3.0 * h * theta * acc"))
    assert response() == f"1 {1.0 + 1.5 * 1.875} {2.0 + 1.5 * 1.875}", "the edited kernel was not the one that ran"
    assert not list(copy.rglob("*.nbi")), "numba cached kernels inside the package"


def test_numba_disable_jit_runs_in_python_without_a_traceback(tmp_path):
    """NUMBA_DISABLE_JIT=1 (numba's own switch for debugging in Python) made run, continue and
    run --dry-run end in a traceback (AttributeError: 'function' object has no attribute
    'py_func') where they asked whether the kernel was cached; run --quiet, simulate and validate
    worked. With the JIT off nothing compiles: no notice, and the point is computed in Python."""
    config = tmp_path / "one.yaml"
    config.write_text("model: effective\nparameters: {g: 5}\n"
                      "integration: {transient_periods: 0, measure_periods: 1, strobe_periods: 1}\n")
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1", "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    result = subprocess.run([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(tmp_path / "one.h5")],
                            capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr and "Compiling" not in result.stderr
    assert "1 of 1 points computed (1 ok)" in result.stderr


def test_numba_disable_jit_on_the_gpu_is_one_line_not_a_traceback(tmp_path):
    """No CPU command imports numerics/cuda.py; `run --device cuda` does, and with the JIT off it
    ended in a traceback (cuda.py reads the CPU kernel's py_func when imported): the GPU's kernel
    needs numba's compiler, so the run is refused in one line, exit 2, before any file exists.
    numba's CUDA simulator stands in for the card."""
    pytest.importorskip("numba_cuda")
    config = tmp_path / "two.yaml"
    config.write_text("model: effective\nsweep:\n  g: [5, 10]\n"
                      "integration: {transient_periods: 0, measure_periods: 1, strobe_periods: 1}\n")
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1", "NUMBA_ENABLE_CUDASIM": "1",
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    result = subprocess.run([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(tmp_path / "two.h5"),
                             "--device", "cuda"], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert result.returncode == 2, result.stderr
    assert result.stderr.strip().splitlines() == [
        "Error: integration.device: cuda: NUMBA_DISABLE_JIT=1 turns numba's compiler off, and the GPU's kernel "
        "is compiled by it: unset it, or run on the cpu"], result.stderr
    assert not (tmp_path / "two.h5").exists()


@pytest.mark.parametrize("limit", ["ulimit -f 1", "ulimit -f 2"], ids=["index", "data"])
def test_a_kernel_the_cache_has_no_room_for_still_runs_with_one_note(tmp_path, limit):
    """A home folder at its quota, a full disk or `ulimit -f`: numba let the OSError of saving a
    freshly compiled kernel escape, and every command ended "Error: No space left on device"
    (no file named) after its compile, with the kernel in memory and the output folder fine.
    1 kB stops numba's first file (the index, 1.4 kB), 2 kB the compiled code after it (9 kB)."""
    (tmp_path / "tiny_kernel.py").write_text(
        "from vrsweep.numerics.jit import kernel_jit\n\n\n@kernel_jit\ndef twice(x):\n"
        "    return 2.0 * x\n")
    paths = os.pathsep.join([str(tmp_path), str(PACKAGE.parent), os.environ.get("PYTHONPATH", "")])
    env = {**{k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"},
           "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": paths}
    code = "import tiny_kernel; print(tiny_kernel.twice(21.0))"
    done = subprocess.run(["bash", "-c", f'{limit}; exec "$0" -c "$1"', sys.executable, code],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "42.0"
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Note: the compiled kernel could not be saved in the numba "
                                                   "cache") and "File too large" in lines[0], done.stderr


@pytest.mark.parametrize("value, expected", [
    ("~/numba", "{home}/numba"),     # quoted in a job script: the shell left the ~
    ("relative/numba", "{cwd}/relative/numba"),
    (" ", "{xdg}/vrsweep"),           # blank: the default, not a folder named " "
])
def test_numba_cache_dir_is_read_as_a_shell_would(value, expected, tmp_path):
    """NUMBA_CACHE_DIR='~/numba' made a folder named '~' in the current folder, a relative path
    one folder per folder a command started in (a worker inherits it as given), and a blank value
    a folder named ' '. Now ~ is the home folder, the path absolute, a blank value the default."""
    (tmp_path / "home").mkdir()
    (tmp_path / "cwd").mkdir()
    code = "import os, vrsweep, numba.core.config as c; print(os.environ['NUMBA_CACHE_DIR']); print(c.CACHE_DIR)"
    done = _run(code, {"NUMBA_CACHE_DIR": value, "HOME": str(tmp_path / "home"),
                       "XDG_CACHE_HOME": str(tmp_path / "xdg"), "PYTHONPATH": str(PACKAGE.parent)},
                tmp_path / "cwd")
    assert done.returncode == 0, done.stderr
    folder = expected.format(home=tmp_path / "home", cwd=tmp_path / "cwd", xdg=tmp_path / "xdg")
    assert done.stdout.split() == [f"{folder}/{folder_name()}"] * 2
    assert list((tmp_path / "cwd").iterdir()) == ([tmp_path / "cwd" / "relative"] if value.startswith("rel") else [])
