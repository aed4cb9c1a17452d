"""Where numba caches vrsweep's compiled kernels.

A per-user folder, one sub-folder per vrsweep version (``platformdirs.user_cache_dir``), unless
``NUMBA_CACHE_DIR`` is set: never inside the installed package, which may be read-only or be
replaced by a reinstall.
"""

import os
from pathlib import Path

from vrsweep import __version__


def cache_dir() -> Path:
    """The folder numba caches vrsweep's kernels in."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    import platformdirs

    return Path(platformdirs.user_cache_dir("vrsweep")) / __version__


def kernel_is_cached() -> bool:
    """Whether the sweep kernel (sweep.run_lines) has been compiled into the cache already.

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
    function = sweep.run_lines.py_func
    index = (cache_dir() / subfolder /
             f"{source.stem}.{function.__qualname__}-{function.__code__.co_firstlineno}"
             f".py{sys.version_info.major}{sys.version_info.minor}.nbi")
    try:
        return index.stat().st_mtime >= source.stat().st_mtime
    except OSError:
        return False
