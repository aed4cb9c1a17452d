"""One point of a config integrated for ``vrsweep simulate``: the samples, impacts and sticking
of each model run, and the slow-flow reconstructions of the first-order theory.

What is computed and how the result is stored: ``vrsweep/store/trajectory_file.py``. This module
computes (numerics, analysis); that one writes and reads.
"""

from __future__ import annotations

import numpy as np

from vrsweep.analysis.sampling import SAMPLES_PER_CYCLE
from vrsweep.errors import UsageError
from vrsweep.results import Status
from vrsweep.store.trajectory_file import ModelRun, SlowFlowRun, TrajectoryData

DEFAULT_SAMPLES_PER_PERIOD = 200
"""Samples per slow period T = 2 pi/omega, at least. With the paper's omega = 0.5 and Omega = 4 or 5
a slow period holds 8 or 10 fast periods, so 200 samples give 20-25 per fast period: enough to draw
the fast wiggle of Fig. 3-5. Impacts are stored exactly besides, and the plots insert them."""
MAX_SAMPLES = 20_000_000  # per model: 320 MB of x and v; more is a typo, not a figure
# A trajectory keeps every period's record, transient included (impacts per period are stored):
# 80 bytes a period (numerics/records.py), 320 MB at most, as for the samples.
MAX_PERIODS = 4_000_000

SLOW_FLOW_STARTS = {
    "state": dict(rule="state", literal=False,
                  description="corrected slow flow eq2.24 (ERRATA 1) from R0, theta0 of the initial state (ERRATA 9)"),
    "paper": dict(rule="paper", literal=False,
                  description="corrected slow flow eq2.24 (ERRATA 1) from the paper's R0, theta0 (eq2.20-eq2.22)"),
    "paper_literal": dict(rule="paper", literal=True,
                          description="the paper's printed eq2.24 (sin/cos swapped, ERRATA 1) from the paper's "
                                      "R0, theta0: reproduces the paper's Fig. 6 only"),
}


def sample_times(config, samples_per_period=DEFAULT_SAMPLES_PER_PERIOD):
    """Evenly spaced times over the whole run, ``samples_per_period`` per slow period, ends included."""
    if samples_per_period < 1:
        raise UsageError.naming("{samples_per_period} must be at least 1, got {value}", value=samples_per_period)
    n_periods = config.integration.transient_periods + config.integration.measure_periods
    periods = "periods T" if config.written else "slow periods"  # a written model's own period
    if n_periods > MAX_PERIODS:
        raise UsageError.naming(
            "{n_periods} {periods} (transient + measured) is more than {most} for one trajectory, which "
            "keeps a record of every period: lower the run length", n_periods=n_periods, most=MAX_PERIODS,
            periods=periods)
    n_samples = n_periods * samples_per_period + 1
    if n_samples > MAX_SAMPLES:
        raise UsageError.naming(
            "{n_periods} {periods} x {samples} samples per period = {n_samples} samples (more than {most}): "
            "lower {samples_per_period} or the run length", n_periods=n_periods, samples=samples_per_period,
            n_samples=n_samples, most=MAX_SAMPLES, periods=periods)
    return np.linspace(0.0, n_periods * stroboscopic_period(config), n_samples)


def default_samples(config) -> int:
    """Samples per period T when none is asked for: DEFAULT_SAMPLES_PER_PERIOD, or SAMPLES_PER_CYCLE
    per cycle of the fastest force when that is more (Omega = 50: 100 cycles a slow period, 2000
    samples), within MAX_SAMPLES for the run."""
    from vrsweep.analysis.diagnostics import sampling_of_forcing

    cycles = float(sampling_of_forcing(config.model, [config.parameters], 1)[1][0])
    wanted = int(np.ceil(SAMPLES_PER_CYCLE * cycles)) if np.isfinite(cycles) else DEFAULT_SAMPLES_PER_PERIOD
    n_periods = max(1, config.integration.transient_periods + config.integration.measure_periods)
    room = (MAX_SAMPLES - 1) // n_periods
    return max(DEFAULT_SAMPLES_PER_PERIOD, min(wanted, room))


def stroboscopic_period(config) -> float:
    """T at the config's fixed parameters: 2 pi / omega for the paper's models, a written model's period."""
    from vrsweep.numerics.coefficients import PERIOD
    from vrsweep.numerics.models import kernels_for

    return float(kernels_for(config.model).coefficients(config.parameters)[PERIOD])


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


def simulate_point(config, samples_per_period=None, compare_effective=False):
    """Integrate the single point of ``config``; returns TrajectoryData (not yet written).
    samples_per_period: None for ``default_samples``."""
    from vrsweep.numerics import trajectory
    from vrsweep.numerics.models import kernels_for
    from vrsweep.store.provenance import model_key

    check_single_point(config)
    if compare_effective and config.model == "effective":
        raise UsageError.naming("{compare_effective} compares the original model with the effective one, but "
                                "the config's model is already effective: drop {compare}, or {model_original}",
                                {"compare": "compare_effective", "model_original": "use model: original"})
    if samples_per_period is None:
        samples_per_period = default_samples(config)
    times = sample_times(config, samples_per_period)
    settings = trajectory.settings_vector(**vars(config.integration))
    initial_state = np.array([config.initial["x"], config.initial["v"]])

    if compare_effective and config.written:
        raise UsageError.naming("{compare_effective} compares the paper's original model with its effective one "
                                "(eq2.10); a written model has no effective model", {"compare": "compare_effective"})
    models = [config.model] + (["effective"] if compare_effective else [])
    runs = {}
    for model in models:
        result = trajectory.simulate(kernels_for(model).coefficients(config.parameters), initial_state, settings,
                                     times, method=config.integration.method, model=model)
        runs[model_key(model)] = _model_run(model_key(model), result)

    slow_flow = {}
    if "effective" in runs:
        slow_flow = slow_flow_runs(config.parameters, config.initial, times)
    attrs = {"model": model_key(config.model), "samples_per_period": int(samples_per_period),
             "slow_period": stroboscopic_period(config)}
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
