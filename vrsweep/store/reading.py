"""Results in Python: any vrsweep file as a lazily read ``xarray.Dataset``.

Every file vrsweep writes is netCDF-4 compatible HDF5 (docs/design.md, "Sweep and shard files"), so xarray's
h5netcdf backend reads it as it is; this module adds only what xarray cannot know:

- which file it is (sweep, shard or trajectory) and a clear error for anything else;
- for a trajectory file, which group to open (the config's model by default), with the file's
  root attributes (config, versions, provenance) carried over to the Dataset;
- the locking policy of the store, so that opening a file works on NFS as writing it does.

Nothing is read until it is used: variables stay on disk until indexed, computed or loaded
(``ds.R.sel(Omega=4).values``, ``ds.load()``). Close the Dataset (or use ``with``) to release the
file. An unfinished sweep or shard file is read lazily too, its points not done as not computed
(:func:`_as_done`). ``status`` keeps its int8 codes
with the CF attributes ``flag_values`` and ``flag_meanings``
(no fill-value masking, so -1 = not computed stays -1); :func:`status_names` turns codes into
names, and CF-aware tools (cf_xarray's ``ds.status.cf == "ok"``) decode them as well.
"""

from __future__ import annotations

import decimal
import functools
import math
import os
import time

import numpy as np

from vrsweep.errors import ResultFileError, UsageError, clip
from vrsweep.numbertext import NumberTextError, to_float

__all__ = ["open_results", "load_results", "status_names", "file_kind", "grid_axes", "point_variables", "derived_variables", "stored_variables", "open_groups"]


def _open_dataset(path, group=None, **kwargs):
    """xarray's h5netcdf backend on the file as ``fileio.open_hdf5`` opens it (the one place of the
    locking policy, with its fallback for an HDF5 too old to be asked); closing the Dataset closes
    the file."""
    import xarray as xr

    from vrsweep.store.fileio import open_hdf5

    h5file = open_hdf5(path, "r")
    try:
        ds = xr.open_dataset(h5file, engine="h5netcdf", group=group, **kwargs)
    except BaseException:
        h5file.close()
        raise
    ds.set_close(h5file.close)  # xarray closes only its own wrapper of a file it was handed
    ds.encoding["source"] = os.fspath(path)
    return ds


def file_kind(path) -> str:
    """``"sweep"``, ``"shard"``, ``"trajectory"``, ``"branch"`` or ``"curves"``; ResultFileError for
    anything else."""
    from vrsweep.store import branch_file, curve_file, trajectory_file
    from vrsweep.store.reader import open_checked

    if trajectory_file.is_trajectory_file(path):
        return "trajectory"
    if branch_file.is_branch_file(path):
        return "branch"
    if curve_file.is_curves_file(path):
        return "curves"
    with open_checked(path) as f:  # raises a ResultFileError that says what is wrong
        return "shard" if "shard" in f.attrs else "sweep"


def _trajectory_groups(path):
    from vrsweep.store.trajectory_file import RUN_GROUPS, _open, check_trajectory

    check_trajectory(path)  # one line for a damaged file, before xarray sees it
    with _open(path, "r") as f:
        runs = [name for name in RUN_GROUPS if name in f]
        slow = [f"slow_flow/{name}" for name in f["slow_flow"]] if "slow_flow" in f else []
        # The checksum is of the whole file (every group's attributes), not of one group's Dataset.
        root_attrs = {key: _plain(value) for key, value in f.attrs.items() if key != "vrsweep_attributes_sha256"}
    return runs, slow, root_attrs


def _plain(value):
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def open_results(path, group: str | None = None):
    """Open a vrsweep result file as an ``xarray.Dataset``, lazily.

    Parameters
    ----------
    path : str or os.PathLike
        A sweep file (``vrsweep run``), a shard file (``--shard I/N``, possibly unfinished), a
        trajectory file (``vrsweep simulate``) or a branch file (``vrsweep continue``: dimension
        ``point`` along the branches, store/branch_file.py) or a curves file (``vrsweep continue
        BRANCH.h5 --point K --along NAME``: dimension ``point`` along the bifurcation curves,
        store/curve_file.py).
    group : str, optional
        Trajectory files only: ``"original"``, ``"effective"`` or ``"slow_flow/<start>"``
        (``state``, ``paper``, ``paper_literal``). Default: the config's own model.

    Returns
    -------
    xarray.Dataset
        Coordinates as stored (one per sweep axis, with ``units`` and ``long_name``); the file's
        attributes in ``ds.attrs``. A trajectory group's Dataset carries the file's root
        attributes too, its own (``status``, ``model``...) taking precedence.
    """
    from vrsweep.errors import PathTypeError

    if not isinstance(path, (str, bytes, os.PathLike)):  # bytes: os.fspath keeps it, as it always did
        raise PathTypeError("path", path)
    path = os.fspath(path)
    if not path:  # not "results file not found: " with nothing after it
        raise ResultFileError("an empty path names no results file: give the file's name")
    kind = file_kind(path)
    if kind == "trajectory":
        runs, slow, root_attrs = _trajectory_groups(path)
        groups = runs + slow
        if group is None:
            model = root_attrs.get("model")
            group = model if model in runs else runs[0]
        if group not in groups:
            raise ResultFileError(f"{path} has no group {group!r}; it has: {', '.join(groups)}")
    elif group is not None:
        raise ResultFileError(f"{path} is a {kind} file, which has no groups (group={group!r})")
    if kind == "branch":
        from vrsweep.store.branch_file import check_branch

        check_branch(path)  # one line for a damaged file, before xarray sees it
    if kind == "curves":
        from vrsweep.store.curve_file import check_curves

        check_curves(path)

    try:
        ds = _open_dataset(path, group)
        if kind in ("sweep", "shard") and not ds.attrs.get("vrsweep_complete", 0):
            ds = _as_done(path, ds)
    except ResultFileError:
        raise
    except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        from vrsweep.store.reader import corrupt_error

        raise corrupt_error(path, error) from None
    if kind == "trajectory":
        ds.attrs = {**root_attrs, **ds.attrs, "vrsweep_group": group}
    ds.attrs.setdefault("vrsweep_file", kind)
    return ds


def _as_done(path, ds):
    """An unfinished sweep or shard file as its ``done`` flags say: a point not done reads as not
    computed (its fill value: NaN, status -1), whatever its bytes. A run writes a chunk's values
    before it marks them done, so a file read while it is written (``HDF5_USE_FILE_LOCKING=FALSE``),
    or left by a kill, holds values of points not yet done, and they showed, R without its ``done``.

    Lazily, as a finished file: every chunk is read once here, a few MiB at a time, to check its
    checksum (store/torn.py), and ``done`` is kept (a byte a point); the values are read when used,
    and masked with that ``done`` (_NotDoneAsFill). Read whole, a 1000 x 1000 map mid-run took
    570 MB and 2 s to open in a notebook. A chunk whose write a kill cut (its checksum fails) is
    recovered as ``--resume`` recovers it, and such a file is read whole (a rare file: its
    recovered chunks live in memory anyway); points that cannot be read back read as not computed,
    with one line, and their number is the Dataset's attribute ``vrsweep_unreadable_points``."""
    from xarray.core import indexing

    from vrsweep.store import torn
    from vrsweep.store.fileio import open_hdf5
    from vrsweep.store.layout import point_variables_of

    try:
        with open_hdf5(path, "r") as f:
            recovery, values = torn.find(f)
            if recovery is not None and recovery.n_torn:
                return _as_done_whole(path, ds, *torn.find(f, keep=True), fills=_fills(f, values))
            done = np.asarray(values["done"]) == 1
            fills = _fills(f, point_variables_of(f))
        ds["done"] = ds["done"].copy(data=done.astype(np.int8))
        for name, fill in fills.items():
            masked = _not_done_as_fill()(ds[name].variable, done, fill)
            ds[name] = ds[name].copy(data=indexing.LazilyIndexedArray(masked))
    except BaseException:
        ds.close()
        raise
    return ds


def _fills(f, names):
    return {name: f[name].fillvalue for name in names}


@functools.cache
def _not_done_as_fill():
    """The class of a point variable of an unfinished file read lazily (made on first use: xarray
    is imported only when a file is read, so that ``vrsweep --help`` starts fast)."""
    from xarray.backends import BackendArray
    from xarray.core import indexing

    class NotDoneAsFill(BackendArray):
        """Read when indexed, its points not done as its fill value. ``variable``: the variable as
        xarray opened it (lazy); ``done``: the grid's flags as read when the file was opened."""

        def __init__(self, variable, done, fill):
            self.variable, self.done, self.fill = variable, done, fill
            self.shape, self.dtype = tuple(variable.shape), variable.dtype

        def __getitem__(self, key):
            return indexing.explicit_indexing_adapter(key, self.shape, indexing.IndexingSupport.BASIC, self._read)

        def _read(self, key):
            for attempt in range(20):  # a live run may be rewriting the chunk right now (locking off)
                try:
                    data = np.asarray(self.variable[key].values)
                    break
                except OSError:
                    if attempt == 19:
                        raise
                    time.sleep(0.05)
            # the grid's part of the key on done: an integer drops an axis from both alike
            mask = self.done[key[:self.done.ndim]]
            mask = np.reshape(mask, np.shape(mask) + (1,) * (data.ndim - np.ndim(mask)))
            return np.where(mask, data, np.asarray(self.fill, dtype=data.dtype))

    return NotDoneAsFill


def _as_done_whole(path, ds, recovery, values, fills):
    """``_as_done`` of a file with chunks a kill cut: read whole, the recovered chunks in place, and
    the file closed."""
    from vrsweep.store.fileio import notice

    done = values.pop("done").astype(bool)
    ds["done"] = ds["done"].copy(data=done.astype(np.int8))
    for name, array in values.items():
        array[~done] = fills[name]  # extra dimensions follow the grid's
        ds[name] = ds[name].copy(data=array)
    ds.load()
    ds.close()
    notice(f"Note: {recovery.describe(path, reading=True)}")
    if recovery.n_lost:
        ds.attrs["vrsweep_unreadable_points"] = recovery.n_lost
    return ds


def open_groups(path) -> dict:
    """Every group of a vrsweep file as a lazily read Dataset, by its path ("" for the root): for
    describing a file whatever it holds (``vrsweep info``). Close each Dataset when done.

    A dataset without dimension scales (not written by vrsweep's store) gets h5netcdf's
    ``phony_dim_N`` dimensions.
    """
    import h5py

    from vrsweep.store.fileio import open_hdf5
    from vrsweep.store.reader import corrupt_error

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ResultFileError(f"results file not found: {path}")
    try:
        if not h5py.is_hdf5(path):
            raise ResultFileError(f"{path} is not an HDF5 file (so not a vrsweep file)")
        names = [""]
        with open_hdf5(path, "r") as f:  # only the names of the groups

            def visit(name, obj):
                if isinstance(obj, h5py.Group):
                    names.append(name)

            f.visititems(visit)
        datasets = {}
        try:
            for name in names:
                datasets[name] = _open_dataset(path, name or None, phony_dims="access")
        except BaseException:
            for ds in datasets.values():
                ds.close()
            raise
        return datasets
    except ResultFileError:
        raise
    except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        raise corrupt_error(path, error) from None


def load_results(path, group: str | None = None):
    """:func:`open_results`, loaded into memory and the file closed (as ``xarray.load_dataset``):
    for a file that is about to be written again, or read once whole."""
    with open_results(path, group) as ds:
        try:
            return ds.load()
        except Exception as error:  # noqa: BLE001 - a chunk failing its checksum, or worse
            from vrsweep.store.reader import corrupt_error

            raise corrupt_error(os.fspath(path), error) from None


def axis_index(name, values, wanted):
    """Index of ``wanted`` on an axis ({at} is how the caller names its choice); 'up'/'down'
    allowed for direction. Must be a finite number on the grid: the nearest value would answer a
    question that was not asked. Shared by plot's selection and continue's start."""
    if name == "direction":
        words = {"up": 1.0, "down": -1.0}
        key = str(wanted).strip().lower()
        try:
            number = words[key] if key in words else to_float(key)
        except ValueError:  # NumberTextError is one
            number = None
        # Numbers too, not only their text: continue's --at hands over -1.0, which as the text
        # "-1.0" was refused although the message itself offers -1.
        if number not in (1.0, -1.0):
            raise UsageError.naming("{at} direction={value}: the direction is up or down (+1 or -1)", value=wanted)
        wanted = number
    given = wanted
    try:
        wanted = to_float(wanted)
    except NumberTextError as error:  # also nan, inf, 1e400 and 1e-400 given as text
        reason = "not a " + str(error).removeprefix("is not a ") if str(error).startswith("is not a ") \
            else "not a number a double holds: it " + str(error).removeprefix("is ")
        raise UsageError.naming("{at} {name}={value}: {reason}; the axis {name}: {span}",
                                name=name, value=clip(given), reason=reason, span=_axis_span(values)) from None
    if not np.isfinite(wanted):  # nan or inf given as a number: argmin would answer with the first value
        raise UsageError.naming("{at} {name}={value}: not a finite number; the axis {name}: {span}",
                                name=name, value=given, span=_axis_span(values))
    index = int(np.argmin(np.abs(values - wanted)))
    if not _matches(values[index], wanted) and not _rounds_to(values, index, given, wanted):
        raise UsageError.naming("{at} {name}={value}: not a value of the axis {name}; {nearest} (axis: {span})",
                                name=name, value=_short(wanted), nearest=_nearest_text(values, wanted),
                                span=_axis_span(values))
    return index


def _matches(value, wanted):
    """Whether ``wanted`` (typed) names the grid value ``value``: to 1e-9, relative."""
    return abs(value - wanted) <= 1e-9 * max(1.0, abs(wanted))


def _rounds_to(values, index, given, wanted):
    """Whether ``given``, typed as text, is grid value ``values[index]`` rounded to the digits typed
    ('1.109' for linspace(0.6, 2, 12)[4] = 1.1090909...), to a last place at least ten times finer
    than the axis's smallest spacing (so '1.1' there is no grid value: the digits barely tell the
    values apart). No quiet nearest value: '12' on an axis of 10 and 20 is neither."""
    if not isinstance(given, str):
        return False
    try:
        place = 10.0 ** decimal.Decimal(given.strip()).as_tuple().exponent
    except (decimal.InvalidOperation, ValueError, TypeError, OverflowError):
        return False
    gaps = np.diff(np.unique(values))
    spacing = float(np.min(gaps)) if gaps.size else math.inf
    return 10.0 * place <= spacing and abs(values[index] - wanted) <= 0.5 * place * (1.0 + 1e-12)


def _typeable(value):
    """The shortest decimal of a grid value that names it (_matches): '1.109090909' for
    linspace(0.6, 2, 12)[4]. Its 6 digits, '1.10909', were offered and then refused."""
    for digits in range(6, 18):
        text = f"{value:.{digits}g}"
        if _matches(value, float(text)):
            return text
    return repr(float(value))


def _nearest_text(values, wanted):
    """'the nearest are 19.5 and 21' -- the grid values on either side of ``wanted``, each as it
    may be typed back."""
    below, above = values[values < wanted], values[values > wanted]
    sides = ([_typeable(below.max())] if below.size else []) + ([_typeable(above.min())] if above.size else [])
    if len(sides) == 2:
        return f"the nearest are {sides[0]} and {sides[1]}"
    return f"the nearest is {sides[0]}"


def _axis_span(values):
    """'81 values from 0 to 40', or the values themselves when there are few."""
    if len(values) <= 6:
        return ", ".join(_short(v) for v in values)
    return f"{len(values)} values from {_short(np.min(values))} to {_short(np.max(values))}"


def _short(value) -> str:
    return f"{value:.6g}"


def grid_axes(ds) -> tuple:
    """The sweep axes of a sweep or shard Dataset, in sweep order (the dimensions of ``done``)."""
    return tuple(ds["done"].dims)


def point_variables(ds) -> tuple:
    """The variables filled point by point, in creation order (derived ones, e.g. theory columns,
    are the Dataset's other data variables); see store.layout."""
    return tuple(str(ds["done"].attrs["point_variables"]).split())


def derived_variables(ds) -> tuple:
    """The variables added when the sweep finished (theory columns, attractor labels)."""
    points = set(point_variables(ds))
    return tuple(name for name in stored_variables(ds) if name not in points)


def stored_variables(ds) -> tuple:
    """Every data variable but the bookkeeping masks (``done``, ``owned``): point variables first,
    then derived ones, in the file's order."""
    from vrsweep.store.layout import BOOKKEEPING

    return tuple(str(name) for name in ds.data_vars if name not in BOOKKEEPING)


def status_names(status) -> np.ndarray:
    """The names of status codes (``"ok"``, ``"max_steps"``...) from an int array or DataArray.

    Uses the array's own ``flag_values`` / ``flag_meanings`` when it has them (CF flags), so it
    reads files of any version; falls back to this version's :mod:`vrsweep.results`.
    """
    from vrsweep.results import FLAG_MEANINGS, FLAG_VALUES

    attrs = getattr(status, "attrs", {})
    values = [int(v) for v in np.atleast_1d(attrs.get("flag_values", FLAG_VALUES))]
    meanings = str(attrs.get("flag_meanings", FLAG_MEANINGS)).split()
    lookup = dict(zip(values, meanings))
    codes = np.asarray(status)
    names = np.array([lookup.get(int(code), f"unknown({int(code)})") for code in codes.reshape(-1)],
                     dtype=object)
    names = names.reshape(codes.shape)
    if hasattr(status, "copy") and hasattr(status, "dims"):  # keep coordinates of a DataArray
        named = status.copy(data=names)
        named.attrs = {"long_name": "how the point's integration ended (name)"}
        return named
    return names
