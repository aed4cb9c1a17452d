"""Branches across grazes where the map beyond is steep (issue 32, item 3).

Beyond a graze the new impact's speed u grows like the square root of the distance, and the
impacting map has a multiplier of order 1/u: Newton on the map alone diverged from every
predictor at three grazes of the original model, and the branches ended there ("no impacting
orbit converged beyond the graze"):

- Fig. 1 (Omega = 4), the period-2 branch from g = 17.86 up, graze at g = 17.8973;
- its period-4 branch (stable between 17.8324 and 17.8330) down, graze at g = 17.8275;
- Omega = 5, the period-1 branch from g = 50 down, graze at g = 45.12196.

vrsweep now follows the branch beyond in u itself (continuation.march_in_speed,
grazing.correct_at_speed). Each test follows the branch across and checks, with SciPy's DOP853 and
impact events (tests/reference.py), the first orbit beyond (the slowest new impact, the steepest
map) and the last one of the march: each returns to itself after its periods, and SciPy counts one
impact more than on the orbit before the graze. With multipliers up to 1.4e4 a state error of
the solvers' size is amplified by |mu| in one pass, in either solver, so the return itself says
little; the fixed points are compared instead: SciPy's fixed point, one Newton step from vrsweep's
orbit with vrsweep's monodromy (y* = y + (M - I)^-1 (P_scipy(y) - y)), lies within 1e-7 * max(1,
|y|) of it (the agreement of SciPy and vrsweep on every other branch, docs/continuation.md,
"Accuracy"), and SciPy's map returns from y* at least ten times closer than from y.
"""

import math

import numpy as np
import pytest

from reference import reference_trajectory
from vrsweep.analysis import continuation
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.trajectory import settings_vector

FIG1 = dict(gamma=0.22, alpha=0.1, c=0.04, omega0=0.1, omega=0.5, Delta=1.0, e=0.95, Omega=4.0)
SLOW_PERIOD = 2.0 * math.pi / FIG1["omega"]
SCIPY_RTOL = 1e-12
AGREEMENT = 1e-7


def _problem(parameters, value):
    # rtol 1e-12: beyond these grazes the map's noise is |mu| times the solver's (|mu| ~ 1e3 to 1e4)
    return continuation.ContinuationProblem(dict(parameters, g=value), "original", "g",
                                            settings_vector(rtol=1e-12, atol=1e-14), "rk45",
                                            dict(continuation.DEFAULTS))


def _across(parameters, start_value, direction, lo, hi, max_points, max_period=16):
    """Follow from the orbit reached at start_value; returns (the start, orbits, grazes, end)."""
    problem = _problem(parameters, start_value)
    start = continuation.find_start(problem, [0.99, 0.5], start_value, 400, max_period)
    orbits, found, end = continuation.follow(problem, start, direction, lo, hi, max_points)
    return problem, start, orbits, [orbit for kind, orbit in found if kind == "grazing"], end


def _beyond(start, orbits):
    """The orbits with one impact more than the start (in the orbit's periods)."""
    impacts = round(start.impacts_per_period * start.periods)
    return [o for o in orbits if round(o.impacts_per_period * o.periods) == impacts + 1]


def _scipy_map(parameters, orbit, state):
    """SciPy's P^p from ``state`` at the orbit's parameter: (end state (2,), impacts)."""
    coefficients = kernel_coefficients(dict(parameters, g=orbit.parameter), "original")
    # Steps short enough to see the slowest impact (it flies past Delta for ~2u / a, a ~ g).
    max_step = min(orbit.slowest_impact / 20.0, 0.05)
    run = reference_trajectory(coefficients, state[0], state[1], orbit.periods * SLOW_PERIOD,
                               rtol=SCIPY_RTOL, atol=SCIPY_RTOL * 1e-2, max_step=max_step)
    return np.array([run["x_final"], run["v_final"]]), len(run["impact_times"])


def _scipy_confirms(parameters, orbit, impacts):
    """SciPy's fixed point next to the orbit (module doc), with ``impacts`` impacts."""
    end, counted = _scipy_map(parameters, orbit, orbit.state)
    assert counted == impacts, (orbit.parameter, counted, impacts)
    returned = end - orbit.state
    shift = np.linalg.solve(orbit.monodromy - np.eye(2), -returned)
    scale = max(1.0, float(np.max(np.abs(orbit.state))))
    assert np.max(np.abs(shift)) < AGREEMENT * scale, (orbit.parameter, shift)
    end, counted = _scipy_map(parameters, orbit, orbit.state + shift)
    assert counted == impacts
    assert np.max(np.abs(end - orbit.state - shift)) < 0.1 * np.max(np.abs(returned)), (orbit.parameter, returned)


def _check_crossed(parameters, start, orbits, grazes, graze_near, side):
    """The branch has a graze within 1e-3 of graze_near, orbits beyond it on ``side`` (+1: larger
    g) with one impact more, the first and the last of them confirmed by SciPy."""
    assert any(abs(g.parameter - graze_near) < 1e-3 for g in grazes), [g.parameter for g in grazes]
    graze = min(grazes, key=lambda g: abs(g.parameter - graze_near)).parameter
    beyond = _beyond(start, orbits)
    assert len(beyond) >= 3, len(beyond)
    assert all((o.parameter - graze) * side > 0.0 for o in beyond)
    impacts = round(start.impacts_per_period * start.periods) + 1
    for orbit in (beyond[0], beyond[-1]):
        assert orbit.residual <= continuation.DEFAULTS["newton_tolerance"] * max(1.0, np.max(np.abs(orbit.state)))
        _scipy_confirms(parameters, orbit, impacts)
    return beyond


def test_fig1_period_two_branch_crosses_its_graze():
    """Fig. 1's period-2 branch (5 impacts in 2 periods) beyond g = 17.8973: orbits with 6, the
    new impact from speed 0.01 up, the multiplier falling from about -24 as it speeds up."""
    _, start, orbits, grazes, _ = _across(FIG1, 17.86, +1, 17.0, 18.0, 20)
    assert start.periods == 2 and round(start.impacts_per_period * 2) == 5
    beyond = _check_crossed(FIG1, start, orbits, grazes, 17.8973, +1)
    speeds = [o.slowest_impact for o in beyond]
    assert speeds[0] < 0.02 and all(b > a for a, b in zip(speeds, speeds[1:4]))
    # |mu| ~ 1/u next to the graze (the saltation matrix's 1/v coupling), plus the smooth map's
    # part: it falls as u grows, by more than half the factor u grows by over the first four
    moduli = [float(np.max(np.abs(o.multipliers))) for o in beyond[:4]]
    assert all(b < a for a, b in zip(moduli, moduli[1:]))
    assert moduli[0] / moduli[3] > 0.5 * speeds[3] / speeds[0]


@pytest.mark.slow
def test_fig1_period_four_branch_crosses_its_graze():
    """The period-4 branch (10 impacts in 4 periods), followed down from its stable stretch, beyond
    g = 17.8275: orbits with 11 impacts, multipliers of order 10^3."""
    _, start, orbits, grazes, _ = _across(FIG1, 17.8328, -1, 17.80, 17.86, 40)
    assert start.periods == 4 and round(start.impacts_per_period * 4) == 10
    _check_crossed(FIG1, start, orbits, grazes, 17.8275, +1)


def test_omega_five_period_one_branch_crosses_its_graze():
    """The original model at Omega = 5, the period-1 branch (5 impacts) from g = 50 down, beyond
    g = 45.12196: orbits with 6 impacts and multipliers of 3e3 to 1.4e4, followed in the new
    impact's speed (the ordinary corrector converges nowhere along them)."""
    parameters = dict(DEFAULT_PARAMETERS, Omega=5.0)
    _, start, orbits, grazes, _ = _across(parameters, 50.0, -1, 44.0, 55.0, 100)
    assert start.periods == 1 and round(start.impacts_per_period) == 5
    _check_crossed(parameters, start, orbits, grazes, 45.12196, +1)
