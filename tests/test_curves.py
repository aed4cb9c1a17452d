"""Bifurcation curves in two parameters (analysis/curves.py).

Every check is independent of the curve code's own test functions where it can be: a closed form
(the effective model depends on g and Omega only through g/Omega^2, eq2.11 and eq2.12, so every
curve in (g, Omega) is g = k Omega^2; a fold orbit that does not touch the barrier does not
depend on Delta), the one-parameter continuation (analysis/continuation.py) locating the fold or
period doubling at the curve's point, simulations on either side of a grazing curve, two curves
meeting at the same codimension-two point, and the corrected first-order theory.

The cases: the README's hysteresis example (effective model, gamma = alpha = 0.05, Omega = 4),
its fold (g = 25.27) and the graze of its unstable orbit (g = 25.08); the effective model at the
paper's parameters, whose impacting period-1 orbit doubles its period near g = 18.1.
"""

import numpy as np
import pytest

from vrsweep.analysis import continuation, curves, theory
from vrsweep.errors import UsageError
from vrsweep.numerics import kernel
from vrsweep.numerics.model import DEFAULT_PARAMETERS
from vrsweep.numerics.trajectory import settings_vector, simulate

HYSTERESIS = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, Omega=4.0)
SETTINGS = settings_vector(rtol=1e-10, atol=1e-12)
OPTIONS = dict(continuation.DEFAULTS, max_step=0.3)


def _relative_location(problem, point):
    """The curve's location tolerance at ``point``: location_tolerance * max(1, |z|) (curves.correct)."""
    return problem.options["location_tolerance"] * max(1.0, float(np.max(np.abs(point.z))))


@pytest.fixture(scope="module")
def hysteresis_bifurcations():
    """The one-parameter branch in g through the small orbit: its fold and its graze, by kind."""
    problem = continuation.ContinuationProblem(dict(HYSTERESIS, g=24.0), "effective", "g", SETTINGS, "rk45",
                                               dict(OPTIONS))
    start = continuation.find_start(problem, [0.0, 0.0], 24.0, 200, 16)
    _, bifurcations = continuation.continue_branch(problem, start, 23.5, 25.4, 60)
    found = {b.kind: b.orbit for b in bifurcations}
    assert {"fold", "grazing"} <= set(found)
    return found


def _curve(kind, orbit, along, ranges, parameters=HYSTERESIS, max_points=100, **options):
    problem = curves.CurveProblem(dict(parameters), "effective", ("g", along), SETTINGS, "rk45",
                                  dict(OPTIONS, **options))
    start, failure = curves.start_point(problem, kind, orbit.state, [orbit.parameter, parameters[along]],
                                        orbit.periods)
    assert failure is None, failure
    curve, specials = curves.continue_curve(problem, kind, start, ranges, max_points)
    return problem, curve, specials


@pytest.fixture(scope="module")
def fold_g_Omega(hysteresis_bifurcations):
    return _curve("fold", hysteresis_bifurcations["fold"], "Omega", ((15.0, 40.0), (3.6, 4.4)))


@pytest.fixture(scope="module")
def grazing_g_Omega(hysteresis_bifurcations):
    return _curve("grazing", hysteresis_bifurcations["grazing"], "Omega", ((15.0, 40.0), (3.6, 4.4)))


@pytest.fixture(scope="module")
def fold_g_Delta(hysteresis_bifurcations):
    return _curve("fold", hysteresis_bifurcations["fold"], "Delta", ((15.0, 40.0), (0.5, 1.5)))


@pytest.fixture(scope="module")
def grazing_g_Delta(hysteresis_bifurcations):
    return _curve("grazing", hysteresis_bifurcations["grazing"], "Delta", ((23.5, 25.4), (0.5, 1.5)))


def _sample(points, count):
    index = np.unique(np.linspace(0, len(points) - 1, count).round().astype(int))
    return [points[i] for i in index]


@pytest.mark.parametrize("name", ["fold_g_Omega", "grazing_g_Omega"])
def test_curves_in_g_Omega_keep_g_over_Omega_squared(name, request):
    # Closed form: the effective model sees g and Omega only through wt2 and K, functions of
    # g/Omega^2 (eq2.11, eq2.12), so every bifurcation curve in (g, Omega) is g = k Omega^2.
    # Each point is within location_tolerance * max(1, |z|) of the curve in every component
    # (curves.correct): at most 4e-5 here, i.e. 2e-6 relative in g >= 20 and 1.1e-5 in Omega >=
    # 3.6, so g/Omega^2 is constant to 2e-6 + 2 * 1.1e-5 < 3e-5.
    problem, curve, _ = request.getfixturevalue(name)
    values = np.array([point.values for point in curve.points])
    assert values[:, 1].min() < 3.7 and values[:, 1].max() > 4.3  # the curve crossed the whole range
    ratio = values[:, 0] / values[:, 1] ** 2
    assert np.max(np.abs(ratio / ratio[0] - 1.0)) < 3e-5
    assert curve.ends["first"][0] == curve.ends["last"][0] == curves.ENDED_RANGE


def _fold_located_by_one_parameter_continuation(problem, point, offset=0.02):
    """g of the fold the one-parameter continuation at the point's second parameter finds, starting
    ``offset`` from the point along the null vector of M - I (the branch's tangent at the fold)."""
    one = problem.one_parameter(point.values[1])
    one.options["max_step"] = 0.01
    _, _, rows = np.linalg.svd(point.monodromy - np.eye(2))
    direction = np.array([rows[-1][0], rows[-1][1], 0.0])
    z = np.array([point.state[0], point.state[1], point.values[0]]) + offset * direction
    orbit, failure = continuation.correct(one, z, point.periods, direction, z)
    assert failure is None, failure
    g = point.values[0]
    _, bifurcations = continuation.continue_branch(one, orbit, g - 0.05, g + 0.05, 40)
    return [b.orbit.parameter for b in bifurcations if b.kind == "fold"]


@pytest.mark.slow
def test_one_parameter_continuation_finds_the_fold_where_the_curve_is(fold_g_Omega):
    problem, curve, _ = fold_g_Omega
    for point in _sample(curve.points, 3):
        located = _fold_located_by_one_parameter_continuation(problem, point)
        assert len(located) == 1, (point.values, located)
        # Both locate to location_tolerance * max(1, |z|) (the one-parameter one in g alone).
        assert abs(located[0] - point.values[0]) < 2.0 * _relative_location(problem, point), (point.values, located)


def _free_orbit(problem, point, g):
    """The fixed point of the barrier-free map at (g, the point's second parameter), from the point."""
    one = problem.one_parameter(point.values[1])
    free = continuation.ContinuationProblem(dict(one.parameters, Delta=np.inf), one.model, "g", one.settings,
                                            one.method, one.options)
    orbit, failure = continuation.correct(free, np.array([point.state[0], point.state[1], g]), point.periods)
    assert failure is None, failure
    return orbit


@pytest.mark.slow
def test_simulations_on_either_side_of_the_grazing_curve_impact_on_one_side_only(grazing_g_Omega):
    # At fixed Omega, the orbit at g -/+ 0.02 from the curve (the barrier-free one: on the side
    # where it crosses the barrier the real orbit is another one) is integrated with the barrier
    # over its p periods: no impact on one side, at least one on the other.
    problem, curve, _ = grazing_g_Omega
    for point in _sample(curve.points, 3):
        settings = np.array(SETTINGS)
        settings[kernel.TRANSIENT_PERIODS], settings[kernel.MEASURE_PERIODS] = 0, point.periods
        impacts = []
        for g in (point.values[0] - 0.02, point.values[0] + 0.02):
            orbit = _free_orbit(problem, point, g)
            run = simulate(problem.coefficients([g, point.values[1]]), orbit.state, settings)
            impacts.append(int(run.summary[kernel.SUM_IMPACTS]) / point.periods)
        assert sorted(impacts)[0] == 0 and sorted(impacts)[1] >= 1, (point.values, impacts)


def test_fold_curve_in_g_Delta_is_vertical_until_the_fold_orbit_grazes(fold_g_Delta, grazing_g_Delta):
    # A fold orbit clear of the barrier does not see Delta: the curve is g = constant, down to
    # the Delta at which the fold orbit touches the barrier, where the fold curve meets the
    # grazing curve (a fold-grazing point), found here from both curves independently.
    problem, curve, specials = fold_g_Delta
    values = np.array([point.values for point in curve.points])
    assert np.max(np.abs(values[:, 0] - values[0, 0])) < 2.0 * _relative_location(problem, curve.points[0])
    assert curve.ends["first"][0] == "fold_grazing" or curve.ends["last"][0] == "fold_grazing"
    from_fold = [s for s in specials if s.kind == "fold_grazing"]
    from_graze = [s for s in grazing_g_Delta[2] if s.kind == "fold_grazing"]
    assert len(from_fold) == 1 and len(from_graze) == 1
    # The fold curve's point is extrapolated to the barrier along the exactly linear barrier
    # distance (Delta - x_max, x_max fixed); the grazing curve's is located by regula falsi on
    # det(M - I) to location_tolerance. Both to about 3e-5 in each parameter.
    assert np.allclose(from_fold[0].values, from_graze[0].values, rtol=0, atol=1e-4), (from_fold[0].values,
                                                                                        from_graze[0].values)


def test_grazing_curve_points_touch_the_barrier(grazing_g_Delta):
    problem, curve, _ = grazing_g_Delta
    for point in curve.points:
        assert point.impacts_per_period == 0
        assert abs(point.barrier_distance) < 10 * problem.options["newton_tolerance"] + _relative_location(problem, point)


@pytest.fixture(scope="module")
def fold_g_c(hysteresis_bifurcations):
    return _curve("fold", hysteresis_bifurcations["fold"], "c", ((15.0, 40.0), (0.001, 0.2)), max_points=200,
                  max_step=0.05)


def test_fold_curve_in_g_c_turns_back_at_a_cusp(fold_g_c):
    # Smaller c, smaller response: the hysteresis loop closes, its two folds meeting in a cusp,
    # where the curve's projection on (g, c) turns back: the cusp is the curve's smallest c and
    # largest g (both to about a step of the location, 1e-6 * max(1, |z|) per component).
    problem, curve, specials = fold_g_c
    cusps = [s for s in specials if s.kind == "cusp"]
    assert len(cusps) == 1
    values = np.array([point.values for point in curve.points])
    cusp = cusps[0].values
    slack = 2.0 * _relative_location(problem, cusps[0].point)
    assert cusp[1] <= values[:, 1].min() + slack and cusp[0] >= values[:, 0].max() - slack
    # Points on both sides of it, i.e. both folds of the loop.
    assert (values[:, 1] > cusp[1] + 0.005).sum() > 5


def _analytic_fold(parameters, low, high):
    """g where the corrected first-order theory's lower and middle fixed points merge (the root
    count of the fixed-point cubic drops from 3 to 1), by bisection; with their mean amplitude
    and phase there."""
    def count(g):
        return len(theory.fixed_points(dict(parameters, g=g)))
    assert count(low) == 3 and count(high) == 1
    for _ in range(60):
        middle = 0.5 * (low + high)
        if count(middle) == 3:
            low = middle
        else:
            high = middle
    three = theory.fixed_points(dict(parameters, g=low))
    return low, 0.5 * (three.R[0] + three.R[1]), 0.5 * (three.theta[0] + three.theta[1])


@pytest.mark.parametrize("scale", [1.0, 0.25])
def test_fold_against_the_corrected_first_order_theory(scale):
    # First-order multiple scales (theory.py, eq2.15-eq2.27) makes an error of second order in
    # the small products of eq2.13-eq2.14, eps = max(gamma/omega, c/omega^2, alpha A^2/omega^2)
    # at the fold's amplitude A: the slow flow is right to O(eps) and its neglected terms are
    # O(eps^2) relative to omega^2. The fold is where the slow flow's fixed points merge, so its
    # detuning eps*sigma = 1 - wt2/omega^2 is off by O(eps^2): |wt2_num - wt2_th| <= eps^2 omega^2
    # (constant 1: the order, not a fit). wt2 (eq2.11) is the same function of g/Omega^2 on
    # both sides, so this holds along the whole fold curve in (g, Omega) (the first test).
    # Smaller gamma and c (scale) shrink eps, and the difference must shrink with it.
    parameters = dict(HYSTERESIS, gamma=0.05 * scale, c=0.04 * scale)
    g_theory, amplitude, phase = _analytic_fold(parameters, 20.0, 30.0)
    omega = parameters["omega"]
    state = np.array([amplitude * np.cos(phase), -amplitude * omega * np.sin(phase)])  # eq2.21 at t = 0
    problem = curves.CurveProblem(dict(parameters), "effective", ("g", "Omega"), SETTINGS, "rk45", dict(OPTIONS))
    point, failure = curves.start_point(problem, "fold", state, [g_theory, parameters["Omega"]], 1)
    assert failure is None, failure
    assert point.impacts_per_period == 0  # the theory ignores the barrier: compare clear of it

    def wt2(g):
        return theory.effective_frequency_squared(dict(parameters, g=g))
    eps = max(parameters["gamma"] / omega, parameters["c"] / omega**2, parameters["alpha"] * amplitude**2 / omega**2)
    difference = abs(wt2(point.values[0]) - wt2(g_theory)) / omega**2
    assert difference <= eps**2, (point.values[0], g_theory, difference, eps**2)
    test_fold_against_the_corrected_first_order_theory.differences[scale] = difference
    if len(test_fold_against_the_corrected_first_order_theory.differences) == 2:
        differences = test_fold_against_the_corrected_first_order_theory.differences
        assert differences[0.25] < differences[1.0]


test_fold_against_the_corrected_first_order_theory.differences = {}

PAPER_EFFECTIVE = dict(DEFAULT_PARAMETERS, Omega=4.0)


@pytest.fixture(scope="module")
def doubling_g_e():
    """The effective model at the paper's parameters: its impacting period-1 orbit from g = 18
    doubles its period; that point followed in (g, e)."""
    settings = settings_vector(rtol=1e-9, atol=1e-11)
    problem = continuation.ContinuationProblem(dict(PAPER_EFFECTIVE, g=18.0), "effective", "g", settings, "rk45",
                                               dict(continuation.DEFAULTS))
    start = continuation.find_start(problem, [0.0, 0.0], 18.0, 100, 16)
    _, bifurcations = continuation.continue_branch(problem, start, 17.8, 18.4, 40)
    doubling = [b.orbit for b in bifurcations if b.kind == "period_doubling"]
    assert len(doubling) == 1
    orbit = doubling[0]
    curve_problem = curves.CurveProblem(dict(PAPER_EFFECTIVE), "effective", ("g", "e"), settings, "rk45",
                                        dict(continuation.DEFAULTS, max_step=0.1))
    point, failure = curves.start_point(curve_problem, "period_doubling", orbit.state, [orbit.parameter, 0.95],
                                        orbit.periods)
    assert failure is None, failure
    curve, specials = curves.continue_curve(curve_problem, "period_doubling", point, ((15.0, 21.0), (0.75, 1.0)), 30)
    return curve_problem, curve, specials


@pytest.mark.slow
def test_period_doubling_curve_points_double_in_one_parameter(doubling_g_e):
    # At fixed e, the orbit at g -/+ 0.01 from the curve (one-parameter Newton from the curve's
    # state) has det(M + I) of opposite signs: a multiplier crosses -1 between them.
    problem, curve, _ = doubling_g_e
    assert len(curve.points) > 3 and all(point.impacts_per_period >= 1 for point in curve.points)
    for point in _sample(curve.points, 3):
        one = problem.one_parameter(point.values[1])
        signs = []
        for g in (point.values[0] - 0.01, point.values[0] + 0.01):
            orbit, failure = continuation.correct(one, np.array([point.state[0], point.state[1], g]), point.periods)
            assert failure is None, failure
            signs.append(np.sign(np.linalg.det(orbit.monodromy + np.eye(2))))
        assert signs[0] * signs[1] < 0, point.values


def test_pairs_the_original_model_cannot_follow_are_refused():
    with pytest.raises(UsageError, match="cannot move in the original model"):
        curves.check_pair(dict(DEFAULT_PARAMETERS, g=20.0), "original", ("g", "Omega"))
    with pytest.raises(UsageError, match="branch's own parameter"):
        curves.check_pair(DEFAULT_PARAMETERS, "effective", ("g", "g"))
    with pytest.raises(UsageError, match="not a parameter"):
        curves.check_pair(DEFAULT_PARAMETERS, "effective", ("g", "beta"))
    curves.check_pair(DEFAULT_PARAMETERS, "original", ("g", "e"))
    curves.check_pair(DEFAULT_PARAMETERS, "effective", ("g", "Omega"))


def test_difference_step_is_the_cube_root_of_the_tolerance():
    assert curves._difference_step(settings_vector(rtol=1e-12, atol=1e-14)) == pytest.approx(1e-4)


@pytest.mark.slow
def test_original_model_fold_curve_in_g_e_is_where_one_parameter_continuation_folds():
    # The original model (fast force kept, Omega/omega = 8): its period-1 orbit with 4 impacts
    # per slow period folds near g = 23.5; the fold followed in the restitution coefficient e.
    parameters = dict(DEFAULT_PARAMETERS, Omega=4.0)
    settings = settings_vector(rtol=1e-9, atol=1e-11)
    options = dict(continuation.DEFAULTS, max_step=0.2)
    one = continuation.ContinuationProblem(dict(parameters, g=24.0), "original", "g", settings, "rk45", options)
    start = continuation.find_start(one, [0.99, 0.5], 24.0, 100, 16)
    _, bifurcations = continuation.continue_branch(one, start, 23.3, 24.5, 40)
    fold = [b.orbit for b in bifurcations if b.kind == "fold"]
    assert len(fold) == 1
    problem = curves.CurveProblem(dict(parameters), "original", ("g", "e"), settings, "rk45", dict(options))
    point, failure = curves.start_point(problem, "fold", fold[0].state, [fold[0].parameter, 0.95], 1)
    assert failure is None, failure
    curve, _ = curves.continue_curve(problem, "fold", point, ((20.0, 27.0), (0.8, 1.0)), 40)
    assert len(curve.points) >= 5 and all(p.impacts_per_period > 0 for p in curve.points)
    for point in _sample(curve.points, 3):
        located = _fold_located_by_one_parameter_continuation(problem, point)
        assert len(located) == 1, (point.values, located)
        assert abs(located[0] - point.values[0]) < 2.0 * _relative_location(problem, point), (point.values, located)


def test_dop853_finds_the_same_fold_curve(hysteresis_bifurcations, fold_g_Omega):
    # Another integrator (its own dense output, error control and monodromy kernel) gives the
    # same curve g = k Omega^2 to the location tolerances of both (3e-5 relative in k each, see
    # test_curves_in_g_Omega_keep_g_over_Omega_squared) plus the integrations' own errors.
    problem, curve, _ = fold_g_Omega
    fold = hysteresis_bifurcations["fold"]
    other = curves.CurveProblem(dict(HYSTERESIS), "effective", ("g", "Omega"), SETTINGS, "dop853", dict(OPTIONS))
    start, failure = curves.start_point(other, "fold", fold.state, [fold.parameter, 4.2], 1)
    assert failure is None, failure
    k_rk45 = np.mean([point.values[0] / point.values[1] ** 2 for point in curve.points])
    assert start.values[0] / start.values[1] ** 2 == pytest.approx(k_rk45, rel=6e-5)


def _analytic_cusp(parameters, low, high):
    """(g, c, amplitude) of the corrected first-order theory's cusp: the fixed-point cubic
    a3 u^3 + a2 u^2 + a1 u + a0 (u = A^2) has a triple root u0 = -a2 / (3 a3). a3, a2, a1 do not
    depend on c, so g solves a2^2 = 3 a1 a3 (bisection), and then a0 = -F^2 = -a3 u0^3 gives
    F = c / omega^2 (eq2.13), i.e. c."""
    def condition(g):
        a3, a2, a1, _ = theory.fixed_point_cubic(dict(parameters, g=g))
        return float(a2 ** 2 - 3.0 * a1 * a3)
    assert condition(low) * condition(high) < 0.0
    for _ in range(80):
        middle = 0.5 * (low + high)
        if condition(low) * condition(middle) <= 0.0:
            high = middle
        else:
            low = middle
    g = 0.5 * (low + high)
    a3, a2, _, _ = theory.fixed_point_cubic(dict(parameters, g=g))
    u0 = float(-a2 / (3.0 * a3))
    return g, float(np.sqrt(a3 * u0 ** 3)) * parameters["omega"] ** 2, np.sqrt(u0)


def test_cusp_against_the_corrected_first_order_theory(fold_g_c):
    # The theory's cusp, where its three fixed points merge, has the same O(eps^2) error in the
    # detuning as its folds (test_fold_against_the_corrected_first_order_theory): |wt2_num -
    # wt2_th| <= eps^2 omega^2 at the cusp's g. Its c follows from F^2 = a3 u0^3, a relation
    # between first-order coefficients (Gamma, Lambda, sigma) that the dropped second-order
    # terms change by a relative O(eps): |c_num - c_th| <= eps c_th. eps as there, at the
    # cusp's amplitude.
    problem, _, specials = fold_g_c
    cusp = [s for s in specials if s.kind == "cusp"][0].values
    parameters = problem.parameters
    g_theory, c_theory, amplitude = _analytic_cusp(parameters, 25.0, 30.0)
    omega = parameters["omega"]
    eps = max(parameters["gamma"] / omega, c_theory / omega**2, parameters["alpha"] * amplitude**2 / omega**2)

    def wt2(g):
        return theory.effective_frequency_squared(dict(parameters, g=g))
    assert abs(wt2(cusp[0]) - wt2(g_theory)) / omega**2 <= eps**2, (cusp, g_theory)
    assert abs(cusp[1] - c_theory) <= eps * c_theory, (cusp, c_theory)
