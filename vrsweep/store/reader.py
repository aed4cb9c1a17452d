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

from vrsweep.errors import ResultFileError
from vrsweep.store.fileio import open_hdf5
from vrsweep.store.layout import (
    BOOKKEEPING, FORMAT_VERSION, VariableSpec, clean_attrs, decode, point_label, point_variables_of, scale_names,
)

# Chunk cache per open dataset: a scattered write (a shard's points) revisits the same chunks.
RDCC_NBYTES = 32 * 1024 * 1024
RDCC_NSLOTS = 10007  # a prime, ~100x the chunks that fit in the cache


def open_store_file(path, mode, **kwargs):
    return open_hdf5(path, mode, rdcc_nbytes=RDCC_NBYTES, rdcc_nslots=RDCC_NSLOTS, **kwargs)


def open_checked(path, mode="r"):
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
        f = open_store_file(path, mode)
    except OSError as error:
        raise corrupt_error(path, error) from None
    try:
        if "vrsweep_format_version" not in f.attrs:
            raise ResultFileError(f"{path} is an HDF5 file but not a vrsweep results file "
                                  "(no vrsweep_format_version attribute)")
        version = int(decode(f.attrs["vrsweep_format_version"]))
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
        raise corrupt_error(path, error) from None
    return f


def corrupt_error(path, error):
    text = str(error)
    if "unable to lock file" in text:  # not just "lock": "sblock" appears in truncation messages
        return ResultFileError(
            f"{path} is locked: another process (a run in progress?) has it open for writing; "
            "set HDF5_USE_FILE_LOCKING=FALSE to read it anyway")
    if "Permission denied" in text or getattr(error, "errno", None) == 13:
        return ResultFileError(f"{path}: permission denied")
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
