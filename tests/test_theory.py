"""The paper's analysis (vrsweep.analysis.theory), corrected per ERRATA 1-4, 9.

Parameter sets used below:

- PAPER: the paper's parameters (Fig. 1). At Omega = 4 the cubic has three roots for
  0 <= g <~ 17.3 (only the largest stable) and one root above; g_res = 21.065.
- BISTABLE: gamma = 0.05, alpha = 0.05 (otherwise PAPER), Omega = 4, g = 23.6: three roots
  0.4475 (stable), 1.3812 (saddle), 1.7022 (stable) -- true hysteresis, found by scanning gamma,
  alpha and c. The two stable roots exist together for 21.97 <~ g <~ 25.25.
"""

import time
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrsweep.analysis import theory
from vrsweep.numerics.model import DEFAULT_PARAMETERS, effective_damping_level, effective_stiffness

PAPER = dict(DEFAULT_PARAMETERS)
BISTABLE = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, g=23.6, Omega=4.0)


def at(**changes):
    return dict(PAPER, **changes)


# --- eq2.11, eq2.12, eq3.4 ---------------------------------------------------------------------

def test_g_res_has_the_paper_values():
    # ERRATA 7: 21.065 and 32.914 (the text rounds them to 21 and 32).
    assert theory.g_res(0.1, 0.1, 0.5, 4.0) == pytest.approx(21.065, abs=1e-3)
    assert theory.g_res(0.1, 0.1, 0.5, 5.0) == pytest.approx(32.914, abs=1e-3)
    np.testing.assert_allclose(theory.g_res(0.1, 0.1, 0.5, np.array([4.0, 5.0])), [21.065, 32.914], atol=1e-3)


def test_at_g_res_the_effective_frequency_matches_the_drive():
    for Omega in (4.0, 5.0):
        params = at(Omega=Omega, g=theory.g_res(0.1, 0.1, 0.5, Omega))
        assert theory.effective_frequency_squared(params) == pytest.approx(0.25)  # omega^2
        assert theory.slow_flow_coefficients(params).sigma == pytest.approx(0.0, abs=1e-12)


def test_wt2_is_signed_and_k_matches_the_model():
    # ERRATA 5: below g = Omega^2 omega0 sqrt(2/(3 alpha)) the effective stiffness is negative.
    assert theory.effective_frequency_squared(at(g=0.0)) == pytest.approx(-0.01)
    g = np.linspace(0, 40, 9)
    params = at(g=g)
    np.testing.assert_array_equal(theory.effective_frequency_squared(params), effective_stiffness(0.1, 0.1, g, 4.0))
    np.testing.assert_array_equal(theory.damping_level(params), effective_damping_level(g, 4.0))


def test_slow_flow_coefficients_are_the_epsilon_products():
    # ERRATA 4: eps*Gamma = gamma/omega, eps*Lambda = alpha/omega^2, eps*F = c/omega^2,
    # eps*sigma = 1 - wt2/omega^2.
    co = theory.slow_flow_coefficients(at(g=10.0))
    assert co.Gamma == pytest.approx(0.22 / 0.5)
    assert co.Lambda == pytest.approx(0.1 / 0.25)
    assert co.F == pytest.approx(0.04 / 0.25)
    assert co.sigma == pytest.approx(1 - (0.15 * 100 / 256 - 0.01) / 0.25)
    assert co.K == pytest.approx(1 - 100 / 512)


# --- fixed points ------------------------------------------------------------------------------

SLOW_FLOW_CASES = [at(g=g, Omega=Omega) for Omega in (4.0, 5.0) for g in np.linspace(0.0, 60.0, 31)]
SLOW_FLOW_CASES += [dict(BISTABLE, g=g) for g in np.linspace(21.0, 26.0, 11)]


@pytest.mark.parametrize("literal", [False, True])
def test_every_fixed_point_makes_the_slow_flow_vanish(literal):
    n_roots = 0
    for params in SLOW_FLOW_CASES:
        points = theory.fixed_points(params, literal=literal)
        assert 1 <= len(points) <= 3
        assert np.all(np.diff(points.R) > 0) and np.all(points.R > 0)
        dR, dtheta = theory.slow_flow(points.R, points.theta, params, literal=literal)
        np.testing.assert_allclose(dR, 0.0, atol=1e-10)
        np.testing.assert_allclose(dtheta, 0.0, atol=1e-10)
        n_roots += len(points)
    assert n_roots > len(SLOW_FLOW_CASES)  # some cases had three roots


def test_three_roots_exist_in_the_hysteresis_regions():
    # The paper's own parameters: three roots at g = 10, only the largest stable (the others are an
    # unstable focus and a saddle).
    points = theory.fixed_points(at(g=10.0))
    np.testing.assert_allclose(points.R, [0.18408, 1.57530, 1.72679], atol=1e-5)
    np.testing.assert_array_equal(points.stable, [False, False, True])
    # Bistability: two stable roots with a saddle between them.
    points = theory.fixed_points(BISTABLE)
    np.testing.assert_allclose(points.R, [0.44750, 1.38125, 1.70221], atol=1e-5)
    np.testing.assert_array_equal(points.stable, [True, False, True])
    saddle = points.eigenvalues[1]
    assert np.all(saddle.imag == 0) and saddle.real.min() < 0 < saddle.real.max()


def test_above_the_fold_there_is_one_root():
    points = theory.fixed_points(at(g=21.0))
    assert len(points) == 1 and points.stable[0]


def test_literal_and_corrected_flows_share_fixed_point_amplitudes():
    # ERRATA 1: the sin/cos swap keeps the amplitudes (so eq2.27) but not the phases or stability.
    stabilities_differ = False
    for params in SLOW_FLOW_CASES:
        corrected = theory.fixed_points(params)
        literal = theory.fixed_points(params, literal=True)
        np.testing.assert_allclose(literal.R, corrected.R, rtol=1e-12)
        # theta_literal = pi/2 - theta_corrected (mod 2 pi)
        np.testing.assert_allclose(np.cos(literal.theta), np.sin(corrected.theta), atol=1e-12)
        stabilities_differ |= not np.array_equal(literal.stable, corrected.stable)
    assert stabilities_differ


@pytest.mark.parametrize("literal", [False, True])
def test_jacobian_matches_finite_differences(literal):
    rng = np.random.default_rng(3)
    h = 1e-6
    for _ in range(20):
        params = at(g=rng.uniform(0, 40), Omega=rng.choice([4.0, 5.0]))
        R, theta = rng.uniform(0.1, 2.5), rng.uniform(-np.pi, np.pi)
        J = theory.slow_flow_jacobian(R, theta, params, literal=literal)
        dR_plus, dt_plus = theory.slow_flow(R + h, theta, params, literal)
        dR_minus, dt_minus = theory.slow_flow(R - h, theta, params, literal)
        column_R = np.array([dR_plus - dR_minus, dt_plus - dt_minus]) / (2 * h)
        dR_plus, dt_plus = theory.slow_flow(R, theta + h, params, literal)
        dR_minus, dt_minus = theory.slow_flow(R, theta - h, params, literal)
        column_theta = np.array([dR_plus - dR_minus, dt_plus - dt_minus]) / (2 * h)
        np.testing.assert_allclose(J[:, 0], column_R, atol=1e-8)
        np.testing.assert_allclose(J[:, 1], column_theta, atol=1e-8)


def test_stability_is_the_sign_of_the_jacobian_eigenvalues():
    for params in SLOW_FLOW_CASES:
        points = theory.fixed_points(params)
        J = theory.slow_flow_jacobian(points.R, points.theta, params)
        for k in range(len(points)):
            eigenvalues = np.linalg.eigvals(J[k])
            np.testing.assert_allclose(np.sort_complex(eigenvalues), np.sort_complex(points.eigenvalues[k]), atol=1e-12)
            assert points.stable[k] == bool(np.all(eigenvalues.real < 0))


# --- slow flow in time -------------------------------------------------------------------------

def _run_from_near(params, R, theta, tau_end, offset=(0.02, 0.02)):
    _, R_path, theta_path = theory.integrate_slow_flow(params, R + offset[0], theta + offset[1], tau_end, 201)
    return R_path, theta_path


@pytest.mark.parametrize("params, tau_end", [(at(g=0.0), 150.0), (at(g=21.065), 600.0), (BISTABLE, 1500.0)])
def test_started_near_a_stable_fixed_point_the_slow_flow_converges_to_it(params, tau_end):
    points = theory.fixed_points(params)
    for R, theta in zip(points.R[points.stable], points.theta[points.stable]):
        R_path, theta_path = _run_from_near(params, R, theta, tau_end)
        assert abs(R_path[-1] - R) < 1e-6
        assert abs(np.angle(np.exp(1j * (theta_path[-1] - theta)))) < 1e-5


@pytest.mark.parametrize("params", [at(g=0.0), at(g=10.0), BISTABLE])
def test_started_near_an_unstable_fixed_point_the_slow_flow_leaves_it(params):
    points = theory.fixed_points(params)
    assert not np.all(points.stable)
    for R, theta in zip(points.R[~points.stable], points.theta[~points.stable]):
        R_path, _ = _run_from_near(params, R, theta, 200.0, offset=(1e-3, 1e-3))
        assert np.max(np.abs(R_path - R)) > 0.1


def test_the_bistable_case_ends_on_the_side_of_the_saddle_it_started():
    points = theory.fixed_points(BISTABLE)
    saddle_R, saddle_theta = points.R[1], points.theta[1]
    # Along the saddle's unstable direction, one side goes to each stable fixed point.
    J = theory.slow_flow_jacobian(saddle_R, saddle_theta, BISTABLE)
    eigenvalues, vectors = np.linalg.eig(J)
    unstable = vectors[:, np.argmax(eigenvalues.real)].real * 1e-3
    ends = []
    for sign in (+1, -1):
        _, R_path, _ = theory.integrate_slow_flow(BISTABLE, saddle_R + sign * unstable[0],
                                                  saddle_theta + sign * unstable[1], 1500.0, 3)
        ends.append(R_path[-1])
    np.testing.assert_allclose(sorted(ends), points.R[[0, 2]], atol=1e-5)


def test_the_cartesian_flow_is_the_polar_flow_written_in_u_and_w():
    """d/dtau (R cos theta, R sin theta) from slow_flow's (dR, dtheta) equals slow_flow_cartesian."""
    rng = np.random.default_rng(7)
    R, theta = rng.uniform(0.1, 3.0, 50), rng.uniform(-np.pi, np.pi, 50)
    for literal in (False, True):
        dR, dtheta = theory.slow_flow(R, theta, BISTABLE, literal=literal)
        du, dw = theory.slow_flow_cartesian(R * np.cos(theta), R * np.sin(theta), BISTABLE, literal=literal)
        np.testing.assert_allclose(du, dR * np.cos(theta) - R * dtheta * np.sin(theta), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(dw, dR * np.sin(theta) + R * dtheta * np.cos(theta), rtol=1e-12, atol=1e-14)


def test_the_slow_flow_starts_from_rest():
    """R0 = 0 is the polar form's singular point (issue 15: all NaN, divide-by-zero warnings).

    configs/hysteresis_effective.yaml at g = 24, from x = v = 0: the flow leaves the origin at
    once (dw/dtau = -F/2 there), agrees with the polar form started 1e-4 off rest, and settles on
    the small stable fixed point (the up sweep's branch in docs/hysteresis.md's table).
    """
    params = dict(BISTABLE, g=24.0)
    R0, theta0 = theory.initial_slow_state(params, rule="state", x0=0.0, v0=0.0)
    assert R0 == 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning, no NaN
        tau, R_path, theta_path = theory.integrate_slow_flow(params, R0, theta0, 400.0, 4001)
        _, R_literal, _ = theory.integrate_slow_flow(params, R0, theta0, 400.0, 4001, literal=True)
    assert np.all(np.isfinite(R_path)) and np.all(np.isfinite(theta_path)) and np.all(np.isfinite(R_literal))
    F = 0.04 / 0.5**2
    assert R_path[1] == pytest.approx(0.5 * F * tau[1], rel=1e-3)  # pushed off along -w at rate F/2
    # The polar form just off rest (1e-4 along the same direction, theta = -pi/2) follows it.
    _, R_near, _ = theory.integrate_slow_flow(params, 1e-4, -np.pi / 2, 400.0, 4001)
    np.testing.assert_allclose(R_near[100:], R_path[100:], atol=1e-3)
    points = theory.fixed_points(params)
    small_stable = points.R[points.stable].min()
    _, R_late, _ = theory.integrate_slow_flow(params, R0, theta0, 2000.0, 3)
    assert R_late[-1] == pytest.approx(small_stable, abs=1e-6)


def test_rk4_converges_with_fourth_order():
    params = at(g=18.0)
    R0, theta0 = theory.initial_slow_state(params, rule="state", x0=0.99, v0=0.5)
    _, R_ref, theta_ref = theory.integrate_slow_flow(params, R0, theta0, 20.0, 3, max_step=0.4 / 64)
    errors = []
    for step in (0.4, 0.2, 0.1):
        _, R_path, theta_path = theory.integrate_slow_flow(params, R0, theta0, 20.0, 3, max_step=step)
        errors.append(np.hypot(R_path[-1] - R_ref[-1], theta_path[-1] - theta_ref[-1]))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.7) & (orders < 4.3)), orders


def test_integration_samples_and_several_starts_at_once():
    tau, R_path, theta_path = theory.integrate_slow_flow(PAPER, np.array([1.0, 1.5]), 0.0, 10.0, 11)
    np.testing.assert_allclose(tau, np.arange(11.0))
    assert R_path.shape == theta_path.shape == (11, 2)
    _, R_single, _ = theory.integrate_slow_flow(PAPER, 1.5, 0.0, 10.0, 11)
    np.testing.assert_allclose(R_path[:, 1], R_single, rtol=1e-14)


def test_initial_slow_state_paper_rule():
    # ERRATA 9: omega = 0.5, l = 1 gives R0 = Delta, theta0 = 0.
    R0, theta0 = theory.initial_slow_state(at(Delta=1.0), rule="paper", l=1)
    assert R0 == pytest.approx(1.0) and theta0 == pytest.approx(0.0, abs=1e-12)
    # A generic omega: R0 = Delta sec(pi l/omega), theta0 = atan(-tan(pi l/omega)) where sec > 0.
    params = at(omega=0.45, Delta=0.8)
    R0, theta0 = theory.initial_slow_state(params, rule="paper", l=1)
    angle = np.pi / 0.45
    assert np.cos(angle) > 0
    assert R0 == pytest.approx(0.8 / np.cos(angle))
    assert theta0 == pytest.approx(np.arctan(-np.tan(angle)))
    # Wherever the rule is evaluated, X(0) = R0 cos(theta0) = Delta (eq2.20) with R0 > 0.
    for omega in (0.3, 0.45, 0.7, 1.1):
        R0, theta0 = theory.initial_slow_state(at(omega=omega, Delta=0.8), rule="paper", l=1)
        assert R0 > 0 and R0 * np.cos(theta0) == pytest.approx(0.8)


def test_initial_slow_state_from_the_initial_state_reproduces_it():
    R0, theta0 = theory.initial_slow_state(PAPER, rule="state", x0=0.99, v0=0.5)
    assert R0 == pytest.approx(np.hypot(0.99, 1.0))
    x, v = theory.reconstruct(np.array([0.0]), np.array([0.0, 1.0]), np.array([R0, R0]),
                              np.array([theta0, theta0]), PAPER)
    assert x[0] == pytest.approx(0.99) and v[0] == pytest.approx(0.5)
    with pytest.raises(ValueError):
        theory.initial_slow_state(PAPER, rule="state")
    with pytest.raises(ValueError):
        theory.initial_slow_state(PAPER, rule="nonsense")


def test_reconstruct_at_a_fixed_point_is_a_pure_cosine():
    params = at(g=21.065)
    point = theory.fixed_points(params)
    R, theta = point.R[0], point.theta[0]
    omega = params["omega"]
    period = 2 * np.pi / omega
    t = np.arange(4096) * (4 * period / 4096)  # four whole periods
    tau = np.array([0.0, omega * t[-1]])
    x, v = theory.reconstruct(t, tau, [R, R], [theta, theta], params)
    np.testing.assert_allclose(x, R * np.cos(omega * t + theta), atol=1e-14)
    np.testing.assert_allclose(v, -omega * R * np.sin(omega * t + theta), atol=1e-14)
    spectrum = np.abs(np.fft.rfft(x)) * 2 / len(t)
    assert spectrum[4] == pytest.approx(R)  # bin 4 = omega over four periods
    assert np.delete(spectrum, 4).max() < 1e-12

    # eq2.26: the correction adds only a third harmonic, of amplitude
    # R^3/32 sqrt((gamma/omega)^2 + (alpha/omega^2)^2); the slow-flow drift terms vanish here.
    x_corrected, v_corrected = theory.reconstruct(t, tau, [R, R], [theta, theta], params, correction=True)
    spectrum = np.abs(np.fft.rfft(x_corrected)) * 2 / len(t)
    co = theory.slow_flow_coefficients(params)
    assert spectrum[4] == pytest.approx(R)
    assert spectrum[12] == pytest.approx(R**3 / 32 * np.hypot(co.Gamma, co.Lambda))
    assert np.delete(spectrum, [4, 12]).max() < 1e-12
    # Its velocity is the time derivative of its displacement.
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(x_corrected, dt)[1:-1], v_corrected[1:-1], atol=1e-4 * R * omega)


def test_reconstruct_rejects_times_outside_the_samples():
    with pytest.raises(ValueError):
        theory.reconstruct(np.array([10.0]), np.array([0.0, 1.0]), [1.0, 1.0], [0.0, 0.0], PAPER)


# --- grids: response branches, sweep columns, peak ---------------------------------------------

def test_response_branches_match_fixed_points():
    g = np.linspace(0, 40, 41)
    branches = theory.response_branches(at(Omega=4.0), g)
    assert branches.R.shape == branches.theta.shape == branches.stable.shape == (41, 3)
    for k in (0, 10, 17, 18, 21, 40):
        points = theory.fixed_points(at(Omega=4.0, g=g[k]))
        n = len(points)
        np.testing.assert_allclose(branches.R[k, :n], points.R, rtol=1e-13)
        np.testing.assert_array_equal(branches.stable[k, :n], points.stable)
        assert np.all(np.isnan(branches.R[k, n:])) and not np.any(branches.stable[k, n:])
    n_roots = np.isfinite(branches.R).sum(axis=1)
    assert set(n_roots) == {1, 3}


def test_analytic_columns_shapes_nan_handling_and_agreement():
    g = np.linspace(0.0, 60.0, 121)[:, None]
    Omega = np.array([4.0, 5.0])[None, :]
    shape = (121, 2)
    grid = {name: np.broadcast_to(value, shape).astype(float) for name, value in at(g=g, Omega=Omega).items()}
    # A region with no stable root (c small, K > 0 near g_res): max_stable must be NaN there.
    grid["c"][:, 1] = 0.01
    columns = theory.analytic_columns(grid)
    assert set(columns) == {"A_theory", "A_theory_stable", "A_theory_max_stable", "g_res"}

    A, dims, attrs = columns["A_theory"]
    assert A.shape == shape + (3,) and dims == ("root",) and A.dtype == np.float64
    assert attrs["units"] == "1"
    assert "analytic amplitude of the slow motion X (eq2.21), not the gain |Q|/c; ERRATA 6" in attrs["long_name"]
    stable, dims, attrs = columns["A_theory_stable"]
    assert stable.shape == shape + (3,) and dims == ("root",) and stable.dtype == np.int8
    assert set(np.unique(stable)) <= {0, 1}
    assert not np.any(stable[np.isnan(A)])
    best, dims, _ = columns["A_theory_max_stable"]
    assert best.shape == shape and dims == ()
    expected_best = np.where(stable.any(axis=-1), np.nanmax(np.where(stable == 1, A, np.nan), axis=-1, initial=-1), np.nan)
    np.testing.assert_array_equal(best, expected_best)
    assert np.any(np.isnan(best[:, 1])) and not np.any(np.isnan(best[:, 0]))
    resonance, dims, _ = columns["g_res"]
    assert resonance.shape == shape and dims == ()
    np.testing.assert_allclose(resonance[0], [21.065, 32.914], atol=1e-3)

    for i, j in [(0, 0), (20, 0), (42, 0), (60, 1), (84, 1), (120, 1)]:
        params = {name: value[i, j] for name, value in grid.items()}
        points = theory.fixed_points(params)
        np.testing.assert_allclose(A[i, j, :len(points)], points.R, rtol=1e-13)
        np.testing.assert_array_equal(stable[i, j, :len(points)], points.stable)


def test_analytic_columns_are_fast_for_a_large_grid():
    shape = (1000, 100)
    g = np.linspace(0.0, 80.0, shape[0])[:, None]
    Omega = np.linspace(3.0, 6.0, shape[1])[None, :]
    grid = {name: np.broadcast_to(value, shape) for name, value in at(g=g, Omega=Omega).items()}
    start = time.perf_counter()
    columns = theory.analytic_columns(grid)
    assert time.perf_counter() - start < 2.0
    assert np.isfinite(columns["A_theory"][0][..., 0]).all()  # at least one root everywhere (F > 0)


def test_analytic_peak_is_the_largest_stable_amplitude_on_the_grid():
    g = np.linspace(0, 80, 401)
    peak = theory.analytic_peak(at(Omega=np.array([4.0, 5.0])), g)
    assert peak.g.shape == peak.amplitude.shape == (2,)
    for k, Omega in enumerate((4.0, 5.0)):
        branches = theory.response_branches(at(Omega=Omega), g)
        best = np.where(branches.stable, branches.R, -np.inf).max(axis=1)
        assert peak.amplitude[k] == best.max()
        assert peak.g[k] == g[np.argmax(best)]
        assert peak.gain[k] == pytest.approx(best.max() / 0.04)
    # With the paper's parameters the largest stable root is the self-excited branch at g = 0.
    np.testing.assert_allclose(peak.g, 0.0)
    np.testing.assert_allclose(peak.amplitude, 1.92972, atol=1e-5)
    # In the bistable family the peak is interior.
    peak = theory.analytic_peak(dict(BISTABLE, Omega=4.0), np.linspace(0, 60, 601))
    assert 10 < peak.g < 20 and peak.amplitude > 2


# --- property: the cubic's roots are fixed points ----------------------------------------------

@settings(max_examples=300, deadline=None)
@given(
    gamma=st.floats(0.01, 1.0), alpha=st.floats(0.01, 1.0), c=st.floats(1e-3, 1.0),
    omega0=st.floats(0.0, 1.0), omega=st.floats(0.1, 2.0), g=st.floats(0.0, 100.0), Omega=st.floats(1.0, 10.0),
)
def test_roots_of_the_cubic_are_fixed_points(gamma, alpha, c, omega0, omega, g, Omega):
    params = dict(gamma=gamma, alpha=alpha, c=c, omega0=omega0, omega=omega, g=g, Omega=Omega)
    points = theory.fixed_points(params)
    assert 1 <= len(points) <= 3  # F > 0: at least one root, every real root positive
    co = theory.slow_flow_coefficients(params)
    u = points.R**2
    # F^2 = Gamma^2 u (K - u/4)^2 + u (3 Lambda u/4 - sigma)^2, to rounding of its largest term.
    damping_term = co.Gamma**2 * u * (co.K - u / 4) ** 2
    detuning_term = u * (3 * co.Lambda * u / 4 - co.sigma) ** 2
    scale = np.maximum(co.F**2, np.maximum(co.Gamma**2 * u * (np.abs(co.K) + u / 4) ** 2,
                                           u * (3 * co.Lambda * u / 4 + np.abs(co.sigma)) ** 2))
    assert np.all(np.abs(damping_term + detuning_term - co.F**2) <= 1e-9 * scale)
    # And the slow flow vanishes there, relative to the size of its terms.
    dR, dtheta = theory.slow_flow(points.R, points.theta, params)
    R = points.R
    assert np.all(np.abs(dR) <= 1e-9 * (co.Gamma * (R**3 / 8 + np.abs(co.K) * R / 2) + co.F / 2))
    assert np.all(np.abs(dtheta) <= 1e-9 * (3 * co.Lambda * R**2 / 8 + np.abs(co.sigma) / 2 + co.F / (2 * R)))


# --- the first-order theory against the effective system (SciPy, no barrier) --------------------

def _effective_amplitude(params, x0, v0, transient_periods=150, measure_periods=40):
    """|Q| (eq3.1-eq3.3 without the division by c) of the effective system eq2.10 without impacts."""
    return np.hypot(*_effective_fourier_components(params, x0, v0, transient_periods, measure_periods))


def _effective_fourier_components(params, x0, v0, transient_periods=150, measure_periods=40):
    """(Qs, Qc) of eq3.1-eq3.2 for the effective system eq2.10 without impacts (SciPy DOP853)."""
    from scipy.integrate import solve_ivp

    gamma, alpha, c, omega = params["gamma"], params["alpha"], params["c"], params["omega"]
    wt2, K = theory.effective_frequency_squared(params), theory.damping_level(params)

    def rhs(t, y):
        return [y[1], -gamma * (y[0] ** 2 - K) * y[1] - wt2 * y[0] - alpha * y[0] ** 3 + c * np.cos(omega * t)]

    period = 2 * np.pi / omega
    start = transient_periods * period
    y0 = solve_ivp(rhs, (0, start), [x0, v0], method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
    n = measure_periods * 256
    t = start + np.arange(n) * (period / 256)  # whole periods: the rectangle rule is spectral here
    x = solve_ivp(rhs, (start, t[-1]), y0, method="DOP853", rtol=1e-10, atol=1e-12, t_eval=t).y[0]
    return 2 * np.mean(x * np.sin(omega * t)), 2 * np.mean(x * np.cos(omega * t))


@pytest.mark.slow
@pytest.mark.parametrize("params, root, tolerance", [
    (at(g=21.065, Omega=4.0), 0, 0.005),   # at g_res: one stable root 0.810, |Q| within 0.2 %
    (at(g=30.0, Omega=5.0), 0, 0.005),     # one stable root 1.047: within 0.35 %
    (at(g=10.0, Omega=4.0), 2, 0.02),      # three roots, the largest stable (1.727): within 1.1 %
    (BISTABLE, 0, 0.005),                  # bistable: the lower stable root ...
    (BISTABLE, 2, 0.02),                   # ... and the upper one, each from its own start
])
def test_stable_amplitude_matches_the_effective_system(params, root, tolerance):
    points = theory.fixed_points(params)
    assert points.stable[root]
    R, theta = points.R[root], points.theta[root]
    x0, v0 = R * np.cos(theta), -params["omega"] * R * np.sin(theta)  # eq2.21 at t = 0
    assert _effective_amplitude(params, x0, v0) == pytest.approx(R, rel=tolerance)


@pytest.mark.slow
def test_the_corrected_phase_and_stability_are_those_of_the_effective_system():
    # ERRATA 1: only the re-derived eq2.24 predicts the motion. X = R cos(omega t + theta) has
    # Qc = R cos(theta) and Qs = -R sin(theta), so the simulated phase is atan2(-Qs, Qc). At g_res
    # (Omega = 4) both flows have the one root R = 0.810; the corrected flow puts it at
    # theta = -0.069 and calls it stable, the printed one at theta = 1.640 and calls it unstable.
    # The effective system, started elsewhere, settles on it with theta = -0.080.
    params = at(g=float(theory.g_res(0.1, 0.1, 0.5, 4.0)), Omega=4.0)
    corrected, printed = theory.fixed_points(params), theory.fixed_points(params, literal=True)
    assert len(corrected) == len(printed) == 1
    Qs, Qc = _effective_fourier_components(params, 0.5, 0.0)
    assert np.hypot(Qs, Qc) == pytest.approx(corrected.R[0], rel=0.005)
    phase = np.arctan2(-Qs, Qc)
    assert phase == pytest.approx(corrected.theta[0], abs=0.03)  # first-order accuracy
    assert abs(phase - printed.theta[0]) > 1.5                   # about pi/2 off
    assert corrected.stable[0] and not printed.stable[0]
