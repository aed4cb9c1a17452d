"""The layout of a vrsweep result file: its variables, dimensions and attributes.

This module alone decides what a result file holds and where; the writer, the reader, the merge,
``vrsweep info`` and ``vrsweep.open_results`` (through xarray) all follow it.

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
  ``numpy_version``...), and ``vrsweep_attributes_sha256``: the checksum of every attribute but
  ``vrsweep_complete`` and when and how the file was written (store/sealing.py), sealed again
  whenever variables are added.

Fill values
-----------
Floats are filled with NaN and carry ``_FillValue = NaN``, so xarray shows NaN where a point has
not been computed. Integer variables (``status`` with -1 = not_computed, counters with -1 or 0)
get the HDF5 fill value but *no* ``_FillValue`` attribute: with one, xarray's CF decoding would
mask it and turn the int8 ``status`` into float64. ``status`` documents -1 through its
``flag_values`` / ``flag_meanings`` instead.
"""

from __future__ import annotations

import datetime
import math
from dataclasses import dataclass, field

import h5py
import numpy as np

from vrsweep.errors import ResultFileError
from vrsweep.numerics.model import PARAMETER_LONG_NAMES, PARAMETER_UNITS
from vrsweep.store.sealing import ATTRIBUTES_CHECKSUM, SWEEP_UNSEALED, seal_attributes

FORMAT_VERSION = 1

# Root attributes the store owns; callers may not set them.
RESERVED_ROOT_ATTRS = ("vrsweep_format_version", "vrsweep_complete", "created", ATTRIBUTES_CHECKSUM)
# Attributes HDF5 dimension scales and netCDF-4 use internally; not shown to users.
INTERNAL_ATTRS = frozenset(
    ["CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "_Netcdf4Dimid", "_Netcdf4Coordinates",
     "_NCProperties", "_nc3_strict"]
)
BOOKKEEPING = ("done", "owned")

# 4 KiB chunks (each with its checksum): a sweep chunk writes shuffled points, touching many HDF5
# chunks, each read and written whole, so small ones cost less per point written; small, too, is
# what a kill cutting a chunk's write puts at stake (store/torn.py recovers it).
CHUNK_TARGET_BYTES = 4 * 1024


def utc_now_iso():
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _default_fill(dtype):
    if dtype.kind == "f":
        return np.nan
    if dtype.kind == "i":
        return -1
    return 0


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
    (measured from 1 to 10^5 points), and ~3 kB per coordinate for the chunk index of its checksummed
    chunk; the allowance doubles each.
    """
    data = layout_bytes(axes, specs, shard)
    specs = [s if isinstance(s, VariableSpec) else VariableSpec(**s) for s in specs]
    n_coordinates = len(axes) + len({dim for spec in specs for dim, _ in spec.extra_dims})
    return data + 64 * 1024 + 4096 * (len(specs) + 2) + 6144 * n_coordinates + data // 25


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
    # A checksum, as every variable has: a flipped bit in an axis would otherwise label every
    # point with a wrong parameter value (g = 5.3e-315), silently. Files written before have none
    # and still open (reader.check_structure reads them plain).
    ds = f.create_dataset(name, data=values, track_order=True, chunks=values.shape, fletcher32=True)
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


def build_skeleton(f, axes, specs, attrs, extra_coords, owned_mask):
    """Write the complete pre-allocated layout of a result file into the open file ``f``."""
    axis_names = [a[0] for a in axes]
    if len(set(axis_names)) != len(axis_names):
        raise ValueError(f"duplicate axis names: {axis_names}")
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate variable names: {names}")
    for key in RESERVED_ROOT_ATTRS:
        if key in attrs:
            raise ValueError(f"root attribute {key!r} is set by the store, not the caller")
    if "config" not in attrs:
        raise ValueError("root attribute 'config' (the YAML text as run) is required")

    # Root attributes: the store's own first, then the caller's in the caller's order.
    f.attrs["vrsweep_format_version"] = np.int32(FORMAT_VERSION)
    f.attrs["vrsweep_complete"] = np.int32(0)
    f.attrs["created"] = utc_now_iso()
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
    seal_attributes(f, SWEEP_UNSEALED)  # the config, the axes' and variables' labels (store/sealing.py)
    return grid_shape


def scale_names(ds):
    """Names of the dimension scales attached to each dimension of ``ds``."""
    out = []
    for i, dim in enumerate(ds.dims):
        scale_name = dim[0].name if len(dim) else None
        if not scale_name:  # no scale attached, or its reference is damaged
            raise ResultFileError(f"{ds.file.filename}: dataset {ds.name} has no dimension scale on "
                                  f"dimension {i}: corrupt, or not written by vrsweep")
        out.append(scale_name.rsplit("/", 1)[-1])
    return tuple(out)


def add_extras(f, extra, coords, attributes=None):
    """Add derived variables (``finish``) over existing or new dimensions; replaces same names.
    attributes: root attributes to set (or replace) with them."""
    coords = dict(coords or {})
    point_variables = set(point_variables_of(f))
    for name, item in (extra or {}).items():
        array, dims, attrs = item
        array = np.asarray(array)
        dims = tuple(dims)
        if name in point_variables or name in BOOKKEEPING:
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
    for name, value in (attributes or {}).items():
        f.attrs[name] = value
    if extra or attributes:
        seal_attributes(f, SWEEP_UNSEALED)  # the new variables' labels too


def point_variables_of(f):
    return tuple(decode(f["done"].attrs["point_variables"]).split())


def decode(value):
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.generic):
        return value.item()
    return value


def point_label(axes, flat_index) -> str:
    """``g=1.5, Omega=4``: the point at a flat (C-order) index of the grid of ``axes``
    (name -> values), for messages."""
    if not axes:
        return "the single point"
    where = np.unravel_index(int(flat_index), tuple(len(values) for values in axes.values()))
    return ", ".join(f"{name}={values[i]:g}" for (name, values), i in zip(axes.items(), where))


def clean_attrs(attrs):
    return {k: decode(v) for k, v in attrs.items() if k not in INTERNAL_ATTRS}
