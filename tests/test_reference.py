"""Tests of the references themselves (tests/reference.py, tests/closed_form.py).

The kernel is compared against these references elsewhere; a reference is only worth that if it
is right and converged, which is what this file shows:

- the closed form agrees with an ODE solution of the same linear system (no impacts) for positive,
  negative and zero stiffness, and refuses exact resonance;
- the closed form and SciPy (rtol 1e-12) give the same impact sequences to ~1e-8: two independent
  computations, one exact up to root finding, one an 8th-order integrator with event location;
- SciPy's restart at the barrier does not re-trigger the event, even for a return inside the
  first step (a bouncing ball with a tiny rebound, compared with the closed form's k = 0 branch);
- with gamma = c = g = 0 and e = 1 the reference conserves v^2/2 + k x^2/2 + alpha x^4/4 across
  impacts;
- at the CONVERGED_POINTS the reference's R does not depend on the solver tolerance.
"""

import math

import numpy as np
import pytest

from closed_form import (CLOSED_FORM_CASES, LinearOscillator, closed_form_impacts,
                         closed_form_state, linear_energy)
from reference import (CONVERGED_POINTS, coefficient_vector, point_coefficients,
                       reference_point, reference_run, reference_trajectory)
from vrsweep.numerics.model import PARAMETER_NAMES, kernel_coefficients


def _linear_vector(case):
    """Kernel coefficients of a closed-form case: gamma = alpha = 0, stiffness k."""
    return coefficient_vector(stiffness=case["k"], c=case["c"], omega=case["omega"], g=case["g"],
                              Omega=case["Omega"], Delta=case["Delta"], e=case["e"])


# --- the closed form ------------------------------------------------------------------------

@pytest.mark.parametrize("k", [1.0, 0.04, 0.0, -0.01, -0.5])
def test_closed_form_solves_the_ode_without_barrier(k):
    """x'' + k x = c cos(omega t) + g cos(Omega t): closed form vs DOP853 at rtol 1e-13."""
    from scipy.integrate import solve_ivp

    c, omega, g, Omega = 0.3, 0.5, 2.0, 4.0
    osc = LinearOscillator(k, c, omega, g, Omega)
    t0, x0, v0 = 1.3, 0.2, -0.7
    t = np.linspace(t0, t0 + 20.0, 201)
    x, v = osc.state(t0, x0, v0, t)

    def rhs(tt, y):
        return [y[1], c * math.cos(omega * tt) + g * math.cos(Omega * tt) - k * y[0]]

    sol = solve_ivp(rhs, (t0, t[-1]), [x0, v0], method="DOP853", rtol=1e-13, atol=1e-14,
                    t_eval=t)
    scale = 1.0 + np.abs(sol.y).max()
    np.testing.assert_allclose(x, sol.y[0], rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(v, sol.y[1], rtol=0, atol=1e-10 * scale)


def test_closed_form_refuses_exact_resonance():
    with pytest.raises(ValueError, match="resonance"):
        LinearOscillator(0.25, 0.3, 0.5, 0.0, 4.0)
    with pytest.raises(ValueError, match="resonance"):
        LinearOscillator(16.0, 0.3, 0.5, 1.0, 4.0)
    LinearOscillator(16.0, 0.3, 0.5, 0.0, 4.0)  # no fast forcing, so Omega = sqrt(k) is harmless


@pytest.mark.parametrize("case", CLOSED_FORM_CASES, ids=["slow-forcing", "slow+fast-forcing"])
def test_closed_form_cases_are_well_separated(case):
    """The cases' documented promise: many impacts, well apart, none slow (no chatter, no graze)."""
    times, before, after = closed_form_impacts(**case)
    assert len(times) == case["n_impacts"] >= 20
    assert np.diff(times).min() > 3.0
    assert np.abs(after).min() > 0.3
    np.testing.assert_array_equal(after, -case["e"] * before)


def test_closed_form_sees_a_graze_between_grid_points():
    """A free oscillation x = A sin t whose crest is 1e-10 above the barrier must impact near pi/2."""
    A = 0.8
    times, before, _ = closed_form_impacts(k=1.0, c=0.0, omega=1.0, g=0.0, Omega=1.0,
                                           Delta=A - 1e-10, e=0.5, x0=0.0, v0=A, n_impacts=1)
    assert abs(times[0] - math.pi / 2) < 1e-4
    assert 0.0 < before[0] < 1e-4


# --- closed form vs SciPy reference -------------------------------------------------------

@pytest.mark.parametrize("case", CLOSED_FORM_CASES, ids=["slow-forcing", "slow+fast-forcing"])
def test_closed_form_and_scipy_impact_sequences_agree(case):
    """Impact times and both velocities agree to 1e-8 over all impacts of the case."""
    times, before, after = closed_form_impacts(**case)
    ref = reference_trajectory(_linear_vector(case), case["x0"], case["v0"],
                               t_end=times[-1] + 0.5, rtol=1e-12, atol=1e-14)
    assert len(ref["impact_times"]) == len(times)
    np.testing.assert_allclose(ref["impact_times"], times, rtol=0, atol=1e-8)
    np.testing.assert_allclose(ref["v_before"], before, rtol=0, atol=1e-8)
    np.testing.assert_allclose(ref["v_after"], after, rtol=0, atol=1e-8)
    # Between impacts too: the dense output follows the closed form.
    t = np.linspace(0.0, times[-1], 4001)
    x_cf, v_cf = closed_form_state(**{k: case[k] for k in ("k", "c", "omega", "g", "Omega",
                                                          "Delta", "e", "x0", "v0")}, t=t)
    x_ref, v_ref = ref["sol"](t)
    np.testing.assert_allclose(x_ref, x_cf, rtol=0, atol=1e-8)
    near_impact = np.min(np.abs(t[:, None] - times[None, :]), axis=1) < 1e-7
    np.testing.assert_allclose(v_ref[~near_impact], v_cf[~near_impact], rtol=0, atol=1e-8)


def test_negative_stiffness_impact_then_escape():
    """The cosh/sinh branch with an impact: the paper's k = -omega0^2, alpha = 0, from its start.

    Without the cubic term the mass escapes to -inf after its first rebound; both references must
    agree on that impact and on the escaping flight.
    """
    case = dict(k=-0.01, c=0.04, omega=0.5, g=2.0, Omega=4.0, Delta=1.0, e=0.95)
    times, before, after = closed_form_impacts(**case, x0=0.99, v0=0.5, n_impacts=1)
    ref = reference_trajectory(_linear_vector(case), 0.99, 0.5, t_end=60.0, rtol=1e-12,
                               atol=1e-14)
    assert len(ref["impact_times"]) == 1
    np.testing.assert_allclose(ref["impact_times"], times, rtol=0, atol=1e-10)
    np.testing.assert_allclose(ref["v_after"], after, rtol=0, atol=1e-10)
    x_cf, v_cf = closed_form_state(**case, x0=0.99, v0=0.5, t=[60.0])
    assert x_cf[0] < -5.0  # it did escape
    np.testing.assert_allclose([ref["x_final"], ref["v_final"]], [x_cf[0], v_cf[0]], rtol=1e-9)


def test_quick_return_after_restart_is_not_a_spurious_impact():
    """A bouncing ball: k = 0, a force of ~1 into the barrier, rebound speed 0.0045 (flights of 0.009).

    Each flight fits in scipy's first step after the restart (checked below), so scipy must find
    the return inside a step that starts at x = Delta, where the event function is 0. Without the
    guard in reference._make_event, brentq returns the restart time itself (a spurious impact
    with x'(-) < 0). Compared with the closed form's k = 0 branch; e = 1 keeps the ball bouncing.
    """
    case = dict(k=0.0, c=1.0, omega=0.5, g=0.0, Omega=1.0, Delta=1.0, e=1.0)
    x0 = 1.0 - 1e-5
    times, before, after = closed_form_impacts(**case, x0=x0, v0=0.0, n_impacts=20)
    ref = reference_trajectory(_linear_vector(case), x0, 0.0, t_end=times[-1] + 1e-5,
                               rtol=1e-12, atol=1e-14)
    steps_per_flight = [len(segment[2].ts) - 1 for segment in ref["sol"].segments[1:]]
    assert max(steps_per_flight) == 1  # the return really is inside the first step
    assert len(ref["impact_times"]) == len(times)
    np.testing.assert_allclose(ref["impact_times"], times, rtol=0, atol=1e-10)
    np.testing.assert_allclose(ref["v_before"], before, rtol=1e-9)


# --- SciPy reference on the nonlinear system -----------------------------------------------

def test_energy_conserved_across_elastic_impacts():
    """gamma = c = g = 0, e = 1: v^2/2 + k x^2/2 + alpha x^4/4 is a constant of the motion (eq2.1),
    and an elastic impact (eq2.2, e = 1) only flips v. Paper's double well, barrier at 1."""
    k, alpha = -0.01, 0.1
    x0, v0 = -0.3, 0.6
    vec = coefficient_vector(gamma=0.0, stiffness=k, alpha=alpha, Delta=1.0, e=1.0)
    ref = reference_trajectory(vec, x0, v0, t_end=300.0, rtol=1e-12, atol=1e-14)
    E0 = linear_energy(k, x0, v0, alpha)
    assert len(ref["impact_times"]) >= 20
    np.testing.assert_allclose(ref["v_after"], -ref["v_before"], rtol=0, atol=0)
    for v in (ref["v_before"], ref["v_after"]):
        np.testing.assert_allclose(linear_energy(k, 1.0, v, alpha), E0, rtol=1e-10)
    t = np.linspace(0.0, 300.0, 3001)
    x, v = ref["sol"](t)
    np.testing.assert_allclose(linear_energy(k, x, v, alpha), E0, rtol=1e-10)


def test_reference_run_contract():
    """Keys and their meaning on a short run: counts, window, and the Fourier measures."""
    point = CONVERGED_POINTS[0]
    r = reference_run(point_coefficients(point), 0.99, 0.5, 2, 3, rtol=1e-9, atol=1e-11)
    for key in ("R", "Qs", "Qc", "Q_amplitude", "impacts_per_period", "impact_times",
                "impact_velocities_before", "impact_velocities_after", "x_final", "v_final",
                "n_rhs"):
        assert key in r
    T = 2 * math.pi / point["parameters"]["omega"]
    assert r["t_a"] == pytest.approx(2 * T) and r["t_end"] == pytest.approx(5 * T)
    in_window = (r["impact_times"] >= r["t_a"]) & (r["impact_times"] < r["t_end"])
    assert r["impacts_per_period"] == in_window.sum() / 3
    assert r["Q_amplitude"] == pytest.approx(math.hypot(r["Qs"], r["Qc"]))
    assert r["R"] == pytest.approx(r["Q_amplitude"] / point["parameters"]["c"])
    assert r["n_rhs"] > 0


def test_fourier_quadrature_matches_sampled_integral():
    """Qs, Qc (eq3.1, eq3.2) from the quadrature states agree with a fine trapezoid rule applied
    to the dense output over the same window, so the window starts exactly at t_a."""
    point = CONVERGED_POINTS[1]
    vec = point_coefficients(point)
    r = reference_run(vec, 0.99, 0.5, 1, 2, rtol=1e-11, atol=1e-13)
    traj = reference_trajectory(vec, 0.99, 0.5, r["t_end"], rtol=1e-11, atol=1e-13)
    omega = point["parameters"]["omega"]
    t = np.linspace(r["t_a"], r["t_end"], 400001)
    x = traj["sol"](t)[0]
    mT = r["t_end"] - r["t_a"]
    Qs = 2 / mT * np.trapezoid(x * np.sin(omega * t), t)
    Qc = 2 / mT * np.trapezoid(x * np.cos(omega * t), t)
    # x has kinks at impacts, so the trapezoid rule is only ~dt^2-accurate there.
    assert r["Qs"] == pytest.approx(Qs, abs=1e-6)
    assert r["Qc"] == pytest.approx(Qc, abs=1e-6)


def test_chatter_is_refused():
    """Chatter (impacts accumulating at the wall) must raise, never hang: constant push into the
    barrier (k = 0; c cos(0.5 t) ~ 1 for t < 2) with e = 0.5: a Zeno bouncing ball, whose impacts
    accumulate at t ~ 1.42."""
    vec = coefficient_vector(stiffness=0.0, c=1.0, omega=0.5, Delta=1.0, e=0.5)
    with pytest.raises(RuntimeError, match="chatter"):
        reference_trajectory(vec, 0.9, 0.0, t_end=2.0, rtol=1e-10, atol=1e-12)


def test_converged_points_are_well_formed():
    assert 4 <= len(CONVERGED_POINTS) <= 6
    assert {p["model"] for p in CONVERGED_POINTS} == {"original", "effective"}
    for p in CONVERGED_POINTS:
        assert set(p["parameters"]) == set(PARAMETER_NAMES)
        assert p["note"]
        kernel_coefficients(p["parameters"], model=p["model"])


@pytest.mark.slow
@pytest.mark.parametrize("point", CONVERGED_POINTS,
                         ids=[f"{p['model']}-g{p['parameters']['g']:g}-Delta{p['parameters']['Delta']:g}"
                              for p in CONVERGED_POINTS])
def test_converged_points(point):
    """R is the same (to 1e-7 relative) at rtol 1e-10 and 1e-12, and so are the impact counts.

    Also checks the impact/no-impact character the point was chosen for.
    """
    coarse = reference_point(point, rtol=1e-10, atol=1e-12)
    fine = reference_point(point, rtol=1e-12, atol=1e-14)
    assert coarse["R"] == pytest.approx(fine["R"], rel=1e-7)
    assert len(coarse["impact_times"]) == len(fine["impact_times"])
    assert coarse["impacts_per_period"] == fine["impacts_per_period"]
    if "no impacts" in point["note"] or "never impacts" in point["note"]:
        assert len(fine["impact_times"]) == 0
    elif "none in the window" in point["note"]:
        assert fine["impacts_per_period"] == 0 and len(fine["impact_times"]) > 0
    else:
        assert fine["impacts_per_period"] >= 1
