"""matplotlib's folder for its settings and font cache, chosen before anything imports matplotlib.

matplotlib picks ``MPLCONFIGDIR``, else ``$XDG_CONFIG_HOME/matplotlib`` and
``$XDG_CACHE_HOME/matplotlib`` (``~/.config``, ``~/.cache``; ``~/.matplotlib`` off Linux). Where
one is not a writable folder (HOME a file or read-only, as on some cluster nodes; an XDG variable
naming a file) it logged two warnings of several lines on every import ("mkdir -p failed for
path ...", "Matplotlib created a temporary cache directory ...") and rebuilt its font cache in a
new temporary folder each time: `vrsweep plot` and `vrsweep info` printed them ahead of their
own output. As for numba's cache (numerics/numba_cache.py), vrsweep falls back to its own
private folder under the system's temporary folder, which persists, and `plot` says so once.
"""

import os
import sys
from pathlib import Path

from vrsweep.numerics.numba_cache import _private, _writable, fallback_dir

_notice = None


def _default_folders():
    """The folders matplotlib would use here (its ``_get_config_or_cache_dir``), or None where
    no home folder can be found (matplotlib then fails in its own way: left to it)."""
    asked = os.environ.get("MPLCONFIGDIR")
    if asked:
        return [Path(asked)]
    try:
        if sys.platform.startswith(("linux", "freebsd")):
            return [Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config", "matplotlib"),
                    Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache", "matplotlib")]
        return [Path.home() / ".matplotlib"]
    except RuntimeError:  # no HOME and no entry in the password database
        return None


def configure() -> None:
    """Set ``MPLCONFIGDIR`` to vrsweep's fallback folder if matplotlib's own is not writable
    (idempotent; nothing once matplotlib is imported, which has chosen already)."""
    global _notice
    if "matplotlib" in sys.modules or _notice is not None:
        return
    folders = _default_folders()
    if not folders:
        return
    for folder in folders:
        why = _writable(folder)
        if why is not None:
            break
    else:
        return
    fallback = fallback_dir().parent / "matplotlib"
    if _private(fallback.parent) is not None or _writable(fallback) is not None:
        return  # no better folder: matplotlib's own temporary one, and its warnings
    os.environ["MPLCONFIGDIR"] = str(fallback)
    _notice = f"matplotlib's folder {folder} is not writable ({why}); its settings and font cache are in {fallback} instead"


def notice() -> str | None:
    """One sentence for the user when matplotlib's folder is not its usual one, else None."""
    return _notice
