"""Opening an existing result file: the checks every reader shares, and its metadata without its data.

:func:`open_checked` opens a file only if it is a vrsweep result of a format this version reads,
and :func:`corrupt_error` turns whatever HDF5 says about a damaged or locked file into one line
(ResultFileError, exit 2). :class:`StoredLayout` reads what the layout module wrote (axes,
variables, their dimensions, types and attributes) without reading a variable's values: the
merge streams the values block by block, and ``vrsweep.open_results`` reads them lazily through
xarray. Every file is opened through ``fileio.open_hdf5`` (the locking policy).
"""

from __future__ import annotations

import os

import h5py
import numpy as np

from vrsweep.errors import ResultFileError, clip
from vrsweep.store.fileio import KIND_WORDS, NAMED_KINDS, _errno_of, open_hdf5, refuse_a_special_file
from vrsweep.store.layout import (
    BOOKKEEPING, FORMAT_VERSION, VariableSpec, clean_attrs, decode, point_label, point_variables_of, scale_names,
)
from vrsweep.store.sealing import SWEEP_UNSEALED, check_attributes, note_if_unprotected, unless_changed

# Chunk cache per open dataset: a scattered write (a shard's points) revisits the same chunks.
RDCC_NBYTES = 32 * 1024 * 1024
RDCC_NSLOTS = 10007  # a prime, ~100x the chunks that fit in the cache


def open_store_file(path, mode, **kwargs):
    """A result file, with the chunk cache its writes need. Read only, it keeps HDF5's default
    cache (1 MiB): the check of every checksum (check_structure) reads each chunk once, in order,
    and the 32 MiB cache filled during that read was 32 MiB more of a merge's peak per shard
    checked (2 shards of a 73 MiB result: 124 MiB where 92 MiB are needed)."""
    if mode == "r":
        return open_hdf5(path, mode, **kwargs)
    return open_hdf5(path, mode, rdcc_nbytes=RDCC_NBYTES, rdcc_nslots=RDCC_NSLOTS, **kwargs)


def open_checked(path, mode="r"):
    """Open ``path`` as a vrsweep file of a format this version reads, or raise ResultFileError."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ResultFileError(f"results file not found: {path}")
    if os.path.isdir(path):
        raise ResultFileError(f"{path} is a directory, not a results file")
    refuse_a_special_file(path)
    if os.path.getsize(path) == 0:
        raise ResultFileError(f"{path} is empty (0 bytes): truncated or never written")
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError as error:
        raise ResultFileError(f"cannot read {path}: {error.strerror or error}") from None
    if not is_hdf5:
        raise ResultFileError(f"{path} is not an HDF5 file (so not a vrsweep results file)")
    try:
        f = open_store_file(path, mode)
    except OSError as error:
        raise corrupt_error(path, error, writing=mode != "r") from None
    try:
        if "vrsweep_format_version" not in f.attrs:
            raise ResultFileError(f"{path} is an HDF5 file but not a vrsweep results file "
                                  "(no vrsweep_format_version attribute)")
        version = _whole_number_attr(f, "vrsweep_format_version", path)
        # (a refusal for what an attribute says names the checksum too where the attributes fail it)
        if version > FORMAT_VERSION:
            raise ResultFileError(f"{path} was written by a newer vrsweep (format {version}; this "
                                  f"vrsweep reads format {FORMAT_VERSION}); upgrade vrsweep to read it"
                                  + unless_changed(f, path))
        if version < FORMAT_VERSION:
            raise ResultFileError(f"{path} was written by an older vrsweep (format {version}; this "
                                  f"vrsweep reads format {FORMAT_VERSION})" + unless_changed(f, path))
        if "done" not in f or "point_variables" not in f["done"].attrs:
            # A trajectory, a branch or curves say what they are: "not a sweep result (no 'done'
            # mask)" named what a sweep's file has, not what this file is.
            kind = f.attrs.get("vrsweep_file", "")
            kind = kind.decode(errors="replace") if isinstance(kind, bytes) else kind
            what = KIND_WORDS[kind] if isinstance(kind, str) and kind in NAMED_KINDS else "a vrsweep file"
            raise ResultFileError(f"{path} is {what} but not a sweep's results (no 'done' mask)"
                                  + unless_changed(f, path))
        check_structure(f, path)
    except ResultFileError:
        f.close()
        raise
    except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        f.close()
        raise corrupt_error(path, error) from None
    return f


# Root attributes vrsweep reads back, and what they must be. Every other attribute is shown as it is.
TEXT_ROOT_ATTRS = ("config", "model", "shard", "title", "history", "created", "vrsweep_version")
# Bytes read at a time while checking checksums: the check costs one read of the file, not its size
# in memory. A few MiB, as merge's blocks (store/merge.BLOCK_BYTES): at 64 MiB the check of each
# shard, not the merge, set a merge's peak (242 MiB for 2 shards of a 122 MiB result, 143 MiB with
# 4 MiB blocks), and the chunks, of a few kB, read no faster in larger blocks.
CHECK_BLOCK_BYTES = 4 * 2 ** 20


def _whole_number_attr(f, name, path, allowed=None):
    """The root attribute ``name`` as an int, or ResultFileError if it is not a whole number (in ``allowed``)."""
    value = f.attrs[name]
    if isinstance(value, np.ndarray) and value.shape == (1,):
        value = value[0]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ResultFileError(f"{path} is corrupt: attribute {name} must be a whole number, got {_shown(value)}")
    if allowed is not None and int(value) not in allowed:
        raise ResultFileError(f"{path} is corrupt: attribute {name} must be one of "
                              f"{', '.join(map(str, allowed))}, got {int(value)}")
    return int(value)


def _shown(value):
    text = repr(decode(value) if not isinstance(value, np.ndarray) else value.tolist())
    return clip(text)


def _text_attr(obj, name, path, where="attribute"):
    value = obj.attrs[name]
    if isinstance(value, bytes):
        try:
            return value.decode("utf-8")
        except UnicodeDecodeError:
            pass
    elif isinstance(value, str):
        return value
    raise ResultFileError(f"{path} is corrupt: {where} {name} must be text, got {_shown(value)}")


def check_structure(f, path):
    """Everything a reader relies on, checked once where the file is opened (ResultFileError, one
    line, naming what is wrong): the root attributes vrsweep reads have their types; ``done`` spans
    the grid of the axes it names; every axis is a non-empty 1-D array of finite numbers; every
    dataset's dimensions have the lengths of their coordinates; a point variable has the type it is
    written with; and every byte reads back through its checksum: of the coordinates always (axes
    carry one in files of this version; older files' axes do not and are compared with their stored
    config), of every dataset in a finished file (an unfinished checkpoint may hold a chunk cut by
    a kill among points not yet done, which --resume writes again)."""
    from vrsweep.store.variables import LYAPUNOV_VARIABLES, point_variables

    complete = _whole_number_attr(f, "vrsweep_complete", path, allowed=(0, 1))
    if "config" not in f.attrs:
        raise ResultFileError(f"{path} is corrupt: attribute config (the config it was run from) is missing")
    for name in TEXT_ROOT_ATTRS:
        if name in f.attrs:
            _text_attr(f, name, path)
    if "shard" in f.attrs:
        index, _, count = _text_attr(f, "shard", path).partition("/")
        if not (index.isascii() and index.isdigit() and count.isascii() and count.isdigit()):
            raise ResultFileError(f"{path} is corrupt: attribute shard must be I/N, got {_shown(f.attrs['shard'])}")
    done = f["done"]
    names = _text_attr(done, "point_variables", path, "attribute done.").split()
    expected = {name: np.dtype(dtype) for name, dtype, _, _ in point_variables(_AnyIntegration) + LYAPUNOV_VARIABLES}
    axis_names = scale_names(done) if done.ndim else ()
    grid = None
    if any(not f[name].fletcher32 for name in axis_names):
        # A file written before axes had checksums: its config is all that can vouch for them.
        grid = _grid_of(_text_attr(f, "config", path))
        if grid is not None and (tuple(grid.axis_names) != axis_names or tuple(grid.shape) != done.shape):
            grid = None  # not a config this check can compare with (a hand-made file)
    for index, name in enumerate(axis_names):
        axis = f[name]
        if axis.ndim != 1 or axis.size == 0 or axis.dtype.kind != "f":
            raise ResultFileError(f"{path} is corrupt: axis {name} must be a non-empty 1-D float array, "
                                  f"got shape {axis.shape} of {axis.dtype}")
        _read_through_checksums(axis, path, finite=True)
        # The config fixes every axis value: a changed one (a bit flipped in a file whose axes
        # have no checksum) would label every point with a wrong parameter value.
        if grid is not None and not axis.fletcher32 and not np.array_equal(axis[()], grid.axis_values[index]):
            raise ResultFileError(f"{path} is corrupt: axis {name} holds values other than those of the "
                                  "config it was run from")
    _check_flags(f, path, complete)
    for name in names:
        if name not in f or not isinstance(f[name], h5py.Dataset):
            raise ResultFileError(f"{path} is corrupt: variable {name} is missing")
        variable = f[name]
        dtype = expected.get(name)
        if (dtype is not None and variable.dtype != dtype) or variable.dtype.kind not in "iuf":
            raise ResultFileError(f"{path} is corrupt: variable {name} is {variable.dtype}, "
                                  f"expected {dtype or 'numbers'}")
        dims = scale_names(variable) if variable.ndim else ()
        has_extra = name in expected and name in _EXTRA_DIMENSIONED
        if dims[:len(axis_names)] != axis_names or (name in expected and not has_extra
                                                     and len(dims) != len(axis_names)):
            raise ResultFileError(f"{path} is corrupt: variable {name} spans {_grid_words(dims, variable.shape)}, "
                                  f"the grid is {_grid_words(axis_names, done.shape)}")
    for name in f:
        obj = f[name]
        if not isinstance(obj, h5py.Dataset):
            continue
        if obj.ndim and not obj.is_scale:
            for i, scale in enumerate(scale_names(obj)):
                if scale not in f or f[scale].shape != (obj.shape[i],):
                    raise ResultFileError(f"{path} is corrupt: {name} has {obj.shape[i]} values along {scale}, "
                                          f"its coordinate has {f[scale].shape if scale in f else 'none'}")
        # An unfinished checkpoint may hold a chunk cut by a kill -9 among points not yet done,
        # which --resume writes again: only a finished file must read back whole. Coordinates are
        # written whole when a file is created, so they are read in every file.
        if complete or obj.is_scale:
            _read_through_checksums(obj, path, finite=name in axis_names)
    # After the structure: a variable replaced whole loses its attributes too, and its own message says more.
    note_if_unprotected(path, check_attributes(f, path, SWEEP_UNSEALED))


def _check_flags(f, path, complete):
    """``done`` (and a shard's ``owned``) are what every vrsweep wrote: int8 flags, 0 or 1, over the
    grid; and a file marked finished has every point (of a shard: every point it owns) done. A mask
    of another type or with other values (a damaged or hand-made file) would otherwise be read as
    flags, and a finished file missing points would be plotted and merged as if whole."""
    shape = f["done"].shape
    flags = {}  # name -> its values
    for name in ("done", "owned") if "owned" in f else ("done",):
        mask = f[name]
        if not isinstance(mask, h5py.Dataset) or mask.dtype != np.int8 or mask.shape != shape:
            got = f"{mask.shape} of {mask.dtype}" if isinstance(mask, h5py.Dataset) else "a group"
            raise ResultFileError(f"{path} is corrupt: {name} must be int8 flags over the grid {shape}, got {got}")
        if name == "done" and not complete:
            # A kill may have cut a chunk of done mid-write: store/torn.py reads what it can
            # (its flags are recovered where --resume opens the file, and by every reader).
            from vrsweep.store.torn import failing_chunks

            flags[name] = failing_chunks(mask, keep=True)[1]
        else:
            flags[name] = np.asarray(mask[()])
        if not np.isin(flags[name], (0, 1)).all():
            raise ResultFileError(f"{path} is corrupt: {name} must hold only 0 and 1")
    if complete:
        wanted = flags["owned"] == 1 if "owned" in flags else np.ones(shape, dtype=bool)
        missing = int(np.count_nonzero(wanted & (flags["done"] == 0)))
        if missing:
            raise ResultFileError(f"{path} is corrupt: it is marked finished (vrsweep_complete = 1), but "
                                  f"{missing} of its {int(np.count_nonzero(wanted))} points are not done")


def _grid_of(config_text):
    """The Grid of a stored config, or None if this version cannot read that config (then the
    file's own axes are checked without it)."""
    from vrsweep.config import parse_config
    from vrsweep.config.grid import Grid
    from vrsweep.errors import ConfigError

    try:
        return Grid.from_config(parse_config(config_text, "<the stored config>"))
    except ConfigError:
        return None


_EXTRA_DIMENSIONED = ("strobe_x", "strobe_v")


def _grid_words(names, shape):
    if not names:
        return "a single point"
    return " x ".join(f"{name} ({n})" for name, n in zip(names, shape))


class _AnyIntegration:
    """point_variables' argument for learning the variables' types: any strobe length does."""

    strobe_periods = 1
    lyapunov = False


def _read_through_checksums(dataset, path, finite=False):
    """Read every byte of ``dataset`` (block by block along its first axis): HDF5 checks each
    chunk's checksum as it reads it, so damaged bytes are an error here, not numbers later."""
    if dataset.ndim == 0:
        dataset[()]
        return
    row_bytes = max(1, dataset.dtype.itemsize * int(np.prod(dataset.shape[1:], dtype=np.int64)))
    step = max(1, CHECK_BLOCK_BYTES // row_bytes)
    for start in range(0, dataset.shape[0], step):
        block = dataset[start:start + step]
        if finite and not np.all(np.isfinite(block)):
            raise ResultFileError(f"{path} is corrupt: axis {dataset.name.lstrip('/')} holds a value that is not "
                                  "a finite number")


def open_in_this_process_error(path, error):
    """The ResultFileError for a file that HDF5 refuses because this process holds it open in
    another mode, or None. A Dataset of ``open_results`` (lazy: it keeps its file open) and then
    ``sweep(..., output=that file, resume=True)`` was told the file is "truncated or corrupt", a
    word that has files deleted; it is sound, and closing the Dataset is all it takes."""
    text = str(error)
    if "already open" in text or "close degree" in text:
        return ResultFileError(
            f"{path} is open in this process in another mode (a Dataset from vrsweep.open_results or "
            "xarray, or an h5py File, still holds it): close it (ds.close()) and try again")
    return None


def corrupt_error(path, error, writing=False):
    # A KeyError's str() is its message quoted: "'Unable to open object (component not found)'",
    # whose reason came out as "component not found)'" (the message ended ")')")
    text = str(error.args[0]) if isinstance(error, KeyError) and error.args else str(error)
    in_use = open_in_this_process_error(path, error)
    if in_use is not None:
        return in_use
    if "unable to lock file" in text and writing:
        # A writer is refused by its own lock first (fileio.refuse_if_being_written): what holds the
        # file here is a reader, and a lazy Dataset holds its file until it is closed. It was told
        # "has it open for writing; set HDF5_USE_FILE_LOCKING=FALSE to read it anyway".
        return ResultFileError(
            f"{path} is open in another process (a Dataset of vrsweep.open_results or xarray, a viewer): "
            "HDF5 cannot lock it for writing; close it there (ds.close()) and try again")
    if "unable to lock file" in text:  # not just "lock": "sblock" appears in truncation messages
        return ResultFileError(
            f"{path} is locked: another process (a run in progress?) has it open for writing; "
            "set HDF5_USE_FILE_LOCKING=FALSE to read it anyway")
    if "Permission denied" in text or getattr(error, "errno", None) == 13:
        return ResultFileError(f"{path}: permission denied")
    number = _errno_of(error)
    if number:  # the system refused the open, not the file: --resume on a read-only file system
        # (errno 30) was "is truncated or corrupt (HDF5: unable to open file: ... Read-only file system)"
        return ResultFileError(f"{path}: cannot open it: {os.strerror(number)}")
    reason = text.split("(", 1)[-1].rstrip(")") if "(" in text else text
    return ResultFileError(f"{path} is truncated or corrupt (HDF5: {reason.strip()})")


class StoredLayout:
    """What a result file holds, without the values of its variables (see ``store.layout``).

    axes: ordered ``{name: values}`` of the sweep axes; coords and coord_attrs: the other
    dimensions' values and attributes; dtypes, shapes, dims, var_attrs, fill_values: per data
    variable (not ``done``/``owned``), point variables first in creation order, derived ones
    after; attrs: the root attributes; shape: the grid's.
    """

    def __init__(self, path, f):
        self.path = os.fspath(path)
        self._read_layout(f)

    @classmethod
    def read(cls, path):
        """The layout of the result file at ``path``, or ResultFileError with a one-line reason."""
        f = open_checked(path, "r")
        try:
            with f:
                return cls(path, f)
        except ResultFileError:
            raise
        except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
            raise corrupt_error(path, error) from None

    def _read_layout(self, f):
        done = f["done"]
        self.axis_names = scale_names(done) if done.ndim else ()
        self.shape = tuple(done.shape)
        self.point_variables = point_variables_of(f)
        axes, self.coords, self.coord_attrs = {}, {}, {}
        dtypes, self.shapes, self.dims, self.var_attrs, self.fill_values = {}, {}, {}, {}, {}
        for name in f:
            obj = f[name]  # not f.items(): its .get() turns an object that fails to open into None
            if not isinstance(obj, h5py.Dataset):
                continue
            if obj.is_scale:  # coordinates: small, read whole
                (axes if name in self.axis_names else self.coords)[name] = obj[()]
                self.coord_attrs[name] = clean_attrs(obj.attrs)
                continue
            if name in BOOKKEEPING:
                continue
            dtypes[name] = obj.dtype
            self.shapes[name] = tuple(obj.shape)
            self.dims[name] = scale_names(obj) if obj.ndim else ()
            self.var_attrs[name] = clean_attrs(obj.attrs)
            self.fill_values[name] = obj.fillvalue
        self.axes = {name: axes[name] for name in self.axis_names}
        missing = [n for n in self.point_variables if n not in dtypes]
        if missing:
            raise ResultFileError(f"{self.path} is corrupt: variables {missing} are missing")
        self.dtypes = {n: dtypes[n] for n in self.point_variables}
        self.dtypes.update((n, t) for n, t in dtypes.items() if n not in self.dtypes)
        self.derived_variables = tuple(n for n in self.dtypes if n not in self.point_variables)
        self.attrs = clean_attrs(f.attrs)
        self.has_owned = "owned" in f

    @property
    def shard(self):
        """The shard label "I/N", or None for a whole run."""
        return self.attrs.get("shard")

    @property
    def complete(self) -> bool:
        return bool(self.attrs.get("vrsweep_complete", 0))

    def variable_specs(self):
        """The VariableSpec list that created this file's point variables."""
        n_axes = len(self.axes)
        specs = []
        for name in self.point_variables:
            attrs = {k: v for k, v in self.var_attrs[name].items() if k != "_FillValue"}
            extra = tuple((d, len(self.coords[d])) for d in self.dims[name][n_axes:])
            specs.append(VariableSpec(name, self.dtypes[name], extra, attrs, self.fill_values[name]))
        return specs

    def point_label(self, flat_index) -> str:
        """``g=1.5, Omega=4`` for a flat grid index (for messages)."""
        return point_label(self.axes, flat_index)
