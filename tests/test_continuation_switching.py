"""Period-doubling branch switching (analysis/period_doubling.py).

The case is the original model at the paper's Fig. 1 parameters (Omega = 4, omega = 0.5), where
the orbit of two slow periods (2.5 impacts per period) that exists near g = 17.86 period-doubles
as g decreases, the first step of a cascade to chaos. Every check is against something the
switching does not compute itself: simulations of the kind sweeps run (their period detection),
SciPy's DOP853 with impact events (tests/reference.py) for the 2p-orbits, and the multipliers'
definition.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from reference import reference_trajectory
from vrsweep.analysis import continuation, period_doubling, switching
from vrsweep.analysis.diagnostics import detect_period
from vrsweep.numerics import kernel
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.trajectory import settings_vector, simulate

FIG1 = dict(DEFAULT_PARAMETERS, Omega=4.0)
# rtol 1e-10 leaves P^4 of these orbits 1e-6 off (fast forcing, 10 impacts, |mu| up to 20): the
# tolerance the Newton tolerance needs is tighter than the effective model's.
SETTINGS = settings_vector(rtol=1e-12, atol=1e-14)
SLOW_PERIOD = 2.0 * math.pi / FIG1["omega"]
LOW, HIGH = 17.8255, 17.87


def _coefficients(g):
    return kernel_coefficients(dict(FIG1, g=g), "original")


@pytest.fixture(scope="module")
def cascade():
    """The period-2 branch over [LOW, HIGH] and the period-4 branch switched at its doubling
    (max_period 4: the period-4 branch's own doubling is located, not switched)."""
    problem = continuation.ContinuationProblem(dict(FIG1, g=17.86), "original", "g", SETTINGS, "rk45",
                                               dict(continuation.DEFAULTS, max_step=0.3))
    start = continuation.find_start(problem, [0.99, 0.5], 17.86, 300, 16)
    branch, bifurcations = continuation.continue_branch(problem, start, LOW, HIGH, 40)
    branches, found, failures = switching.switch_all(problem, branch, bifurcations, LOW, HIGH, 40, 4)
    return problem, branches, found, failures


def _doubling(found, branch=0):
    doublings = [b.orbit for b in found if b.kind == "period_doubling" and b.branch == branch]
    assert doublings, [(b.kind, b.branch) for b in found]
    return doublings[0]


def test_doubling_is_located_with_a_multiplier_at_minus_one(cascade):
    _, branches, found, failures = cascade
    assert branches[0].periods == 2 and not failures
    doubling = _doubling(found)
    assert np.min(np.abs(doubling.multipliers + 1.0)) < 1e-3
    # The orbit is stable on the side of larger g (where the branch starts) and not beyond.
    above = [o for o in branches[0].orbits if o.parameter > doubling.parameter + 1e-4]
    below = [o for o in branches[0].orbits if o.parameter < doubling.parameter - 1e-4]
    assert above and below and all(o.stable for o in above) and not any(o.stable for o in below)


def test_switched_branch_starts_at_the_doubling(cascade):
    problem, branches, found, _ = cascade
    doubling = _doubling(found)
    assert len(branches) == 2
    doubled = branches[1]
    assert doubled.periods == 4 and all(o.periods == 4 for o in doubled.orbits)
    assert doubled.ends["down"][0] == period_doubling.ENDED_PERIOD_DOUBLING
    assert f"{doubling.parameter:.8g}" in doubled.ends["down"][1]
    # The first point is the doubling itself; the first 2p-orbit computed lies within the location
    # tolerance of it in g, and near the p-orbit's state (the switching amplitude is 1e-3 relative).
    first = doubled.orbits[1]
    tolerance = problem.options["location_tolerance"] * max(1.0, doubling.parameter)
    assert doubled.orbits[0].parameter == doubling.parameter
    assert abs(first.parameter - doubling.parameter) <= tolerance
    scale = max(1.0, np.max(np.abs(doubling.state)))
    assert np.max(np.abs(first.state - doubling.state)) < 2e-3 * scale
    # ... and it is a 2p-orbit, not the p-orbit again; so is every point after it.
    threshold = period_doubling.GENUINE_DISTANCE * problem.options["newton_tolerance"] * scale
    for orbit in doubled.orbits[1:]:
        assert period_doubling.distance_from_p_orbit(problem, orbit, 2) > threshold, orbit.parameter


def test_cascade_goes_on_below_the_first_doubling(cascade):
    """The period-4 branch is stable just below the first doubling (a supercritical doubling) and
    doubles again further down."""
    problem, branches, found, _ = cascade
    first, second = _doubling(found, 0), _doubling(found, 1)
    assert second.parameter < first.parameter
    stable = [o for o in branches[1].orbits[1:] if o.stable]
    # Both doublings are located to location_tolerance in g.
    tolerance = problem.options["location_tolerance"] * first.parameter
    assert stable and all(second.parameter - tolerance < o.parameter < first.parameter + tolerance for o in stable)


def _settled_period(g, state, transient, max_period=8):
    """What a sweep point does: the transient from ``state``, then the period found in the
    stroboscopic samples (diagnostics.detect_period). Returns (period, samples (n, 2))."""
    settings = settings_vector(rtol=1e-10, atol=1e-12, transient_periods=transient, measure_periods=32)
    run = simulate(_coefficients(g), state, settings)
    strobe = run.period_records[-32:][:, [kernel.REC_X, kernel.REC_V]]
    period = int(detect_period(strobe[None, :, 0], strobe[None, :, 1], max_period, 1e-6)[0])
    return period, strobe


def _contracting_transient(orbit):
    """Slow periods for the orbit's attraction to shrink a perturbation below 1e-9."""
    contraction = max(np.max(np.abs(orbit.multipliers)), 1e-3)
    return orbit.periods * (int(math.log(1e-9) / math.log(contraction)) + 1)


@pytest.mark.slow
def test_simulations_find_p_above_and_2p_below_the_doubling(cascade):
    """As a down-sweep does: settled on the p-orbit above the doubling, then moved below it, a
    simulation finds period 2p, on the switched branch's orbit."""
    problem, branches, found, _ = cascade
    doubling = _doubling(found)
    # The most strongly attracting stable point of each side (its transient is the shortest).
    p_orbit = min((o for o in branches[0].orbits if o.stable and o.parameter > doubling.parameter),
                  key=lambda o: np.max(np.abs(o.multipliers)))
    doubled = min((o for o in branches[1].orbits[1:] if o.stable), key=lambda o: np.max(np.abs(o.multipliers)))
    period, strobe = _settled_period(p_orbit.parameter, doubling.state, 64 + _contracting_transient(p_orbit))
    assert period == 2
    assert np.min(np.max(np.abs(strobe - p_orbit.state), axis=1)) < 1e-6
    # The down-sweep's next point, below the doubling: the p-orbit is unstable there.
    period, strobe = _settled_period(doubled.parameter, strobe[-1] + [1e-6, 0.0],
                                     200 + _contracting_transient(doubled))
    assert period == 4
    assert np.min(np.max(np.abs(strobe - doubled.state), axis=1)) < 1e-6


def _scipy_periods(g, state, periods):
    """SciPy's stroboscopic samples after 1..periods slow periods from ``state``: (periods, 2)."""
    samples = []
    for k in range(periods):
        run = reference_trajectory(_coefficients(g), state[0], state[1], (k + 1) * SLOW_PERIOD,
                                   t0=k * SLOW_PERIOD, rtol=1e-12, atol=1e-14)
        state = np.array([run["x_final"], run["v_final"]])
        samples.append(state)
    return np.array(samples)


@pytest.mark.slow
def test_sampled_2p_points_are_fixed_points_of_scipys_2p_map_not_of_its_p_map(cascade):
    _, branches, _, _ = cascade
    orbits = branches[1].orbits[1:]  # the first 2p-orbit (next to the doubling) included
    sample = [orbits[i] for i in np.unique(np.linspace(0, len(orbits) - 1, 6).round().astype(int))]
    for orbit in sample:
        samples = _scipy_periods(orbit.parameter, orbit.state, orbit.periods)
        scale = max(1.0, np.max(np.abs(orbit.state)))
        assert np.max(np.abs(samples[-1] - orbit.state)) < 1e-7 * scale, orbit.parameter
        half = orbit.periods // 2
        assert np.max(np.abs(samples[half - 1] - orbit.state)) > 1e-5 * scale, orbit.parameter


def _orbit_with(monodromy):
    return continuation.Orbit(parameter=1.0, state=np.zeros(2), periods=1, monodromy=np.asarray(monodromy, float),
                              R=0.0, Q_amplitude=0.0, impacts_per_period=0.0, x_max=0.0, slowest_impact=np.inf,
                              residual=0.0, newton_iterations=0)


def test_only_a_real_multiplier_near_minus_one_is_switched():
    # det(M + I) changes sign across a graze where M jumps (the effective model's impacting orbit
    # at g = 29.5: mu = 0.53 +/- 0.43i on one side); that is not a period doubling.
    rotation = 0.7 * np.array([[np.cos(0.68), -np.sin(0.68)], [np.sin(0.68), np.cos(0.68)]])
    assert not period_doubling.is_doubling(_orbit_with(rotation))
    assert not period_doubling.is_doubling(_orbit_with([[5.8, 0.0], [0.0, 0.02]]))
    doubling = _orbit_with([[-1.0, 0.3], [0.0, -0.4]])
    assert period_doubling.is_doubling(doubling)
    w, u = period_doubling.doubling_vectors(doubling)
    assert doubling.monodromy @ w == pytest.approx(-w) and u @ doubling.monodromy == pytest.approx(-u)
    assert u @ w == pytest.approx(1.0) and np.linalg.norm(w) == pytest.approx(1.0)


def test_a_step_passes_the_doubling_only_when_its_chord_does():
    point = np.array([0.0, 0.0, 1.0])
    assert period_doubling._passes_by(np.array([-0.1, 0.0, 1.0]), np.array([0.1, 0.0, 1.0]), point)
    # the same sign change of x, a chord's length away from the doubling: not a return
    assert not period_doubling._passes_by(np.array([-0.1, 0.0, 1.2]), np.array([0.1, 0.0, 1.2]), point)


def test_the_pitchfork_at_a_switched_branch_birth_is_no_fold(cascade):
    """M^2 has the multiplier +1 where the 2p-branch is born, so its fold test changes sign there
    (seen from g = 17.8335 with 200 points); only a fold away from the birth is the branch's own."""
    problem, _, found, _ = cascade
    doubling = _doubling(found)
    tolerance = problem.options["location_tolerance"] * doubling.parameter
    birth = SimpleNamespace(parameter=doubling.parameter + 2.0 * tolerance)
    elsewhere = SimpleNamespace(parameter=doubling.parameter - 0.01)
    kept = period_doubling.without_birth_folds(problem, doubling, [("fold", birth), ("fold", elsewhere),
                                                                   ("period_doubling", birth)])
    assert kept == [("fold", elsewhere), ("period_doubling", birth)]
