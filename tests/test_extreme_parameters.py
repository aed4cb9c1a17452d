"""Parameters of any magnitude the config accepts end in a point status, never an exception.

Issue 14, item 3: g = 1e200 once ended in ``SystemError: CPUDispatcher(<function run_lines>)
returned a result with an exception set`` (a ZeroDivisionError inside the parallel loop). The
kernel now runs with numba's numpy error model (vrsweep/numerics/jit.py: a division by zero gives inf or
nan) and turns a step estimate of zero or NaN into ``step_too_small`` / ``non_finite``.

test_faults.py draws parameters in the paper's range; here every parameter may instead be drawn
from 1e-300 .. 1e300 in magnitude, with either sign where its domain allows (config/schema.py:
c, omega, Omega > 0, 0 < e <= 1, Delta above x0). Runs are short and capped so that hypothesis
can try many points: what is checked is the contract, not the physics.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from vrsweep.numerics import kernel
from vrsweep.config import parse_config
from vrsweep.numerics.model import kernel_coefficients
from vrsweep.results import Status
from vrsweep.store.reading import load_results
from vrsweep.execution.sweep import run_sweep
from vrsweep.numerics.trajectory import settings_vector, simulate


KNOWN_FAILURES = {Status.MAX_STEPS, Status.DIVERGED, Status.CHATTER_LIMIT, Status.STEP_TOO_SMALL,
                  Status.NON_FINITE}
METHODS = ("rk45", "dop853")


def magnitudes(signed):
    """|value| log-uniform in [1e-300, 1e300], either sign if ``signed``; also exactly 0 if signed."""
    exponents = st.floats(-300.0, 300.0)
    positive = exponents.map(lambda exponent: 10.0 ** exponent)
    if not signed:
        return positive
    return st.one_of(st.just(0.0), positive, positive.map(lambda value: -value))


def usual(low, high):
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


def parameter(low, high, signed):
    """Mostly the usual range, often an extreme magnitude."""
    return st.one_of(usual(low, high), magnitudes(signed))


@st.composite
def extreme_points(draw):
    parameters = {
        "gamma": draw(parameter(0.0, 1.0, signed=True)),
        "alpha": draw(parameter(0.0, 1.0, signed=True)),
        "omega0": draw(parameter(0.0, 1.0, signed=True)),
        "g": draw(parameter(0.0, 50.0, signed=True)),
        "c": draw(parameter(1e-3, 1.0, signed=False)),
        "omega": draw(parameter(0.1, 2.0, signed=False)),
        "Omega": draw(parameter(1.0, 10.0, signed=False)),
        "e": draw(st.one_of(usual(0.05, 1.0), magnitudes(signed=False).filter(lambda e: e <= 1.0))),
    }
    x0 = draw(parameter(-2.0, 2.0, signed=True))
    gap = draw(st.one_of(usual(1e-3, 2.0), magnitudes(signed=False)))
    delta = x0 + gap
    if not delta > x0:  # the gap vanished in rounding next to a huge x0
        delta = x0 + abs(x0) * 1e-15 + 1e-300
    if not math.isfinite(delta):
        delta = x0 * (1.0 + 1e-15) if x0 > 0 else abs(x0)
    parameters["Delta"] = delta
    v0 = draw(parameter(-2.0, 2.0, signed=True))
    run_settings = {"rtol": draw(st.sampled_from([1e-9, 1e-6])), "transient_periods": 1,
                    "measure_periods": 1, "max_steps": 2_000, "max_impacts_per_period": 200}
    run_settings["atol"] = run_settings["rtol"] * 1e-2
    model = draw(st.sampled_from(["original", "effective"]))
    return model, parameters, (x0, v0), run_settings


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(extreme_points(), st.sampled_from(METHODS))
def test_extreme_parameters_end_in_a_status(point, method):
    model, parameters, initial, run_settings = point
    assert parameters["Delta"] > initial[0]
    with np.errstate(all="ignore"):  # the effective model's K and wt2 may overflow: inf is honest
        coefficients = kernel_coefficients(parameters, model)
    run = simulate(coefficients, list(initial), settings_vector(**run_settings), method=method)
    assert run.status == Status.OK or run.status in KNOWN_FAILURES
    event(run.status.name.lower())
    if run.status == Status.OK:
        for name, k in (("R", kernel.SUM_R), ("Qs", kernel.SUM_QS), ("Qc", kernel.SUM_QC),
                        ("x_final", kernel.SUM_X_FINAL), ("v_final", kernel.SUM_V_FINAL)):
            assert math.isfinite(run.summary[k]), f"ok point with {name} = {run.summary[k]}"
    else:
        assert math.isnan(run.summary[kernel.SUM_R])


@pytest.mark.parametrize("method", METHODS)
def test_extreme_values_in_a_parallel_sweep(method):
    """The parallel loop itself (run_lines) with values that overflow on the first step."""
    text = ("sweep:\n  g: [-1.0e+300, 1.0e-300, 10.0, 1.0e+200, 1.0e+300]\n"  # an axis is monotonic
            "  Omega: [4.0, 1.0e+300]\n"
            f"integration: {{transient_periods: 1, measure_periods: 1, strobe_periods: 1, "
            f"max_steps: 5000, method: {method}}}\n")
    statuses = {}

    def keep(flat, values):
        statuses.update(zip(flat.tolist(), values["status"].tolist()))

    run_sweep(parse_config(text), threads=2, on_chunk=keep)
    assert sorted(statuses) == list(range(10))
    assert all(Status(code) == Status.OK or Status(code) in KNOWN_FAILURES for code in statuses.values())
    # g = 1e200 and 1e300 at Omega = 4: the first step estimate overflows.
    assert {Status(statuses[6]), Status(statuses[8])} <= {Status.STEP_TOO_SMALL, Status.NON_FINITE}
    assert Status(statuses[4]) == Status.OK  # g = 10, Omega = 4: an ordinary point


@pytest.mark.parametrize("g", ["1.0e+200", "1.0e+300"])
def test_cli_overflowing_forcing_is_a_point_status(tmp_path, g, invoke):
    config = tmp_path / "huge.yaml"
    config.write_text(f"parameters: {{g: {g}}}\n"
                      "integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}\n")
    out = tmp_path / "huge.h5"
    result = invoke("run", config, "-o", out)
    assert result.exit_code == 0, result.output
    assert "Traceback" not in result.output and "Error" not in result.output
    assert "1 step_too_small" in result.output or "1 non_finite" in result.output, result.output
    stored = load_results(out)
    assert Status(int(stored["status"])) in {Status.STEP_TOO_SMALL, Status.NON_FINITE}
    assert np.isnan(stored["R"].values)


def _overflowing_omega(tmp_path):
    """A config at Omega = 1e308 (docs/faults.md): Omega T / (2 pi) = 2e308 overflows to inf."""
    config = tmp_path / "huge.yaml"
    config.write_text("model: original\nparameters: {g: 20.0, Omega: 1.0e+308}\n"
                      "integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}\n")
    return config


def test_cli_omega_whose_phase_per_period_overflows_is_a_point_status(tmp_path, invoke):
    # docs/faults.md's Omega: 1.0e308: Omega T / (2 pi) = 2e308 is inf, and the forcing's period
    # (analysis/diagnostics.forcing_periods) was a Fraction(inf) traceback after the kernel ran.
    config = _overflowing_omega(tmp_path)
    result = invoke("run", config, "-o", tmp_path / "huge.h5")
    assert result.exit_code == 0, result.output
    assert "Traceback" not in result.output and "Error" not in result.output, result.output


def test_simulate_of_a_failed_run_counts_only_the_periods_it_reached(tmp_path, invoke):
    # The periods after a step_too_small have NaN records, which astype(int64) made -2**63: the
    # file held that, and simulate said "0 impacts (-230584300921369408.00 per slow period)".
    import h5py

    config = _overflowing_omega(tmp_path)
    result = invoke("simulate", config, "-o", tmp_path / "huge.h5")
    assert result.exit_code == 0, result.output
    assert "step_too_small" in result.output and "0 impacts (0.00 per slow period)" in result.output, result.output
    with h5py.File(tmp_path / "huge.h5", "r") as f:
        counts = f["original/impacts_per_period"][()]
    assert counts.min() >= -1 and (counts == -1).any()
    assert invoke("plot", tmp_path / "huge.h5", "--kind", "impacts", "-o", tmp_path / "i.png").exit_code == 0


def test_forcing_periods_of_an_infinite_ratio_is_none():
    from vrsweep.analysis.diagnostics import forcing_periods

    slow = 2.0 * np.pi / 0.5
    # Omega/omega = 8 = 8/1 repeats every period, 8.6 = 43/5 after 5; inf (Omega = 1e308) never.
    periods = forcing_periods(np.full(3, slow), np.array([[0.5, 4.0], [0.5, 4.3], [0.5, 1.0e308]]), 8)
    assert periods.tolist() == [1, 5, 0]


def test_continuation_refuses_an_infinite_forcing_ratio_in_one_line():
    from vrsweep.analysis.commensurate import check_commensurate
    from vrsweep.errors import UsageError

    with pytest.raises(UsageError, match="is not a ratio p/q"):
        check_commensurate(dict(g=20.0, Omega=1.0e308, omega=0.5), "original", "g")
    assert check_commensurate(dict(g=20.0, Omega=4.3, omega=0.5), "original", "g") == 5


def test_sticking_under_a_very_fast_forcing_ends():
    """A mass that sticks at once while Omega = 1e12: the release scan (steps of 1/64 of the fast
    period) would need ~1e14 intervals for one slow period. It has the step cap as its budget."""
    coefficients = kernel_coefficients(dict(gamma=0.0, alpha=0.0, c=1.0, omega0=0.0, omega=0.5,
                                            Delta=1.0, e=0.5, g=1e-30, Omega=1e12), "original")
    run = simulate(coefficients, [1.0 - 1e-16, 1e-4],
                   settings_vector(transient_periods=0, measure_periods=1, stick_velocity=1e-3,
                                   max_steps=2_000))
    assert run.status == Status.MAX_STEPS
    assert len(run.sticks) == 1 and math.isnan(run.summary[kernel.SUM_R])


@pytest.mark.parametrize("method", METHODS)
def test_an_unused_fast_frequency_cannot_overflow(method):
    """The effective model has no fast forcing (g enters K and wt2 only, eq2.10-eq2.12): an
    Omega so large that Omega t overflows must not make the point non-finite."""
    parameters = dict(gamma=0.22, alpha=0.1, c=0.04, omega0=0.1, omega=0.5, Delta=1.0, e=0.95, g=10.0)
    settings = settings_vector(transient_periods=2, measure_periods=2)
    huge = simulate(kernel_coefficients(dict(parameters, Omega=1e308), "effective"), [0.99, 0.5], settings,
                    method=method)
    # Omega = 1e308 makes K = 1 and wt2 = -omega0^2 (Omega^4 overflows): the effective model at
    # g = 0; Omega t overflows from t = 2 on.
    plain = simulate(kernel_coefficients(dict(parameters, g=0.0, Omega=4.0), "effective"), [0.99, 0.5], settings,
                     method=method)
    assert huge.status == Status.OK
    np.testing.assert_array_equal(huge.summary, plain.summary)


def test_a_tiny_slow_amplitude_gives_a_finite_error_bar_or_a_status():
    """R = |Q|/c (eq3.3) and R_err both scale as 1/c once c*cos(wt) is below the double's
    resolution of the other forces: the trajectory, and so |Q| and its batch spread, are then
    those of c = 0. At c = 1e-300 R was 1.6e298 and R_err inf, status ok (the squares of R's
    deviations overflowed); at c = 1.2e-310, R still finite, R_err truly past the largest double:
    the point is non_finite, as the kernel marks an R that overflows."""
    text = ("model: effective\nparameters: {g: 5.0}\n"
            "sweep:\n  c: [1.2e-310, 1.0e-300, 1.0e-150]\n"
            "integration: {transient_periods: 5, measure_periods: 20}\n")
    values = {}

    def keep(flat, chunk):
        for name in ("status", "R", "R_err", "Q_amplitude"):
            values.setdefault(name, {}).update(zip(flat.tolist(), chunk[name].tolist()))

    run_sweep(parse_config(text), threads=1, on_chunk=keep)
    status, R, R_err, amplitude = ([values[name][k] for k in range(3)] for name in ("status", "R", "R_err", "Q_amplitude"))
    assert [Status(code) for code in status] == [Status.NON_FINITE, Status.OK, Status.OK]
    assert math.isnan(R[0]) and math.isnan(R_err[0]) and math.isnan(amplitude[0])
    assert amplitude[1] == amplitude[2] > 0  # c*cos(wt) is lost beside the other forces
    assert math.isclose(R[1] * 1e-300, R[2] * 1e-150, rel_tol=1e-14)
    assert 0 < R_err[2] < math.inf
    assert math.isclose(R_err[1] * 1e-300, R_err[2] * 1e-150, rel_tol=1e-12)
    # Only the overflowed point's values are redone: those of its chunk's other points are the
    # ones they have in a chunk of their own, every value, bit for bit.
    def every_value(config_text):
        by_point = {}
        run_sweep(parse_config(config_text), threads=1, on_chunk=lambda flat, chunk: by_point.update(
            {int(k): {name: np.asarray(column)[i] for name, column in chunk.items()} for i, k in enumerate(flat)}))
        return [by_point[k] for k in sorted(by_point)]

    alone, shared = every_value(text.replace("1.2e-310, ", "")), every_value(text)[1:]
    assert len(alone) == len(shared) == 2
    for own, beside in zip(alone, shared):
        assert set(own) == set(beside)
        for name in own:
            np.testing.assert_array_equal(beside[name], own[name], err_msg=name)
