"""Where compiled kernels go: never into the installed package (a read-only install must work,
and a cache left in site-packages once broke the next install)."""

import os
import subprocess
import sys
from pathlib import Path

import vrsweep
from vrsweep.numba_cache import folder_name

PACKAGE = Path(vrsweep.__file__).resolve().parent


def _run(code, env_changes, cwd):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(env_changes)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=300)


def test_default_is_a_per_user_folder_per_version_and_sources(tmp_path):
    code = ("import vrsweep, os, numba.core.config as c; "
            "print(os.environ['NUMBA_CACHE_DIR']); print(c.CACHE_DIR); print(vrsweep.numba_cache.cache_dir())")
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


def test_a_compiled_kernel_lands_in_the_user_folder_not_in_the_package(tmp_path):
    before = {p for p in PACKAGE.rglob("*.nbi")}
    done = _run("import vrsweep.numba_cache as n; print(n.is_empty())",
                {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.stdout.strip() == "True", done.stderr
    config = tmp_path / "one.yaml"
    config.write_text("integration: {transient_periods: 1, measure_periods: 1, strobe_periods: 1}\n")
    done = subprocess.run([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(tmp_path / "one.h5"),
                           "--quiet"], capture_output=True, text=True, cwd=tmp_path, timeout=600,
                          env={**{k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"},
                               "XDG_CACHE_HOME": str(tmp_path / "xdg")})
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "xdg" / "vrsweep" / folder_name()
    assert any(folder.rglob("*.nbi")), "nothing was cached in the per-user folder"
    assert {p for p in PACKAGE.rglob("*.nbi")} == before, "a kernel was cached inside the package"
    done = _run("import vrsweep.numba_cache as n; print(n.is_empty())",
                {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    assert done.stdout.strip() == "False"


def test_an_edit_of_any_module_gives_a_new_folder(tmp_path):
    """numba checks a cached loop against its own file only: sweep.py's loops carry kernel.py's
    code, so an edit of kernel.py alone must not load them from the old folder."""
    import shutil

    copy = tmp_path / "site" / "vrsweep"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "examples"))
    code = (f"import sys; sys.path.insert(0, {str(copy.parent)!r}); import vrsweep.numba_cache as n; "
            "print(n.__file__); print(n.folder_name())")
    before = _run(code, {}, tmp_path)
    assert before.returncode == 0, before.stderr
    assert before.stdout.split() == [str(copy / "numba_cache.py"), folder_name()]
    with open(copy / "kernel.py", "a") as kernel:
        kernel.write("\n# an edit\n")
    after = _run(code, {}, tmp_path)
    assert after.stdout.split()[1] != folder_name()
