"""The trajectory file of ``vrsweep simulate``: one point of a config, integrated and stored.

What is computed (``simulate_point``)
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
from vrsweep.errors import ResultFileError, UsageError
from vrsweep.results import MESSAGES, Status
from vrsweep.store.fileio import open_hdf5, write_bytes
from vrsweep.store.layout import FORMAT_VERSION

FILE_KIND = "trajectory"
DEFAULT_SAMPLES_PER_PERIOD = 200
"""Samples per slow period T = 2 pi/omega. With the paper's omega = 0.5 and Omega = 4 or 5 a slow
period holds 8 or 10 fast periods, so 200 samples give 20-25 per fast period: enough to draw the
fast wiggle of Fig. 3-5. Impacts are stored exactly besides, and the plots insert them."""
MAX_SAMPLES = 20_000_000  # per model: 320 MB of x and v; more is a typo, not a figure

SLOW_FLOW_STARTS = {
    "state": dict(rule="state", literal=False,
                  description="corrected slow flow eq2.24 (ERRATA 1) from R0, theta0 of the initial state (ERRATA 9)"),
    "paper": dict(rule="paper", literal=False,
                  description="corrected slow flow eq2.24 (ERRATA 1) from the paper's R0, theta0 (eq2.20-eq2.22)"),
    "paper_literal": dict(rule="paper", literal=True,
                          description="the paper's printed eq2.24 (sin/cos swapped, ERRATA 1) from the paper's "
                                      "R0, theta0: reproduces the paper's Fig. 6 only"),
}


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
# Computing it
# --------------------------------------------------------------------------------------------


def sample_times(config, samples_per_period=DEFAULT_SAMPLES_PER_PERIOD):
    """Evenly spaced times over the whole run, ``samples_per_period`` per slow period, ends included."""
    if samples_per_period < 1:
        raise UsageError.naming("{samples_per_period} must be at least 1, got {value}", value=samples_per_period)
    n_periods = config.integration.transient_periods + config.integration.measure_periods
    n_samples = n_periods * samples_per_period + 1
    if n_samples > MAX_SAMPLES:
        raise UsageError.naming(
            "{n_periods} slow periods x {samples} samples per period = {n_samples} samples (more than {most}): "
            "lower {samples_per_period} or the run length", n_periods=n_periods, samples=samples_per_period,
            n_samples=n_samples, most=MAX_SAMPLES)
    slow_period = 2.0 * np.pi / config.parameters["omega"]
    return np.linspace(0.0, n_periods * slow_period, n_samples)


def check_single_point(config):
    """simulate integrates one point: a config that still sweeps something is a usage error."""
    if config.axes:
        swept = ", ".join(f"{axis.name} ({len(axis)} values)" for axis in config.axes)
        # {set} before each override: nothing in Python (with_overrides takes "g=5"), --set at the CLI
        example = " ".join("{set}" + f"{axis.name}={axis.values[0]:g}".replace("{", "{{").replace("}", "}}")
                           for axis in config.axes)
        raise UsageError.naming(
            "{source} sweeps {swept}; simulate integrates a single point: fix every swept parameter, e.g. "
            + example, {"set": ""}, source=config.source_name, swept=swept)


def simulate_point(config, samples_per_period=DEFAULT_SAMPLES_PER_PERIOD, compare_effective=False):
    """Integrate the single point of ``config``; returns TrajectoryData (not yet written)."""
    from vrsweep.numerics import trajectory
    from vrsweep.numerics.model import kernel_coefficients

    check_single_point(config)
    if compare_effective and config.model == "effective":
        raise UsageError.naming("{compare_effective} compares the original model with the effective one, but "
                                "the config's model is already effective: drop {compare}, or {model_original}",
                                {"compare": "compare_effective", "model_original": "use model: original"})
    times = sample_times(config, samples_per_period)
    settings = trajectory.settings_vector(**vars(config.integration))
    initial_state = np.array([config.initial["x"], config.initial["v"]])

    models = [config.model] + (["effective"] if compare_effective else [])
    runs = {}
    for model in models:
        result = trajectory.simulate(kernel_coefficients(config.parameters, model), initial_state, settings, times,
                                     method=config.integration.method)
        runs[model] = _model_run(model, result)

    slow_flow = {}
    if "effective" in runs:
        slow_flow = slow_flow_runs(config.parameters, config.initial, times)
    attrs = {"model": config.model, "samples_per_period": int(samples_per_period),
             "slow_period": float(2.0 * np.pi / config.parameters["omega"])}
    return TrajectoryData(runs=runs, slow_flow=slow_flow, attrs=attrs)


def _model_run(model, result):
    from vrsweep.numerics import kernel

    records = result.period_records
    return ModelRun(
        model=model, status=Status(int(result.status)), t=result.sample_times,
        x=result.samples[:, 0], v=result.samples[:, 1], impacts=result.impacts, sticks=result.sticks,
        impacts_per_period=result.impacts_per_period,
        strobe_x=records[:, kernel.REC_X], strobe_v=records[:, kernel.REC_V])


def slow_flow_runs(parameters, initial, times):
    """The reconstruction eq2.21 from each start of SLOW_FLOW_STARTS, sampled at ``times``."""
    from vrsweep.analysis import theory

    omega = parameters["omega"]
    runs = {}
    for start, how in SLOW_FLOW_STARTS.items():
        R0, theta0 = theory.initial_slow_state(parameters, rule=how["rule"], x0=initial["x"], v0=initial["v"])
        # times are evenly spaced from 0, so tau = omega t falls exactly on the slow flow's samples
        tau, R, theta = theory.integrate_slow_flow(parameters, R0, theta0, omega * times[-1], len(times),
                                                   literal=how["literal"])
        x, v = theory.reconstruct(times, tau, R, theta, parameters)
        runs[start] = SlowFlowRun(start=start, literal=how["literal"], R0=float(R0), theta0=float(theta0),
                                  description=how["description"], t=times, x=x, v=v, R=R, theta=theta)
    return runs


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------


def root_attributes(config):
    import numba

    from vrsweep.store.provenance import cf_attributes

    at = ", ".join(f"{name} = {config.parameters[name]:g}" for name in ("g", "Omega"))
    return {"config": config.to_yaml(), "vrsweep_version": __version__,
            "numba_version": numba.__version__, "numpy_version": np.__version__,
            **cf_attributes(f"vrsweep trajectory of the {config.model} model at {at}")}


def write_trajectory(path, data: TrajectoryData, config, overwrite=False):
    """Write ``data`` to ``path`` atomically; refuse an existing file unless ``overwrite``."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise UsageError(f"output {path} is a directory")
    if os.path.lexists(path) and not overwrite:
        raise UsageError.naming("output {path} already exists: pass {overwrite} to replace it",
                                {"overwrite": "overwrite=True"}, path=path)
    attrs = {"vrsweep_file": FILE_KIND, "vrsweep_format_version": np.int32(FORMAT_VERSION),
             "vrsweep_complete": np.int32(1),
             "created": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
             **root_attributes(config), **data.attrs}

    # Built in memory, then written whole: the disk only ever sees plain bytes, so a full disk
    # is one clear error, and its message knows the file's exact size.
    image = io.BytesIO()
    with h5py.File(image, "w") as f:  # a buffer, not a file: no locking to decide
        for name, value in attrs.items():
            f.attrs[name] = value
        for model, run in data.runs.items():
            _write_model_run(f.create_group(model, track_order=True), run)
        if data.slow_flow:
            group = f.create_group("slow_flow", track_order=True)
            for start, run in data.slow_flow.items():
                _write_slow_flow(group.create_group(start, track_order=True), run)
    write_bytes(path, image.getvalue())


def _dimension(group, name, values, long_name):
    values = np.asarray(values)
    scale = group.create_dataset(name, data=values, **(_COMPRESSION if values.size > 4096 else {}))
    scale.make_scale(name)
    scale.attrs["units"] = "1"
    scale.attrs["long_name"] = long_name
    return scale


# Time series compress about twofold and are written once: worth it. Short arrays stay plain.
_COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


def _variable(group, name, values, scale, long_name):
    values = np.asarray(values, dtype=np.float64)
    ds = group.create_dataset(name, data=values, **(_COMPRESSION if values.size > 4096 else {}))
    ds.dims[0].attach_scale(scale)
    ds.attrs["units"] = "1"
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
    impact = _dimension(group, "impact", np.arange(len(run.impacts), dtype=np.int64), "impact number")
    _variable(group, "impact_t", run.impacts[:, 0], impact, "time of the impact at x = Delta")
    _variable(group, "impact_v_before", run.impacts[:, 1], impact, "velocity just before the impact")
    _variable(group, "impact_v_after", run.impacts[:, 2], impact, "velocity just after the impact (eq2.2)")
    stick = _dimension(group, "stick", np.arange(len(run.sticks), dtype=np.int64), "sticking interval number")
    _variable(group, "stick_start", run.sticks[:, 0], stick, "time the mass sticks to the barrier")
    _variable(group, "stick_end", run.sticks[:, 1], stick, "time the mass is released")
    period = _dimension(group, "period", np.arange(1, len(run.impacts_per_period) + 1, dtype=np.int64),
                        "slow period number n (nT - T < t <= nT, T = 2 pi/omega)")
    counts = group.create_dataset("impacts_per_period", data=np.asarray(run.impacts_per_period, dtype=np.int64))
    counts.dims[0].attach_scale(period)
    counts.attrs["units"] = "1"
    counts.attrs["long_name"] = "impacts in each slow period, transient included (Fig. impact_no)"
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
    _variable(group, "theta", run.theta, time, "slow-flow phase theta (not wrapped)")


# --------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------


def _open(path, mode):
    return open_hdf5(path, mode)  # the results store's locking policy


def is_trajectory_file(path) -> bool:
    """True for an HDF5 file that says it is a vrsweep trajectory; False for anything else."""
    try:
        if not os.path.isfile(path) or not h5py.is_hdf5(path):
            return False
        with _open(path, "r") as f:
            return _text(f.attrs.get("vrsweep_file", "")) == FILE_KIND
    except (OSError, ValueError):
        return False  # unreadable: let the results reader say why


def read_trajectory(path) -> TrajectoryData:
    """Read a trajectory file, or raise ResultFileError with a one-line reason."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ResultFileError(f"trajectory file not found: {path}")
    try:
        with _open(path, "r") as f:
            if _text(f.attrs.get("vrsweep_file", "")) != FILE_KIND:
                raise ResultFileError(f"{path} is not a vrsweep trajectory file (written by vrsweep simulate)")
            version = int(f.attrs.get("vrsweep_format_version", 0))
            if version != FORMAT_VERSION:
                raise ResultFileError(f"{path} has trajectory format {version}; this vrsweep reads format "
                                      f"{FORMAT_VERSION}")
            attrs = {key: _text(value) for key, value in f.attrs.items()}
            runs = {name: _read_model_run(f[name]) for name in ("original", "effective") if name in f}
            slow_flow = {}
            if "slow_flow" in f:
                slow_flow = {start: _read_slow_flow(group) for start, group in f["slow_flow"].items()}
    except ResultFileError:
        raise
    except (OSError, KeyError, ValueError) as error:
        raise ResultFileError(f"{path} is truncated or corrupt (HDF5: {error})") from None
    if not runs:
        raise ResultFileError(f"{path} holds no trajectory (no 'original' or 'effective' group)")
    return TrajectoryData(runs=runs, slow_flow=slow_flow, attrs=attrs, path=path)


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


def _text(value):
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.generic):
        return value.item()
    return value


__all__ = [
    "DEFAULT_SAMPLES_PER_PERIOD", "SLOW_FLOW_STARTS", "ModelRun", "SlowFlowRun", "TrajectoryData",
    "sample_times", "check_single_point", "simulate_point", "slow_flow_runs", "write_trajectory",
    "read_trajectory", "is_trajectory_file",
]
