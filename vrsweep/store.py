"""HDF5 result files: create, checkpoint, resume, finish, read and merge.

The store knows nothing of numerics: it writes what it is given, where it is told.

Life of a result file
---------------------
1. :meth:`ResultWriter.create` writes the whole layout up front: one coordinate per sweep axis,
   every variable pre-allocated and filled with its fill value, a per-point ``done`` mask, and the
   root attributes with ``vrsweep_complete = 0``. The skeleton is written under a temporary name
   and renamed into place, so whatever exists at ``path`` is always a readable vrsweep file. The
   writer keeps that very file open (and locked) until ``finish``: it never reopens the path,
   and checks before each write that the path still names its file (a run with ``--overwrite``
   or a scratch purge may have replaced or removed it; see ``fileio``).
2. :meth:`ResultWriter.write_points` fills finished points chunk by chunk and flushes: this file
   *is* the checkpoint. A ``kill -9`` at any moment loses at most the chunk in flight.
3. :meth:`ResultWriter.finish` copies the file it holds, adds derived variables (theory
   columns) to the copy, sets ``vrsweep_complete = 1`` and renames the copy into place.

A full disk at any of these steps ends in one line (``OutputError``, exit 1) saying how much
space the file needs, with HDF5 closed cleanly and no temporary file left (``fileio``).

Layout (netCDF-4 compatible; ``xarray.open_dataset(path, engine="h5netcdf")`` reads it)
------------------------------------------------------------------------------------
- One 1-D coordinate dataset per sweep axis, named after the parameter, made an HDF5 dimension
  scale, with ``units`` and ``long_name``.
- Each extra dimension of a variable (``root``, ``strobe``, ``direction``...) is a dimension scale
  too; unless the caller gives its values it is an int32 index ``0..n-1``.
- Data variables over the axes in axis order, extra dimensions last. A config without a sweep is
  one point: the grid has shape ``()`` and every variable is 0-d (plus its extra dimensions).
- ``done`` (int8 over the axes): 1 where a point has been written. Its attribute
  ``point_variables`` lists the variables that are filled point by point, so that a resume or a
  merge can tell them from the derived variables added by ``finish``.
- Shard files add the root attribute ``shard`` ("I/N") and ``owned`` (int8 over the axes).
- Root attributes: ``vrsweep_format_version``, ``vrsweep_complete``, ``created`` (ISO 8601 UTC)
  and whatever the caller passes (``config``, ``vrsweep_version``, ``numba_version``,
  ``numpy_version``...).

Fill values
-----------
Floats are filled with NaN and carry ``_FillValue = NaN``, so xarray shows NaN where a point has
not been computed. Integer variables (``status`` with -1 = not_computed, counters with -1 or 0)
get the HDF5 fill value but *no* ``_FillValue`` attribute: with one, xarray's CF decoding would
mask it and turn the int8 ``status`` into float64. ``status`` documents -1 through its
``flag_values`` / ``flag_meanings`` instead.

Why crash-safe
--------------
Datasets are chunked (about 128 KiB per chunk, trailing axes whole, so a C-order run of points
touches few chunks), uncompressed and allocated at creation time (``H5D_ALLOC_TIME_EARLY``). After
``create`` the file's metadata therefore never changes while points are written: a write only
overwrites raw bytes at fixed places. ``write_points`` writes the values, flushes and fsyncs, and
only then sets ``done`` and flushes again, so a point is never marked done before its values are
on disk. ``finish`` works on a copy and renames it into place, so a crash while finishing leaves the
checkpoint as it was. Compression is deliberately off: compressed chunks change size and would
make every write a metadata update.

File locking (shared and NFS file systems)
------------------------------------------
HDF5 locks files it opens (a writer excludes readers). On file systems where locks are not
supported (some NFS and Lustre mounts) HDF5 would refuse to open anything, so when the
``HDF5_USE_FILE_LOCKING`` environment variable is *not* set, vrsweep asks h5py for
``locking="best-effort"`` (lock where possible, carry on where locking is disabled). When
``HDF5_USE_FILE_LOCKING`` is set (``FALSE`` is the usual advice on NFS), vrsweep passes nothing and
HDF5 obeys the variable. Reading a file a running sweep is writing fails with a message saying so;
``HDF5_USE_FILE_LOCKING=FALSE`` lets you read it anyway (at your own risk: it may be mid-write).
A writer also takes a ``flock`` of its own on its file, so that ``--overwrite`` and ``--resume``
refuse a file that another run writes even when that run switched HDF5's locking off. All files
are opened through ``fileio.open_hdf5``, which also copes with an h5py too old for ``locking=``.
"""

from __future__ import annotations

import datetime
import math
import os
from dataclasses import dataclass, field

import h5py
import numpy as np

from vrsweep.errors import ResultFileError, UsageError
from vrsweep.fileio import (
    atomic_write, check_still_at_path, close_without_writing, closed_without_writing_on_failure,
    fsync_path, identity, lock_for_writing, open_hdf5, refuse_if_being_written, replacing, reserve_space, trim_to_contents, write_failure, writing_hdf5,
)
from vrsweep.model import PARAMETER_LONG_NAMES, PARAMETER_UNITS

FORMAT_VERSION = 1

# Root attributes the store owns; callers may not set them.
_RESERVED_ROOT_ATTRS = ("vrsweep_format_version", "vrsweep_complete", "created")
# Attributes HDF5 dimension scales and netCDF-4 use internally; not shown to users.
_INTERNAL_ATTRS = frozenset(
    ["CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "_Netcdf4Dimid", "_Netcdf4Coordinates",
     "_NCProperties", "_nc3_strict"]
)
_BOOKKEEPING = ("done", "owned")

# ~128 KiB chunks: well under HDF5's 1 MiB default chunk cache, a few chunks per variable for a
# 10^5-point grid, and small enough that a chunk cache holds every chunk a write touches.
CHUNK_TARGET_BYTES = 4 * 1024  # small: a sweep chunk writes shuffled points, touching many HDF5 chunks
# Chunk cache per open dataset: a scattered write (a shard's points) revisits the same chunks.
_RDCC_NBYTES = 32 * 1024 * 1024
_RDCC_NSLOTS = 10007  # a prime, ~100x the chunks that fit in the cache


# --------------------------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------------------------


def _h5open(path, mode, **kwargs):
    return open_hdf5(path, mode, rdcc_nbytes=_RDCC_NBYTES, rdcc_nslots=_RDCC_NSLOTS, **kwargs)


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


def _utc_now_iso():
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _default_fill(dtype):
    if dtype.kind == "f":
        return np.nan
    if dtype.kind == "i":
        return -1
    return 0


def _first_difference(a: str, b: str) -> str:
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



# --------------------------------------------------------------------------------------------
# Layout
# --------------------------------------------------------------------------------------------


@dataclass
class VariableSpec:
    """One data variable filled point by point.

    ``extra_dims`` are ``(dim_name, size)`` pairs after the axis dimensions; ``attrs`` must hold
    ``long_name`` and, unless it is a flag variable (``flag_values``), ``units``. ``fill`` is what
    a point holds until it is written: NaN for floats, -1 for signed ints, 0 otherwise by default
    (``Status.NOT_COMPUTED`` is -1).
    """

    name: str
    dtype: np.dtype
    extra_dims: tuple = ()
    attrs: dict = field(default_factory=dict)
    fill: object = None

    def __post_init__(self):
        self.dtype = np.dtype(self.dtype)
        self.extra_dims = tuple((str(d), int(n)) for d, n in self.extra_dims)
        self.attrs = dict(self.attrs)
        if self.fill is None:
            self.fill = _default_fill(self.dtype)

    @property
    def extra_shape(self):
        return tuple(n for _, n in self.extra_dims)


def _chunk_shape(grid_shape, extra_shape, itemsize, target_bytes=CHUNK_TARGET_BYTES):
    """Chunk shape for a variable: extra dims whole, then trailing axes whole, then a slab.

    Filling trailing axes first follows C order, so a run of consecutive flat indices (a sweep
    chunk) lands in one or two chunks.
    """
    budget = max(1, target_bytes // (itemsize * max(1, math.prod(extra_shape))))
    chunk = []
    for n in reversed(grid_shape):
        take = max(1, min(n, budget))
        chunk.append(take)
        budget = max(1, budget // take)
    return tuple(reversed(chunk)) + tuple(extra_shape)


def layout_bytes(axes, specs, shard=False) -> int:
    """Bytes that the pre-allocated data of a new result file take on disk.

    Every chunk of every point variable (chunks at the grid's edge are stored whole) with its
    4-byte checksum, ``done`` (and ``owned``), and the coordinates. HDF5's metadata comes on top,
    so this is a lower bound of the file's size: what a check of free space may ask for.
    """
    grid_shape = tuple(len(axis[1]) for axis in axes)
    bookkeeping = [VariableSpec("done", np.int8)] + ([VariableSpec("owned", np.int8)] if shard else [])
    specs = [s if isinstance(s, VariableSpec) else VariableSpec(**s) for s in specs] + bookkeeping
    total = sum(np.asarray(axis[1]).nbytes for axis in axes)
    total += sum(4 * n for n in dict(d for s in specs for d in s.extra_dims).values())  # int32 indices
    for spec in specs:
        shape = grid_shape + spec.extra_shape
        if not shape:
            total += spec.dtype.itemsize
            continue
        if not grid_shape:
            total += math.prod(shape) * spec.dtype.itemsize + 4
            continue
        chunk = _chunk_shape(grid_shape, spec.extra_shape, spec.dtype.itemsize)
        n_chunks = math.prod(-(-n // c) for n, c in zip(shape, chunk))
        total += n_chunks * (math.prod(chunk) * spec.dtype.itemsize + 4)
    return total


def creation_reserve(axes, specs, shard=False) -> int:
    """Bytes to allocate before HDF5 builds a result file: an upper bound of its size.

    layout_bytes plus HDF5's metadata: about 20 kB for the smallest file, 2.5 kB per variable
    (headers, attributes, dimension scales) and under 2 % for the chunk indexes of large grids
    (measured from 1 to 10^5 points); the allowance doubles each.
    """
    data = layout_bytes(axes, specs, shard)
    return data + 64 * 1024 + 4096 * (len(specs) + 2) + data // 25


def finish_reserve(extra) -> int:
    """Bytes that finishing adds to a result file, at most: the derived variables, twice over
    for their chunks and coordinates, and the metadata of each (measured: about 2 kB each)."""
    arrays = [np.asarray(item[0]) for item in (extra or {}).values()]
    return 2 * sum(a.nbytes for a in arrays) + 64 * 1024 + 8192 * len(arrays)


def _coerce_attr(value, dtype=None):
    if value is None:
        raise ValueError("attribute values may not be None")
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return np.int8(value)
    if dtype is not None:
        return np.asarray(value, dtype=dtype)
    return value


def _write_attrs(obj, attrs, dtype=None):
    for key, value in attrs.items():
        # CF: flag_values has the variable's own type (int8 for status).
        obj.attrs[key] = _coerce_attr(value, dtype if key in ("flag_values", "valid_range") else None)


def _make_coordinate(f, name, values, attrs):
    values = np.asarray(values)
    if values.ndim != 1 or values.size == 0:
        raise ValueError(f"coordinate {name!r} must be a non-empty 1-D array, got shape {values.shape}")
    ds = f.create_dataset(name, data=values, track_order=True)
    ds.make_scale(name)
    _write_attrs(ds, attrs)
    return ds


def _create_point_variable(f, spec, grid_shape, scales):
    shape = tuple(grid_shape) + spec.extra_shape
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    kwargs = {}
    if shape:  # HDF5 cannot chunk a scalar dataspace; a 0-d variable stays contiguous
        kwargs["chunks"] = _chunk_shape(tuple(grid_shape), spec.extra_shape, spec.dtype.itemsize)
        # A checksum per chunk: bytes damaged on disk or in a copy are an error when read,
        # never silently wrong numbers.
        kwargs["fletcher32"] = True
    ds = f.create_dataset(spec.name, shape=shape, dtype=spec.dtype, fillvalue=spec.fill, dcpl=dcpl,
                          track_order=True, track_times=False, **kwargs)
    for i, scale in enumerate(scales):
        ds.dims[i].attach_scale(scale)
    attrs = {k: v for k, v in spec.attrs.items() if k != "_FillValue"}
    if spec.dtype.kind == "f":  # only floats: see "Fill values" in the module docstring
        attrs = {"_FillValue": spec.dtype.type(spec.fill), **attrs}
    _write_attrs(ds, attrs, spec.dtype)
    return ds


def _build_skeleton(f, axes, specs, attrs, extra_coords, owned_mask):
    """Write the complete pre-allocated layout of a result file into the open file ``f``."""
    axis_names = [a[0] for a in axes]
    if len(set(axis_names)) != len(axis_names):
        raise ValueError(f"duplicate axis names: {axis_names}")
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate variable names: {names}")
    for key in _RESERVED_ROOT_ATTRS:
        if key in attrs:
            raise ValueError(f"root attribute {key!r} is set by the store, not the caller")
    if "config" not in attrs:
        raise ValueError("root attribute 'config' (the YAML text as run) is required")

    # Root attributes: the store's own first, then the caller's in the caller's order.
    f.attrs["vrsweep_format_version"] = np.int32(FORMAT_VERSION)
    f.attrs["vrsweep_complete"] = np.int32(0)
    f.attrs["created"] = _utc_now_iso()
    _write_attrs(f, attrs)

    scales = {}
    for axis in axes:
        name, values = axis[0], axis[1]
        axis_attrs = {"units": PARAMETER_UNITS.get(name, "1"),
                      "long_name": PARAMETER_LONG_NAMES.get(name, name)}
        if len(axis) > 2:
            axis_attrs.update(axis[2])
        scales[name] = _make_coordinate(f, name, values, axis_attrs)
    grid_shape = tuple(len(scales[n]) for n in axis_names)

    # Extra dimensions, in order of first appearance; all variables must agree on a dim's size.
    extra_coords = dict(extra_coords or {})
    sizes = {}
    for spec in specs:
        for dim, size in spec.extra_dims:
            if dim in scales and dim not in sizes:
                raise ValueError(f"{spec.name}: extra dimension {dim!r} clashes with a sweep axis")
            if sizes.setdefault(dim, size) != size:
                raise ValueError(f"dimension {dim!r} has size {sizes[dim]} and {size}")
    for dim, size in sizes.items():
        values, dim_attrs = extra_coords.pop(dim, (np.arange(size, dtype=np.int32), None))
        if dim_attrs is None:
            dim_attrs = {"units": "1", "long_name": f"index along {dim}"}
        if len(values) != size:
            raise ValueError(f"coordinate {dim!r} has {len(values)} values, dimension size is {size}")
        scales[dim] = _make_coordinate(f, dim, values, dim_attrs)
    if extra_coords:
        raise ValueError(f"extra_coords for dimensions no variable uses: {sorted(extra_coords)}")

    axis_scales = [scales[n] for n in axis_names]
    for spec in specs:
        if "long_name" not in spec.attrs or ("units" not in spec.attrs and "flag_values" not in spec.attrs):
            raise ValueError(f"variable {spec.name!r} needs 'units' and 'long_name' attributes")
        _create_point_variable(f, spec, grid_shape, axis_scales + [scales[d] for d, _ in spec.extra_dims])

    _create_point_variable(
        f,
        VariableSpec("done", np.int8, (), {
            "long_name": "point computed and written (1) or not yet (0)",
            "flag_values": [0, 1], "flag_meanings": "not_done done",
            "point_variables": " ".join(names),
        }, fill=0),
        grid_shape, axis_scales)
    if owned_mask is not None:
        owned_mask = np.asarray(owned_mask, dtype=bool)
        if owned_mask.shape != grid_shape:
            raise ValueError(f"owned_mask has shape {owned_mask.shape}, grid is {grid_shape}")
        owned = _create_point_variable(
            f,
            VariableSpec("owned", np.int8, (), {
                "long_name": "point belongs to this shard (1) or to another (0)",
                "flag_values": [0, 1], "flag_meanings": "other_shard this_shard",
            }, fill=0),
            grid_shape, axis_scales)
        owned[()] = owned_mask.astype(np.int8)
    return grid_shape


def _scale_names(ds):
    """Names of the dimension scales attached to each dimension of ``ds``."""
    out = []
    for i, dim in enumerate(ds.dims):
        scale_name = dim[0].name if len(dim) else None
        if not scale_name:  # no scale attached, or its reference is damaged
            raise ResultFileError(f"{ds.file.filename}: dataset {ds.name} has no dimension scale on "
                                  f"dimension {i}: corrupt, or not written by vrsweep")
        out.append(scale_name.rsplit("/", 1)[-1])
    return tuple(out)


def _add_extras(f, extra, coords):
    """Add derived variables (``finish``) over existing or new dimensions; replaces same names."""
    coords = dict(coords or {})
    point_variables = set(_point_variables(f))
    for name, item in (extra or {}).items():
        array, dims, attrs = item
        array = np.asarray(array)
        dims = tuple(dims)
        if name in point_variables or name in _BOOKKEEPING:
            raise ValueError(f"derived variable {name!r} would replace a point variable")
        if array.ndim != len(dims):
            raise ValueError(f"derived variable {name!r}: {array.ndim}-d array for dims {dims}")
        scales = []
        for dim, size in zip(dims, array.shape):
            if dim in f and f[dim].is_scale:
                if len(f[dim]) != size:
                    raise ValueError(f"derived variable {name!r}: dimension {dim!r} has size "
                                     f"{len(f[dim])}, array has {size}")
            else:
                values, dim_attrs = coords.pop(dim, (np.arange(size, dtype=np.int32), None))
                if dim_attrs is None:
                    dim_attrs = {"units": "1", "long_name": f"index along {dim}"}
                _make_coordinate(f, dim, values, dim_attrs)
            scales.append(f[dim])
        if name in f:  # finishing again (a resumed finished file): replace, detaching first
            old = f[name]  # so the scales' REFERENCE_LIST does not point at a deleted dataset
            for i, dim in enumerate(old.dims):
                for scale in list(dim.values()):
                    old.dims[i].detach_scale(scale)
            del f[name]
        checksum = {"chunks": array.shape, "fletcher32": True} if array.ndim else {}
        ds = f.create_dataset(name, data=array, track_order=True, track_times=False, **checksum)
        for i, scale in enumerate(scales):
            ds.dims[i].attach_scale(scale)
        _write_attrs(ds, attrs or {}, array.dtype)


def _point_variables(f):
    return tuple(_decode(f["done"].attrs["point_variables"]).split())


def _decode(value):
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.generic):
        return value.item()
    return value


# --------------------------------------------------------------------------------------------
# Opening and checking existing files
# --------------------------------------------------------------------------------------------


def _open_checked(path, mode="r"):
    """Open ``path`` as a vrsweep file of a format this version reads, or raise ResultFileError."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ResultFileError(f"results file not found: {path}")
    if os.path.isdir(path):
        raise ResultFileError(f"{path} is a directory, not a results file")
    if os.path.getsize(path) == 0:
        raise ResultFileError(f"{path} is empty (0 bytes): truncated or never written")
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError as error:
        raise ResultFileError(f"cannot read {path}: {error.strerror or error}") from None
    if not is_hdf5:
        raise ResultFileError(f"{path} is not an HDF5 file (so not a vrsweep results file)")
    try:
        f = _h5open(path, mode)
    except OSError as error:
        raise _corrupt_error(path, error) from None
    try:
        if "vrsweep_format_version" not in f.attrs:
            raise ResultFileError(f"{path} is an HDF5 file but not a vrsweep results file "
                                  "(no vrsweep_format_version attribute)")
        version = int(_decode(f.attrs["vrsweep_format_version"]))
        if version > FORMAT_VERSION:
            raise ResultFileError(f"{path} was written by a newer vrsweep (format {version}; this "
                                  f"vrsweep reads format {FORMAT_VERSION}); upgrade vrsweep to read it")
        if version < FORMAT_VERSION:
            raise ResultFileError(f"{path} was written by an older vrsweep (format {version}; this "
                                  f"vrsweep reads format {FORMAT_VERSION})")
        if "done" not in f or "point_variables" not in f["done"].attrs:
            raise ResultFileError(f"{path} is a vrsweep file but not a sweep result (no 'done' mask)")
    except ResultFileError:
        f.close()
        raise
    except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        f.close()
        raise _corrupt_error(path, error) from None
    return f


def _corrupt_error(path, error):
    text = str(error)
    if "unable to lock file" in text:  # not just "lock": "sblock" appears in truncation messages
        return ResultFileError(
            f"{path} is locked: another process (a run in progress?) has it open for writing; "
            "set HDF5_USE_FILE_LOCKING=FALSE to read it anyway")
    if "Permission denied" in text or getattr(error, "errno", None) == 13:
        return ResultFileError(f"{path}: permission denied")
    reason = text.split("(", 1)[-1].rstrip(")") if "(" in text else text
    return ResultFileError(f"{path} is truncated or corrupt (HDF5: {reason.strip()})")


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


# --------------------------------------------------------------------------------------------
# Writer
# --------------------------------------------------------------------------------------------


class ResultWriter:
    """A result file being filled: the checkpoint of a sweep. Use ``create`` or ``open_for_resume``."""

    def __init__(self, path, h5file):
        self.path = os.fspath(path)
        self._file = h5file
        # The writer holds its file open from creation to finish and never reopens it by path:
        # it checks instead that the path still names this very file (see _check_still_mine).
        self._fd = h5file.id.get_vfd_handle()
        self._identity = identity(self._fd)
        lock_for_writing(self._fd)
        done = h5file["done"]
        self.axis_names = _scale_names(done) if done.ndim else ()
        self.grid_shape = tuple(done.shape)
        self.n_points = math.prod(self.grid_shape)
        self.point_variables = _point_variables(h5file)
        self._done = np.array(done[()], dtype=bool)  # 0-d array, not a scalar, for one point
        self._owned = np.array(h5file["owned"][()], dtype=bool) if "owned" in h5file else None
        self._extra_shapes = {}
        for name in self.point_variables:
            ds = h5file[name]
            self._extra_shapes[name] = tuple(ds.shape[len(self.grid_shape):])

    # -- construction ---------------------------------------------------------------------

    @classmethod
    def create(cls, path, axes, variables, attrs, overwrite=False, owned_mask=None,
               extra_coords=None):
        """Create a result file with every variable pre-allocated; return a writer on it.

        axes: ``[(name, values)]`` (or ``(name, values, attrs)``) in sweep order; ``[]`` for one
        point. variables: ``VariableSpec`` list. attrs: root attributes, ``config`` required
        (``shard`` = "I/N" for a shard file, with ``owned_mask`` its points). extra_coords:
        optional ``{dim: (values, attrs)}`` for extra dimensions (default: an int32 index).
        Refuses an existing ``path`` unless ``overwrite``.
        """
        path = os.fspath(path)
        if os.path.isdir(path):
            raise UsageError(f"output {path} is a directory")
        if os.path.lexists(path):
            if not overwrite:
                raise UsageError(f"output {path} already exists: pass --overwrite to replace it, "
                                 "or --resume to continue the run that wrote it")
            refuse_if_being_written(path)
        specs = [v if isinstance(v, VariableSpec) else VariableSpec(**v) for v in variables]
        reserve = creation_reserve(axes, specs, shard=owned_mask is not None)

        # Built under a temporary name and renamed into place while still open: the writer
        # keeps the very file it built, never a file that someone else put at the path since.
        with replacing(path, reserve, doing="create") as tmp:
            # HDF5 1.8 object headers carry checksums, so damaged metadata is caught too.
            f = _h5open(tmp, "w", track_order=True, libver=("v108", "latest"))
            with closed_without_writing_on_failure(f):
                fd = f.id.get_vfd_handle()
                reserve_space(fd, reserve)  # a full disk fails here, before HDF5 writes anything
                _build_skeleton(f, list(axes), specs, dict(attrs), extra_coords, owned_mask)
                f.flush()
                trim_to_contents(f)
                _fsync(f)
        try:
            return cls(path, f)
        except BaseException:
            close_without_writing(f)
            raise

    @classmethod
    def open_for_resume(cls, path, expected_config_text: str, expected_shard=None):
        """Reopen an unfinished (or finished) result file to compute what is missing.

        Raises ResultFileError if it is not a vrsweep result file, is truncated, has another
        format version, was written from a different config, or (if ``expected_shard`` is given)
        belongs to another shard.
        """
        path = os.fspath(path)
        if not os.path.exists(path):
            raise ResultFileError(f"cannot resume: {path} does not exist (run without --resume)")
        refuse_if_being_written(path, "resume")  # also where HDF5's own locking is switched off
        f = _open_checked(path, "r+")
        try:
            stored = _decode(f.attrs.get("config", ""))
            if stored != expected_config_text:
                raise ResultFileError(
                    f"cannot resume: {path} was written from a different config "
                    f"({_first_difference(stored, expected_config_text)}); "
                    "pass --overwrite to replace it")
            shard = _decode(f.attrs.get("shard")) if "shard" in f.attrs else None
            if expected_shard is not None or shard is not None:
                if shard != expected_shard:
                    raise ResultFileError(
                        f"cannot resume: {path} holds shard {shard or 'none (a whole run)'}, "
                        f"not {expected_shard or 'a whole run'}; pass --overwrite to replace it")
            return cls(path, f)
        except ResultFileError:
            f.close()
            raise
        except (OSError, KeyError, ValueError) as error:
            f.close()
            raise _corrupt_error(path, error) from None

    # -- state ----------------------------------------------------------------------------

    def done_mask(self) -> np.ndarray:
        """Boolean mask over the grid: True where a point has been written."""
        return self._done.copy()

    def owned_mask(self):
        """Boolean mask of this shard's points, or None for a whole run."""
        return None if self._owned is None else self._owned.copy()

    @property
    def complete(self) -> bool:
        return bool(_decode(self._file.attrs["vrsweep_complete"]))

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
            for name, array in arrays.items():
                _write_selection(self._file[name], self.grid_shape, idx, array)
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

    def finish(self, extra=None, coords=None) -> None:
        """Add derived variables, mark the file complete, and close it.

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
                with writing_hdf5(tmp, "r+", reserve=reserve, rdcc_nbytes=_RDCC_NBYTES,
                                  rdcc_nslots=_RDCC_NSLOTS) as f:
                    _add_extras(f, extra, coords)
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


# --------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------


@dataclass
class ResultSet:
    """A result file read into memory.

    axes: ordered ``{name: values}`` of the sweep axes; variables: ``{name: array}`` of every
    data variable (point variables first, then derived ones; not ``done``/``owned``); dims and
    var_attrs per variable; coords: values of the non-axis dimensions; attrs: root attributes;
    done (and owned for a shard) over the grid.
    """

    path: str
    axes: dict
    variables: dict
    dims: dict
    var_attrs: dict
    coords: dict
    coord_attrs: dict
    attrs: dict
    done: np.ndarray
    owned: np.ndarray | None
    point_variables: tuple
    fill_values: dict

    @property
    def complete(self) -> bool:
        return bool(self.attrs.get("vrsweep_complete", 0))

    @property
    def shape(self):
        return tuple(self.done.shape)

    @property
    def shard(self):
        return self.attrs.get("shard")

    @property
    def derived_variables(self):
        return tuple(n for n in self.variables if n not in self.point_variables)

    def variable_specs(self):
        """The VariableSpec list that created this file's point variables."""
        specs = []
        n_axes = len(self.axes)
        for name in self.point_variables:
            attrs = {k: v for k, v in self.var_attrs[name].items() if k != "_FillValue"}
            extra = tuple((d, len(self.coords[d])) for d in self.dims[name][n_axes:])
            specs.append(VariableSpec(name, self.variables[name].dtype, extra, attrs,
                                      self.fill_values[name]))
        return specs

    def point_label(self, flat_index) -> str:
        """``g=1.5, Omega=4`` for a flat grid index (for messages)."""
        return point_label(self.axes, flat_index)


def point_label(axes, flat_index) -> str:
    """``g=1.5, Omega=4``: the point at a flat (C-order) index of the grid of ``axes``
    (name -> values), for messages."""
    if not axes:
        return "the single point"
    where = np.unravel_index(int(flat_index), tuple(len(values) for values in axes.values()))
    return ", ".join(f"{name}={values[i]:g}" for (name, values), i in zip(axes.items(), where))


def _clean_attrs(attrs):
    return {k: _decode(v) for k, v in attrs.items() if k not in _INTERNAL_ATTRS}


def read_results(path) -> ResultSet:
    """Read a result file, or raise ResultFileError with a one-line reason.

    Reasons: missing file, not HDF5, HDF5 but not vrsweep, newer format version, truncated or
    corrupt, locked by a running writer.
    """
    path = os.fspath(path)
    f = _open_checked(path, "r")
    try:
        with f:
            done_ds = f["done"]
            axis_names = _scale_names(done_ds) if done_ds.ndim else ()
            point_variables = _point_variables(f)
            axes, coords, coord_attrs = {}, {}, {}
            variables, dims, var_attrs, fills = {}, {}, {}, {}
            for name in f:
                obj = f[name]  # not f.items(): its .get() turns an object that fails to open into None
                if not isinstance(obj, h5py.Dataset):
                    continue
                if obj.is_scale:
                    (axes if name in axis_names else coords)[name] = obj[()]
                    coord_attrs[name] = _clean_attrs(obj.attrs)
                    continue
                if name in _BOOKKEEPING:
                    continue
                variables[name] = np.asarray(obj[()])
                dims[name] = _scale_names(obj) if obj.ndim else ()
                var_attrs[name] = _clean_attrs(obj.attrs)
                fills[name] = obj.fillvalue
            axes = {name: axes[name] for name in axis_names}
            missing = [n for n in point_variables if n not in variables]
            if missing:
                raise ResultFileError(f"{path} is corrupt: variables {missing} are missing")
            # Point variables first, in their creation order; derived ones after.
            ordered = {n: variables[n] for n in point_variables}
            ordered.update((n, v) for n, v in variables.items() if n not in ordered)
            return ResultSet(
                path=path, axes=axes, variables=ordered, dims=dims, var_attrs=var_attrs,
                coords=coords, coord_attrs=coord_attrs, attrs=_clean_attrs(f.attrs),
                done=np.array(done_ds[()], dtype=bool),
                owned=np.array(f["owned"][()], dtype=bool) if "owned" in f else None,
                point_variables=point_variables, fill_values=fills)
    except ResultFileError:
        raise
    except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        raise _corrupt_error(path, error) from None


# --------------------------------------------------------------------------------------------
# Merge: vrsweep/merge.py (it streams the shards block by block); importable from here as before
# --------------------------------------------------------------------------------------------


def __getattr__(name):
    if name in ("merge_results", "MergeReport"):
        from vrsweep import merge

        return getattr(merge, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "FORMAT_VERSION", "VariableSpec", "ResultWriter", "ResultSet", "read_results",
    "atomic_write", "merge_results", "MergeReport", "CHUNK_TARGET_BYTES",
]
