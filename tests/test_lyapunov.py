"""Lyapunov exponents (tangent.py, integration.lyapunov): checks that would fail if they were wrong.

- the largest exponent of a periodic orbit against the Floquet multipliers of its monodromy
  matrix, obtained by central differences of the stroboscopic map computed by SciPy (an
  independent solver with its own impact handling, tests/reference.py);
- with the barrier out of reach, against the variational equations of the smooth system
  integrated by SciPy with Gram-Schmidt every slow period;
- on a chaotic point: positive, and equal to a two-trajectory (Benettin) estimate built from the
  state integration alone along the same stroboscopic points;
- the sum of both exponents against the time average of the flow's divergence (from the kernel's
  own dense samples) plus 2 ln e per impact per unit time (the saltation matrix's determinant
  is e^2): no reference solver needed, derivation in docs/design.md;
- a point that sticks has -inf (the tangent map of a sticking interval is zero);
- carrying the tangent vectors changes nothing else: every record and R bit for bit.
No reference value is stored: each is computed at test time.
"""

import math

import numpy as np
import pytest
from scipy.integrate import simpson, solve_ivp

from vrsweep.numerics import kernel
from vrsweep.analysis.diagnostics import detect_period, lyapunov_error
from vrsweep.numerics.model import DEFAULT_PARAMETERS, E, GAMMA, MU, kernel_coefficients
from vrsweep.results import Status
from vrsweep.numerics.trajectory import settings_vector, simulate

from reference import coefficient_vector, reference_trajectory

METHODS = tuple(kernel.INTEGRATORS)
every_method = pytest.mark.parametrize("method", METHODS)


def _paper_coefficients(model="original", **changes):
    parameters = dict(DEFAULT_PARAMETERS, Omega=4.0)
    parameters.update(changes)
    return kernel_coefficients({k: np.array([v]) for k, v in parameters.items()}, model)[0]


def _slow_period(coefficients):
    return 2.0 * math.pi / coefficients[kernel.OMEGA]


def _lyapunov_run(coefficients, start, transient, measure, rtol=1e-11, method="dop853", sample_times=()):
    settings = settings_vector(rtol=rtol, atol=rtol * 1e-2, transient_periods=transient, measure_periods=measure)
    run = simulate(coefficients, start, settings, method=method, lyapunov=True, sample_times=sample_times)
    assert run.status == Status.OK
    return run


def _strobe(run):
    return run.period_records[:, [kernel.REC_X, kernel.REC_V]]


def _monodromy(coefficients, state, periods, h=1e-5):
    """d(P^periods)/d(x, v) at state, by central differences of SciPy's stroboscopic map."""
    duration = periods * _slow_period(coefficients)

    def power_map(s):
        out = reference_trajectory(coefficients, s[0], s[1], duration, rtol=1e-12, atol=1e-14)
        return np.array([out["x_final"], out["v_final"]])

    assert np.allclose(power_map(state), state, rtol=0, atol=1e-9)  # it is a periodic point
    jacobian = np.empty((2, 2))
    for j in range(2):
        step = np.zeros(2)
        step[j] = h
        jacobian[:, j] = (power_map(state + step) - power_map(state - step)) / (2 * h)
    return jacobian


# The paper's parameters at Omega = 4 (original model): period-1 orbits with real Floquet
# multipliers of distinct moduli, 8 and 4 impacts per slow period. The phase of both forces is
# the same at every t = nT (Omega T = 16 pi), so the stroboscopic map does not depend on n.
REAL_MULTIPLIER_POINTS = [dict(g=40.0), dict(g=25.0)]


@pytest.mark.parametrize("changes", REAL_MULTIPLIER_POINTS, ids=lambda c: f"g={c['g']:g}")
@every_method
def test_largest_exponent_is_that_of_the_monodromy_matrix(changes, method):
    coefficients = _paper_coefficients(**changes)
    run = _lyapunov_run(coefficients, [0.99, 0.5], 100, 40, method=method)
    strobe = _strobe(run)
    assert detect_period(strobe[None, -20:, 0], strobe[None, -20:, 1], 8, 1e-8)[0] == 1
    assert run.period_records[-1, kernel.REC_IMPACTS] >= 4  # the saltation matrices matter
    multipliers = np.linalg.eigvals(_monodromy(coefficients, strobe[-1], 1))
    assert np.all(np.abs(multipliers.imag) == 0.0)
    expected = math.log(np.max(np.abs(multipliers))) / _slow_period(coefficients)
    # Real multipliers of distinct moduli: the tangent vector aligns exponentially fast, so the
    # window's mean is the orbit's exponent up to the solvers' accuracy.
    assert run.summary[kernel.SUM_LYAPUNOV] == pytest.approx(expected, rel=1e-4)


@every_method
def test_complex_multipliers_give_half_the_sum_and_a_covered_largest_exponent(method):
    # The hysteresis example's impacting orbit (effective model, gamma = alpha = 0.05, g = 23):
    # period 1, one impact per period, a complex pair of multipliers. Both exponents are then
    # ln|mu| / T; a single tangent vector rotates with the pair, and its mean stretch over m
    # periods converges only as 1/m, which lyapunov_err must cover.
    coefficients = _paper_coefficients("effective", gamma=0.05, alpha=0.05, g=23.0)
    run = _lyapunov_run(coefficients, [0.9, 1.0], 100, 200, method=method)
    strobe = _strobe(run)
    multipliers = np.linalg.eigvals(_monodromy(coefficients, strobe[-1], 1))
    assert abs(multipliers[0].imag) > 0.1
    expected = math.log(abs(multipliers[0])) / _slow_period(coefficients)
    assert run.summary[kernel.SUM_LYAPUNOV_SUM] / 2 == pytest.approx(expected, rel=1e-5)
    error = lyapunov_error(run.period_records[100:, kernel.REC_LOG_STRETCH], _slow_period(coefficients), 1)
    assert run.summary[kernel.SUM_LYAPUNOV] == pytest.approx(expected, rel=0.03)  # "a few per cent"
    assert abs(run.summary[kernel.SUM_LYAPUNOV] - expected) <= error


def _smooth_exponents(coefficients, start, transient, measure):
    """Both exponents of the smooth system by SciPy: x, v and two tangent vectors, Gram-Schmidt
    (numpy's QR) every slow period, logs summed over the measurement window."""
    gamma, mu, k, alpha, c, omega, g, big_omega = (coefficients[i] for i in (
        kernel.GAMMA, kernel.MU, kernel.STIFFNESS, kernel.ALPHA, kernel.C, kernel.OMEGA, kernel.G,
        kernel.BIG_OMEGA))

    def rhs(t, y):
        x, v = y[0], y[1]
        tangents = y[2:].reshape(2, 2).T  # columns (dx, dv)
        jacobian = np.array([[0.0, 1.0], [-(2 * gamma * x * v + k + 3 * alpha * x * x), -gamma * (x * x - mu)]])
        acceleration = (c * math.cos(omega * t) + g * math.cos(big_omega * t) - gamma * (x * x - mu) * v
                        - k * x - alpha * x ** 3)
        return np.concatenate([[v, acceleration], (jacobian @ tangents).T.ravel()])

    period = _slow_period(coefficients)
    state = np.array(start, dtype=float)
    basis = np.eye(2)
    logs = np.zeros(2)
    for n in range(transient + measure):
        y0 = np.concatenate([state, basis.T.ravel()])
        y = solve_ivp(rhs, (n * period, (n + 1) * period), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        state = y[:2]
        q, r = np.linalg.qr(y[2:].reshape(2, 2).T)
        basis = q * np.sign(np.diag(r))
        if n >= transient:
            logs += np.log(np.abs(np.diag(r)))
    return logs / (measure * period)


@every_method
def test_barrier_out_of_reach_matches_the_smooth_system(method):
    coefficients = _paper_coefficients(g=10.0, Delta=3.0)  # |x| < 2.43: no impact ever
    run = _lyapunov_run(coefficients, [0.99, 0.5], 30, 20, method=method)
    assert run.summary[kernel.SUM_IMPACTS] == 0
    largest, second = _smooth_exponents(coefficients, [0.99, 0.5], 30, 20)
    assert run.summary[kernel.SUM_LYAPUNOV] == pytest.approx(largest, rel=1e-5)
    assert run.summary[kernel.SUM_LYAPUNOV_SUM] == pytest.approx(largest + second, rel=1e-5)


def _benettin(coefficients, strobe_states, method, separation=1e-7):
    """Per-period log growth of a small separation, from the state integration alone.

    Period n runs a trajectory from each stroboscopic state s_n of the run under test and one
    from s_n + separation u_n, u_n the direction the previous period's separation took (the
    first along x): the two-trajectory method of Benettin et al., on the same points as the
    tangent vector.
    """
    one_period = settings_vector(rtol=1e-11, atol=1e-13, transient_periods=0, measure_periods=1)
    direction = np.array([1.0, 0.0])
    logs = []
    for state in strobe_states:
        ends = []
        for start in (state, state + separation * direction):
            summary = simulate(coefficients, start, one_period, method=method).summary
            ends.append(summary[[kernel.SUM_X_FINAL, kernel.SUM_V_FINAL]])
        difference = ends[1] - ends[0]
        length = np.linalg.norm(difference)
        logs.append(math.log(length / separation))
        direction = difference / length
    return np.array(logs)


@every_method
def test_chaotic_point_is_positive_and_agrees_with_two_trajectories(method):
    # The paper's parameters at g = 5, Omega = 4 (original model): R over 100 periods depends on
    # the tolerance alone (diagnostics.py), a chaotic orbit with impacts and no sticking.
    coefficients = _paper_coefficients(g=5.0)
    transient, measure = 20, 40
    run = _lyapunov_run(coefficients, [0.99, 0.5], transient, measure, method=method)
    assert run.summary[kernel.SUM_IMPACTS] > 40 and len(run.sticks) == 0
    period = _slow_period(coefficients)
    strobe_states = np.vstack([[0.99, 0.5], _strobe(run)[:-1]])
    logs = _benettin(coefficients, strobe_states, method)
    benettin = logs[transient:].sum() / (measure * period)
    largest = run.summary[kernel.SUM_LYAPUNOV]
    assert largest > 0.1
    assert largest == pytest.approx(benettin, rel=1e-3)


@pytest.mark.parametrize("changes", [dict(g=10.0), dict(g=5.0)], ids=["periodic", "chaotic"])
@every_method
def test_sum_of_exponents_is_mean_divergence_plus_saltation(changes, method):
    # d/dt ln(area) = div f = -gamma (x^2 - mu) between impacts; each impact multiplies areas by
    # det S = e^2. So lambda_1 + lambda_2 = <-gamma (x^2 - mu)> + 2 ln(e) (impacts / time).
    coefficients = _paper_coefficients(**changes)
    transient, measure = 20, 20
    period = _slow_period(coefficients)
    times = np.linspace(transient * period, (transient + measure) * period, measure * 2000 + 1)
    run = _lyapunov_run(coefficients, [0.99, 0.5], transient, measure, rtol=1e-10, method=method,
                        sample_times=times)
    x = run.samples[:, 0]
    window = measure * period
    mean_divergence = -coefficients[GAMMA] * (simpson(x * x, x=times) / window - coefficients[MU])
    impacts = run.period_records[transient:, kernel.REC_IMPACTS].sum()
    assert impacts > 20
    expected = mean_divergence + 2.0 * math.log(coefficients[E]) * impacts / window
    assert run.summary[kernel.SUM_LYAPUNOV_SUM] == pytest.approx(expected, rel=1e-5)


@every_method
def test_sticking_gives_minus_infinity(method):
    # Stiffness pulls the mass off the barrier and the slow force (5 > k Delta) pushes it back
    # for part of every slow period: it sticks in every period (tests/test_kernel.py).
    coefficients = coefficient_vector(gamma=0.1, stiffness=1.0, c=5.0, omega=0.5, Delta=1.0, e=0.5)
    run = _lyapunov_run(coefficients, [0.0, 0.0], 2, 4, rtol=1e-10, method=method)
    assert len(run.sticks) >= 4
    assert run.summary[kernel.SUM_LYAPUNOV] == -math.inf
    assert lyapunov_error(run.period_records[2:, kernel.REC_LOG_STRETCH], 4 * math.pi, 0) == 0.0


@pytest.mark.parametrize("changes", [dict(g=5.0), dict(g=40.0)], ids=["chaotic", "periodic"])
@every_method
def test_tangent_vectors_change_nothing_else(changes, method):
    coefficients = _paper_coefficients(**changes)
    settings = settings_vector(rtol=1e-9, atol=1e-11, transient_periods=10, measure_periods=10)
    plain = simulate(coefficients, [0.99, 0.5], settings, method=method)
    with_tangents = simulate(coefficients, [0.99, 0.5], settings, method=method, lyapunov=True)
    columns = slice(0, kernel.REC_LOG_STRETCH)
    np.testing.assert_array_equal(plain.period_records[:, columns], with_tangents.period_records[:, columns])
    np.testing.assert_array_equal(plain.summary[:kernel.SUM_LYAPUNOV], with_tangents.summary[:kernel.SUM_LYAPUNOV])
    assert np.all(np.isnan(plain.period_records[:, kernel.REC_LOG_STRETCH]))
    assert np.isnan(plain.summary[kernel.SUM_LYAPUNOV])
    assert np.isfinite(with_tangents.summary[kernel.SUM_LYAPUNOV])


# --- the sweep: integration.lyapunov, the file's variables, the config key ------------------------

def _cli(*args):
    from click.testing import CliRunner

    from vrsweep.cli import main

    result = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in result.output, result.output
    return result


SWEEP = """\
sweep:
  g: [5.0, 25.0, 40.0]
integration: {method: dop853, rtol: 1.0e-9, atol: 1.0e-11, transient_periods: 20, measure_periods: 20,
              strobe_periods: 8}
"""


def test_a_sweep_stores_the_kernels_exponent_and_its_error(tmp_path):
    import vrsweep

    config = tmp_path / "sweep.yaml"
    config.write_text(SWEEP + "output: on.h5\n")
    result = _cli("run", config, "--set", "lyapunov=true", "-o", tmp_path / "on.h5", "--quiet")
    assert result.exit_code == 0, result.output
    off = _cli("run", config, "-o", tmp_path / "off.h5", "--quiet")
    assert off.exit_code == 0, off.output
    with vrsweep.open_results(tmp_path / "on.h5") as on, vrsweep.open_results(tmp_path / "off.h5") as plain:
        assert "lyapunov" not in plain and "lyapunov_err" not in plain
        np.testing.assert_array_equal(on["R"].values, plain["R"].values)  # the same steps
        assert "lyapunov: true" in on.attrs["config"]
        assert on["lyapunov"].attrs["units"] == "1" and "Lyapunov" in on["lyapunov"].attrs["long_name"]
        settings = settings_vector(rtol=1e-9, atol=1e-11, transient_periods=20, measure_periods=20)
        for g in (5.0, 25.0, 40.0):
            run = simulate(_paper_coefficients(g=g), [0.99, 0.5], settings, method="dop853", lyapunov=True)
            point = on.sel(g=g)
            assert float(point["lyapunov"]) == run.summary[kernel.SUM_LYAPUNOV]
            expected_error = lyapunov_error(run.period_records[20:, kernel.REC_LOG_STRETCH],
                                            4 * math.pi, int(point["period"]))
            assert float(point["lyapunov_err"]) == pytest.approx(expected_error, rel=1e-12)
        chaotic, periodic = on.sel(g=5.0), on.sel(g=40.0)
        assert float(chaotic["lyapunov"]) > 3 * float(chaotic["lyapunov_err"])
        assert float(periodic["lyapunov_err"]) < 1e-6


def test_lyapunov_must_be_a_boolean(tmp_path):
    config = tmp_path / "bad.yaml"
    config.write_text("integration:\n  lyapunov: maybe\n")
    result = _cli("validate", config)
    assert result.exit_code == 2
    assert "bad.yaml:2" in result.output and "integration.lyapunov" in result.output


@every_method
def test_a_damping_that_would_underflow_the_tangent_in_one_period_gives_a_finite_exponent(method):
    # Effective model with K = 1 - g^2/2 = -241 (Omega = 1): damping gamma (x^2 - K) ~ 30 over a
    # slow period of 57 shrinks a tangent vector by e^-1700, below the smallest double, unless it is
    # renormalised within the period (tangent.TANGENT_RANGE). Found by the property test.
    parameters = dict(gamma=0.125, alpha=1.0, c=0.25, omega0=0.0, omega=0.109375, Delta=1.0, e=1.0, g=22.0,
                      Omega=1.0)
    coefficients = kernel_coefficients(parameters, "effective")
    period = _slow_period(coefficients)
    times = np.linspace(2 * period, 4 * period, 40001)
    run = _lyapunov_run(coefficients, [0.0, 0.0], 2, 2, rtol=1e-10, method=method, sample_times=times)
    assert run.summary[kernel.SUM_IMPACTS] == 0 and len(run.sticks) == 0
    x = run.samples[:, 0]
    mean_divergence = -coefficients[GAMMA] * (simpson(x * x, x=times) / (2 * period) - coefficients[MU])
    assert mean_divergence < -30.0
    # Untracked by error control, the tangent's fast, strongly damped modes carry the steps' error:
    # 2e-4 here (the steps resolve the slowly forced state, not the homogeneous decay).
    assert run.summary[kernel.SUM_LYAPUNOV_SUM] == pytest.approx(mean_divergence, rel=1e-3)
    assert math.isfinite(run.summary[kernel.SUM_LYAPUNOV])


def _saltation_monodromy(parameters, state, start_time, periods):
    """The p-period map's Jacobian at ``state`` by SciPy: the original model (eq2.1) with its
    variational equations, each impact (eq2.2) found as an event and the tangent matrix multiplied
    there by the saltation matrix S = [[-e, 0], [(a+ + e a-) / v-, -e]] (a+-: the acceleration at
    the barrier just after and before; det S = e^2). Written here, independent of tangent.py."""
    gamma, alpha, c, omega0, omega, delta, e, g, big_omega = (parameters[name] for name in (
        "gamma", "alpha", "c", "omega0", "omega", "Delta", "e", "g", "Omega"))
    period = 2.0 * math.pi / omega

    def acceleration(t, x, v):
        return (-gamma * (x * x - 1.0) * v + omega0 ** 2 * x - alpha * x ** 3 + c * math.cos(omega * t)
                + g * math.cos(big_omega * t))

    def rhs(t, y):
        x, v = y[0], y[1]
        jacobian = np.array([[0.0, 1.0], [-2.0 * gamma * x * v + omega0 ** 2 - 3.0 * alpha * x * x,
                                          -gamma * (x * x - 1.0)]])
        return np.concatenate([[v, acceleration(t, x, v)], (jacobian @ y[2:].reshape(2, 2)).ravel()])

    def barrier(t, y):
        return delta - y[0]

    barrier.terminal, barrier.direction = True, -1
    y = np.concatenate([state, np.eye(2).ravel()])
    t, end = start_time, start_time + periods * period
    while True:
        out = solve_ivp(rhs, (t, end), y, method="DOP853", rtol=1e-12, atol=1e-14, events=barrier,
                        max_step=min(period / 6, 2 * math.pi / big_omega / 8))
        if out.status != 1:
            return out.y[2:, -1].reshape(2, 2)
        t, y = out.t_events[0][0], out.y_events[0][0].copy()
        before, after = y[1], -e * y[1]
        salt = np.array([[-e, 0.0], [(acceleration(t, delta, after) + e * acceleration(t, delta, before)) / before,
                                     -e]])
        y = np.concatenate([[delta, after], (salt @ y[2:].reshape(2, 2)).ravel()])


@every_method
def test_a_periodic_points_exponent_is_its_orbits_when_the_window_is_no_whole_number_of_cycles(method):
    # g = 10, Omega = 4: period 3, 8 impacts a cycle; 50 measured periods are 16 cycles and 2
    # periods. The stored exponent must be the orbit's, log|mu_1| / 3T, as R is the orbit's
    # (motion.whole_cycle_gain), not the window's mean, which counts the first 2 periods of a cycle
    # once more (-0.4651 against -0.4664 over 100 periods).
    import vrsweep

    parameters = dict(DEFAULT_PARAMETERS, Omega=4.0, g=10.0)
    ds = vrsweep.sweep({"model": "original", "parameters": parameters, "sweep": {"x0": [0.99]},
                        "integration": {"method": method, "rtol": 1e-10, "atol": 1e-12, "lyapunov": True,
                                        "transient_periods": 40, "measure_periods": 50}}, progress=False)
    point = ds.isel(x0=0)
    assert int(point["period"]) == 3 and int(point["impacts_per_cycle"]) == 8
    period = 2.0 * math.pi / parameters["omega"]
    state = np.array([float(point["x_final"]), float(point["v_final"])])
    monodromy = _saltation_monodromy(parameters, state, 90 * period, 3)
    expected = math.log(np.max(np.abs(np.linalg.eigvals(monodromy)))) / (3 * period)
    assert float(point["lyapunov"]) == pytest.approx(expected, rel=1e-7)
    assert float(point["lyapunov_err"]) < 1e-7 * abs(expected)  # identical batches of whole cycles
