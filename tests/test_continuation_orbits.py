"""Continuation of periodic orbits (analysis/continuation.py, numerics/shooting.py).

Every check is against something independent of the kernel: SciPy's DOP853 with impact events
(tests/reference.py) for the fixed points and the monodromy, Liouville's formula for the product
of the multipliers, and simulations of the kind sweeps run for the stable branch and the folds.
The case is the README's hysteresis example (effective model, gamma = alpha = 0.05, Omega = 4),
followed in g: its small orbit, the Neimark-Sacker point where it is born, its fold, the unstable
orbit beyond, and the grazing where that orbit starts to hit the barrier.
"""

import math

import numpy as np
import pytest
from scipy.integrate import simpson

from reference import reference_trajectory
from vrsweep.analysis import continuation
from vrsweep.errors import VrsweepError
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.trajectory import settings_vector, simulate

HYSTERESIS = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, Omega=4.0)
SETTINGS = settings_vector(rtol=1e-10, atol=1e-12)
SLOW_PERIOD = 2.0 * math.pi / HYSTERESIS["omega"]
# The sweep grid of configs/hysteresis_effective.yaml: g from 21 to 27 in 25 points.
GRID = np.linspace(21.0, 27.0, 25)


def _problem(method="rk45", **options):
    return continuation.ContinuationProblem(dict(HYSTERESIS, g=23.0), "effective", "g", SETTINGS, method,
                                            dict(continuation.DEFAULTS, max_step=0.3, **options))


@pytest.fixture(scope="module")
def hysteresis_branch():
    problem = _problem()
    start = continuation.find_start(problem, [0.0, 0.0], 23.0, 200, 16)
    branch, bifurcations = continuation.continue_branch(problem, start, 21.0, 27.0, 120)
    return problem, branch, bifurcations


def _coefficients(g):
    return kernel_coefficients(dict(HYSTERESIS, g=g), "effective")


def _sample(orbits, count):
    """About ``count`` orbits spread along the branch, both ends included."""
    index = np.unique(np.linspace(0, len(orbits) - 1, count).round().astype(int))
    return [orbits[i] for i in index]


def _one_period(coefficients, state, k):
    """SciPy's stroboscopic map over the slow period [kT, (k+1)T] (the force is T-periodic)."""
    run = reference_trajectory(coefficients, state[0], state[1], (k + 1) * SLOW_PERIOD, t0=k * SLOW_PERIOD,
                               rtol=1e-12, atol=1e-14)
    return np.array([run["x_final"], run["v_final"]]), run


def test_branch_has_stable_and_unstable_orbits_and_both_bifurcations(hysteresis_branch):
    _, branch, bifurcations = hysteresis_branch
    stable = [orbit.stable for orbit in branch.orbits]
    assert any(stable) and not all(stable)
    kinds = [b.kind for b in bifurcations]
    assert "fold" in kinds and "neimark_sacker" in kinds


@pytest.mark.slow
def test_every_sampled_point_is_a_fixed_point_of_scipys_map(hysteresis_branch):
    _, branch, bifurcations = hysteresis_branch
    for orbit in _sample(branch.orbits, 8) + [b.orbit for b in bifurcations]:
        state = orbit.state
        for k in range(orbit.periods):
            state, _ = _one_period(_coefficients(orbit.parameter), state, k)
        scale = max(1.0, np.max(np.abs(orbit.state)))
        assert np.max(np.abs(state - orbit.state)) < 1e-7 * scale, (orbit.parameter, orbit.stable)


def _scipy_monodromy(orbit, step=1e-6):
    """Product of central-difference Jacobians of SciPy's one-period maps along the orbit."""
    coefficients = _coefficients(orbit.parameter)
    monodromy = np.eye(2)
    state = orbit.state
    for k in range(orbit.periods):
        jacobian = np.empty((2, 2))
        for j in range(2):
            shift = np.zeros(2)
            shift[j] = step
            jacobian[:, j] = (_one_period(coefficients, state + shift, k)[0]
                              - _one_period(coefficients, state - shift, k)[0]) / (2.0 * step)
        monodromy = jacobian @ monodromy
        state = _one_period(coefficients, state, k)[0]
    return monodromy


@pytest.mark.slow
def test_multipliers_match_scipy_central_differences(hysteresis_branch):
    _, branch, _ = hysteresis_branch
    for orbit in _sample(branch.orbits, 4):
        reference = np.sort_complex(np.linalg.eigvals(_scipy_monodromy(orbit)))
        computed = np.sort_complex(orbit.multipliers)
        assert np.max(np.abs(reference - computed)) < 1e-6, (orbit.parameter, reference, computed)


def _liouville_determinant(orbit):
    """exp(-int gamma (x^2 - mu) dt) over the orbit, times e^2 per impact (det of the saltation)."""
    coefficients = _coefficients(orbit.parameter)
    gamma, mu = HYSTERESIS["gamma"], coefficients[1]
    log_det, impacts = 0.0, 0
    state = orbit.state
    for k in range(orbit.periods):
        state, run = _one_period(coefficients, state, k)
        solution = run["sol"]
        impacts += len(run["impact_times"])
        for t_start, t_end, _ in solution.segments:
            t = np.linspace(t_start, t_end, 4001)
            x = solution(t)[0]
            log_det += -gamma * simpson(x * x - mu, x=t)
    return math.exp(log_det) * HYSTERESIS["e"] ** (2 * impacts)


@pytest.mark.slow
def test_product_of_multipliers_obeys_liouville(hysteresis_branch):
    _, branch, _ = hysteresis_branch
    for orbit in _sample(branch.orbits, 4):
        product = np.prod(orbit.multipliers).real
        assert product == pytest.approx(_liouville_determinant(orbit), rel=1e-7), orbit.parameter


def _sweep(values, state, transient=100, measure=100):
    """What `vrsweep run` does along an axis with `continuation`: each point starts from the
    previous one's final state. Returns (R, impacts per period, final states)."""
    settings = settings_vector(rtol=1e-10, atol=1e-12, transient_periods=transient, measure_periods=measure)
    gains, impacts, finals = [], [], []
    for g in values:
        run = simulate(_coefficients(g), state, settings)
        state = run.summary[[8, 9]]
        gains.append(run.summary[0])
        impacts.append(run.summary[4])
        finals.append(state)
    return np.array(gains), np.array(impacts), finals


def _orbit_at(problem, branch, g, stable=True):
    """The branch's orbit at exactly g (fixed-parameter Newton from the nearest point)."""
    candidates = [o for o in branch.orbits if o.stable == stable]
    nearest = min(candidates, key=lambda o: abs(o.parameter - g))
    orbit, failure = continuation.correct(problem, np.array([nearest.state[0], nearest.state[1], g]),
                                          nearest.periods)
    assert failure is None, failure
    return orbit


@pytest.mark.slow
def test_stable_points_equal_long_simulations(hysteresis_branch):
    problem, branch, _ = hysteresis_branch
    for g in (23.5, 24.5):
        orbit = _orbit_at(problem, branch, g)
        assert orbit.stable
        # From rest, the up-sweep's side of the loop: transient long enough for |mu|^n < 1e-9.
        contraction = np.max(np.abs(orbit.multipliers))
        transient = int(math.log(1e-9) / math.log(contraction)) + 1
        gains, _, _ = _sweep([g], [0.0, 0.0], transient=transient, measure=20)
        assert gains[0] == pytest.approx(orbit.R, rel=1e-6)


@pytest.mark.slow
def test_fold_lies_where_the_up_sweep_jumps(hysteresis_branch):
    _, _, bifurcations = hysteresis_branch
    folds = [b.orbit.parameter for b in bifurcations if b.kind == "fold"]
    up = GRID[GRID >= 22.0]
    gains, _, _ = _sweep(up, [0.0, 0.0], transient=300, measure=20)
    jump = int(np.argmax(np.diff(gains) > 3.0))  # the small orbit's gain is < 20, the impacting one's ~24
    assert np.diff(gains)[jump] > 3.0
    assert any(up[jump] <= fold <= up[jump + 1] for fold in folds), (folds, up[jump])


def test_neimark_sacker_point_has_a_unit_complex_pair(hysteresis_branch):
    _, _, bifurcations = hysteresis_branch
    torus = [b.orbit for b in bifurcations if b.kind == "neimark_sacker"]
    assert torus
    multipliers = torus[0].multipliers
    assert abs(multipliers[0].imag) > 0.1
    assert np.abs(multipliers) == pytest.approx([1.0, 1.0], abs=1e-5)


def test_fold_has_a_unit_real_multiplier(hysteresis_branch):
    _, _, bifurcations = hysteresis_branch
    fold = [b.orbit for b in bifurcations if b.kind == "fold"][0]
    assert np.min(np.abs(fold.multipliers - 1.0)) < 1e-5


@pytest.mark.slow
def test_grazing_separates_impacting_and_free_orbits(hysteresis_branch):
    problem, branch, bifurcations = hysteresis_branch
    grazings = [b.orbit for b in bifurcations if b.kind == "grazing"]
    assert grazings, branch.ends
    graze = grazings[0]
    counts = []
    for shift in (-1e-3, 1e-3):
        nearest = min(branch.orbits, key=lambda o: abs(o.parameter - (graze.parameter + shift)))
        counts.append(nearest.impacts_per_period)
        # SciPy from the branch point: its impacts in one period are the orbit's.
        _, run = _one_period(_coefficients(nearest.parameter), nearest.state, 0)
        assert len(run["impact_times"]) == nearest.impacts_per_period * nearest.periods
    assert min(counts) == 0 and max(counts) >= 1


@pytest.mark.slow
def test_dop853_branch_points_are_fixed_points():
    problem = _problem("dop853")
    start = continuation.find_start(problem, [0.0, 0.0], 24.0, 200, 16)
    branch, _ = continuation.continue_branch(problem, start, 23.5, 24.5, 10)
    for orbit in _sample(branch.orbits, 3):
        state, _ = _one_period(_coefficients(orbit.parameter), orbit.state, 0)
        assert np.max(np.abs(state - orbit.state)) < 1e-7


def test_original_model_refuses_an_incommensurate_forcing():
    with pytest.raises(VrsweepError, match="not a whole number"):
        continuation.check_commensurate(dict(DEFAULT_PARAMETERS, g=5.0, Omega=4.3), "original", "g")


def test_original_model_refuses_omega_as_the_parameter():
    for name in ("Omega", "omega"):
        with pytest.raises(VrsweepError, match="effective model"):
            continuation.check_commensurate(dict(DEFAULT_PARAMETERS, g=5.0), "original", name)
    continuation.check_commensurate(dict(HYSTERESIS, g=5.0, Omega=4.3), "effective", "Omega")


@pytest.mark.slow
def test_chaotic_start_is_a_clear_error():
    # The original model at g = 5, Omega = 4 is chaotic (tests/reference.py: tolerance-dependent R).
    problem = continuation.ContinuationProblem(dict(DEFAULT_PARAMETERS, g=5.0), "original", "g",
                                               settings_vector(), "rk45", dict(continuation.DEFAULTS))
    with pytest.raises(VrsweepError, match="no periodic orbit"):
        continuation.find_start(problem, [0.99, 0.5], 5.0, 100, 8)
