"""Where numba caches vrsweep's compiled kernels.

numba's default is a ``__pycache__`` folder beside each source file, i.e. inside the installed
package. That breaks twice: a read-only install cannot be cached at all, and a cache written into
``site-packages/vrsweep/__pycache__`` outlives ``pip uninstall``, after which Python imports the
left-over folder as an empty namespace package named ``vrsweep`` ahead of a later editable install
(``ImportError: cannot import name '__version__'``). So kernels go to a per-user cache folder::

    ~/.cache/vrsweep/vrsweep-<version>-<source digest>/    (Linux; platformdirs elsewhere)

or, when ``NUMBA_CACHE_DIR`` is set, to the same sub-folder of it.

Why a digest of the sources in the name: numba checks a cached function against its *own* source
file only. The sweep's loops in ``lines.py`` have the whole kernel compiled into them, so after
an edit of ``kernel.py`` alone (a ``git pull`` into an editable install, a patched release with
the same version number) numba would load the old kernel and compute with it, silently. A folder
per state of the package's sources makes every change compile afresh; the old folders are inert
and may be deleted.

:func:`configure` must run before numba compiles anything: ``vrsweep/__init__.py`` calls it
first thing, so every entry point (the CLI, the library, Dask workers) gets the same folder, and
it is idempotent: a subprocess that inherits the variable keeps the folder.

Why the folder is tested before numba sees it: when numba cannot write to ``NUMBA_CACHE_DIR`` it
does not fail, it falls back to ``__pycache__`` beside the sources, a cache keyed by each file's
own timestamp only, i.e. exactly the stale-loop case above (seen: a read-only ``XDG_CACHE_HOME``,
an edit of ``kernel.py``, and the next run returned the old kernel's R). So :func:`configure`
writes a probe file into the folder it chose. If that fails it takes a fallback folder of its own
under the system's temporary folder (``vrsweep-cache-<uid>``, mode 0700, refused unless owned by
this user), and if that fails too, caching is switched off: :func:`enabled` is False, every
kernel compiles with ``cache=False`` (``vrsweep/numerics/jit.py``), and :func:`notice` says so once.
Compiling every run is slow; computing with code that is not the installed code is wrong.
"""

from __future__ import annotations

import functools
import hashlib
import os
import stat
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from vrsweep._version import __version__


@functools.lru_cache(maxsize=None)
def sources_digest() -> str:
    """12 hex digits of SHA-1 over every module of the package, sub-packages included (relative
    paths and bytes): ~2 ms. Every folder, because a kernel compiled into a loop may come from any
    of them."""
    package = Path(__file__).resolve().parent.parent  # vrsweep/, not numerics/
    digest = hashlib.sha1()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def folder_name() -> str:
    return f"vrsweep-{__version__}-{sources_digest()}"


def preferred_dir() -> Path:
    """The folder the user asked for: ``NUMBA_CACHE_DIR`` or the per-user cache, plus
    :func:`folder_name` (unless the path already ends in it, as in a worker that inherited it)."""
    explicit = os.environ.get("NUMBA_CACHE_DIR")
    if explicit and explicit.strip():
        # As a shell would have read it unquoted: NUMBA_CACHE_DIR="~/.cache/numba" in a job script
        # made a folder named "~" in the current folder, and a relative path another folder in
        # each folder a command (or a worker, which inherits the variable) starts in.
        base = Path(os.path.abspath(os.path.expanduser(explicit)))
    else:  # unset, empty or blank (a blank value made a folder named " " in the current folder)
        import platformdirs

        base = Path(platformdirs.user_cache_dir("vrsweep", appauthor=False))
    return base if base.name == folder_name() else base / folder_name()


def fallback_dir() -> Path:
    """vrsweep's own folder under the system's temporary folder, for when the preferred one is
    not writable."""
    owner = os.getuid() if hasattr(os, "getuid") else "user"
    return Path(tempfile.gettempdir()) / f"vrsweep-cache-{owner}" / folder_name()


@dataclass
class _Choice:
    asked: str | None  # NUMBA_CACHE_DIR when the choice was made, or as configure() left it
    folder: Path | None = None  # None: caching is off
    unusable: list = field(default_factory=list)  # (folder, why) of every folder refused


_choice: _Choice | None = None


def _writable(folder: Path) -> str | None:
    """None if numba can cache in ``folder`` (created if need be), else why not, in a few words."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):  # the same probe as numba's own locators
            pass
    except OSError as error:
        return error.strerror or type(error).__name__
    return None


def _private(root: Path) -> str | None:
    """None if ``root`` is a real folder of this user's that nobody else may write to: a cache
    folder in a shared /tmp that another user prepared would let them choose the code we run."""
    try:
        root.mkdir(mode=0o700, exist_ok=True)
        info = os.lstat(root)
    except OSError as error:
        return error.strerror or type(error).__name__
    if not stat.S_ISDIR(info.st_mode):
        return "not a folder"
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        return "owned by another user"
    if info.st_mode & 0o022:
        return "writable by other users"
    return None


def _choose() -> _Choice:
    """The folder for this process, chosen once (again only if NUMBA_CACHE_DIR is changed)."""
    global _choice
    asked = os.environ.get("NUMBA_CACHE_DIR")
    if _choice is not None and _choice.asked == asked:
        return _choice
    choice = _Choice(asked)
    preferred = preferred_dir()
    why = _writable(preferred)
    if why is None:
        choice.folder = preferred
    else:
        choice.unusable.append((preferred, why))
        fallback = fallback_dir()
        why = _private(fallback.parent) or _writable(fallback)
        if why is None:
            choice.folder = fallback
        else:
            choice.unusable.append((fallback, why))
    _choice = choice
    return choice


def cache_dir() -> Path:
    """The folder that holds (or will hold) the compiled kernels of these vrsweep sources; when
    caching is off (:func:`enabled` False), the folder that was asked for and refused."""
    choice = _choose()
    return choice.folder if choice.folder is not None else choice.unusable[0][0]


def enabled() -> bool:
    """Whether kernels are cached at all: False when no folder vrsweep can key by its sources is
    writable. Read by ``vrsweep/numerics/jit.py`` when each kernel is decorated."""
    return _choose().folder is not None


def notice() -> str | None:
    """One sentence for the user when the cache is not where they asked for it, else None."""
    choice = _choose()
    if not choice.unusable:
        return None
    asked, why = choice.unusable[0]
    if choice.folder is not None:
        return (f"the numba cache folder {asked} is not writable ({why}); compiled kernels are "
                f"cached in {choice.folder} instead")
    return (f"no numba cache folder is writable ({asked}: {why}); kernels are compiled on every "
            f"run: set NUMBA_CACHE_DIR to a writable folder to cache them")


def configure() -> Path:
    """Point numba's cache at :func:`cache_dir` (set before numba is imported; idempotent)."""
    folder = str(cache_dir())
    # numba reads NUMBA_CACHE_DIR when it is imported; worker subprocesses inherit it. With
    # caching off the variable still names the refused folder, so a worker tries it afresh.
    os.environ["NUMBA_CACHE_DIR"] = folder
    _choice.asked = folder
    numba_config = sys.modules.get("numba.core.config")
    if numba_config is not None:  # numba imported before vrsweep (a notebook, say)
        numba_config.CACHE_DIR = folder
    return Path(folder)


_save_failure_told = False


def keep_going_when_a_save_fails() -> None:
    """Make a failed save of a compiled kernel a note, not the end of the command (idempotent).

    numba saves each kernel to the cache right after compiling it and lets an OSError of that
    save escape the call that compiled it (it guards only against a Windows race). A home folder
    at its quota, a full disk or ``ulimit -f`` then ended every command with "Error: No space
    left on device", naming no file, after the whole compile, with the kernel in memory and the
    output folder fine. The cache saves time, never results: so the run goes on, and the next
    one compiles again. numba writes each cache file under a temporary name and removes it when
    the write fails, and reads an index whose data file is missing as no cache.
    """
    from numba.core import caching

    save = caching.Cache.save_overload
    if getattr(save, "keeps_going", False):
        return

    def save_overload(self, sig, data):
        global _save_failure_told
        try:
            save(self, sig, data)
        except OSError as error:
            if not _save_failure_told:
                _save_failure_told = True
                print(f"Note: the compiled kernel could not be saved in the numba cache {cache_dir()} "
                      f"({error.strerror or error}); this run goes on, the next compiles again: free "
                      "space there, or set NUMBA_CACHE_DIR to another folder", file=sys.stderr, flush=True)

    save_overload.keeps_going = True
    caching.Cache.save_overload = save_overload


def is_empty() -> bool:
    """True when no kernel of this version has been cached yet: the next run compiles."""
    if not enabled():
        return True
    folder = cache_dir()
    return not folder.is_dir() or not any(folder.rglob("*.nbi"))


def is_compiled(dispatcher) -> bool:
    """Whether numba has cached a compiled version of ``dispatcher`` (a cached njit function).

    Looks for numba's index file of that function where numba puts it: in :func:`cache_dir`, under
    a sub-folder named after the source folder (numba.core.caching's get_suitable_cache_subpath),
    named ``<module>.<function>-<first line>.py<XY>.nbi``, and not older than the source (numba
    discards an index whose source has changed since). An index written on another CPU model
    counts as cached although numba will compile again: the answer is a hint for the user, not a
    promise.
    """
    if not enabled():
        return False
    function = getattr(dispatcher, "py_func", None)
    if function is None:  # NUMBA_DISABLE_JIT=1: njit hands back the Python function, nothing compiles
        return True
    return is_cached_function(function.__code__.co_filename, function.__qualname__, function.__code__.co_firstlineno)


def is_cached_function(source, qualname, first_line=None) -> bool:
    """is_compiled for the function ``qualname`` of the file ``source`` (defined at ``first_line``;
    None: at any line), without importing it or numba: `validate`, which imports no numba, says
    whether the run will compile first."""
    if not enabled():
        return False
    source = Path(os.path.abspath(source))  # abspath, not resolve(): as numba does
    subfolder = cache_dir() / f"{source.parent.name}_{hashlib.sha1(str(source.parent).encode()).hexdigest()}"
    pattern = (f"{source.stem}.{qualname}-{'*' if first_line is None else first_line}"
               f".py{sys.version_info.major}{sys.version_info.minor}.nbi")
    try:
        built = source.stat().st_mtime
        return any(index.stat().st_mtime >= built for index in subfolder.glob(pattern))
    except OSError:
        return False
