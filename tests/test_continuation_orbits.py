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
from vrsweep.analysis.diagnostics import detect_period
from vrsweep.errors import VrsweepError
from vrsweep.numerics import kernel
from vrsweep.numerics.model import DEFAULT_PARAMETERS, MU, kernel_coefficients
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


@pytest.fixture(scope="module")
def impacting_branch():
    """The large orbit the down-sweep stays on: one impact per slow period."""
    problem = _problem()
    run = simulate(_coefficients(27.0), [0.0, 0.0], settings_vector(transient_periods=100, measure_periods=5))
    start = continuation.find_start(problem, run.summary[[8, 9]], 24.0, 100, 16)
    branch, bifurcations = continuation.continue_branch(problem, start, 21.0, 27.0, 30)
    return problem, branch, bifurcations


def _coefficients(g):
    return kernel_coefficients(dict(HYSTERESIS, g=g), "effective")


def _sample(orbits, count):
    """About ``count`` orbits spread along the branch, both ends included."""
    index = np.unique(np.linspace(0, len(orbits) - 1, count).round().astype(int))
    return [orbits[i] for i in index]


def _one_period(coefficients, state, k, max_step=np.inf):
    """SciPy's stroboscopic map over the slow period [kT, (k+1)T] (the force is T-periodic)."""
    run = reference_trajectory(coefficients, state[0], state[1], (k + 1) * SLOW_PERIOD, t0=k * SLOW_PERIOD,
                               rtol=1e-12, atol=1e-14, max_step=max_step)
    return np.array([run["x_final"], run["v_final"]]), run


def _resolving_step(orbit):
    """A SciPy step short enough to see the orbit's slowest impact (tests/reference.py). An impact
    at speed u would have flown beyond the barrier for 2 u / a, where a = -x'' at the barrier is
    below 0.3 here (wt2 Delta + alpha Delta^3 + c at g <= 27, eq2.11): a step of u is 6 times
    shorter."""
    return orbit.slowest_impact if orbit.impacts_per_period > 0 else np.inf


def test_branch_has_stable_and_unstable_orbits_and_both_bifurcations(hysteresis_branch):
    _, branch, bifurcations = hysteresis_branch
    stable = [orbit.stable for orbit in branch.orbits]
    assert any(stable) and not all(stable)
    kinds = [b.kind for b in bifurcations]
    assert "fold" in kinds and "neimark_sacker" in kinds


def test_each_located_fold_and_neimark_sacker_point_has_its_multiplier_critical(hysteresis_branch):
    """A located fold has a real multiplier at +1, a Neimark-Sacker point a complex pair on the unit
    circle, each to 1e-3 (continuation.LOCATED_MULTIPLIER), not only its parameter in a bracket."""
    _, _, bifurcations = hysteresis_branch
    for bifurcation in bifurcations:
        mu = bifurcation.orbit.multipliers
        if bifurcation.kind == "fold":
            assert np.min(np.abs(mu - 1.0)) <= 1e-3, mu
        elif bifurcation.kind == "neimark_sacker":
            assert abs(mu[0].imag) > 0 and abs(abs(mu[0]) - 1.0) <= 1e-3, mu


def test_a_bifurcation_whose_multiplier_cannot_be_brought_to_critical_is_recorded_unlocated(monkeypatch):
    """Where the location pins the parameter but not the multiplier (asked here for a distance from
    critical below zero, which no orbit has), the point is not given a location it does not have: it is recorded as unlocated_fold
    and unlocated_neimark_sacker, the step's first orbit its row (as when the corrector fails),
    never as a fold whose multiplier is elsewhere. Up to 0.7.2 a bracket in the parameter alone
    made a point located, whatever its multiplier (-0.989 for a period doubling at g = 17.799 on
    Fig. 1's period-3 branch)."""
    monkeypatch.setattr(continuation, "LOCATED_MULTIPLIER", -1.0, raising=False)
    problem = _problem()
    start = continuation.find_start(problem, [0.0, 0.0], 23.0, 200, 16)
    branch, bifurcations = continuation.continue_branch(problem, start, 21.0, 27.0, 120)
    kinds = sorted(b.kind for b in bifurcations)
    assert "fold" not in kinds and "neimark_sacker" not in kinds, kinds
    assert "unlocated_fold" in kinds and "unlocated_neimark_sacker" in kinds, kinds
    parameters = [orbit.parameter for orbit in branch.orbits]
    assert all(b.orbit.parameter in parameters for b in bifurcations if b.kind.startswith("unlocated_"))


def test_a_branch_ends_with_its_orbits_at_both_ends_of_a_narrow_range():
    """continuation.to = [22.99, 23.01] around the start at 23: the first step (initial_step 0.05)
    leaves the range both ways, and up to 0.7.2 the branch was its start alone, "left_range".
    It now ends at the orbits at g = 22.99 and 23.01 exactly, each a fixed point of SciPy's map."""
    problem = _problem()
    start = continuation.find_start(problem, [0.0, 0.0], 23.0, 200, 16)
    branch, _ = continuation.continue_branch(problem, start, 22.99, 23.01, 20)
    assert [orbit.parameter for orbit in (branch.orbits[0], branch.orbits[-1])] == [22.99, 23.01]
    assert [status for status, _ in branch.ends.values()] == ["left_range", "left_range"]
    assert "g reached the end of [22.99, 23.01] at g = 23.01" in branch.ends["up"][1]
    for orbit in (branch.orbits[0], branch.orbits[-1]):
        state, _ = _one_period(_coefficients(orbit.parameter), orbit.state, 0, _resolving_step(orbit))
        assert np.max(np.abs(state - orbit.state)) < 1e-7 * max(1.0, np.max(np.abs(orbit.state)))
    # a start at an end of the range is that end's orbit: nothing more is looked for there
    branch, _ = continuation.continue_branch(problem, start, 23.0, 23.2, 20)
    assert branch.orbits[0] is start and branch.orbits[-1].parameter == 23.2
    assert branch.ends["down"] == ("left_range", "g reached the end of [23, 23.2] at g = 23")


@pytest.mark.slow
def test_every_sampled_point_is_a_fixed_point_of_scipys_map(hysteresis_branch, impacting_branch):
    _, branch, bifurcations = hysteresis_branch
    orbits = _sample(branch.orbits, 8) + [b.orbit for b in bifurcations] + _sample(impacting_branch[1].orbits, 3)
    assert any(orbit.impacts_per_period > 0 for orbit in orbits)
    for orbit in orbits:
        state = orbit.state
        for k in range(orbit.periods):
            state, _ = _one_period(_coefficients(orbit.parameter), state, k, _resolving_step(orbit))
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


def _away_from_grazing(orbits):
    """The orbits where central differences of step 1e-6 measure the monodromy: next to a graze
    the map has a square-root term in the penetration sigma = u^2 / (2 a) >= u^2 / 0.6 (u the slowest
    impact, a as in _resolving_step), whose differences are off by (1e-6 / sigma)^2 relative;
    u > 0.05 keeps that below 1e-7. A free orbit 1e-3 below the barrier stays free under them."""
    return [o for o in orbits if (o.slowest_impact > 0.05 if o.impacts_per_period > 0
                                  else o.x_max < HYSTERESIS["Delta"] - 1e-3)]


@pytest.mark.slow
def test_multipliers_match_scipy_central_differences(hysteresis_branch, impacting_branch):
    # The impacting orbits check the saltation matrix too: the unstable ones beyond the graze
    # (|mu| up to 5 here) and the stable ones of the down-sweep.
    free = [o for o in _away_from_grazing(hysteresis_branch[1].orbits) if o.impacts_per_period == 0]
    beyond = [o for o in _away_from_grazing(hysteresis_branch[1].orbits) if o.impacts_per_period > 0]
    assert beyond, "the branch did not cross its graze"
    for orbit in _sample(free, 3) + _sample(beyond, 2) + _sample(impacting_branch[1].orbits, 2):
        reference = np.sort_complex(np.linalg.eigvals(_scipy_monodromy(orbit)))
        computed = np.sort_complex(orbit.multipliers)
        scale = max(1.0, np.max(np.abs(computed)))
        assert np.max(np.abs(reference - computed)) < 1e-6 * scale, (orbit.parameter, reference, computed)


def _liouville_determinant(orbit):
    """exp(-int gamma (x^2 - mu) dt) over the orbit, times e^2 per impact (det of the saltation)."""
    coefficients = _coefficients(orbit.parameter)
    gamma, mu = HYSTERESIS["gamma"], coefficients[MU]
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
def test_product_of_multipliers_obeys_liouville(hysteresis_branch, impacting_branch):
    for orbit in _sample(hysteresis_branch[1].orbits, 3) + _sample(impacting_branch[1].orbits, 2):
        product = np.prod(orbit.multipliers).real
        assert product == pytest.approx(_liouville_determinant(orbit), rel=1e-7), orbit.parameter


def _sweep(values, state, transient=100, measure=100, rtol=1e-10, atol=1e-12):
    """What `vrsweep run` does along an axis with `continuation`: each point starts from the
    previous one's final state. Returns (R, impacts per period, final states)."""
    settings = settings_vector(rtol=rtol, atol=atol, transient_periods=transient, measure_periods=measure)
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
def test_stable_points_equal_long_simulations_on_both_sides_of_the_loop(hysteresis_branch, impacting_branch):
    large_start = simulate(_coefficients(27.0), [0.0, 0.0], settings_vector(transient_periods=100,
                                                                             measure_periods=5)).summary[[8, 9]]
    # The up-sweep of configs/hysteresis_effective.yaml: from rest at g = 21, each point from the last.
    small_start = _sweep(GRID[GRID < 24.5], [0.0, 0.0])[2][-1]
    for (problem, branch, _), start, g in ((hysteresis_branch, small_start, 24.5),
                                           (impacting_branch, large_start, 24.5),
                                           (impacting_branch, large_start, 23.0)):
        orbit = _orbit_at(problem, branch, g)
        assert orbit.stable
        # The up-sweep lands on the small orbit, the down-sweep from g = 27 on the impacting
        # one; the last transient is long enough for |mu|^n < 1e-9.
        contraction = np.max(np.abs(orbit.multipliers))
        transient = int(math.log(1e-9) / math.log(contraction)) + 1
        gains, impacts, _ = _sweep([g], start, transient=transient, measure=20)
        assert impacts[0] == orbit.impacts_per_period
        assert gains[0] == pytest.approx(orbit.R, rel=1e-6)


@pytest.mark.slow
def test_fold_lies_where_the_up_sweep_jumps(hysteresis_branch):
    """The up-sweep of configs/hysteresis_effective.yaml (from rest at g = 21, each point from the
    last, 100 + 100 periods) leaves the small orbit at the first grid point past its end: the
    located fold is within one grid step of that jump."""
    _, _, bifurcations = hysteresis_branch
    folds = [b.orbit.parameter for b in bifurcations if b.kind == "fold"]
    _, impacts, _ = _sweep(GRID, [0.0, 0.0])
    jumped = int(np.argmax(impacts > 0))  # the small orbit never impacts, the large one does
    assert impacts[jumped] > 0 and np.all(impacts[:jumped] == 0)
    grid_step = GRID[1] - GRID[0]
    assert any(abs(GRID[jumped] - fold) <= grid_step for fold in folds), (folds, GRID[jumped])


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
def test_dop853_branch_points_are_fixed_points():
    problem = _problem("dop853")
    start = continuation.find_start(problem, [0.0, 0.0], 24.0, 200, 16)
    branch, _ = continuation.continue_branch(problem, start, 23.5, 24.5, 10)
    for orbit in _sample(branch.orbits, 3):
        state, _ = _one_period(_coefficients(orbit.parameter), orbit.state, 0)
        assert np.max(np.abs(state - orbit.state)) < 1e-7


@pytest.mark.parametrize("g", [5.0, 0.0])
def test_the_forcing_rule_is_decided_from_the_values_continued(g):
    """Issue 35: Omega/omega = 8.6 was refused when parameters.g was set and ran (a period-15 branch)
    when g was continued from the config's default 0. Now both are the forcing of the values
    continued: p/q with q within max_period repeats after q slow periods (accepted, orbits of
    multiples of q), anything else never does (refused), whatever parameters.g says."""
    parameters = dict(DEFAULT_PARAMETERS, g=g)
    assert continuation.check_commensurate(dict(parameters, Omega=4.3), "original", "g") == 5  # 8.6 = 43/5
    assert continuation.check_commensurate(dict(parameters, Omega=4.0), "original", "g") == 1  # 8
    with pytest.raises(VrsweepError, match=r"Omega/omega = 8.6002 is not a ratio p/q of whole numbers with q at "
                                           r"most continuation.max_period = 16"):
        continuation.check_commensurate(dict(parameters, Omega=4.3001), "original", "g")
    with pytest.raises(VrsweepError, match="q at most continuation.max_period = 4"):
        continuation.check_commensurate(dict(parameters, Omega=4.3), "original", "g", max_period=4)
    # without a fast force anywhere (g = 0, not continued) there is nothing to repeat
    assert continuation.check_commensurate(dict(DEFAULT_PARAMETERS, g=0.0, Omega=4.3001), "original", "e") == 1


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


# --- grazing ----------------------------------------------------------------------------------
def _free_maximum(coefficients, state, periods):
    """SciPy's largest x over the orbit without the barrier (Delta moved out of reach)."""
    free = np.array(coefficients, dtype=float)
    free[8] = 1e3
    run = reference_trajectory(free, state[0], state[1], periods * SLOW_PERIOD, rtol=1e-12, atol=1e-14)
    t = np.linspace(0.0, periods * SLOW_PERIOD, 200001)
    x = run["sol"](t)[0]
    k = int(np.argmax(x))
    # Refine the sampled maximum by the parabola through its neighbours (spacing 6e-5: its error
    # is far below the 1e-9 asked).
    x0, x1, x2 = x[k - 1], x[k], x[k + 1]
    return x1 + 0.125 * (x0 - x2) ** 2 / (2.0 * x1 - x0 - x2)


def _graze_neighbours(branch, graze):
    """The branch's orbits on either side of the graze: (last free one, first impacting one)."""
    index = min(range(len(branch.orbits)), key=lambda i: abs(branch.orbits[i].parameter - graze.parameter))
    window = branch.orbits[max(index - 3, 0):index + 4]
    free = [o for o in window if o.impacts_per_period == 0]
    impacting = [o for o in window if o.impacts_per_period > 0]
    return (min(free, key=lambda o: abs(o.parameter - graze.parameter)),
            min(impacting, key=lambda o: abs(o.parameter - graze.parameter)))


@pytest.mark.slow
def test_the_branch_crosses_its_graze_onto_impacting_orbits(hysteresis_branch):
    """The unstable orbit beyond the fold grows until it touches the barrier; the branch goes on
    through the graze onto the unstable orbits that hit it once per period (continuation.py,
    grazing.py). Checked by SciPy: the grazing orbit's free maximum is Delta, and next to it the
    free neighbour has no impact and the impacting one has one per period."""
    _, branch, bifurcations = hysteresis_branch
    grazes = [b.orbit for b in bifurcations if b.kind == "grazing"]
    assert len(grazes) == 1
    graze = grazes[0]
    assert _free_maximum(_coefficients(graze.parameter), graze.state, graze.periods) == pytest.approx(
        HYSTERESIS["Delta"], abs=1e-8)
    free, impacting = _graze_neighbours(branch, graze)
    for orbit, impacts in ((free, 0), (impacting, 1)):
        state, run = _one_period(_coefficients(orbit.parameter), orbit.state, 0, _resolving_step(orbit))
        assert len(run["impact_times"]) == impacts, (orbit.parameter, impacts)
        assert np.max(np.abs(state - orbit.state)) < 1e-7 * max(1.0, np.max(np.abs(orbit.state)))
    # The free unstable orbit exists above the graze only (it is born at the fold above), the
    # impacting one below: the branch turns back at the graze no more than the normal form says.
    assert free.parameter > graze.parameter > impacting.parameter
    assert branch.ends["up"][0] == continuation.ENDED_RANGE


@pytest.mark.slow
def test_the_graze_is_found_alike_from_the_impacting_side(hysteresis_branch):
    """Followed the other way, from an impacting orbit towards its graze, the branch locates the
    same grazing orbit and goes on onto the free one."""
    problem, branch, bifurcations = hysteresis_branch
    graze = next(b.orbit for b in bifurcations if b.kind == "grazing")
    start = next(o for o in branch.orbits if o.impacts_per_period > 0 and o.parameter < graze.parameter - 1.0)
    orbits, found, _ = continuation.follow(problem, start, +1, 21.0, 27.0, 25)
    reverse = [orbit for kind, orbit in found if kind == "grazing"]
    assert len(reverse) == 1
    tolerance = problem.options["location_tolerance"] * graze.parameter
    assert reverse[0].parameter == pytest.approx(graze.parameter, abs=tolerance)
    assert any(o.impacts_per_period == 0 and o.parameter > graze.parameter for o in orbits)


@pytest.mark.slow
def test_dop853_crosses_the_same_graze(hysteresis_branch):
    """The crossing with the other method: from the small orbit at g = 25 up through the fold and
    back through the graze. SciPy's free orbit from dop853's grazing point reaches Delta, and
    SciPy sees no impact on its free neighbour and one on its impacting one."""
    _, branch, _ = hysteresis_branch
    problem = _problem("dop853")
    nearest = min((o for o in branch.orbits if o.stable), key=lambda o: abs(o.parameter - 25.0))
    start, failure = continuation.correct(problem, np.array([*nearest.state, 25.0]), 1)
    assert failure is None, failure
    crossed, bifurcations = continuation.continue_branch(problem, start, 24.8, 25.5, 60)
    grazes = [b.orbit for b in bifurcations if b.kind == "grazing"]
    assert len(grazes) == 1, crossed.ends
    graze = grazes[0]
    assert _free_maximum(_coefficients(graze.parameter), graze.state, 1) == pytest.approx(HYSTERESIS["Delta"], abs=1e-8)
    free, impacting = _graze_neighbours(crossed, graze)
    for orbit, impacts in ((free, 0), (impacting, 1)):
        _, run = _one_period(_coefficients(orbit.parameter), orbit.state, 0, _resolving_step(orbit))
        assert len(run["impact_times"]) == impacts, (orbit.parameter, impacts)


@pytest.mark.slow
def test_fold_lies_where_a_down_sweep_jumps_in_the_original_model():
    """The other side of a hysteresis loop: in the original model at Fig. 1's parameters the
    orbit of three slow periods is born at a fold near g = 6.24 (the left end of Fig. 1's
    period-3 window). A down-sweep along it (each point from the last, as `continuation: down`)
    leaves it at the first grid point past the fold: within one grid step of the located fold.
    (The hysteresis example's impacting branch, the down-sweep's there, has no fold above
    g = 10.3, out of that sweep's reach.)"""
    parameters = dict(DEFAULT_PARAMETERS, Omega=4.0)
    settings = settings_vector(rtol=1e-12, atol=1e-14)
    problem = continuation.ContinuationProblem(dict(parameters, g=6.5), "original", "g", settings, "rk45",
                                               dict(continuation.DEFAULTS, max_step=0.05))
    start = continuation.find_start(problem, [0.99, 0.5], 6.5, 100, 8)
    assert start.periods == 3
    _, bifurcations = continuation.continue_branch(problem, start, 6.0, 6.6, 16)
    folds = [b.orbit.parameter for b in bifurcations if b.kind == "fold"]
    assert folds
    grid = np.arange(6.5, 5.99, -0.05)
    state, periods = start.state, []
    sweep_settings = settings_vector(rtol=1e-10, atol=1e-12, transient_periods=100, measure_periods=48)
    for g in grid:
        run = simulate(kernel_coefficients(dict(parameters, g=g), "original"), state, sweep_settings)
        state = run.summary[[8, 9]]
        strobe = run.period_records[-48:]
        periods.append(int(detect_period(strobe[None, :, kernel.REC_X], strobe[None, :, kernel.REC_V], 8, 1e-6)[0]))
    periods = np.array(periods)
    jumped = int(np.argmax(periods != 3))
    assert periods[jumped] != 3 and np.all(periods[:jumped] == 3), periods
    assert any(abs(grid[jumped] - fold) <= 0.05 + 1e-12 for fold in folds), (folds, grid[jumped])


def test_a_fold_that_cannot_be_located_is_recorded_with_its_bracket_not_dropped(monkeypatch, tmp_path):
    """Where the corrector fails at the first point of a fold's location, the fold was dropped
    without a word (as a graze not located was until 0.7.2): no row in the table, nothing on the
    figure. It is now an unlocated_fold (tag F?1), its orbit the step's first one; info names the
    bracket (two orbits of the branch), whose ends have multipliers on either side of +1 and
    between which lies the fold that the same run locates when the corrector does not fail."""
    from click.testing import CliRunner

    import vrsweep
    from vrsweep.cli import main

    def follow(name):
        out = tmp_path / f"{name}.h5"
        result = CliRunner().invoke(main, ["continue", "configs/continuation_hysteresis.yaml", "-o", str(out), "-q",
                                           "--set", "continuation.to=22.5,27"])
        assert result.exit_code == 0, result.output
        return out

    located = follow("located")
    with vrsweep.open_results(located) as ds:
        kinds = [str(kind) for kind in ds["bifurcation_kind"].values]
        fold = float(ds["bifurcation_x"].values[kinds.index("fold")])
    locate = continuation._locate
    monkeypatch.setattr(continuation, "_locate", lambda *args: None if args[4] == "fold" else locate(*args))
    unlocated = follow("unlocated")
    with vrsweep.open_results(unlocated) as ds:
        kinds = [str(kind) for kind in ds["bifurcation_kind"].values]
        assert "fold" not in kinds and kinds.count("unlocated_fold") == 1, kinds
        at = float(ds["bifurcation_parameter"].values[kinds.index("unlocated_fold")])
        parameter = ds["parameter"].values
        k = int(np.flatnonzero(parameter == at)[0])
        mu = ds["multiplier_real"].values + 1j * ds["multiplier_imag"].values
        x = ds["x"].values
    info = CliRunner().invoke(main, ["info", str(unlocated)])
    assert info.exit_code == 0, info.output
    line = next(line for line in info.output.splitlines() if "unlocated_fold" in line)
    assert "F?1" in line and "fold test function changes sign between the branch's orbits at g = " in line, line
    other = float(line.split(" and ")[1].split(",")[0])
    j = int(np.argmin(np.abs(parameter - other)))  # info prints 8 digits
    assert abs(j - k) == 1 and abs(parameter[j] - other) < 1e-6 * abs(other)
    # a multiplier passes +1 across the bracket: det(M - I) changes sign
    assert ((1 - mu[k, 0]) * (1 - mu[k, 1])).real * ((1 - mu[j, 0]) * (1 - mu[j, 1])).real < 0
    # g turns at the fold, x goes on: the located fold's x lies between the bracket's
    assert min(x[k], x[j]) < fold < max(x[k], x[j])
    figure = CliRunner().invoke(main, ["plot", str(unlocated), "-o", str(tmp_path / "branch.png")])
    assert figure.exit_code == 0, figure.output
    curve = CliRunner().invoke(main, ["continue", str(unlocated), "--point", str(kinds.index("unlocated_fold")),
                                      "--along", "Omega", "--to", "3.9", "4.1", "-o", str(tmp_path / "curve.h5")])
    assert curve.exit_code == 2 and "unlocated_fold point: it was not located" in curve.output, curve.output
    assert len(curve.output.strip().splitlines()) == 1



def test_a_sticking_orbit_ends_a_branch_saying_it_is_not_followed_not_that_it_is_singular():
    """A plastic stop's orbit (r = 0) rests on the barrier: continuation ended it saying "its
    monodromy is singular there", which sent a researcher looking for a defect in a valid orbit."""
    from types import SimpleNamespace

    from vrsweep.results import Status

    status, reason = continuation._failure(SimpleNamespace(status=Status.OK, stuck_time=0.3))
    assert status == continuation.ENDED_STICKING == "sticking"
    assert "sticks to the barrier" in reason and "follows only orbits that do not stick" in reason
    assert "singular" not in reason
    assert continuation._failure(SimpleNamespace(status=Status.OK, stuck_time=0.0)) is None


def test_a_hop_onto_another_family_at_the_smallest_step_ends_the_branch_saying_so(monkeypatch):
    """A step whose orbit reverses the null vector of [M - I | F_lam] with its fold test changing
    sign (continuation._flips) hopped onto another family; retried shorter down to min_step, it
    was then taken, recorded as an unlocated fold and period doubling, and the branch went on along
    both families in turn (Fig. 1's period-12 branch beyond g = 17.793242, six such pairs, where
    the other family lies 2e-6 away). Now the branch ends there with a reason that says so. The
    hop is staged here at the hysteresis example's fold (g = 25.2675): every step over it is
    taken for a hop."""
    flips = continuation._flips
    monkeypatch.setattr(continuation, "_flips", lambda previous, orbit, tangent: flips(previous, orbit, tangent) or (
        continuation._fold_test(previous) * continuation._fold_test(orbit) < 0.0))
    problem = _problem()
    start = continuation.find_start(problem, [0.0, 0.0], 23.0, 200, 16)
    orbits, found, (status, reason) = continuation.follow(problem, start, +1, 20.0, 27.0, 200)
    assert status == continuation.ENDED_NEWTON and "hopping onto another family" in reason, (status, reason)
    assert "min_step = 1e-05" in reason and "smaller continuation.min_step" in reason
    assert not [kind for kind, _ in found if "fold" in kind], found  # no hop recorded as a fold
    assert abs(orbits[-1].parameter - 25.2675) < 1e-3, orbits[-1].parameter


def test_a_branch_whose_corrector_fails_down_to_min_step_names_the_lever(monkeypatch):
    """A branch that ends newton_failed with the smallest step said only where: Fig. 1's bubble of
    six periods ends so 1e-5 short of its other doubling, which continuation.min_step = 1e-6
    reaches. The reason now names min_step and its value, so a reader knows what to try."""
    correct = continuation.correct

    def failing_beyond(problem, z_guess, *args, **kwargs):
        if z_guess[2] > 23.2:  # an orbit the corrector cannot reach, as at a steep curl
            return None, (continuation.ENDED_NEWTON, "Newton did not converge in 8 iterations (residual 0.1)")
        return correct(problem, z_guess, *args, **kwargs)

    monkeypatch.setattr(continuation, "correct", failing_beyond)
    problem = _problem(min_step=1e-4)
    start = continuation.find_start(problem, [0.0, 0.0], 23.0, 200, 16)
    branch, _ = continuation.continue_branch(problem, start, 22.9, 23.5, 50)
    status, reason = branch.ends["up"]
    assert status == "newton_failed", branch.ends
    assert "with the smallest step" in reason and "a smaller continuation.min_step (now 0.0001)" in reason, reason
    assert branch.orbits[-1].parameter <= 23.2 < branch.orbits[-1].parameter + 1e-3, branch.orbits[-1].parameter
