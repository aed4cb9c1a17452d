"""Results in Python: any vrsweep file as a lazily read ``xarray.Dataset``.

Every file vrsweep writes is netCDF-4 compatible HDF5 (docs/design.md, "Result files"), so xarray's
h5netcdf backend reads it as it is; this module adds only what xarray cannot know:

- which file it is (sweep, shard or trajectory) and a clear error for anything else;
- for a trajectory file, which group to open (the config's model by default), with the file's
  root attributes (config, versions, provenance) carried over to the Dataset;
- the locking policy of the store, so that opening a file works on NFS as writing it does.

Nothing is read until it is used: variables stay on disk until indexed, computed or loaded
(``ds.R.sel(Omega=4).values``, ``ds.load()``). Close the Dataset (or use ``with``) to release the
file. ``status`` keeps its int8 codes with the CF attributes ``flag_values`` and ``flag_meanings``
(no fill-value masking, so -1 = not computed stays -1); :func:`status_names` turns codes into
names, and CF-aware tools (cf_xarray's ``ds.status.cf == "ok"``) decode them as well.
"""

from __future__ import annotations

import os

import numpy as np

from vrsweep.errors import ResultFileError

__all__ = ["open_results", "status_names", "file_kind"]


def _locking_kwargs():
    from vrsweep.fileio import hdf5_locking_kwargs

    return hdf5_locking_kwargs()


def file_kind(path) -> str:
    """``"sweep"``, ``"shard"`` or ``"trajectory"``; ResultFileError for anything else."""
    from vrsweep import store, trajectory_file

    if trajectory_file.is_trajectory_file(path):
        return "trajectory"
    with store._open_checked(path) as f:  # raises a ResultFileError that says what is wrong
        return "shard" if "shard" in f.attrs else "sweep"


def _trajectory_groups(path):
    from vrsweep.trajectory_file import _open

    with _open(path, "r") as f:
        runs = [name for name in ("original", "effective") if name in f]
        slow = [f"slow_flow/{name}" for name in f["slow_flow"]] if "slow_flow" in f else []
        root_attrs = {key: _plain(value) for key, value in f.attrs.items()}
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
        A sweep file (``vrsweep run``), a shard file (``--shard I/N``, possibly unfinished) or a
        trajectory file (``vrsweep simulate``).
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
    import xarray as xr

    path = os.fspath(path)
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

    try:
        ds = xr.open_dataset(path, engine="h5netcdf", group=group, driver_kwds=_locking_kwargs())
    except OSError as error:
        from vrsweep.store import _corrupt_error

        raise _corrupt_error(path, error) from None
    if kind == "trajectory":
        ds.attrs = {**root_attrs, **ds.attrs, "vrsweep_group": group}
    ds.attrs.setdefault("vrsweep_file", kind)
    return ds


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
