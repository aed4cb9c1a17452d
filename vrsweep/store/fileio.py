"""Opening and writing files so that faults end in one line, never in a traceback or a lost result.

Everything vrsweep writes whole (result files, finished results, shard merges, trajectories,
figures) is written beside its path and renamed into place (:func:`replacing`,
:func:`atomic_write`), and every HDF5 file it opens goes through :func:`open_hdf5`. What a
shared machine does to a run, and what happens then (docs/clusters.md, "Long runs and clusters"):

- **A full disk or quota.** HDF5 cannot recover from a failed write: closing what it holds
  writes again, fails again, and the process crashes (at exit, or at the next HDF5 call). So the
  space an HDF5 file will take is allocated before HDF5 writes (:func:`reserve_space`), and
  where that is not possible a file whose write failed is closed without writing another byte
  (:func:`close_without_writing`, :func:`writing_hdf5`). The temporary file is removed, and
  :class:`~vrsweep.errors.OutputError` says in one line which file, why, how much space it needs
  and how much is free. Files that are not HDF5 (figures) and small HDF5 files (trajectories)
  are built in memory and written as plain bytes.
- **Another process writing the same output.** A writer holds a lock on its file
  (:func:`lock_for_writing`); :func:`refuse_if_being_written` refuses to replace a locked file.
- **A file or folder removed or replaced under a writer** (a scratch purge, a run with
  ``--overwrite`` on a file system without locks): :func:`identity` lets a writer check that the
  path still names the file that it created before it touches it again.
- **A process killed while it writes a file** leaves a temporary file beside the output; the next
  write of that output removes it, or names it when it cannot tell that its writer is gone
  (:func:`clean_stale_temporaries`).
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import socket
import sys
import time
import uuid
from contextlib import contextmanager
from typing import Callable

import h5py

from vrsweep.config.wording import folder_ending
from vrsweep.errors import OutputError, UsageError, one_line

# The HDF5 format every file vrsweep writes uses: v108 and later checksum object headers and index
# chunks with version-2 B-trees that carry checksums (with the earliest format one flipped bit in a
# chunk's key made h5py read the fill value silently: a fold at g = 0 instead of 24).
LIBVER = ("v108", "latest")

try:  # POSIX; elsewhere nothing is locked and nothing can be told about other writers
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


def notice(message: str) -> None:
    """One line on stderr about something done on the user's behalf (not an error), whatever the
    names in it hold."""
    print(one_line(message), file=sys.stderr, flush=True)


# --------------------------------------------------------------------------------------------
# Opening HDF5 files: the locking policy
# --------------------------------------------------------------------------------------------

# h5py built on HDF5 older than 1.10.7 has no file-locking property and raises ValueError for
# the locking= argument; after the first such refusal every file is opened without it.
_locking_argument_supported = True


def hdf5_locking_kwargs() -> dict:
    """``locking="best-effort"`` unless ``HDF5_USE_FILE_LOCKING`` decides or HDF5 is too old.

    Best effort: lock where the file system can, carry on where it cannot (some NFS and Lustre
    mounts), so that a reader never blocks on a file system without locks.
    """
    if "HDF5_USE_FILE_LOCKING" in os.environ or not _locking_argument_supported:
        return {}
    return {"locking": "best-effort"}


def refuse_a_special_file(path) -> None:
    """ResultFileError for a path that is there but is no regular file nor folder: HDF5 waited
    forever on a pipe (``vrsweep info FIFO`` hung), and a device or a /proc file, whose size reads
    0, was called "empty (0 bytes): truncated or never written"."""
    import stat

    from vrsweep.errors import ResultFileError

    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return  # missing or unreadable: the caller's own message says which
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise ResultFileError(f"{os.fsdecode(path)} is not a regular file (a device, a pipe or a socket), "
                              "so not a vrsweep file")


def open_hdf5(path, mode="r", **kwargs) -> h5py.File:
    """``h5py.File(path, mode, **kwargs)`` with vrsweep's locking policy (hdf5_locking_kwargs).

    On an HDF5 without the locking property the file is opened without it: HDF5 then locks as it
    always did, and ``HDF5_USE_FILE_LOCKING=FALSE`` still switches locking off. Every reader and
    writer of vrsweep opens its files here, so a pipe or a device is refused here for all.
    """
    global _locking_argument_supported
    if isinstance(path, (str, bytes, os.PathLike)):
        refuse_a_special_file(path)
    locking = hdf5_locking_kwargs()
    if locking:
        try:
            return h5py.File(path, mode, **locking, **kwargs)
        except ValueError as error:
            if "lock" not in str(error).lower():
                raise
            _locking_argument_supported = False
    return h5py.File(path, mode, **kwargs)


def is_hdf5(path) -> bool:
    """True for a file whose bytes say HDF5 (whatever else is wrong with it); False for anything else."""
    try:
        return os.path.isfile(path) and h5py.is_hdf5(path)
    except Exception:  # noqa: BLE001 - unreadable: then it is not for an HDF5 reader to say
        return False


def has_file_kind(path, kind) -> bool:
    """True for an HDF5 file whose root attribute vrsweep_file is ``kind``; False for anything else
    (branch, curves and trajectory files; unreadable: False, and the file's reader, open_checked,
    check_branch..., then says what is wrong)."""
    return kind in _NAMED_KINDS and _kind_of(path) == kind


# --------------------------------------------------------------------------------------------
# Who else writes this file
# --------------------------------------------------------------------------------------------


def lock_for_writing(fd, path=None, action="write") -> None:
    """Take an exclusive lock on the open file ``fd`` for as long as it stays open.

    HDF5 already holds one when its own locking is on; this covers ``HDF5_USE_FILE_LOCKING=FALSE``.
    Both are ``flock`` locks on the same open file, so they never conflict with each other. Where
    locks are not supported nothing happens (and nothing can be told about other writers).

    The lock is the test of a second writer, not only :func:`refuse_if_being_written` before it:
    two runs that resume one file at the same moment (HDF5's locking off, as on NFS or Lustre) both
    passed that test before either locked, and wrote one HDF5 file at once. A lock held by another
    process is a UsageError naming ``path``; a :func:`being_written` probe holds its shared lock
    for an instant, so the lock is tried again for a second before that is concluded.
    """
    if fcntl is None:
        return
    deadline = time.monotonic() + 1.0
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            if time.monotonic() > deadline:
                raise _being_written_error(path, action) from None
            time.sleep(0.02)
        except OSError:
            return  # no locks on this file system


def being_written(path) -> bool:
    """True if another process holds ``path`` open for writing (an exclusive lock on it)."""
    if fcntl is None:
        return False
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))  # a pipe put there never blocks
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False  # no locks on this file system: cannot tell
    finally:
        os.close(fd)  # releases the probe's shared lock too
    return False


def refuse_if_being_written(path, action="replace") -> None:
    """UsageError (exit 2) if another process is writing ``path``: never pull a file from under
    it (``--overwrite``), nor write it twice (``--resume``)."""
    if being_written(path):
        raise _being_written_error(path, action)


def _being_written_error(path, action):
    return UsageError.naming("cannot {action} {path}: it is being written by another process (a run in "
                             "progress?); wait for that run to end, stop it, or choose another {output}",
                             {"output": "output path"}, action=action, path=path)


def identity(fd):
    """(device, inode) of an open file: what a writer compares the path against later."""
    stat = os.fstat(fd)
    return (stat.st_dev, stat.st_ino)


def check_still_at_path(path, expected_identity, doing="writing") -> None:
    """OutputError (exit 1) unless ``path`` still names the file with ``expected_identity``.

    A writer holds its file open; if the path was deleted (by hand, or a scratch purge that took
    the whole folder) or now names another file, writing on would compute into a file nobody can
    see, and reopening the path would find someone else's file.
    """
    try:
        stat = os.stat(path)
    except FileNotFoundError:
        folder = os.path.dirname(os.path.abspath(path))
        gone = (f"its folder {folder} was removed (a scratch purge?)" if not os.path.isdir(folder)
                else "it was deleted")
        raise OutputError(f"{path} is gone: {gone} while this run was {doing} it; stopping, its "
                          "points are lost: run again") from None
    if (stat.st_dev, stat.st_ino) != tuple(expected_identity):
        raise OutputError(f"{path} was replaced by another file while this run was {doing} it "
                          "(another run that replaced its output?); stopping without touching the new file: "
                          "this run's points are not in it") from None


# --------------------------------------------------------------------------------------------
# Closing after a failure
# --------------------------------------------------------------------------------------------


def close_without_writing(file) -> None:
    """Close an HDF5 file (h5py.File or FileID) after a failed write, without a second error.

    HDF5 flushes what it holds (dirty chunks, metadata) when it closes a file. After a write
    failed on a full disk that flush fails too, the file stays open inside the library, and the
    library crashes when the interpreter exits. So the file's descriptor is first pointed at an
    anonymous file in memory: the flush lands there and the close succeeds. The file on disk keeps
    its last successful flush: a checkpoint stays resumable (a point is marked done only after its
    values were flushed), and a temporary file is deleted by the caller anyway.
    """
    file_id = file if isinstance(file, h5py.h5f.FileID) else file.id
    try:
        if not file_id.valid:
            return
        fd = file_id.get_vfd_handle()
        sink = os.memfd_create("vrsweep-discard") if hasattr(os, "memfd_create") else _unlinked_tempfile()
        try:
            os.dup2(sink, fd)
        finally:
            os.close(sink)
    except (OSError, ValueError, TypeError, NotImplementedError):
        pass  # no plain descriptor: close as it is
    try:
        h5py.File(file_id).close()
    except Exception:  # noqa: BLE001 - nothing more can be done; the first error is the one to report
        pass


def _unlinked_tempfile():
    import tempfile

    handle, name = tempfile.mkstemp(prefix="vrsweep-discard-")
    os.unlink(name)
    return handle


@contextmanager
def closed_without_writing_on_failure(h5file):
    """Close ``h5file`` without writing if the block raises (see close_without_writing)."""
    try:
        yield h5file
    except BaseException:
        close_without_writing(h5file)
        raise


@contextmanager
def writing_hdf5(path, mode="r+", reserve=0, **kwargs):
    """``with writing_hdf5(path, "w", reserve=N) as f:`` instead of ``with h5py.File(path, "w") as f:``.

    ``reserve``: bytes the block will add to the file, at most; they are allocated first
    (:func:`reserve_space`), so that a full disk fails before HDF5 writes, and what the file did
    not use is given back at the end. The plain form closes the file when the block fails, and
    closing flushes: on a full disk that flush fails as well, half-way through h5py's close, and
    from then on any use of HDF5 (even the interpreter's exit) can crash the process. Here a
    failed block closes without writing, and the final flush happens before the close, where its
    failure can still be handled the same way.
    """
    h5file = open_hdf5(path, mode, **kwargs)
    with closed_without_writing_on_failure(h5file):
        if reserve:
            fd = h5file.id.get_vfd_handle()
            reserve_space(fd, reserve, offset=os.fstat(fd).st_size)
        yield h5file
        h5file.flush()
        if reserve:
            trim_to_contents(h5file)
    h5file.close()


def trim_to_contents(h5file) -> None:
    """Give back the space reserved beyond what a flushed HDF5 file uses (its end of allocation)."""
    fd = h5file.id.get_vfd_handle()
    end = h5file.id.get_filesize()
    if os.fstat(fd).st_size > end:
        os.ftruncate(fd, end)


# --------------------------------------------------------------------------------------------
# Space, and what a failed write tells the user
# --------------------------------------------------------------------------------------------

def format_bytes(size: float) -> str:
    """1234567 -> '1.2 MB' (decimal units, as disks are sold)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if size < 1000 or unit == "TB":
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1000
    raise AssertionError("unreachable")


_SPACE_ERRNOS = (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC), errno.EFBIG)
_HDF5_ERRNO = re.compile(r"errno = (\d+)")


def _errno_of(error):
    """The operating system's error number behind ``error`` (h5py puts it in its message), or None."""
    seen = set()
    while error is not None and id(error) not in seen:
        seen.add(id(error))
        if isinstance(error, OSError) and error.errno:
            return error.errno
        match = _HDF5_ERRNO.search(str(error))
        if match:
            return int(match.group(1))
        error = error.__cause__ or error.__context__
    return None


def free_bytes(path) -> int | None:
    """Bytes free for this user in the folder of ``path`` (None if that cannot be told)."""
    try:
        return shutil.disk_usage(os.path.dirname(os.path.abspath(path))).free
    except OSError:
        return None


def file_size_limit() -> int | None:
    """The largest file this process may write, in bytes (RLIMIT_FSIZE), or None if unlimited."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    except (ImportError, OSError, ValueError, AttributeError):
        return None
    return None if soft == resource.RLIM_INFINITY else soft


def _space_words(path, needed_bytes, written_bytes=None):
    free = free_bytes(path)
    folder = os.path.dirname(os.path.abspath(path))
    parts = []
    if needed_bytes:
        parts.append(f"the file needs about {format_bytes(needed_bytes)}")
    elif written_bytes:
        parts.append(f"the file needs more than the {format_bytes(written_bytes)} written")
    if free is not None:
        parts.append(f"{format_bytes(free)} free in {folder}")
    return ", ".join(parts)


def write_failure(path, error, needed_bytes=None, doing="write", written_bytes=None) -> OutputError | None:
    """The one-line OutputError for ``error`` raised while writing ``path``, or None if ``error``
    is not about the file system (a bug, an interrupt: let it through). On a full disk it says
    how much space the file needs (``needed_bytes``), or else how much had been written."""
    if isinstance(error, (OutputError, UsageError)):
        return error
    if not isinstance(error, Exception):
        return None  # KeyboardInterrupt, SystemExit
    number = _errno_of(error)
    if number is None:
        return None
    cause = os.strerror(number)
    if number == errno.EFBIG and (limit := file_size_limit()) is not None:
        # Not the disk: the process's own limit (`ulimit -f`, a batch system's), which the free
        # space would hide ("the file needs 201 kB, 78 GB free").
        needs = f"the file needs about {format_bytes(needed_bytes)}, " if needed_bytes else ""
        return OutputError(f"cannot {doing} {path}: {cause} ({needs}this process may write files of at most "
                           f"{format_bytes(limit)}: its file size limit, ulimit -f)")
    if number in _SPACE_ERRNOS:
        space = _space_words(path, needed_bytes, written_bytes)
        return OutputError(f"cannot {doing} {path}: {cause}" + (f" ({space})" if space else ""))
    return OutputError(f"cannot {doing} {path}: {cause}")


def reserve_space(fd, length, offset=0) -> None:
    """Allocate ``length`` bytes of the open file ``fd`` from ``offset`` on, before HDF5 writes there.

    HDF5 cannot take a full disk: once a write fails, closing anything it holds writes again, and
    the library ends in a crash (h5py reports the failures as "Exception ignored" while the
    program goes on). So the space a file will take is allocated first: a full disk or quota is
    then a clean OSError here, and HDF5's writes land in blocks that already exist. Where the
    file system cannot allocate ahead, HDF5 meets the full disk itself, and the file is closed
    without writing (:func:`close_without_writing`).
    """
    if length <= 0 or not hasattr(os, "posix_fallocate"):
        return
    try:
        os.posix_fallocate(fd, offset, length)
    except OSError as error:
        if error.errno not in (errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL):
            raise


# --------------------------------------------------------------------------------------------
# Output folders and temporary files
# --------------------------------------------------------------------------------------------


def refuse_a_folder_name(path, argument="output") -> None:
    """UsageError when ``path`` ends in a slash: it names a folder, and a file written there (as
    pathlib, which drops the slash, would write ``x.png`` for ``x.png/``) is not what was asked.
    Called where a path arrives as text (an option, an argument, a config's ``output``): a
    pathlib.Path has already lost the slash. ``argument`` is worded by the caller's flags."""
    if isinstance(path, str) and path == "":  # Path("") is ".", the current folder
        raise UsageError.naming("{" + argument + "} is an empty path, which names no file: give the file's name")
    ending = folder_ending(path)
    if ending:
        raise UsageError.naming("{" + argument + "} {path} ends in " + ending + ", which names a folder: give the "
                                "file's name (without " + ending.replace("a slash", "the slash") + ")", path=path)


# What each kind of result file is, and the command that writes it: a refusal to replace one says
# which it is, where a command that writes another kind was given its path (`vrsweep continue` of a
# config whose sweep `vrsweep run` already wrote at the same default path).
KIND_WORDS = {"sweep": "a sweep (vrsweep run)", "shard": "a shard of a sweep (vrsweep run)",
              "branch": "a branch (vrsweep continue)", "curves": "bifurcation curves (vrsweep continue of a branch)",
              "trajectory": "a trajectory (vrsweep simulate)"}


# The kinds a file names in its root attribute vrsweep_file (a sweep or shard names none).
_NAMED_KINDS = ("branch", "curves", "trajectory")
NAMED_KINDS = _NAMED_KINDS


def stored_kind(path):
    """The kind of vrsweep file at ``path`` (a KIND_WORDS key: its root attributes say it), None
    for a file vrsweep did not write or cannot read."""
    return _kind_of(path)


def _kind_of(path):
    """The kind of result file at ``path`` (a KIND_WORDS key) as its root attributes say it, None
    for a file vrsweep did not write or cannot read (the plain refusal then says enough)."""
    try:
        if not is_hdf5(path):
            return None
        with open_hdf5(path, "r") as f:
            found = f.attrs.get("vrsweep_file", "")
            found = found.decode() if isinstance(found, bytes) else found
            if isinstance(found, str) and found in _NAMED_KINDS:  # not an array's elementwise answer
                return found
            if "vrsweep_format_version" in f.attrs:  # a sweep: no vrsweep_file attribute
                return "shard" if "shard" in f.attrs else "sweep"
    except Exception:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        return None
    return None


def output_target(path, *, overwrite=False, inputs=(), inputs_are="an input of this command", exists_error=None,
                  writes=None, kind=None) -> str:
    """The one rule of what vrsweep may write at an output ``path`` (run, simulate, merge, plot,
    init). Returns the path to write; raises UsageError (one line) otherwise.

    - A symbolic link is followed, always and only once here: the file written, replaced or
      resumed is the link's target, and the link stays a link (a dangling link: its target is
      created where its folder exists; a link into a missing folder is refused). Callers write at the returned path, so every later step sees the same file.
    - Only a regular file is ever replaced. A folder, a device, a pipe or a socket at the path is
      refused, with or without ``overwrite``.
    - An existing regular file is replaced only with ``overwrite`` (else ``exists_error()`` is
      raised, or a generic message), and never when it is one of ``inputs`` (the config being
      run, the files being merged or plotted), whatever the flags.
    - ``kind``: the kind of result file the caller writes (KIND_WORDS). An existing result file of
      another kind is refused without ``overwrite`` by what it holds and which command wrote it,
      before ``exists_error`` (whose --resume would not apply to it).
    - ``writes`` names what a command writes when it is not results ("a figure", "a config"): an
      HDF5 file at the path is then refused whatever the flags. Results took hours to compute and
      a figure or a config is rewritten in a second: no flag should trade one for the other.
    """
    import stat

    refuse_a_folder_name(path)
    given = os.fspath(path)
    target = os.path.realpath(given) if os.path.islink(given) else given
    shown = given if target == given else f"{given} (a link to {target})"
    if target != given and not os.path.isdir(os.path.dirname(target)):
        # A link into a folder that is gone is a stale link (a purged scratch folder, a network
        # mount not mounted): creating the folder, as for a folder named in the path itself, put
        # the results on whatever disk holds the mount point, hidden once the mount is back.
        raise UsageError(f"output {shown}: the link's folder {os.path.dirname(target)} does not exist: create it, "
                         "or point the link elsewhere (vrsweep creates only a folder the output path itself names)")
    if os.pardir in target.split(os.sep)[:-1]:
        # "x/../y.h5": the checks below and the temporary file beside it read the folder
        # lexically (abspath: "./y.h5"), and the system, which opens x first, refused the write
        # where x does not exist (exit 1, after checks that had all passed) and went elsewhere
        # where x is a link. realpath follows the links a ".." steps out of, as the system
        # does, and drops a missing folder with its "..": the file is written where it says.
        folder, name = os.path.split(target)
        target = os.path.join(os.path.realpath(folder), name)
    for item in inputs:
        item = os.fspath(item)
        try:
            same = os.path.exists(target) and os.path.exists(item) and os.path.samefile(item, target)
        except OSError:
            same = False
        if same:
            raise UsageError(f"output {shown} is {inputs_are} ({item}): choose another output")
    try:
        mode = os.stat(target).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return target  # nothing there to replace; prepare_output_directory judges the folder
    except OSError as error:
        raise UsageError(f"output {shown}: {error.strerror or error}") from None
    if stat.S_ISDIR(mode):
        raise UsageError(f"output {shown} is a directory")
    if not stat.S_ISREG(mode):
        raise UsageError(f"output {shown} is not a regular file (a device, a pipe or a socket): vrsweep "
                         "writes and replaces regular files only; choose another output")
    if writes is not None and is_hdf5(target):  # before the overwrite test: --overwrite would not help
        raise UsageError(f"output {shown} is an HDF5 file (results?): {writes} never replaces one; "
                         "choose another output")
    if not overwrite:
        existing = _kind_of(target) if kind is not None else None
        if existing is not None and existing not in (kind, "shard" if kind == "sweep" else kind):
            raise UsageError.naming(
                "output {path} already exists and holds {holds}: give this {kind} its own file with {output}, or "
                "pass {overwrite} to replace it", {"overwrite": "overwrite=True", "output": "another output path"},
                path=shown, holds=KIND_WORDS[existing], kind=KIND_WORDS[kind].split(" (")[0].removeprefix("a "))
        if exists_error is not None:
            raise exists_error()
        raise UsageError.naming("output {path} already exists: pass {overwrite} to replace it",
                                {"overwrite": "overwrite=True"}, path=shown)
    # Whatever command replaces it (run, merge, simulate, continue): a file a running sweep is
    # writing is that sweep's checkpoint, and replacing it throws its saved points away.
    refuse_if_being_written(target)
    return target


def prepare_output_directory(path) -> None:
    """Make sure the folder of ``path`` exists (creating it, and saying so) and is writable.

    Shipped configs write to ``results/`` relative to the current directory: run from elsewhere,
    that folder is missing, and creating it is what the user wants.
    """
    directory = os.path.dirname(os.path.abspath(path))
    if os.path.exists(directory) and not os.path.isdir(directory):
        raise UsageError(f"output {path}: {directory} is a file, not a directory")
    if not os.path.isdir(directory):
        blocker = directory
        while not os.path.exists(blocker):
            blocker = os.path.dirname(blocker)
        if not os.path.isdir(blocker):
            raise UsageError(f"output {path}: {blocker} is a file, not a directory")
        try:
            os.makedirs(directory, exist_ok=True)
        except OSError as error:
            raise UsageError(f"output directory {directory} does not exist and cannot be created "
                             f"({error.strerror or error}); choose another with -o") from None
        notice(f"Created the output folder {directory}")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise UsageError(f"output directory {directory} is not writable (output: {path})")
    _probe_directory(directory, path)


# Why a folder cannot hold a new file at all, whoever asks; a full disk or quota is not among them:
# the write then says what it needs (write_failure), exit 1, as for a file that stops growing.
_UNWRITABLE_FOLDER = {errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOENT, errno.ENOTDIR}


def _probe_directory(directory, path) -> None:
    """Create and remove an empty file in ``directory``: os.access answers from permission bits,
    which root passes everywhere, and says yes to /proc, /sys and a read-only mount, where a run
    then computed its first chunk (a figure was drawn) before failing, exit 1. The probe is named
    as a temporary file is, so a kill between its two steps leaves what the next write removes."""
    probe = temporary_path(path)
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as error:
        if error.errno not in _UNWRITABLE_FOLDER:
            return
        raise UsageError(f"output directory {directory} is not writable: a file cannot be created there "
                         f"({error.strerror or error}; output: {path})") from None
    os.close(fd)
    try:
        os.remove(probe)
    except OSError:
        pass


_HOST = re.sub(r"[^A-Za-z0-9_-]", "_", socket.gethostname().split(".")[0]) or "host"
# After ".NAME.": HOST.PID.TAG.tmp; TAG is 8 random hex digits and 8 more that sign the name
# (_signature), or 8 alone from vrsweep before names were signed (and PID.TAG.tmp before hosts).
_TEMPORARY_TAIL = re.compile(
    r"(?:(?P<host>[A-Za-z0-9_-]+)\.)?(?P<pid>\d+)\.(?P<tag>[0-9a-f]{8})(?P<signature>[0-9a-f]{8})?\.tmp")


def _signature(base, host, pid, tag) -> str:
    """What makes a temporary name vrsweep's own: a file of the user's named like one by chance (or
    by a tool of theirs) carries it with a chance of 2^-32, and is never removed."""
    import hashlib

    # surrogateescape: a name that is not UTF-8 (café.h5 in Latin-1 under LC_ALL=C) reaches Python
    # as lone surrogates, and its bytes are what the name is
    text = f"vrsweep temporary of {base} by {host} {pid} {tag}"
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()[:8]


def temporary_path(path) -> str:
    """A new temporary name beside ``path`` (same folder, so the final rename stays on one file
    system) that says which host and process wrote it, signed as vrsweep's."""
    directory, base = os.path.split(os.path.abspath(path))
    pid, tag = os.getpid(), uuid.uuid4().hex[:8]
    return os.path.join(directory, f".{base}.{_HOST}.{pid}.{tag}{_signature(base, _HOST, pid, tag)}.tmp")


def _process_alive(pid) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


_named_temporaries = set()


def clean_stale_temporaries(path) -> None:
    """Remove the temporary files that killed writers of ``path`` left beside it; name the rest.

    A temporary file is stale when no process holds it locked and the process that wrote it (its
    name says which, on which host) is gone. One written on another host, or by a process of
    unknown host, cannot be judged from here: it is named on stderr, and left alone. So is a name
    without vrsweep's signature (_signature): a file of the user's named like a temporary one (or
    one of a vrsweep before names were signed) was removed by the pattern alone.
    """
    directory, base = os.path.split(os.path.abspath(path))
    try:
        names = os.listdir(directory)
    except OSError:
        return
    prefix = f".{base}."
    for name in sorted(names):
        match = _TEMPORARY_TAIL.fullmatch(name[len(prefix):]) if name.startswith(prefix) else None
        if not match:
            continue
        temporary = os.path.join(directory, name)
        if being_written(temporary):
            continue  # another process is writing it right now
        pid, host = int(match.group("pid")), match.group("host")
        signed = match.group("signature") == _signature(base, host, match.group("pid"), match.group("tag"))
        if host == _HOST and signed and not _process_alive(pid):
            try:
                os.remove(temporary)
            except OSError:
                continue
            notice(f"Removed {temporary}, left by an interrupted vrsweep (process {pid})")
        elif (host != _HOST or pid != os.getpid()) and temporary not in _named_temporaries:
            _named_temporaries.add(temporary)  # once: a run writes its output more than once
            writer = f"process {pid} on {host}" if host else f"process {pid}"
            notice(f"Note: {temporary} looks like a temporary file left by vrsweep ({writer}); "
                   "delete it if that process is no longer running")


_SCRATCH_TAIL = re.compile(r"(?P<host>[A-Za-z0-9_-]+)\.(?P<pid>\d+)\.[A-Za-z0-9_]+")
# The file that marks a folder as scratch_folder's own, and what it says: a folder of the user's
# named like one (vrsweep-HOST.PID.anything, a pid long gone) was removed with all it held.
SCRATCH_MARKER = ".vrsweep-scratch"
# What vrsweep writes in its scratch folder: the marker, its results file, their temporary names.
_SCRATCH_FILES = re.compile(r"\.vrsweep-scratch|(?:\.)?(?:sweep|trajectory)\.h5(?:\..+\.tmp)?")


# A scratch folder of vrsweep before the marker: tempfile's 8 characters (0.1.0 to 0.6.8), or
# HOST.PID.tag (0.6.9 to 0.7.2). Never removed (vrsweep cannot tell it made it), but named, once.
_UNMARKED_SCRATCH_TAIL = re.compile(r"[a-z0-9_]{8}")
_named_scratch = set()


def _scratch_marker_text(host, pid) -> str:
    return f"vrsweep scratch folder of process {pid} on {host}: removed when that process is gone\n"


def _name_unmarked_scratch(folder, pid=None) -> None:
    """One line, once a process, for a folder of this user's in TMPDIR that looks like the scratch
    folder of a killed vrsweep of a version that made no marker: it may hold a file as large as a
    grid, and nothing else will ever say it is there. Only a folder holding nothing but what vrsweep
    writes there (and something) is named; it is not removed: a folder of the user's may look so."""
    if folder in _named_scratch:
        return
    try:
        if not os.path.isdir(folder) or os.path.islink(folder) or os.stat(folder).st_uid != os.getuid():
            return
        items = os.listdir(folder)
        paths = [os.path.join(folder, item) for item in items]
        if not items or SCRATCH_MARKER in items or not all(
                _SCRATCH_FILES.fullmatch(item) and os.path.isfile(path) and not os.path.islink(path)
                for item, path in zip(items, paths)):
            return
        size = sum(os.path.getsize(path) for path in paths)
    except (OSError, AttributeError):  # AttributeError: no os.getuid (Windows)
        return
    _named_scratch.add(folder)
    process = f"process {pid}, gone" if pid is not None else "process unknown"
    notice(f"Note: {folder} looks like the scratch folder of a vrsweep interrupted before scratch folders "
           f"were marked ({process}; {format_bytes(size)}): it is kept, as vrsweep cannot tell it made it; "
           "delete it if no vrsweep is using it")


def _own_stale_scratch(folder, host, pid) -> bool:
    """Whether ``folder`` is a scratch folder vrsweep made (its marker says so, for this host and
    process), holding only what vrsweep writes there, none of it being written."""
    try:
        if not os.path.isdir(folder) or os.path.islink(folder) or os.stat(folder).st_uid != os.getuid():
            return False  # another user's folder in a shared TMPDIR is theirs to remove
        marker = os.path.join(folder, SCRATCH_MARKER)
        if os.path.islink(marker) or not os.path.isfile(marker):
            return False
        with open(marker, encoding="utf-8", errors="replace") as handle:
            if handle.read(4096) != _scratch_marker_text(host, pid):
                return False
        items = os.listdir(folder)
        return all(_SCRATCH_FILES.fullmatch(item) and not os.path.islink(os.path.join(folder, item))
                   and os.path.isfile(os.path.join(folder, item)) for item in items) \
            and not any(being_written(os.path.join(folder, item)) for item in items)
    except (OSError, AttributeError):  # AttributeError: no os.getuid (Windows)
        return False


@contextmanager
def scratch_folder():
    """A new folder in the system's temporary folder (``TMPDIR``), removed when the block ends;
    its name says which host and process made it, like a temporary file beside an output, and a
    marker file in it (SCRATCH_MARKER) that vrsweep made it.

    A process killed inside the block (``kill -9``, a notebook's kernel restarted) cannot remove
    it, and it holds a file as large as the grid: so the folders of this host's processes that
    are gone are removed first, with a line each, as :func:`clean_stale_temporaries` does. Only
    a folder with vrsweep's marker, holding nothing but what vrsweep writes there, is removed: a
    folder of the user's that is merely named like one is never touched.
    """
    import tempfile

    root = tempfile.gettempdir()
    try:
        names = os.listdir(root)
    except OSError:
        names = []
    for name in sorted(names):
        if not name.startswith("vrsweep-"):
            continue
        folder = os.path.join(root, name)
        match = _SCRATCH_TAIL.fullmatch(name[len("vrsweep-"):])
        if not match:
            if _UNMARKED_SCRATCH_TAIL.fullmatch(name[len("vrsweep-"):]):
                _name_unmarked_scratch(folder)
            continue
        if match.group("host") != _HOST or _process_alive(int(match.group("pid"))):
            continue
        if not _own_stale_scratch(folder, match.group("host"), match.group("pid")):
            _name_unmarked_scratch(folder, match.group("pid"))  # says nothing of a folder with a marker
            continue  # not vrsweep's, or its process id was reused, or a file is shared: leave it
        for item in os.listdir(folder):
            if not _SCRATCH_FILES.fullmatch(item):
                continue  # appeared since the check: not vrsweep's, and the folder stays
            try:
                os.remove(os.path.join(folder, item))
            except OSError:
                pass
        try:
            os.rmdir(folder)
        except OSError:
            continue
        notice(f"Removed {folder}, left by an interrupted vrsweep (process {match.group('pid')})")
    with tempfile.TemporaryDirectory(prefix=f"vrsweep-{_HOST}.{os.getpid()}.") as folder:
        with open(os.path.join(folder, SCRATCH_MARKER), "w", encoding="utf-8") as handle:
            handle.write(_scratch_marker_text(_HOST, os.getpid()))
        yield folder


# --------------------------------------------------------------------------------------------
# Atomic writes
# --------------------------------------------------------------------------------------------


def fsync_path(path) -> None:
    with open(path, "rb") as handle:
        os.fsync(handle.fileno())


def _fsync_directory(directory) -> None:
    try:  # make a rename durable; not possible everywhere, harmless to skip
        dir_fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
    except OSError:
        pass


def _rename_without_replacing(tmp, path) -> None:
    """Rename ``tmp`` to ``path`` unless something is at ``path`` (UsageError then).

    A hard link is made and the temporary name removed: unlike a rename, a link never replaces.
    Where the file system has no hard links, the check and the rename are separate steps.
    """
    appeared = UsageError.naming("output {path} appeared while this command was writing it (a second run or "
                                 "merge of the same output?): it is kept and this command's file is not; "
                                 "choose another output, or pass {overwrite} to replace it",
                                 {"overwrite": "overwrite=True"}, path=path)
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise appeared from None
    except OSError as error:
        if error.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK, errno.ENOSYS):
            raise
        if os.path.lexists(path):  # no hard links here: as close as it can be checked
            raise appeared from None
        os.replace(tmp, path)
        return
    os.remove(tmp)


@contextmanager
def replacing(path, needed_bytes=None, before_replace: Callable[[], None] | None = None,
              doing="write"):
    """Yield a temporary path beside ``path``; when the block ends, rename it over ``path``.

    The block writes (and makes durable) the whole new file at the temporary path; an HDF5 file
    written there must be opened with :func:`writing_hdf5` (or be guarded by
    :func:`closed_without_writing_on_failure`). If the block fails, the temporary file is removed
    and a file-system error becomes a one-line OutputError (with ``needed_bytes``, the size of
    the new file, when the disk is full). ``before_replace`` runs just before the rename (a
    writer checks there that ``path`` is still its own file). By default it refuses a ``path``
    that another process is writing: the block may have taken minutes (a merge), and a sweep that
    started on the path meanwhile would lose its saved points to the rename.

    Where nothing was at ``path`` when the block began (the caller's output rule judged an empty
    path), nothing is replaced at the end either: a file that appeared meanwhile (a second run or
    merge of the same output, finished first) is kept, and the block's file is refused.
    """
    path = os.fspath(path)
    if before_replace is None:
        def before_replace():
            refuse_if_being_written(path)
    prepare_output_directory(path)
    clean_stale_temporaries(path)
    may_replace = os.path.lexists(path)
    tmp = temporary_path(path)
    try:
        yield tmp
        before_replace()
        if may_replace:
            os.replace(tmp, path)
        else:
            _rename_without_replacing(tmp, path)
    except BaseException as error:  # KeyboardInterrupt too: never leave the temporary file behind
        written_bytes = None
        try:
            written_bytes = os.path.getsize(tmp)  # when the size needed is not known, say this
            os.remove(tmp)
        except FileNotFoundError:
            pass
        except OSError:
            pass  # its folder is gone, or worse: the error below says what matters
        failure = write_failure(path, error, needed_bytes, doing, written_bytes)
        if failure is None or failure is error:
            raise
        raise failure from None
    _fsync_directory(os.path.dirname(os.path.abspath(path)))


def atomic_write(path, write_fn: Callable[[str], object], needed_bytes=None, doing="write"):
    """Write a whole file so that ``path`` holds either the old file or the complete new one.

    ``write_fn(tmp_path)`` writes the file at a temporary name in the same directory; the result
    is fsynced and renamed over ``path``. If anything fails, the temporary file is removed and
    nothing changes at ``path`` (see :func:`replacing` for the error raised). Returns what
    ``write_fn`` returns.
    """
    with replacing(path, needed_bytes, doing=doing) as tmp:
        result = write_fn(tmp)
        fsync_path(tmp)
    return result


def write_bytes(path, data: bytes, doing="write") -> None:
    """Write ``data`` to ``path`` atomically (figures: rendered in memory, then saved)."""

    def write(tmp):
        with open(tmp, "wb") as handle:
            handle.write(data)

    atomic_write(path, write, needed_bytes=len(data), doing=doing)
