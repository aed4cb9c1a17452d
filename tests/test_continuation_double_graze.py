"""A graze of two stops at once: the Duffing oscillator in a symmetric gap.

    x'' = -2 zeta x' - x - beta x^3 + F cos(omega t),   -d <= x <= d,   x' -> -r x' at either stop

Its orbits are symmetric under x -> -x, t -> t + T/2, so one that touches x = d touches x = -d
in the same orbit (a double graze, generic under the symmetry) and beyond it has an impact on
each stop. Continued in F (zeta 0.05, beta 0.3, omega 1.2, d 1, r 0.7) the period-1 branch
grazes at F = 0.2459083 between the small free orbits and the impacting ones. Up to 0.7.7:

- from the free side the branch ended there, "the orbit beyond the graze does not gain one impact,
  as its normal form needs" (its probe gained two);
- from the impacting side the slowest of the two slow impacts was windowed alone, the other kept,
  and the graze recorded at F = 0.2438433: the graze of another orbit, not this branch's.

Each test checks the graze against SciPy's own grazing orbit (fsolve on the barrier-free flow:
back to its start after T, its largest x at d), which touches -d too, and the first orbit beyond
as a fixed point of SciPy's map with impact events on both stops.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, fsolve, minimize_scalar

from vrsweep.analysis import continuation
from vrsweep.config import load_config
from vrsweep.execution.continuation import problem_of, run_continuation

ZETA, BETA, OMEGA, D, R = 0.05, 0.3, 1.2, 1.0, 0.7
PERIOD = 2.0 * math.pi / OMEGA
CONFIG = """\
model:
  name: Duffing between two stops
  acceleration: "-2*zeta*v - x - beta*x**3 + F*cos(omega*t)"
  parameters: {zeta: 0.05, beta: 0.3, F: 0.3, omega: 1.2, d: 1.0, r: 0.7}
  barriers:
    - {position: d, side: above, restitution: r}
    - {position: -d, side: below, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
integration: {rtol: 1.0e-11, atol: 1.0e-13, transient_periods: 300}
continuation: {parameter: F, from: START, to: [0.1, 1.5], max_step: 0.05}
"""


def _branch(tmp_path_factory, start):
    path = tmp_path_factory.mktemp("double_graze") / "config.yaml"
    path.write_text(CONFIG.replace("START", str(start)))
    config = load_config(path)
    branches, found = run_continuation(config)
    return problem_of(config), branches[0], found


@pytest.fixture(scope="module")
def from_free(tmp_path_factory):
    """From the small free orbit at F = 0.15: up to the fold, back down to the graze, across."""
    return _branch(tmp_path_factory, 0.15)


@pytest.fixture(scope="module")
def from_impacting(tmp_path_factory):
    """From the impacting orbit at F = 0.3: down through its fold, up to the graze, across."""
    return _branch(tmp_path_factory, 0.3)


def _free_flow(y0, F):
    def rhs(t, y):
        return [y[1], -2 * ZETA * y[1] - y[0] - BETA * y[0] ** 3 + F * math.cos(OMEGA * t)]
    return solve_ivp(rhs, (0.0, PERIOD), y0, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)


def _extreme(solution, sign):
    """sign * the largest of sign * x over the period, the turning point refined by minimize_scalar."""
    t = np.linspace(0.0, PERIOD, 2001)
    i = int(np.argmax(sign * solution.sol(t)[0]))
    found = minimize_scalar(lambda s: -sign * solution.sol(s)[0], bounds=(t[max(i - 1, 0)], t[min(i + 1, 2000)]),
                            method="bounded", options={"xatol": 1e-12})
    return -found.fun * sign


def _scipy_graze(z_guess):
    """SciPy's grazing orbit (x, v, F) near z_guess: periodic without the stops, its max x at d."""
    def system(z):
        solution = _free_flow(z[:2], z[2])
        return [solution.y[0, -1] - z[0], solution.y[1, -1] - z[1], _extreme(solution, 1.0) - D]
    z = fsolve(system, z_guess, xtol=1e-13)
    return z, _extreme(_free_flow(z[:2], z[2]), -1.0)


def _impact_map(y0, F):
    """SciPy's map over one period with both stops (events, x' -> -r x'): (end state, impacts)."""
    def rhs(t, y):
        return [y[1], -2 * ZETA * y[1] - y[0] - BETA * y[0] ** 3 + F * math.cos(OMEGA * t)]

    def top(t, y):
        return y[0] - D
    top.terminal, top.direction = True, 1.0

    def bottom(t, y):
        return y[0] + D
    bottom.terminal, bottom.direction = True, -1.0

    t, y, impacts = 0.0, np.array(y0, dtype=float), 0
    while True:
        # Steps short enough that a shallow excursion past a stop (1e-4 deep, 0.01 long, at
        # impact speed 0.015) is not stepped over between two points below it.
        solution = solve_ivp(rhs, (t, PERIOD), y, method="DOP853", rtol=1e-12, atol=1e-14, events=(top, bottom),
                             max_step=PERIOD / 4000)
        if solution.status != 1:
            return solution.y[:, -1], impacts
        hit = 0 if solution.t_events[0].size else 1
        t = float(solution.t_events[hit][0])
        y = solution.y_events[hit][0].copy()
        y[0] = D if hit == 0 else -D
        y[1] = -R * y[1]
        impacts += 1


def _grazes(found):
    return [b.orbit for b in found if b.kind == "grazing"]


@pytest.mark.parametrize("side", ["from_free", "from_impacting"])
def test_the_double_graze_is_located_where_scipy_puts_it_on_both_stops(side, request):
    problem, branch, found = request.getfixturevalue(side)
    grazes = _grazes(found)
    assert len(grazes) == 1, [(b.kind, b.orbit.parameter) for b in found]
    graze = grazes[0]
    z, lowest = _scipy_graze([graze.state[0], graze.state[1], graze.parameter])
    assert abs(graze.parameter - z[2]) < 1e-7, (graze.parameter, z[2])  # was 0.2438433 from the impacting side
    np.testing.assert_allclose(graze.state, z[:2], rtol=0, atol=1e-6)
    assert abs(lowest + D) < 1e-6  # SciPy's grazing orbit touches the other stop too
    assert not any(b.kind.startswith(continuation.UNLOCATED_PREFIX) for b in found)


@pytest.mark.parametrize("side", ["from_free", "from_impacting"])
def test_the_branch_crosses_the_double_graze_onto_orbits_that_hit_both_stops(side, request):
    problem, branch, found = request.getfixturevalue(side)
    assert all(status == continuation.ENDED_RANGE for status, _ in branch.ends.values()), branch.ends
    counts = {round(orbit.impacts_per_period) for orbit in branch.orbits}
    assert counts == {0, 2}
    graze = _grazes(found)[0].parameter
    # The impacting orbit next to the graze (its slowest impact): SciPy's map with both stops
    # returns to it, with one impact on each stop.
    nearest = min((o for o in branch.orbits if o.impacts_per_period == 2), key=lambda o: o.slowest_impact)
    assert nearest.slowest_impact < 0.03 and abs(nearest.parameter - graze) < 0.03, nearest
    end, impacts = _impact_map(nearest.state, nearest.parameter)
    assert impacts == 2
    # Measured 1.4e-9 (from the free side, u = 0.0145, |mu| = 885) and 2.9e-9 (u = 0.0193).
    np.testing.assert_allclose(end, nearest.state, rtol=0, atol=1e-8)


def test_a_written_models_start_without_a_periodic_orbit_is_said_in_its_periods(tmp_path):
    """The refusal of a start with no periodic orbit counted the paper's 'slow periods' for a
    written model, which has none: its period is T. Undamped and far from the stops, the motion from
    rest is quasi-periodic (the free oscillation at about 1 beside the forcing at omega = 1.2)."""
    from vrsweep.errors import UsageError

    path = tmp_path / "config.yaml"
    path.write_text(CONFIG.replace("zeta: 0.05", "zeta: 0.0").replace("START", "0.12"))
    with pytest.raises(UsageError, match=r"no periodic orbit of at most 16 periods T at the start \(F = 0.12\)"):
        run_continuation(load_config(path))


def test_a_written_models_trajectory_too_long_is_said_in_its_periods(tmp_path):
    """simulate's refusal of a run too long for one trajectory counted 'slow periods' likewise."""
    from vrsweep.errors import UsageError
    from vrsweep.execution.simulate import MAX_PERIODS, sample_times

    path = tmp_path / "config.yaml"
    path.write_text(CONFIG.replace("START", "0.3").replace("transient_periods: 300",
                                                            f"transient_periods: {MAX_PERIODS}"))
    with pytest.raises(UsageError, match=r"periods T \(transient \+ measured\) is more than"):
        sample_times(load_config(path))
