"""The trajectory file of ``vrsweep simulate``: one point of a config, integrated and stored.

What is computed (``vrsweep.execution.simulate.simulate_point``)
-------------------------------------
- the config's model (eq2.1-eq2.2, or the effective eq2.10) from the config's initial state,
  sampled on the solver's dense output at ``samples_per_period`` evenly spaced times per slow
  period T = 2 pi/omega, over transient + measurement periods (the sweep's run length);
- every impact (time, velocity before and after), every sticking interval, and the number of
  impacts in each slow period, period by period, transient included (Fig. impact_no);
- with ``compare_effective`` (or when the model is already the effective one): the effective
  system from the same initial state, and the slow-flow reconstruction X = R cos(omega t + theta)
  (eq2.21) of the first-order theory, from three starts (ERRATA 1, 9):
    ``state``         corrected slow flow eq2.24, (R0, theta0) from the initial state x(0), x'(0);
    ``paper``         corrected slow flow, the paper's start R0 = Delta sec(pi/omega), theta0 from eq2.22;
    ``paper_literal`` the paper's printed eq2.24 (sin and cos swapped) from the paper's start --
                      how the paper's Fig. 6 was made, kept only to reproduce it.

Layout (HDF5; every group opens with ``xarray.open_dataset(path, group=..., engine="h5netcdf")``)
----------------------------------------------------------------------------------------------
root attributes: ``vrsweep_file = "trajectory"``, ``vrsweep_format_version``, ``vrsweep_complete``,
``created``, ``config`` (the resolved YAML), ``model``, ``vrsweep_version``, ``numba_version``,
``numpy_version``, ``samples_per_period``, ``slow_period``.

``/original`` and/or ``/effective``, one group per model run:
    time (dim)        t of the samples
    x, v (time)       position and velocity from the dense output
    impact (dim)      index of the impact
    impact_t, impact_v_before, impact_v_after (impact)
    stick (dim)       index of the sticking interval
    stick_start, stick_end (stick)
    period (dim)      slow period number 1, 2, ... (period n is nT - T < t <= nT)
    impacts_per_period (period), strobe_x, strobe_v (period): state at t = nT
    attrs: model, status (int), status_name, status_message
``/slow_flow/<start>`` for each start above:
    time (dim), x, v (time): the reconstruction eq2.21 at the sample times;
    R, theta (time): the slow flow at tau = omega t
    attrs: start, literal, R0, theta0, description

The file is built in memory and written whole through ``fileio.write_bytes``: it exists complete
or not at all.
"""

from __future__ import annotations

import datetime
import io
import os
from dataclasses import dataclass, field

import h5py
import numpy as np

from vrsweep import __version__
from vrsweep.errors import ResultFileError
from vrsweep.results import MESSAGES, Status
from vrsweep.store.fileio import LIBVER, has_file_kind, open_hdf5, output_target, write_bytes
from vrsweep.store.layout import FORMAT_VERSION
from vrsweep.store.provenance import WRITTEN
from vrsweep.store.reader import open_in_this_process_error
from vrsweep.store.sealing import (ATTRIBUTES_CHECKSUM, WHEN_AND_HOW, check_attributes, note_if_unprotected, seal_attributes,
                                   unless_changed)

FILE_KIND = "trajectory"
# --------------------------------------------------------------------------------------------
# What a trajectory file holds
# --------------------------------------------------------------------------------------------


@dataclass
class ModelRun:
    """One model integrated from the initial state: samples, impacts, sticks, per-period counts."""

    model: str
    status: Status
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    impacts: np.ndarray             # (n, 3): t, v before, v after
    sticks: np.ndarray              # (n, 2): start, end
    impacts_per_period: np.ndarray  # (n_periods,), transient included
    strobe_x: np.ndarray            # (n_periods,): x at t = nT
    strobe_v: np.ndarray


@dataclass
class SlowFlowRun:
    """The first-order reconstruction eq2.21 from the slow flow eq2.24, at the sample times."""

    start: str
    literal: bool
    R0: float
    theta0: float
    description: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    R: np.ndarray
    theta: np.ndarray


@dataclass
class TrajectoryData:
    """A trajectory file in memory (what ``read_trajectory`` returns and ``write_trajectory`` takes)."""

    runs: dict                      # model name -> ModelRun, "original" first
    slow_flow: dict = field(default_factory=dict)   # start name -> SlowFlowRun
    attrs: dict = field(default_factory=dict)
    path: str | None = None

    complete = True  # written atomically: a trajectory file is never partial

    @property
    def model(self) -> str:
        return self.attrs.get("model", next(iter(self.runs)))

    @property
    def config_text(self) -> str:
        return self.attrs.get("config", "")


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------


def root_attributes(config):
    import numba

    from vrsweep.store.provenance import cf_attributes

    from vrsweep.store.provenance import model_attributes

    shown = ("g", "Omega") if isinstance(config.model, str) else config.parameter_names[:4]
    at = ", ".join(f"{name} = {config.parameters[name]:g}" for name in shown)
    return {"config": config.to_yaml(), "vrsweep_version": __version__, **model_attributes(config.model),
            "numba_version": numba.__version__, "numpy_version": np.__version__,
            **cf_attributes(f"vrsweep trajectory of the {config.model} model at {at}", model=config.model)}


def write_trajectory(path, data: TrajectoryData, config, overwrite=False):
    """Write ``data`` to ``path`` atomically; refuse an existing file unless ``overwrite``."""
    path = output_target(path, overwrite=overwrite)  # fileio's one rule of what may be replaced
    attrs = {"vrsweep_file": FILE_KIND, "vrsweep_format_version": np.int32(FORMAT_VERSION),
             "vrsweep_complete": np.int32(1),
             "created": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
             **root_attributes(config), **data.attrs}

    # Built in memory, then written whole: the disk only ever sees plain bytes, so a full disk
    # is one clear error, and its message knows the file's exact size.
    image = io.BytesIO()
    with h5py.File(image, "w", libver=LIBVER) as f:  # a buffer, not a file: no locking to decide
        for name, value in attrs.items():
            f.attrs[name] = value
        for model, run in data.runs.items():
            _write_model_run(f.create_group(model, track_order=True), run)
        if data.slow_flow:
            group = f.create_group("slow_flow", track_order=True)
            for start, run in data.slow_flow.items():
                _write_slow_flow(group.create_group(start, track_order=True), run)
        seal_attributes(f, WHEN_AND_HOW)  # the config, the runs' statuses, every label (store/sealing.py)
    write_bytes(path, image.getvalue())


def _dimension(group, name, values, long_name):
    values = np.asarray(values)
    scale = group.create_dataset(name, data=values, **_storage(values))
    scale.make_scale(name)
    scale.attrs["units"] = "1"
    scale.attrs["long_name"] = long_name
    return scale


# Time series compress about twofold and are written once: worth it. Short arrays stay plain.
# Every dataset carries a checksum, so a flipped bit is an error when read, not a wrong figure.
_COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


def _storage(values):
    options = dict(_COMPRESSION) if values.size > 4096 else {}
    if values.size:  # HDF5 filters need a chunked, non-empty dataset
        options["fletcher32"] = True
    return options


def _variable(group, name, values, scale, long_name, units="1"):
    """units "1": the paper's variables are dimensionless (eq2.4); a phase is in rad."""
    values = np.asarray(values, dtype=np.float64)
    ds = group.create_dataset(name, data=values, **_storage(values))
    ds.dims[0].attach_scale(scale)
    ds.attrs["units"] = units
    ds.attrs["long_name"] = long_name
    return ds


def _write_model_run(group, run: ModelRun):
    group.attrs["model"] = run.model
    group.attrs["status"] = np.int8(run.status)
    group.attrs["status_name"] = run.status.name.lower()
    group.attrs["status_message"] = MESSAGES[run.status]
    time = _dimension(group, "time", run.t, "time t of the dense-output samples")
    _variable(group, "x", run.x, time, "position x")
    _variable(group, "v", run.v, time, "velocity dx/dt")
    written = run.model == WRITTEN  # its own barriers and period T, not the paper's Delta and 2 pi/omega
    impact = _dimension(group, "impact", np.arange(len(run.impacts), dtype=np.int64), "impact number")
    _variable(group, "impact_t", run.impacts[:, 0], impact,
              "time of the impact at a barrier" if written else "time of the impact at x = Delta")
    _variable(group, "impact_v_before", run.impacts[:, 1], impact, "velocity just before the impact")
    _variable(group, "impact_v_after", run.impacts[:, 2], impact, "velocity just after the impact (eq2.2)")
    stick = _dimension(group, "stick", np.arange(len(run.sticks), dtype=np.int64), "sticking interval number")
    _variable(group, "stick_start", run.sticks[:, 0], stick, "time the mass sticks to the barrier")
    _variable(group, "stick_end", run.sticks[:, 1], stick, "time the mass is released")
    period = _dimension(group, "period", np.arange(1, len(run.impacts_per_period) + 1, dtype=np.int64),
                        "period number n (nT - T < t <= nT, T the model's period)" if written else
                        "slow period number n (nT - T < t <= nT, T = 2 pi/omega)")
    counts = group.create_dataset("impacts_per_period", data=np.asarray(run.impacts_per_period, dtype=np.int64))
    counts.dims[0].attach_scale(period)
    counts.attrs["units"] = "1"
    counts.attrs["long_name"] = ("impacts in each period T, transient included" if written else
                                 "impacts in each slow period, transient included (Fig. impact_no)") + (
                                     "; -1: not reached (the run failed before)" if (run.impacts_per_period < 0).any()
                                     else "")
    _variable(group, "strobe_x", run.strobe_x, period, "stroboscopic x at t = nT")
    _variable(group, "strobe_v", run.strobe_v, period, "stroboscopic velocity at t = nT")


def _write_slow_flow(group, run: SlowFlowRun):
    group.attrs["start"] = run.start
    group.attrs["literal"] = np.int8(run.literal)
    group.attrs["R0"] = run.R0
    group.attrs["theta0"] = run.theta0
    group.attrs["description"] = run.description
    time = _dimension(group, "time", run.t, "time t")
    _variable(group, "x", run.x, time, "reconstructed X = R cos(omega t + theta) (eq2.21)")
    _variable(group, "v", run.v, time, "reconstructed dX/dt = -omega R sin(omega t + theta) (eq2.21)")
    _variable(group, "R", run.R, time, "slow-flow amplitude R (amplitude of X, not a gain)")
    _variable(group, "theta", run.theta, time, "slow-flow phase theta (not wrapped)", units="rad")


# --------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------


def _open(path, mode):
    return open_hdf5(path, mode)  # the results store's locking policy


def is_trajectory_file(path) -> bool:
    """True for an HDF5 file that says it is a vrsweep trajectory; False for anything else."""
    return has_file_kind(path, FILE_KIND)  # unreadable: False, and the results reader says why


# The groups a trajectory file may hold: one per model run (provenance.model_key's names).
RUN_GROUPS = ("original", "effective", "written")


def check_trajectory(path) -> None:
    """Raise ResultFileError (one line) unless ``path`` is a trajectory file of this format whose
    structure is sound: the one check every reader of trajectory files goes through."""
    path = os.fspath(path)
    try:
        with _open(path, "r") as f:
            _check_header(f, path)
            for name in RUN_GROUPS:
                if name in f:
                    _checked(f[name], MODEL_RUN_SERIES, path)
            for group in (f["slow_flow"].values() if "slow_flow" in f else ()):
                _checked(group, SLOW_FLOW_SERIES, path)
            protected = check_attributes(f, path, WHEN_AND_HOW)  # after the structure: its messages say more
    except ResultFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as error:
        raise open_in_this_process_error(path, error) or ResultFileError(
            f"{path} is truncated or corrupt (HDF5: {error})") from None
    note_if_unprotected(path, protected)


def _check_header(f, path):
    # (a refusal for what an attribute says names the checksum too where the attributes fail it)
    if _text(f.attrs.get("vrsweep_file", "")) != FILE_KIND:
        raise ResultFileError(f"{path} is not a vrsweep trajectory file (written by vrsweep simulate)"
                              + unless_changed(f, path))
    version = f.attrs.get("vrsweep_format_version", 0)
    if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)):
        raise ResultFileError(f"{path} is corrupt: attribute vrsweep_format_version must be a whole "
                              f"number, got {_text(version)!r}")
    if version != FORMAT_VERSION:
        raise ResultFileError(f"{path} has trajectory format {version}; this vrsweep reads format "
                              f"{FORMAT_VERSION}" + unless_changed(f, path))
    _check_root(f, path)
    for name in RUN_GROUPS:
        if name in f:
            try:
                Status(int(f[name].attrs["status"]))
            except (KeyError, ValueError, TypeError):
                raise _corrupt(path, f"/{name} has no valid status attribute") from None


def read_trajectory(path) -> TrajectoryData:
    """Read a trajectory file, or raise ResultFileError with a one-line reason."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ResultFileError(f"trajectory file not found: {path}")
    try:
        with _open(path, "r") as f:
            _check_header(f, path)
            attrs = {key: _text(value) for key, value in f.attrs.items()}
            runs = {name: _read_model_run(_checked(f[name], MODEL_RUN_SERIES, path))
                    for name in RUN_GROUPS if name in f}
            slow_flow = {}
            if "slow_flow" in f:
                slow_flow = {start: _read_slow_flow(_checked(group, SLOW_FLOW_SERIES, path))
                             for start, group in f["slow_flow"].items()}
            protected = check_attributes(f, path, WHEN_AND_HOW)
    except ResultFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as error:
        raise open_in_this_process_error(path, error) or ResultFileError(
            f"{path} is truncated or corrupt (HDF5: {error})") from None
    if not runs:
        raise ResultFileError(f"{path} holds no trajectory (no 'original', 'effective' or 'written' group)")
    note_if_unprotected(path, protected)
    attrs.pop(ATTRIBUTES_CHECKSUM, None)  # the file's bookkeeping, not the run's
    return TrajectoryData(runs=runs, slow_flow=slow_flow, attrs=attrs, path=path)


# The structure a reader relies on, checked once where the file is opened (as store/reader.py
# checks sweep files): every series 1-D float64 (counts int64), the series of one dimension of
# one length, the time axes finite and non-decreasing. Anything else is a one-line ResultFileError, never a
# traceback in a figure.
MODEL_RUN_SERIES = {"time": ("time", "x", "v"), "impact": ("impact_t", "impact_v_before", "impact_v_after"),
                    "stick": ("stick_start", "stick_end"), "period": ("impacts_per_period", "strobe_x", "strobe_v")}
SLOW_FLOW_SERIES = {"time": ("time", "x", "v", "R", "theta")}
INTEGER_SERIES = {"impacts_per_period"}  # counts; every other series is float64


def _corrupt(path, what):
    return ResultFileError(f"{path} is corrupt: {what}")


def _check_root(f, path):
    from vrsweep.store.branch_file import TEXT_ATTRS, _texts_are_text

    # As a branch file's: every attribute stored as text is UTF-8, and those vrsweep writes as text
    # are text (a title of bytes that are not UTF-8 was a UnicodeDecodeError from open_results).
    _texts_are_text(f, path, "attribute ", tuple(name for name in TEXT_ATTRS if name in f.attrs))
    for name in RUN_GROUPS:
        if name in f:
            _texts_are_text(f[name], path, f"attribute /{name}.", ("model",) if "model" in f[name].attrs else ())
            # a run's model names its group: the figure's rows are titled by it (an array there was
            # an "unhashable type" traceback from plot)
            if _text(f[name].attrs.get("model", name)) != name:
                raise _corrupt(path, f"/{name} is the run of another model ({_text(f[name].attrs['model'])!r})")
    for name in ("config", "model"):
        if name in f.attrs and not isinstance(_text(f.attrs[name]), str):
            raise _corrupt(path, f"attribute {name} must be text, got {_text(f.attrs[name])!r}")
    if "samples_per_period" in f.attrs:
        value = f.attrs["samples_per_period"]
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 1:
            raise _corrupt(path, f"attribute samples_per_period must be a whole number >= 1, got {_text(value)!r}")
    if "slow_period" in f.attrs:
        value = f.attrs["slow_period"]
        if not isinstance(value, (float, np.floating)) or not np.isfinite(value) or value <= 0:
            raise _corrupt(path, f"attribute slow_period must be a positive number, got {_text(value)!r}")


def _checked(group, series, path):
    """``group`` after checking that each set of ``series`` is 1-D float64 of one length; its time
    axis, if any, finite and non-decreasing."""
    for dimension, names in series.items():
        length = None
        for name in names:
            where = f"{group.name}/{name}"
            if name not in group or not isinstance(group[name], h5py.Dataset):
                raise _corrupt(path, f"{where} is missing")
            data = group[name]
            kind = "iu" if name in INTEGER_SERIES else "f"
            if data.ndim != 1 or data.dtype.kind not in kind or data.dtype.itemsize != 8:
                wanted = "int64" if name in INTEGER_SERIES else "float64"
                raise _corrupt(path, f"{where} must be a 1-D {wanted} series, found shape {data.shape} {data.dtype}")
            if length is not None and data.shape[0] != length:
                raise _corrupt(path, f"{where} has {data.shape[0]} values, the other {dimension} series {length}")
            length = data.shape[0]
        if dimension == "time":
            time = group["time"][()]
            if not np.all(np.isfinite(time)) or np.any(np.diff(time) < 0):
                raise _corrupt(path, f"{group.name}/time must be finite and non-decreasing")
    return group


def _read_model_run(group) -> ModelRun:
    impacts = np.stack([group["impact_t"][()], group["impact_v_before"][()], group["impact_v_after"][()]], axis=-1)
    sticks = np.stack([group["stick_start"][()], group["stick_end"][()]], axis=-1)
    return ModelRun(
        model=_text(group.attrs["model"]), status=Status(int(group.attrs["status"])),
        t=group["time"][()], x=group["x"][()], v=group["v"][()],
        impacts=impacts.reshape(-1, 3), sticks=sticks.reshape(-1, 2),
        impacts_per_period=group["impacts_per_period"][()],
        strobe_x=group["strobe_x"][()], strobe_v=group["strobe_v"][()])


def _read_slow_flow(group) -> SlowFlowRun:
    return SlowFlowRun(
        start=_text(group.attrs["start"]), literal=bool(group.attrs["literal"]),
        R0=float(group.attrs["R0"]), theta0=float(group.attrs["theta0"]),
        description=_text(group.attrs["description"]),
        t=group["time"][()], x=group["x"][()], v=group["v"][()], R=group["R"][()], theta=group["theta"][()])


# The attributes open_results gives a group's Dataset beside the file's root ones (its own taking
# precedence): a run's, a slow flow's, and which group it is.
RUN_ATTRIBUTES = ("model", "status", "status_name", "status_message")
SLOW_FLOW_ATTRIBUTES = ("start", "literal", "R0", "theta0", "description")
GROUP_ATTRIBUTE = "vrsweep_group"


def is_trajectory_dataset(ds) -> bool:
    """Whether ``ds`` is one group of a trajectory file as ``vrsweep.simulate`` or ``open_results``
    gives it (an xarray Dataset whose attributes name the group)."""
    attrs = getattr(ds, "attrs", None)
    return (hasattr(ds, "data_vars") and isinstance(attrs, dict) and attrs.get("vrsweep_file") == FILE_KIND
            and isinstance(attrs.get(GROUP_ATTRIBUTE), str))


def from_datasets(datasets) -> TrajectoryData:
    """A trajectory as the Python API hands it out -- one group's Dataset (``vrsweep.simulate``,
    ``open_results``) or ``{group: Dataset}`` of every group (``simulate(..., compare="effective")``)
    -- as the :class:`TrajectoryData` that ``read_trajectory`` makes of its file, which the
    trajectory figures draw. Raises ValueError naming what is not a trajectory's group."""
    if is_trajectory_dataset(datasets):
        datasets = {datasets.attrs[GROUP_ATTRIBUTE]: datasets}
    runs, slow_flow, root = {}, {}, None
    for name, ds in datasets.items():
        if not is_trajectory_dataset(ds):
            raise ValueError(f"{name!r} is not a group of a trajectory (what vrsweep.simulate returns)")
        group = ds.attrs[GROUP_ATTRIBUTE]
        if group in RUN_GROUPS:
            impacts = np.stack([ds[key].values for key in ("impact_t", "impact_v_before", "impact_v_after")], axis=-1)
            sticks = np.stack([ds["stick_start"].values, ds["stick_end"].values], axis=-1)
            runs[group] = ModelRun(
                model=_text(ds.attrs["model"]), status=Status(int(ds.attrs["status"])),
                t=ds["time"].values, x=ds["x"].values, v=ds["v"].values,
                impacts=impacts.reshape(-1, 3), sticks=sticks.reshape(-1, 2),
                impacts_per_period=ds["impacts_per_period"].values,
                strobe_x=ds["strobe_x"].values, strobe_v=ds["strobe_v"].values)
        elif group.startswith("slow_flow/"):
            slow_flow[group.split("/", 1)[1]] = SlowFlowRun(
                start=_text(ds.attrs["start"]), literal=bool(ds.attrs["literal"]), R0=float(ds.attrs["R0"]),
                theta0=float(ds.attrs["theta0"]), description=_text(ds.attrs["description"]),
                t=ds["time"].values, x=ds["x"].values, v=ds["v"].values, R=ds["R"].values,
                theta=ds["theta"].values)
        else:
            raise ValueError(f"{name!r} is group {group!r}, which no trajectory file holds")
        if root is None or not group.startswith("slow_flow/"):
            root = ds  # a run's attributes, or a slow flow's where there is no run
    if not runs:
        raise ValueError("a slow flow alone is no trajectory: give the model's run with it (the dict "
                         "vrsweep.simulate(..., compare='effective') returns)")
    own = (*RUN_ATTRIBUTES, *SLOW_FLOW_ATTRIBUTES, GROUP_ATTRIBUTE)
    attrs = {key: _text(value) for key, value in root.attrs.items() if key not in own}
    # The file's model is the config's: the first run (original before effective), as in the file.
    attrs["model"] = next(name for name in RUN_GROUPS if name in runs)
    ordered = {name: runs[name] for name in RUN_GROUPS if name in runs}
    source = root.encoding.get("source")
    return TrajectoryData(runs=ordered, slow_flow=slow_flow, attrs=attrs, path=source)


def _text(value):
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.generic):
        return value.item()
    return value


__all__ = [
    "ModelRun", "SlowFlowRun", "TrajectoryData", "write_trajectory", "read_trajectory", "is_trajectory_file",
    "is_trajectory_dataset", "from_datasets",
]
