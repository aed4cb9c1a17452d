"""The numba kernel against closed forms, conservation laws, convergence and SciPy.

References are computed at test time (tests/closed_form.py, tests/reference.py); no value
here was copied from the kernel's own output.
"""

import math

import numpy as np
import pytest

from vrsweep.numerics import kernel
from vrsweep.numerics.model import (
    ALPHA, BIG_OMEGA, C, DELTA, E, G, GAMMA, MU, N_COEFFICIENTS, OMEGA, STIFFNESS, fill_header, kernel_coefficients,
)
from vrsweep.results import Status
from vrsweep.numerics.trajectory import settings_vector, simulate

METHODS = tuple(kernel.INTEGRATORS)  # every test marked with @every_method runs for each
every_method = pytest.mark.parametrize("method", METHODS)

from closed_form import CLOSED_FORM_CASES, closed_form_impacts
from reference import CONVERGED_POINTS, point_coefficients, reference_point


def coefficients(gamma=0.0, mu=1.0, k=0.0, alpha=0.0, c=0.0, omega=0.5, g=0.0, Omega=4.0, Delta=1.0, e=1.0):
    """A kernel coefficient vector for any member of the family (model.py)."""
    vector = np.zeros(N_COEFFICIENTS)
    vector[[GAMMA, MU, STIFFNESS, ALPHA, C, OMEGA, G, BIG_OMEGA, DELTA, E]] = \
        [gamma, mu, k, alpha, c, omega, g, Omega, Delta, e]
    fill_header(vector)
    return vector


# --- closed form: gamma = alpha = 0, linear between impacts ------------------------------------

@pytest.mark.parametrize("case", CLOSED_FORM_CASES, ids=["slow-forcing", "slow+fast-forcing"])
@every_method
def test_impacts_match_closed_form(case, method):
    times, v_before, v_after = closed_form_impacts(**case)
    n = case["n_impacts"]
    assert n >= 20
    slow_period = 2 * math.pi / case["omega"]
    periods = int(math.ceil(times[-1] / slow_period)) + 1
    vector = coefficients(k=case["k"], c=case["c"], omega=case["omega"], g=case["g"],
                          Omega=case["Omega"], Delta=case["Delta"], e=case["e"])
    run = simulate(vector, [case["x0"], case["v0"]],
                   settings_vector(rtol=1e-12, atol=1e-14, transient_periods=0, measure_periods=periods), method=method)
    assert run.status == Status.OK
    assert len(run.impacts) >= n
    np.testing.assert_allclose(run.impacts[:n, 0], times, rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.impacts[:n, 1], v_before, rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.impacts[:n, 2], v_after, rtol=0, atol=1e-8)


# --- energy: gamma = c = g = 0, e = 1 ----------------------------------------------------------

def _energy(x, v, k, alpha):
    return 0.5 * v * v + 0.5 * k * x * x + 0.25 * alpha * x ** 4


@pytest.mark.parametrize("rtol", [1e-8, 1e-10])
@every_method
def test_energy_conserved_across_impacts(rtol, method):
    k, alpha = -0.01, 0.1  # the paper's double well, with the barrier cutting its right well
    vector = coefficients(k=k, alpha=alpha, e=1.0, Delta=1.0)
    times = np.linspace(0.0, 30 * 4 * math.pi, 20001)
    run = simulate(vector, [0.2, 1.0], settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=0,
                                                       measure_periods=30), sample_times=times, method=method)
    assert run.status == Status.OK
    assert len(run.impacts) >= 40
    np.testing.assert_allclose(run.impacts[:, 2], -run.impacts[:, 1], rtol=1e-15)  # e = 1
    energy = _energy(run.samples[:, 0], run.samples[:, 1], k, alpha)
    drift = np.max(np.abs(energy - energy[0])) / abs(energy[0])
    # Global error grows with the number of steps; 100 rtol bounds it over 30 slow periods.
    assert drift < 100 * rtol


# --- accuracy scales with rtol ------------------------------------------------------------------

@every_method
def test_global_error_falls_with_rtol(method):
    vector = kernel_coefficients(dict(gamma=0.22, alpha=0.1, c=0.04, omega0=0.1, omega=0.5,
                                      Delta=1.0, e=0.95, g=10.0, Omega=4.0), "original")
    times = np.linspace(0.0, 3 * 4 * math.pi, 301)

    def samples(rtol):
        run = simulate(vector, [0.99, 0.5], settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=0,
                                                            measure_periods=3), sample_times=times, method=method)
        assert run.status == Status.OK
        return run.samples

    exact = samples(1e-13)
    errors = [np.max(np.abs(samples(rtol) - exact)) for rtol in (1e-5, 1e-7, 1e-9, 1e-11)]
    assert all(a > 10 * b for a, b in zip(errors, errors[1:])), errors  # two decades of rtol, > 1 of error
    assert errors[-1] < 1e-8


# --- independent solver: SciPy DOP853 with terminal events --------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize("point", CONVERGED_POINTS, ids=[p["note"][:40] for p in CONVERGED_POINTS])
@every_method
def test_response_matches_scipy(point, method):
    reference = reference_point(point, rtol=1e-11, atol=1e-13)
    run = simulate(point_coefficients(point), [point["x0"], point["v0"]],
                   settings_vector(rtol=1e-11, atol=1e-13, transient_periods=point["transient_periods"],
                                   measure_periods=point["measure_periods"]), method=method)
    assert run.status == Status.OK
    amplitude = math.hypot(reference["Qs"], reference["Qc"])
    assert run.summary[kernel.SUM_R] == pytest.approx(reference["R"], rel=1e-5)
    assert abs(run.summary[kernel.SUM_QS] - reference["Qs"]) < 1e-5 * amplitude
    assert abs(run.summary[kernel.SUM_QC] - reference["Qc"]) < 1e-5 * amplitude
    assert run.summary[kernel.SUM_IMPACTS_PER_PERIOD] == reference["impacts_per_period"]


# --- grazing ----------------------------------------------------------------------------------

@pytest.mark.parametrize("overshoot, expect_impact", [(1e-6, True), (-1e-6, False)])
@every_method
def test_grazing_excursion_inside_one_step(overshoot, expect_impact, method):
    # x = v0 sin t: its peak v0 lies 1e-6 past (or short of) Delta, so x > Delta only for
    # |t - pi/2| < 1.4e-3, far shorter than the steps at rtol 1e-8 (~0.03): both ends of the
    # step around the peak lie below Delta and only the turning-point test sees the excursion.
    Delta = 1.0
    v0 = Delta * (1.0 + overshoot)
    vector = coefficients(k=1.0, Delta=Delta, e=0.5, omega=0.25)  # slow period 8 pi: one peak
    run = simulate(vector, [0.0, v0], settings_vector(rtol=1e-8, atol=1e-10, transient_periods=0,
                                                      measure_periods=1), method=method)
    assert run.status == Status.OK
    if not expect_impact:
        assert len(run.impacts) == 0
        return
    t_impact = math.asin(Delta / v0)
    assert len(run.impacts) >= 1
    # Near a graze the impact speed is sqrt(2 (x_max - Delta)): a position error dx of the
    # solver (~ rtol) moves the impact time and speed by about dx / v, here ~1e-5.
    v_impact = v0 * math.cos(t_impact)
    tolerance = 10 * 1e-8 / v_impact
    assert run.impacts[0, 0] == pytest.approx(t_impact, abs=tolerance)
    assert run.impacts[0, 1] == pytest.approx(v_impact, abs=tolerance)
    assert run.impacts[0, 2] == pytest.approx(-0.5 * run.impacts[0, 1], rel=1e-12)


@pytest.mark.parametrize("overshoot, expect_impact", [(2e-3, True), (-2e-3, False)])
@every_method
def test_graze_inside_a_long_step_between_ends_far_below(overshoot, expect_impact, method):
    # x = v0 sin t at rtol 1e-4: steps of 0.5 (rk45) to 1.1 (dop853) on average (no cap without
    # fast forcing), while x is past the barrier only for |t - pi/2| < 0.063: the step around the
    # peak has both ends far below it, and only the Bernstein test on its dense output sees the excursion (or
    # proves that a peak 2e-3 short of the barrier stays below it).
    Delta = 1.0
    v0 = Delta * (1.0 + overshoot)
    vector = coefficients(k=1.0, Delta=Delta, e=0.5, omega=0.25)  # slow period 8 pi: one peak first
    run = simulate(vector, [0.0, v0], settings_vector(rtol=1e-4, atol=1e-6, transient_periods=0,
                                                      measure_periods=1), method=method)
    assert run.status == Status.OK
    steps = run.summary[kernel.SUM_STEPS]
    assert 8 * math.pi / steps > 0.3  # long steps: the mean step is over twice the excursion's duration
    if not expect_impact:
        assert len(run.impacts) == 0
        return
    t_impact = math.asin(Delta / v0)
    v_impact = v0 * math.cos(t_impact)
    assert len(run.impacts) >= 1
    # a position error dx of the solver (~ rtol) moves the impact by about dx / v
    tolerance = 10 * 1e-4 / v_impact
    assert run.impacts[0, 0] == pytest.approx(t_impact, abs=tolerance)
    assert run.impacts[0, 1] == pytest.approx(v_impact, abs=tolerance)


# --- chatter and sticking -----------------------------------------------------------------------

@every_method
def test_chatter_ends_in_sticking_and_release(method):
    # No stiffness, force c cos(omega t) into the barrier for t < pi/(2 omega): the mass hits,
    # chatters with e = 0.5 (a geometric, Zeno sequence), sticks, and is released exactly where
    # the force changes sign.
    omega = 0.5
    vector = coefficients(c=1.0, omega=omega, Delta=1.0, e=0.5)
    times = np.linspace(0.0, 4 * math.pi, 4001)
    run = simulate(vector, [0.9, 0.0], settings_vector(rtol=1e-10, atol=1e-12, transient_periods=0,
                                                       measure_periods=1), sample_times=times, method=method)
    assert run.status == Status.OK
    assert 10 < len(run.impacts) < 200  # finite: the chatter sequence was cut by sticking
    assert len(run.sticks) >= 1
    release = math.pi / (2 * omega)
    assert run.sticks[0, 1] == pytest.approx(release, abs=1e-10)
    # The chatter sequence itself, impact by impact, against the closed form (k = 0 is linear).
    times_exact, v_before_exact, _ = closed_form_impacts(k=0.0, c=1.0, omega=omega, g=0.0, Omega=4.0,
                                                         Delta=1.0, e=0.5, x0=0.9, v0=0.0, n_impacts=10)
    np.testing.assert_allclose(run.impacts[:10, 0], times_exact, rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.impacts[:10, 1], v_before_exact, rtol=0, atol=1e-8)
    assert np.all(np.diff(run.impacts[:, 1]) < 0)  # every rebound slower: the Zeno sequence
    stuck = (times > run.sticks[0, 0]) & (times < run.sticks[0, 1])
    assert stuck.any()
    np.testing.assert_array_equal(run.samples[stuck, 0], 1.0)
    np.testing.assert_array_equal(run.samples[stuck, 1], 0.0)
    assert np.all(run.samples[:, 0] <= 1.0)
    assert np.all(np.isfinite(run.samples))


@every_method
def test_fourier_sums_include_sticking_intervals(method):
    # Stiffness pulls the mass off the barrier, the slow force (5 > k Delta) pushes it back for
    # part of every slow period: it sticks, is released, and returns, period after period. The
    # kernel's quadrature states must equal the integral of its own dense samples.
    omega = 0.5
    vector = coefficients(k=1.0, c=5.0, omega=omega, Delta=1.0, e=0.5, gamma=0.1)
    slow_period = 2 * math.pi / omega
    settings = settings_vector(rtol=1e-11, atol=1e-13, transient_periods=2, measure_periods=2)
    times = np.linspace(2 * slow_period, 4 * slow_period, 400001)
    run = simulate(vector, [0.0, 0.0], settings, sample_times=times, method=method)
    assert run.status == Status.OK
    assert len(run.sticks) >= 2
    stuck_time = np.sum(run.period_records[2:, kernel.REC_STUCK_TIME])
    assert stuck_time > 0.1 * slow_period
    x = run.samples[:, 0]
    window = 2 * slow_period
    qs = 2 / window * np.trapezoid(x * np.sin(omega * times), times)
    qc = 2 / window * np.trapezoid(x * np.cos(omega * times), times)
    assert run.summary[kernel.SUM_QS] == pytest.approx(qs, abs=1e-8)
    assert run.summary[kernel.SUM_QC] == pytest.approx(qc, abs=1e-8)


# --- failures end with a status, never an exception or a NaN passed off as a result ------------

def _paper_point(**changes):
    parameters = dict(gamma=0.22, alpha=0.1, c=0.04, omega0=0.1, omega=0.5, Delta=1.0, e=0.95, g=10.0, Omega=4.0)
    parameters.update(changes)
    return kernel_coefficients(parameters, "original")


@every_method
def test_divergence_sets_status(method):
    # Negative linear stiffness and nothing cubic: the mass runs away from the barrier.
    vector = coefficients(k=-1.0, Delta=1.0, e=0.9)
    run = simulate(vector, [0.5, -10.0], settings_vector(transient_periods=1, measure_periods=1,
                                                         divergence_bound=1e6), method=method)
    assert run.status == Status.DIVERGED
    assert math.isnan(run.summary[kernel.SUM_R])
    assert abs(run.summary[kernel.SUM_X_FINAL]) > 1e6


@every_method
def test_step_cap_sets_status(method):
    run = simulate(_paper_point(), [0.99, 0.5], settings_vector(max_steps=50, transient_periods=1, measure_periods=1), method=method)
    assert run.status == Status.MAX_STEPS
    assert math.isnan(run.summary[kernel.SUM_R])
    assert run.summary[kernel.SUM_STEPS] == 50


@every_method
def test_chatter_cap_sets_status(method):
    vector = coefficients(c=1.0, omega=0.5, Delta=1.0, e=0.5)
    run = simulate(vector, [0.9, 0.0], settings_vector(max_impacts_per_period=5, transient_periods=0,
                                                       measure_periods=1), method=method)
    assert run.status == Status.CHATTER_LIMIT
    assert math.isnan(run.summary[kernel.SUM_R])


def test_original_and_effective_share_the_kernel():
    # At g = 0 the effective system (eq2.10-eq2.12) is the original one (K = 1, wt2 = -omega0^2).
    parameters = dict(gamma=0.22, alpha=0.1, c=0.04, omega0=0.1, omega=0.5, Delta=1.0, e=0.95, g=0.0, Omega=4.0)
    settings = settings_vector(transient_periods=2, measure_periods=2)
    original = simulate(kernel_coefficients(parameters, "original"), [0.99, 0.5], settings)
    effective = simulate(kernel_coefficients(parameters, "effective"), [0.99, 0.5], settings)
    np.testing.assert_array_equal(original.summary, effective.summary)


@every_method
def test_impact_log_agrees_with_period_counts(method):
    run = simulate(_paper_point(), [0.99, 0.5], settings_vector(transient_periods=5, measure_periods=5), method=method)
    assert run.status == Status.OK
    assert run.impacts_per_period.sum() == len(run.impacts)
    slow_period = 4 * math.pi
    per_period = np.bincount((run.impacts[:, 0] // slow_period).astype(int), minlength=10)[:10]
    np.testing.assert_array_equal(per_period, run.impacts_per_period)
