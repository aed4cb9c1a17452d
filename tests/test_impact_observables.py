"""The impact observables of a sweep (analysis.diagnostics.impact_observables): the slowest, fastest
and mean impact speed, the impacts' circular phase and spread, the time stuck, per point.

Each is checked against what the same run's own logs say impact by impact (simulate keeps every
impact and sticking interval), for the paper's model (one barrier above) and a written model with a
barrier below (speeds into the barrier are positive on either side), and in a sweep file.
"""

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from vrsweep.analysis.diagnostics import impact_observables
from vrsweep.config import load_config
from vrsweep.numerics import kernel
from vrsweep.numerics.coefficients import PERIOD, RESPONSE_FREQUENCY
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.trajectory import settings_vector, simulate

EXAMPLES = Path(__file__).resolve().parents[1] / "vrsweep" / "examples"
N_TRANSIENT, N_MEASURE = 60, 40


def _trajectory(config, parameters=None):
    coefficients = kernels_for(config.model).coefficients(dict(config.parameters, **(parameters or {})))
    settings = settings_vector(rtol=1e-10, atol=1e-12, transient_periods=N_TRANSIENT, measure_periods=N_MEASURE)
    run = simulate(coefficients, [config.initial["x"], config.initial["v"]], settings, model=config.model)
    return run, coefficients


def _from_logs(run, coefficients):
    """The observables from the impact and sticking logs, impact by impact."""
    period = coefficients[PERIOD]
    frequency = coefficients[RESPONSE_FREQUENCY]
    start, end = N_TRANSIENT * period, (N_TRANSIENT + N_MEASURE) * period
    t, v_before = run.impacts[:, 0], run.impacts[:, 1]
    window = (t >= start) & (t <= end)
    speeds = np.abs(v_before[window])
    phases = frequency * t[window]
    mean = np.mean(np.exp(1j * phases))
    stuck = sum(max(0.0, min(b, end) - max(a, start)) for a, b in run.sticks)
    return {"impact_speed_min": speeds.min(), "impact_speed_max": speeds.max(), "impact_speed_mean": speeds.mean(),
            "impact_phase": np.mod(np.angle(mean), 2 * np.pi), "impact_phase_spread": math.sqrt(-2 * math.log(abs(mean))),
            "stuck_fraction": stuck / (end - start), "n": int(window.sum())}


def _observed(run, coefficients):
    measured = run.period_records[None, N_TRANSIENT:]
    return {name: value[0] for name, value in
            impact_observables(measured, np.array([True]), np.array([coefficients[PERIOD]])).items()}


@pytest.mark.parametrize("name, parameters", [
    ("fig3", dict(g=10.0)),                   # the paper's model, period 3, impacts each cycle
    ("fig3", dict(g=5.0)),                    # chaotic impacting motion: many speeds and phases
    ("impact_two_sided", dict(F=2.5)),        # a written model, a barrier above and one below
])
def test_the_observables_are_the_impact_logs(name, parameters):
    config = load_config(EXAMPLES / f"{name}.yaml") if (EXAMPLES / f"{name}.yaml").exists() else None
    if config is None:
        config = load_config(Path(__file__).resolve().parents[1] / "configs" / f"{name}.yaml")
    run, coefficients = _trajectory(config, parameters)
    assert run.status == 0
    logs, observed = _from_logs(run, coefficients), _observed(run, coefficients)
    assert logs["n"] >= 10 and logs["n"] == run.period_records[N_TRANSIENT:, kernel.REC_IMPACTS].sum()
    assert observed["impact_speed_min"] == logs["impact_speed_min"]  # the same numbers, not a recomputation
    assert observed["impact_speed_max"] == logs["impact_speed_max"]
    for key in ("impact_speed_mean", "impact_phase", "impact_phase_spread", "stuck_fraction"):
        assert observed[key] == pytest.approx(logs[key], rel=1e-12, abs=1e-12), key


def test_a_point_without_impacts_has_no_speeds_and_a_failed_point_has_nothing():
    measured = np.zeros((2, 4, kernel.N_RECORD))
    measured[:, :, kernel.REC_IMPACT_SPEED_MIN] = np.inf
    values = impact_observables(measured, np.array([True, False]), np.array([4.0, 4.0]))
    for name in ("impact_speed_min", "impact_speed_max", "impact_speed_mean", "impact_phase", "impact_phase_spread"):
        assert np.isnan(values[name]).all(), name
    assert values["stuck_fraction"][0] == 0.0 and np.isnan(values["stuck_fraction"][1])


def test_every_impact_at_one_phase_has_no_spread():
    measured = np.zeros((1, 3, kernel.N_RECORD))
    measured[0, :, kernel.REC_IMPACTS] = 2
    measured[0, :, kernel.REC_IMPACT_SPEED_MIN] = 0.5
    measured[0, :, kernel.REC_IMPACT_SPEED_MAX] = 0.5
    measured[0, :, kernel.REC_IMPACT_SPEED_SUM] = 1.0
    measured[0, :, kernel.REC_IMPACT_COS] = 2 * math.cos(-0.25)
    measured[0, :, kernel.REC_IMPACT_SIN] = 2 * math.sin(-0.25)
    values = impact_observables(measured, np.array([True]), np.array([1.0]))
    assert values["impact_phase"][0] == pytest.approx(2 * math.pi - 0.25, rel=1e-14)
    assert values["impact_phase_spread"][0] == pytest.approx(0.0, abs=1e-7)
    assert values["impact_speed_mean"][0] == 0.5


def test_an_impact_at_zero_speed_on_a_stop_below_has_speed_plus_zero():
    """The kernel logs side * v-: -0.0 for a touch of a stop below at v- = +0.0 (the bouncing ball at
    Gamma = 1, released where the table's pull is zero). A speed reads +0, as `info` and a map show it."""
    measured = np.zeros((1, 2, kernel.N_RECORD))
    measured[0, :, kernel.REC_IMPACTS] = 1
    measured[0, :, kernel.REC_IMPACT_SPEED_MIN] = -0.0
    measured[0, :, kernel.REC_IMPACT_SPEED_MAX] = -0.0
    measured[0, :, kernel.REC_IMPACT_SPEED_SUM] = -0.0
    measured[0, :, kernel.REC_IMPACT_COS] = 1.0
    values = impact_observables(measured, np.array([True]), np.array([1.0]))
    for name in ("impact_speed_min", "impact_speed_max", "impact_speed_mean"):
        assert values[name][0] == 0.0 and not np.signbit(values[name][0]), name


def test_a_sweep_file_holds_them_with_units(tmp_path, sweep_file):
    _, path = sweep_file(tmp_path, """
        model: original
        parameters: {g: 10.0}
        sweep:
          Delta: {values: [50.0, 1.0]}
        integration: {transient_periods: 40, measure_periods: 16}
        """)
    with h5py.File(path, "r") as f:
        assert f["impact_phase"].attrs["units"] == "rad"
        assert f["impact_speed_min"].attrs["units"] == "1"
        assert np.isnan(f["impact_speed_min"][0])  # Delta = 50: the mass never reaches the barrier
        assert f["impact_speed_min"][1] > 0 and f["impact_speed_max"][1] >= f["impact_speed_mean"][1]
        assert 0 <= f["stuck_fraction"][1] <= 1
