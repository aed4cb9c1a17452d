"""Where numba caches vrsweep's compiled kernels.

numba's default is a ``__pycache__`` folder beside each source file, i.e. inside the installed
package. That breaks twice: a read-only install cannot be cached at all, and a cache written into
``site-packages/vrsweep/__pycache__`` outlives ``pip uninstall``, after which Python imports the
left-over folder as an empty namespace package named ``vrsweep`` ahead of a later editable install
(``ImportError: cannot import name '__version__'``). So kernels go to a per-user cache folder::

    ~/.cache/vrsweep/vrsweep-<version>-<source digest>/    (Linux; platformdirs elsewhere)

or, when ``NUMBA_CACHE_DIR`` is set, to the same sub-folder of it.

Why a digest of the sources in the name: numba checks a cached function against its *own* source
file only. The parallel loops in ``sweep.py`` have the whole kernel compiled into them, so after
an edit of ``kernel.py`` alone (a ``git pull`` into an editable install, a patched release with
the same version number) numba would load the old kernel and compute with it, silently. A folder
per state of the package's sources makes every change compile afresh; the old folders are inert
and may be deleted.

:func:`configure` must run before numba compiles anything: ``vrsweep/__init__.py`` calls it
first thing, so every entry point (the CLI, the library, Dask workers) gets the same folder, and
it is idempotent: a subprocess that inherits the variable keeps the folder.
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
from pathlib import Path

from vrsweep._version import __version__


@functools.lru_cache(maxsize=None)
def sources_digest() -> str:
    """12 hex digits of SHA-1 over the package's own modules (names and bytes): ~1 ms."""
    digest = hashlib.sha1()
    for path in sorted(Path(__file__).resolve().parent.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def folder_name() -> str:
    return f"vrsweep-{__version__}-{sources_digest()}"


def cache_dir() -> Path:
    """The folder that holds (or will hold) the compiled kernels of these vrsweep sources."""
    explicit = os.environ.get("NUMBA_CACHE_DIR")
    if explicit:
        base = Path(explicit)
    else:
        import platformdirs

        base = Path(platformdirs.user_cache_dir("vrsweep", appauthor=False))
    return base if base.name == folder_name() else base / folder_name()


def configure() -> Path:
    """Point numba's cache at :func:`cache_dir` (set before numba is imported; idempotent)."""
    folder = str(cache_dir())
    # numba reads NUMBA_CACHE_DIR when it is imported; worker subprocesses inherit it.
    os.environ["NUMBA_CACHE_DIR"] = folder
    numba_config = sys.modules.get("numba.core.config")
    if numba_config is not None:  # numba imported before vrsweep (a notebook, say)
        numba_config.CACHE_DIR = folder
    return Path(folder)


def is_empty() -> bool:
    """True when no kernel of this version has been cached yet: the next run compiles."""
    folder = cache_dir()
    return not folder.is_dir() or not any(folder.rglob("*.nbi"))


def kernel_is_cached(method: str = "rk45", lyapunov: bool = False) -> bool:
    """Whether the sweep kernel of ``method`` (sweep.RUN_LINES[method, lyapunov]) has been compiled
    into the cache already.

    Looks for numba's index file of that function where numba puts it: in ``cache_dir()``, under
    a sub-folder named after the source folder (numba.core.caching's get_suitable_cache_subpath),
    named ``<module>.<function>-<first line>.py<XY>.nbi``, and not older than the source (numba
    discards an index whose source has changed since). An index written on another CPU model
    counts as cached although numba will compile again: the answer is a hint for the user, not a
    promise. Imports numba (through vrsweep.sweep).
    """
    import hashlib
    import sys

    from vrsweep import sweep

    source = Path(os.path.abspath(sweep.__file__))  # abspath, not resolve(): as numba does
    subfolder = f"{source.parent.name}_{hashlib.sha1(str(source.parent).encode()).hexdigest()}"
    function = sweep.RUN_LINES[method, lyapunov].py_func
    index = (cache_dir() / subfolder /
             f"{source.stem}.{function.__qualname__}-{function.__code__.co_firstlineno}"
             f".py{sys.version_info.major}{sys.version_info.minor}.nbi")
    try:
        return index.stat().st_mtime >= source.stat().st_mtime
    except OSError:
        return False
