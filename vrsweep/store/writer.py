"""Writing a result file: create it, fill it point by point (the checkpoint), resume it, finish it.

Why crash-safe
--------------
Datasets are chunked (about 4 KiB per chunk, trailing axes whole, so a C-order run of points
touches few chunks), uncompressed and allocated at creation time (``H5D_ALLOC_TIME_EARLY``). After
``create`` the file's metadata therefore never changes while points are written: a write only
overwrites raw bytes at fixed places. ``write_points`` writes the values (``status`` last, after
the others are flushed: the record a cut chunk of ``done`` is made again from), flushes and fsyncs,
and only then sets ``done`` and flushes again, so a point is never marked done before its values
are on disk. A chunk is rewritten in place, with the points already in it unchanged: a kill in the
middle of that write leaves it part new, part old, failing its checksum, and ``open_for_resume``
recovers it (store/torn.py). ``finish`` works on a copy and renames it into place, so a crash
while finishing leaves the checkpoint as it was. Compression is deliberately off: compressed
chunks change size and would make every write a metadata update.

File locking (shared and NFS file systems)
------------------------------------------
HDF5 locks files it opens (a writer excludes readers). On file systems where locks are not
supported (some NFS and Lustre mounts) HDF5 would refuse to open anything, so when the
``HDF5_USE_FILE_LOCKING`` environment variable is *not* set, vrsweep asks h5py for
``locking="best-effort"`` (lock where possible, carry on where locking is disabled). When
``HDF5_USE_FILE_LOCKING`` is set (``FALSE`` is the usual advice on NFS), vrsweep passes nothing and
"""

from __future__ import annotations

import math
import os

import h5py
import numpy as np

from vrsweep.errors import ResultFileError, UsageError
from vrsweep.store import torn
from vrsweep.store.fileio import (
    LIBVER, check_still_at_path, close_without_writing, fsync_path, identity, notice,
    lock_for_writing, output_target, refuse_if_being_written, replacing, reserve_space, trim_to_contents, write_failure,
    writing_hdf5,
)
from vrsweep.store.layout import (
    VariableSpec, add_extras, build_skeleton, creation_reserve, decode, finish_reserve, point_variables_of, scale_names,
)
from vrsweep.store.reader import RDCC_NBYTES, RDCC_NSLOTS, corrupt_error, open_checked, open_store_file


# How the writer's messages name what the caller can do; a command names its flags instead
# (commands.options.OUTPUT_FLAGS), through VrsweepError.reworded.
ARGUMENT_WORDS = {"overwrite": "overwrite=True", "resume": "ResultWriter.open_for_resume",
                  "start_afresh": "create it with ResultWriter.create"}


def _copy_open_file(fd, destination, size, block=1 << 20):
    """Copy the first ``size`` bytes of the open file ``fd`` (positioned reads: HDF5 shares it)."""
    with open(destination, "wb") as out:
        reserve_space(out.fileno(), size)  # a full disk fails here, at once
        offset = 0
        while offset < size:
            data = os.pread(fd, min(block, size - offset), offset)
            if not data:
                break
            out.write(data)
            offset += len(data)


def first_difference(a: str, b: str) -> str:
    """Describe the first line where two texts differ (for 'different config' messages)."""
    la, lb = a.splitlines(), b.splitlines()
    for i in range(max(len(la), len(lb))):
        x = la[i] if i < len(la) else "<end of text>"
        y = lb[i] if i < len(lb) else "<end of text>"
        if x != y:
            return f"first difference at line {i + 1}: {x.strip()!r} vs {y.strip()!r}"
    return "they differ only in whitespace at line ends"


def _fsync(h5file):
    """Push the file's bytes to stable storage (ordering values before their done flags)."""
    try:
        fd = h5file.id.get_vfd_handle()
        os.fsync(fd)
    except (OSError, ValueError, TypeError, NotImplementedError):  # driver without a plain fd
        pass


# A chunk's points that make up at least this share of the grid's rows they fall in (a slab along
# the first axis) are written as that slab, read, updated in memory and written back: HDF5's point
# selection costs about 0.3 us per element, a slab's read and write a few ns per byte (a GPU's
# chunks of 131,072 shuffled points of a 512 x 512 map: 32 ms a variable as points, 3 ms as a slab;
# at a thirtieth of the slab the points were faster, 17 against 37 ms).
SLAB_WRITE_SHARE = 1 / 16


def _write_selection(ds, grid_shape, idx, array):
    """Write ``array`` (n, *extra) at grid points ``idx`` (sorted flat indices) of ``ds``."""
    array = np.ascontiguousarray(array, dtype=ds.dtype)
    if not grid_shape:  # one point: the whole (0-d or extra-dims-only) dataset
        ds[()] = array[0]
        return
    extra = array.shape[1:]
    n = idx.size
    if n == math.prod(grid_shape):  # the whole grid (a single chunk run, or a merge)
        ds[()] = array.reshape(grid_shape + extra)
        return
    row = math.prod(grid_shape[1:])  # points per index of the first axis
    first, last = int(idx[0]) // row, int(idx[-1]) // row + 1
    if n >= SLAB_WRITE_SHARE * (last - first) * row:
        # (the other points' values are written back as read: a resumed file's too)
        slab = ds[first:last]
        slab.reshape((-1,) + extra)[idx - first * row] = array
        ds[first:last] = slab
        return
    # An HDF5 point selection: exactly these elements, in this order; the chunk cache keeps
    # the read-modify-write of partially written chunks in memory.
    grid = np.stack(np.unravel_index(idx, grid_shape), axis=-1)  # (n, n_axes)
    if extra:
        m = math.prod(extra)
        inner = np.stack(np.unravel_index(np.arange(m), extra), axis=-1)  # (m, n_extra)
        coords = np.concatenate(
            [np.repeat(grid, m, axis=0), np.tile(inner, (n, 1))], axis=1)
    else:
        coords = grid
    fspace = ds.id.get_space()
    fspace.select_elements(np.ascontiguousarray(coords, dtype=np.uint64))
    mspace = h5py.h5s.create_simple((coords.shape[0],))
    ds.id.write(mspace, fspace, array.reshape(-1))


class ResultWriter:
    """A result file being filled: the checkpoint of a sweep. Use ``create`` or ``open_for_resume``."""

    def __init__(self, path, h5file, action="write"):
        self.path = os.fspath(path)
        self._file = h5file
        # The writer holds its file open from creation to finish and never reopens it by path:
        # it checks instead that the path still names this very file (see _check_still_mine).
        self._fd = h5file.id.get_vfd_handle()
        self._identity = identity(self._fd)
        lock_for_writing(self._fd, self.path, action)  # refuses a second writer (held already after create)
        if action == "resume" and not decode(h5file.attrs["vrsweep_complete"]):
            self._repair_torn_chunks(h5file)
        done = h5file["done"]
        self.axis_names = scale_names(done) if done.ndim else ()
        self.grid_shape = tuple(done.shape)
        self.n_points = math.prod(self.grid_shape)
        self.point_variables = point_variables_of(h5file)
        self._done = np.array(done[()], dtype=bool)  # 0-d array, not a scalar, for one point
        self._owned = np.array(h5file["owned"][()], dtype=bool) if "owned" in h5file else None
        self._extra_shapes = {}
        for name in self.point_variables:
            ds = h5file[name]
            self._extra_shapes[name] = tuple(ds.shape[len(self.grid_shape):])

    # -- construction ---------------------------------------------------------------------

    @classmethod
    def create(cls, path, axes, variables, attrs, overwrite=False, owned_mask=None,
               extra_coords=None, inputs=()):
        """Create a result file with every variable pre-allocated; return a writer on it.

        axes: ``[(name, values)]`` (or ``(name, values, attrs)``) in sweep order; ``[]`` for one
        point. variables: ``VariableSpec`` list. attrs: root attributes, ``config`` required
        (``shard`` = "I/N" for a shard file, with ``owned_mask`` its points). extra_coords:
        optional ``{dim: (values, attrs)}`` for extra dimensions (default: an int32 index).
        Refuses an existing ``path`` unless ``overwrite``, and whatever fileio.output_target
        refuses (anything but a regular file, one of ``inputs``); a symbolic link is followed.
        """
        given = os.fspath(path)
        path = output_target(given, overwrite=overwrite, inputs=inputs, inputs_are="the config being run",
                             kind="sweep", exists_error=lambda: UsageError.naming(
            "output {path} already exists: pass {overwrite} to replace it, or {resume} to continue the run that "
            "wrote it", ARGUMENT_WORDS, path=given))
        specs = [v if isinstance(v, VariableSpec) else VariableSpec(**v) for v in variables]
        reserve = creation_reserve(axes, specs, shard=owned_mask is not None)

        # Built under a temporary name and renamed into place while still open: the writer
        # keeps the very file it built, never a file that someone else put at the path since.
        f = None
        try:
            with replacing(path, reserve, doing="create") as tmp:
                # HDF5 1.8 object headers carry checksums, so damaged metadata is caught too.
                f = open_store_file(tmp, "w", track_order=True, libver=LIBVER)
                fd = f.id.get_vfd_handle()
                # Locked before it has a name others look for: a --resume that finds it renamed
                # into place meets its writer's lock, never a file without one.
                lock_for_writing(fd, path)
                reserve_space(fd, reserve)  # a full disk fails here, before HDF5 writes anything
                build_skeleton(f, list(axes), specs, dict(attrs), extra_coords, owned_mask)
                f.flush()
                trim_to_contents(f)
                _fsync(f)
        except BaseException:
            # Also when the rename is refused (the path was taken meanwhile): the built file stays
            # open in HDF5 otherwise, its temporary name gone.
            if f is not None:
                close_without_writing(f)
            raise
        try:
            return cls(path, f)
        except BaseException:
            close_without_writing(f)
            raise

    @classmethod
    def open_for_resume(cls, path, expected_config_text: str, expected_shard=None, inputs=()):
        """Reopen an unfinished (or finished) result file to compute what is missing.

        Raises ResultFileError if it is not a vrsweep result file, is truncated, has another
        format version, was written from a different config, or (if ``expected_shard`` is given)
        belongs to another shard.
        """
        path = os.fspath(path)
        if not os.path.exists(path):
            raise ResultFileError.naming("cannot resume: {path} does not exist ({start_afresh})", ARGUMENT_WORDS,
                                         path=path)
        # Also where HDF5's own locking is switched off; before output_target, whose refusal would
        # say "replace" (a link is followed by the open either way).
        refuse_if_being_written(path, "resume")
        # A link: its target, as create does.
        path = output_target(path, overwrite=True, inputs=inputs, inputs_are="the config being run")
        f = open_checked(path, "r+")
        try:
            _check_same_run(f, path, expected_config_text, expected_shard)
            return cls(path, f, action="resume")
        except (ResultFileError, UsageError):
            f.close()
            raise
        except (OSError, KeyError, ValueError) as error:
            f.close()
            raise corrupt_error(path, error) from None

    @staticmethod
    def done_for_resume(path, expected_config_text: str, expected_shard=None) -> np.ndarray:
        """The ``done`` flags ``open_for_resume`` would find in ``path`` (after the same checks and
        the same recovery of chunks a kill cut), read without writing anything: for ``run
        --dry-run --resume``, which says how much is left. ResultFileError as open_for_resume."""
        path = os.fspath(path)
        refuse_if_being_written(path, "resume")
        try:
            with open_checked(path, "r") as f:
                _check_same_run(f, path, expected_config_text, expected_shard)
                recovery, values = torn.find(f)
                done = recovery.done if recovery is not None else values["done"]
                return np.asarray(done) == 1
        except (ResultFileError, UsageError):
            raise
        except (OSError, KeyError, ValueError) as error:
            raise corrupt_error(path, error) from None

    def _repair_torn_chunks(self, h5file):
        """Put back what a kill cut mid-write (store/torn.py): chunks whose checksum fails are
        recovered exactly where their checksum confirms it, else their points are computed again;
        one line says which. Values of points not done (a write a kill stopped before its flags)
        go back to their fill value, so that a later cut chunk is always one that can be told.
        Every chunk is read once."""
        recovery, _ = torn.find(h5file)  # an error: open_for_resume's "corrupt", the file closed
        if recovery is None:
            return
        torn.repair(h5file, recovery, _fsync)
        if recovery.n_torn:
            notice(f"Note: {recovery.describe(self.path)}")

    # -- state ----------------------------------------------------------------------------

    def done_mask(self) -> np.ndarray:
        """Boolean mask over the grid: True where a point has been written."""
        return self._done.copy()

    def owned_mask(self):
        """Boolean mask of this shard's points, or None for a whole run."""
        return None if self._owned is None else self._owned.copy()

    @property
    def complete(self) -> bool:
        return bool(decode(self._file.attrs["vrsweep_complete"]))

    def read_variables(self, names) -> dict:
        """The named variables as written so far, read from the file this writer holds (never by
        path: the path may since name another file)."""
        return {name: self._file[name][()] for name in names}

    # -- writing --------------------------------------------------------------------------

    def write_points(self, flat_indices, values) -> None:
        """Write points (flat C-order indices over the grid) for every point variable, then flush.

        ``values[name]`` has shape ``(n,) + extra dims``. The values are flushed (and fsynced)
        before the points are marked done, so a crash never leaves a point marked done without its
        values.
        """
        idx = np.asarray(flat_indices, dtype=np.int64).reshape(-1)
        n = idx.size
        if n == 0:
            return
        if set(values) != set(self.point_variables):
            raise ValueError(f"write_points needs exactly {sorted(self.point_variables)}, "
                             f"got {sorted(values)}")
        if idx.min() < 0 or idx.max() >= self.n_points:
            raise ValueError(f"flat indices must be in [0, {self.n_points})")
        order = np.argsort(idx, kind="stable")  # sorted indices walk the chunks in file order
        idx = idx[order]
        if n > 1 and np.any(idx[1:] == idx[:-1]):
            raise ValueError("write_points got the same flat index twice")
        if self._owned is not None and not self._owned.reshape(-1)[idx].all():
            raise ValueError("write_points got points this shard does not own")

        arrays = {}
        for name in self.point_variables:
            array = np.asarray(values[name])
            expected = (n,) + self._extra_shapes[name]
            if array.shape != expected:
                raise ValueError(f"values[{name!r}] has shape {array.shape}, expected {expected}")
            arrays[name] = array[order]

        self._check_still_mine()
        try:
            # status last, after the others are flushed: a status other than -1 then says that the
            # point's values are all written, the record a torn chunk of done is rebuilt from
            # (store/torn.py). One fsync before done suffices: a chunk of done is only ever cut
            # after every value of its points reached the disk.
            later = [torn.COMPLETION] if torn.COMPLETION in arrays else []
            for name, array in arrays.items():
                if name not in later:
                    _write_selection(self._file[name], self.grid_shape, idx, array)
            for name in later:
                self._file.flush()
                _write_selection(self._file[name], self.grid_shape, idx, arrays[name])
            self._file.flush()
            _fsync(self._file)
            _write_selection(self._file["done"], self.grid_shape, idx, np.ones(n, dtype=np.int8))
            self._file.flush()
        except Exception as error:
            failure = write_failure(self.path, error, os.fstat(self._fd).st_size, doing="save points to")
            if failure is None:
                raise
            raise failure from None
        self._done.reshape(-1)[idx] = True

    def finish(self, extra=None, coords=None, attributes=None) -> None:
        """Add derived variables (and root ``attributes``), mark the file complete, and close it.

        extra: ``{name: (array, dims, attrs)}``; dims name sweep axes, extra dims, or new dims
        (given values in ``coords = {dim: (values, attrs)}``, else an int32 index). The work is
        done on a copy renamed into place, so a crash here leaves the checkpoint intact. The copy
        is read from the file this writer holds (still locked), not from the path.
        """
        try:
            self._check_still_mine()
            self._file.flush()
            _fsync(self._file)
            size = os.fstat(self._fd).st_size
            reserve = finish_reserve(extra)

            with replacing(self.path, size + reserve, before_replace=self._check_still_mine,
                           doing="finish") as tmp:
                _copy_open_file(self._fd, tmp, size)
                with writing_hdf5(tmp, "r+", reserve=reserve, rdcc_nbytes=RDCC_NBYTES,
                                  rdcc_nslots=RDCC_NSLOTS) as f:
                    add_extras(f, extra, coords, attributes)
                    f.attrs.modify("vrsweep_complete", np.int32(1))  # in place: keeps attribute order
                fsync_path(tmp)
        except BaseException:
            self.abandon()  # the checkpoint stays as it was: --resume finishes it
            raise
        self.close()

    def _check_still_mine(self):
        check_still_at_path(self.path, self._identity)

    def close(self) -> None:
        """Flush and close (the file stays a resumable checkpoint). Idempotent.

        If the flush fails (a full disk), the file is closed without writing, keeping its last
        successful flush, and the error is raised.
        """
        f, self._file = self._file, None
        if f is None or not f.id.valid:
            return
        try:
            f.flush()
            f.close()
        except BaseException as error:
            close_without_writing(f)
            failure = write_failure(self.path, error, doing="save")
            if failure is None:
                raise
            raise failure from None

    def abandon(self) -> None:
        """Close after a failure, never raising: what is on disk is the last successful flush."""
        try:
            self.close()
        except Exception:  # noqa: BLE001 - the error that made us abandon is the one to report
            pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.abandon()


def _check_same_run(f, path, expected_config_text, expected_shard):
    """ResultFileError unless the open file ``f`` was written from this config, for this shard:
    the checks before a resume, shared by open_for_resume and done_for_resume."""
    stored = decode(f.attrs.get("config", ""))
    if stored != expected_config_text:
        raise ResultFileError.naming(
            "cannot resume: {path} was written from a different config ({difference}); "
            "pass {overwrite} to replace it", ARGUMENT_WORDS, path=path,
            difference=first_difference(stored, expected_config_text))
    shard = decode(f.attrs.get("shard")) if "shard" in f.attrs else None
    if expected_shard is not None or shard is not None:
        if shard != expected_shard:
            raise ResultFileError.naming(
                "cannot resume: {path} holds shard {found}, not {expected}; pass {overwrite} to replace it",
                ARGUMENT_WORDS, path=path, found=shard or "none (a whole run)",
                expected=expected_shard or "a whole run")
