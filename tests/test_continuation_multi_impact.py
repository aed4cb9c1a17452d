"""Grazes of orbits that keep other impacts (analysis/grazing.py's transparent window).

The case is the end of Fig. 1's period-3 window (original model, Omega = 4, Delta = 1): the orbit
of three slow periods gains impacts one at a time as g grows, 8 -> 9 near g = 17.617 and
9 -> 10 near g = 17.650, each where one of its smooth maxima reaches the barrier while its other
impacts go on. vrsweep locates each graze on the map with the barrier transparent in a window
around the touch. SciPy checks each one with a map of its own: its DOP853 with impact events
(tests/reference.py) up to the window, the barrier removed in it, the events again after it.
The touch time comes from SciPy's own run of the branch's orbit next to the graze.
"""

import dataclasses
import math

import numpy as np
import pytest

from reference import reference_trajectory
from vrsweep.analysis import continuation
from vrsweep.analysis.diagnostics import detect_period
from vrsweep.numerics import kernel
from vrsweep.numerics.model import kernel_coefficients
from vrsweep.numerics.trajectory import settings_vector, simulate

FIG1 = dict(gamma=0.22, alpha=0.1, c=0.04, omega0=0.1, omega=0.5, Delta=1.0, e=0.95, Omega=4.0)
SLOW_PERIOD = 2.0 * math.pi / FIG1["omega"]
PERIODS = 3
# Half the window SciPy removes the barrier in: a quarter of the fast period, as grazing.py.
HALF_WINDOW = 0.25 * 2.0 * math.pi / FIG1["Omega"]


def _resolving_step(orbit):
    """A SciPy step short enough to see the orbit's slowest impact: at speed u it flies past Delta
    for ~2 u / a, with a ~ g ~ 17 here, so steps of u / 20 see it."""
    return min(orbit.slowest_impact / 20.0, 0.05)


def _coefficients(g, delta=FIG1["Delta"]):
    return kernel_coefficients(dict(FIG1, g=g, Delta=delta), "original")


def _problem(rtol):
    return continuation.ContinuationProblem(dict(FIG1, g=17.7), "original", "g",
                                            settings_vector(rtol=rtol, atol=rtol * 1e-2), "rk45",
                                            dict(continuation.DEFAULTS, max_step=0.05))


@pytest.fixture(scope="module")
def window_end_branch():
    """The period-3 orbit from g = 17.7 (10 impacts) down past both grazes."""
    problem = _problem(1e-10)
    start = continuation.find_start(problem, [0.99, 0.5], 17.7, 300, 8)
    assert start.periods == PERIODS
    orbits, found, end = continuation.follow(problem, start, -1, 17.55, 17.8, 40)
    return problem, [start] + orbits, [orbit for kind, orbit in found if kind == "grazing"], end


def _impacts(run):
    return len(run["impact_times"])


def _real(g, state, t0, t_end, max_step):
    return reference_trajectory(_coefficients(g), state[0], state[1], t_end, t0=t0, rtol=1e-12, atol=1e-14,
                                max_step=max_step)


def _touch_time(orbit):
    """When SciPy's run of ``orbit`` (on the free side of a graze) comes closest to the barrier
    without hitting it: its highest smooth maximum, away from its impacts."""
    run = _real(orbit.parameter, orbit.state, 0.0, PERIODS * SLOW_PERIOD, _resolving_step(orbit))
    t = np.linspace(0.0, PERIODS * SLOW_PERIOD, 100001)
    x = run["sol"](t)[0]
    is_maximum = np.zeros_like(x, dtype=bool)
    is_maximum[1:-1] = (x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:])
    if len(run["impact_times"]):
        near_impact = np.min(np.abs(t[:, None] - run["impact_times"][None, :]), axis=1) < 0.05
        is_maximum &= ~near_impact
    k = int(np.argmax(np.where(is_maximum, x, -np.inf)))
    return t[k]


def _scipy_windowed_map(graze, touch_time):
    """SciPy's map of three slow periods with the barrier removed within HALF_WINDOW of
    touch_time: (end state (2,), impacts outside the window, largest x inside it)."""
    g, state, max_step = graze.parameter, graze.state, _resolving_step(graze)
    before = _real(g, state, 0.0, touch_time - HALF_WINDOW, max_step)
    free = reference_trajectory(_coefficients(g, delta=1e3), before["x_final"], before["v_final"],
                                touch_time + HALF_WINDOW, t0=touch_time - HALF_WINDOW, rtol=1e-12, atol=1e-14)
    after = _real(g, [free["x_final"], free["v_final"]], touch_time + HALF_WINDOW, PERIODS * SLOW_PERIOD, max_step)
    t = np.linspace(touch_time - HALF_WINDOW, touch_time + HALF_WINDOW, 100001)
    x = free["sol"](t)[0]
    k = int(np.argmax(x))
    # The parabola through the sampled maximum and its neighbours (spacing 8e-6: its error is far
    # below the 1e-8 asked).
    x0, x1, x2 = x[k - 1], x[k], x[k + 1]
    top = x1 + 0.125 * (x0 - x2) ** 2 / (2.0 * x1 - x0 - x2)
    return np.array([after["x_final"], after["v_final"]]), _impacts(before) + _impacts(after), top


def _neighbours(orbits, graze):
    """The branch's orbits on either side of the graze: (nearest with fewer impacts, with more)."""
    below = [o for o in orbits if o.impacts_per_period < graze.impacts_per_period + 0.5 / PERIODS]
    above = [o for o in orbits if o.impacts_per_period > graze.impacts_per_period + 0.5 / PERIODS]
    return (min(below, key=lambda o: abs(o.parameter - graze.parameter)),
            min(above, key=lambda o: abs(o.parameter - graze.parameter)))


@pytest.mark.slow
def test_each_graze_with_other_impacts_is_located_and_crossed(window_end_branch):
    """Both grazes are found, each between the orbits with one impact fewer and one more; the
    branch goes on through both (it ends where it leaves the range, not at a graze)."""
    _, orbits, grazes, end = window_end_branch
    assert end[0] == continuation.ENDED_RANGE, end
    assert len(grazes) == 2, [g.parameter for g in grazes]
    counts = sorted(round(g.impacts_per_period * PERIODS) for g in grazes)
    assert counts == [8, 9]  # the free sides' counts: 8 -> 9 and 9 -> 10
    for graze in grazes:
        fewer, more = _neighbours(orbits, graze)
        assert round(more.impacts_per_period * PERIODS) == round(fewer.impacts_per_period * PERIODS) + 1
        assert min(fewer.parameter, more.parameter) < graze.parameter < max(fewer.parameter, more.parameter)


@pytest.mark.slow
def test_scipy_confirms_each_graze_and_its_neighbours(window_end_branch):
    """SciPy's own windowed map: from each located grazing state it returns to that state after
    three slow periods (1e-7), with the free side's impacts outside the window, and its largest x
    inside the window is Delta (1e-7). Next to the graze SciPy counts k impacts on one side, k + 1
    on the other, and both neighbours are fixed points of its real map."""
    _, orbits, grazes, _ = window_end_branch
    for graze in grazes:
        fewer, more = _neighbours(orbits, graze)
        touch = _touch_time(fewer)
        end_state, impacts, top = _scipy_windowed_map(graze, touch)
        assert np.max(np.abs(end_state - graze.state)) < 1e-7 * max(1.0, np.max(np.abs(graze.state)))
        assert impacts == round(graze.impacts_per_period * PERIODS)
        assert top == pytest.approx(FIG1["Delta"], abs=1e-7)
        for orbit in (fewer, more):
            run = _real(orbit.parameter, orbit.state, 0.0, PERIODS * SLOW_PERIOD, _resolving_step(orbit))
            assert _impacts(run) == round(orbit.impacts_per_period * PERIODS), orbit.parameter
            end = np.array([run["x_final"], run["v_final"]])
            assert np.max(np.abs(end - orbit.state)) < 1e-7 * max(1.0, np.max(np.abs(orbit.state)))


@pytest.mark.slow
def test_a_sweep_across_the_graze_sees_the_slowest_impact_fall_like_a_square_root(window_end_branch, tmp_path):
    """Issue 31: on a map across a grazing line the smallest impact speed (impact_speed_min, a
    sweep variable) falls to zero like sqrt(g - g_graze). A sweep just above the graze where the
    tenth impact of the period-3 orbit appears (located by continuation, not by the sweep): the
    log-log slope of the speed against the distance is 1/2 over three decades."""
    import xarray as xr

    import vrsweep

    _, orbits, grazes, _ = window_end_branch
    graze = max(grazes, key=lambda orbit: orbit.parameter)  # 9 -> 10 impacts as g grows
    distance = np.array([1e-5, 1e-4, 1e-3, 1e-2])
    config = {"model": "original", "parameters": FIG1, "initial": {"x": 0.99, "v": 0.5},
              "sweep": {"g": (graze.parameter + distance).tolist()},
              "integration": {"rtol": 1e-10, "atol": 1e-12, "transient_periods": 300, "measure_periods": 60}}
    out = tmp_path / "graze.h5"
    vrsweep.sweep(config, output=out, progress=False)
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert (ds["period"].values == PERIODS).all()
        assert (np.round(ds["impacts_per_period"].values * PERIODS) == 10).all()
        speed = ds["impact_speed_min"].values
    slopes = np.diff(np.log(speed)) / np.diff(np.log(distance))
    assert np.all(np.abs(slopes - 0.5) < 0.01), slopes


def test_the_grazes_converge_with_the_tolerance(window_end_branch):
    """At rtol 1e-12 the same grazes lie where rtol 1e-10 put them, to 1e-7 in g: located on the
    windowed map to the Newton tolerance, not to a continuation step."""
    _, orbits, grazes, _ = window_end_branch
    problem = _problem(1e-12)
    start, failure = continuation.correct(problem, orbits[0].z, PERIODS)
    assert failure is None, failure
    _, found, _ = continuation.follow(problem, start, -1, 17.55, 17.8, 40)
    tight = sorted(orbit.parameter for kind, orbit in found if kind == "grazing")
    assert tight == pytest.approx(sorted(g.parameter for g in grazes), abs=1e-7)


@pytest.mark.slow
def test_the_period3_window_ends_at_a_grazing_corner():
    """Where Fig. 1's period-3 window ends (g = 17.796), the stable orbit with 10 impacts reaches a
    graze from below in g and the corrector, unable to go on, hands over to the crossing: the
    normal form on the windowed map carries the branch onto orbits with 11 impacts that turn back
    to lower g, unstable (a grazing corner, where the up-sweep leaves the window). At rtol 1e-12:
    at 1e-10 these 10- and 11-impact maps, with multipliers up to 1e2, are known to 1e-8 only.
    SciPy: the graze is a fixed point of its windowed map touching Delta (1e-7), and the first
    orbit beyond has 11 impacts and is a fixed point of its real map. And the corner is where an
    up-sweep leaves the window, within one grid step."""
    problem = _problem(1e-12)
    start = continuation.find_start(problem, [0.99, 0.5], 17.79, 300, 8)
    assert round(start.impacts_per_period * PERIODS) == 10 and start.stable
    orbits, found, _ = continuation.follow(problem, start, +1, 17.78, 17.8, 4)
    orbits = [start] + orbits
    grazes = [orbit for kind, orbit in found if kind == "grazing"]
    assert len(grazes) == 1
    graze = grazes[0]
    fewer, more = _neighbours(orbits, graze)
    assert round(more.impacts_per_period * PERIODS) == 11 and not more.stable
    assert more.parameter < graze.parameter and fewer.parameter < graze.parameter  # the corner
    end_state, impacts, top = _scipy_windowed_map(graze, _touch_time(fewer))
    assert np.max(np.abs(end_state - graze.state)) < 1e-7 * max(1.0, np.max(np.abs(graze.state)))
    assert impacts == 10
    assert top == pytest.approx(FIG1["Delta"], abs=1e-7)
    run = _real(more.parameter, more.state, 0.0, PERIODS * SLOW_PERIOD, _resolving_step(more))
    assert _impacts(run) == 11
    end = np.array([run["x_final"], run["v_final"]])
    assert np.max(np.abs(end - more.state)) < 1e-7 * max(1.0, np.max(np.abs(more.state)))
    # An up-sweep along the stable orbit (each point from the last one's final state, as
    # `continuation: up`) leaves period 3 at the first grid point past the corner.
    step = 2e-4
    grid = 17.79 + step * np.arange(60)
    left_at = _up_sweep_leaves_period3(grid, start.state)
    assert graze.parameter < left_at <= graze.parameter + step


def _up_sweep_leaves_period3(grid, state):
    """The first g of ``grid`` where a sweep point started from the last one's end is not on an
    orbit of three slow periods (diagnostics.detect_period, as sweeps detect it)."""
    settings = settings_vector(rtol=1e-10, atol=1e-12, transient_periods=300, measure_periods=64)
    for g in grid:
        run = simulate(_coefficients(g), list(state), settings)
        records = run.period_records[-64:]
        period = int(detect_period(records[None, :, kernel.REC_X], records[None, :, kernel.REC_V], 16, 1e-6)[0])
        if period != PERIODS:
            return g
        state = run.summary[[kernel.SUM_X_FINAL, kernel.SUM_V_FINAL]]
    return np.inf


def _orbit_at(z, R):
    return continuation.Orbit(parameter=z[2], state=np.array(z[:2], dtype=float), periods=1,
                              monodromy=np.eye(2), R=R, Q_amplitude=R, impacts_per_period=1.0, x_max=1.0,
                              slowest_impact=1.0, residual=0.0, newton_iterations=1)


def test_a_step_off_the_secant_of_r_is_refused_and_a_smooth_one_is_not():
    """continuation._bends: R carried along the arclength on the secant of the last two points.
    Equal steps of 0.1 in g: R on a line is accepted, R curving by (step/radius)^2 is accepted,
    and R twice the secant's (a landing on another branch) is refused."""
    before, previous = _orbit_at([0.0, 0.0, 17.6], 1.0), _orbit_at([0.0, 0.0, 17.7], 1.2)
    assert not continuation._bends(before, previous, _orbit_at([0.0, 0.0, 17.8], 1.4))
    assert not continuation._bends(before, previous, _orbit_at([0.0, 0.0, 17.8], 1.4 + 0.1 ** 2))
    assert continuation._bends(before, previous, _orbit_at([0.0, 0.0, 17.8], 2.8))
    # no secant yet (the first step, or the first after a crossing): nothing to compare with
    assert not continuation._bends(None, previous, _orbit_at([0.0, 0.0, 17.8], 2.8))


def test_a_transparent_window_removes_the_impacts_inside_it_and_no_other():
    """The kernel's transparent window (settings.TRANSPARENT_FROM/TO) on the README's hysteresis
    example's impacting orbit (effective model, g = 23, one impact per slow period): a window
    around its impact gives the barrier-free map (Delta = inf, another code path) to the
    integration tolerance, with the window's largest x past Delta; a window away from the impact
    changes nothing but the steps (the map to the tolerance, the impact kept)."""
    from vrsweep.analysis.grazing import free_coefficients
    from vrsweep.numerics.model import DEFAULT_PARAMETERS
    from vrsweep.numerics.shooting import periodic_map

    parameters = dict(DEFAULT_PARAMETERS, gamma=0.05, alpha=0.05, Omega=4.0, g=23.0)
    coefficients = kernel_coefficients(parameters, "effective")
    settings = settings_vector(rtol=1e-11, atol=1e-13, transient_periods=200, measure_periods=1)
    run = simulate(kernel_coefficients(dict(parameters, g=27.0), "effective"), [0.0, 0.0], settings)
    run = simulate(coefficients, run.summary[[kernel.SUM_X_FINAL, kernel.SUM_V_FINAL]], settings)
    state = run.summary[[kernel.SUM_X_FINAL, kernel.SUM_V_FINAL]]
    real = periodic_map(coefficients, state, settings, 1)
    assert real.impacts == 1
    period = 2.0 * math.pi / parameters["omega"]
    touch = real.impact_times[0]
    # The free motion stays past Delta from the impact at t = 0.50 to t = 3.32 (it hits at speed
    # 0.32 and the slow force pulls back weakly): the window covers all of it, or none.
    around = (touch - 0.3, touch + 3.2)
    away = (touch + 0.5 * period - 0.5, touch + 0.5 * period + 0.5)
    windowed = periodic_map(coefficients, state, settings, 1, transparent=around)
    free = periodic_map(free_coefficients(coefficients), state, settings, 1)
    assert windowed.impacts == 0 and free.impacts == 0
    assert np.max(np.abs(windowed.end_state - free.end_state)) < 1e-9
    assert windowed.window_x_max == pytest.approx(free.x_max, abs=1e-9)
    assert windowed.window_x_max > parameters["Delta"]
    elsewhere = periodic_map(coefficients, state, settings, 1, transparent=away)
    assert elsewhere.impacts == 1
    assert np.max(np.abs(elsewhere.end_state - real.end_state)) < 1e-9
    assert elsewhere.window_x_max < parameters["Delta"]


def test_past_a_graze_the_branch_goes_back_over_its_parameter_on_its_own_orbits():
    """Fig. 1's period-1 branch gains a sixth impact at the graze g* = 39.844991; beyond it the
    6-impact orbits turn back to lower g, 0.02 to 0.06 from the grazing orbit in state. A step on
    them over g* was refused as a jump onto another branch (the rule for a step from next to a
    graze), again and again: the branch ended "keeps jumping to another branch" at g*. Now it goes
    on below g*, and SciPy confirms its orbits there: six impacts a period, a fixed point."""
    problem = continuation.ContinuationProblem(dict(FIG1, g=39.8), "original", "g",
                                               settings_vector(rtol=1e-10, atol=1e-12), "rk45",
                                               dict(continuation.DEFAULTS, max_step=0.5))
    start = continuation.find_start(problem, [-3.2054, 2.8920], 39.8, 20, 8)  # on the branch from g = 30
    assert start.periods == 1 and start.impacts_per_period == 5
    orbits, found, end = continuation.follow(problem, start, +1, 39.7, 40.0, 40)
    grazes = [orbit.parameter for kind, orbit in found if kind == "grazing"]
    assert any(abs(g - 39.844991) < 1e-5 for g in grazes), grazes
    assert "jumping" not in str(end), end
    below = [o for o in orbits if o.impacts_per_period == 6 and o.parameter < 39.844991 - 1e-4]
    assert below, [(o.parameter, o.impacts_per_period) for o in orbits]
    for orbit in below[:1] + below[-1:]:
        run = reference_trajectory(_coefficients(orbit.parameter), orbit.state[0], orbit.state[1], SLOW_PERIOD,
                                   rtol=1e-12, atol=1e-14, max_step=_resolving_step(orbit))
        assert _impacts(run) == 6
        end_state = np.array([run["x_final"], run["v_final"]])
        assert np.max(np.abs(end_state - orbit.state)) < 1e-6 * max(1.0, np.max(np.abs(orbit.state)))


@pytest.mark.slow
def test_the_way_through_a_crossed_graze_is_searched_for_bifurcations():
    """cross_grazing carries Fig. 1's period-1 branch over its graze at g* = 39.844991 onto a
    6-impact orbit at g = 39.845246 whose multiplier is +2.18: between them, along the branch, the
    new impact's multiplier comes from -infinity (order -1/u at the graze) through -1 (a period
    doubling) and +1 (a fold, where g turns back). A crossing skipped the bifurcation test (_detect)
    and neither was recorded, up to 0.7.4. Now both pieces of the corner are tested: the fold is
    located, and SciPy's map has it as a fixed point with six impacts and a multiplier at +1; the
    doubling, next to the graze where the map is steep, is recorded as not located, bracketed by
    the orbits before and after the crossing."""
    problem = continuation.ContinuationProblem(dict(FIG1, g=39.8), "original", "g",
                                               settings_vector(rtol=1e-10, atol=1e-12), "rk45",
                                               dict(continuation.DEFAULTS, max_step=0.5))
    start = continuation.find_start(problem, [-3.2054, 2.8920], 39.8, 20, 8)  # on the branch from g = 30
    orbits, found, _ = continuation.follow(problem, start, +1, 39.7, 39.86, 40)
    graze = next(orbit.parameter for kind, orbit in found if kind == "grazing")
    assert abs(graze - 39.844991) < 1e-5, found
    folds = [orbit for kind, orbit in found if kind == "fold" and abs(orbit.parameter - graze) < 1e-3]
    assert len(folds) == 1, [(kind, orbit.parameter) for kind, orbit in found]
    fold = folds[0]
    assert fold.parameter > graze and fold.impacts_per_period == 6
    doubling = [orbit for kind, orbit in found if kind.endswith("period_doubling") and abs(orbit.parameter - graze) < 2e-3]
    assert len(doubling) == 1, [(kind, orbit.parameter) for kind, orbit in found]
    # SciPy: the fold is a fixed point of one slow period with six impacts, its monodromy (central
    # differences of SciPy's map) has a multiplier at +1 (det(M - I) = 0)
    step = _resolving_step(fold)

    def scipy_map(state):
        run = reference_trajectory(_coefficients(fold.parameter), state[0], state[1], SLOW_PERIOD,
                                   rtol=1e-12, atol=1e-14, max_step=step)
        return np.array([run["x_final"], run["v_final"]]), _impacts(run)

    end, impacts = scipy_map(fold.state)
    assert impacts == 6
    assert np.max(np.abs(end - fold.state)) < 1e-6 * max(1.0, np.max(np.abs(fold.state)))
    h = 1e-6
    monodromy = np.array([(scipy_map(fold.state + d)[0] - scipy_map(fold.state - d)[0]) / (2 * h)
                          for d in (np.array([h, 0.0]), np.array([0.0, h]))]).T
    mu = np.linalg.eigvals(monodromy)
    assert np.min(np.abs(mu - 1.0)) < 1e-2, mu


def test_a_long_step_towards_the_corner_locates_the_graze_rather_than_passing_it():
    """From g = 17.7 at the default max_step of 0.5 the steps grow as they near the corner at the
    end of the period-3 window; one of them (from g = 17.7866, its smooth maximum 0.008 below Delta)
    used to land beyond the corner on the other 10-impact orbit: the check for a passed graze ran
    Newton on the windowed map from that orbit, whose full first step left the map's piece (two
    of its other impacts gone) and diverged, and a graze not located counted as no graze. The
    branch must instead reach the corner and turn onto the 11-impact orbits, the graze between
    being one SciPy confirms (a fixed point of its windowed map that touches Delta)."""
    problem = continuation.ContinuationProblem(dict(FIG1, g=17.7), "original", "g",
                                               settings_vector(rtol=1e-12, atol=1e-14), "rk45",
                                               dict(continuation.DEFAULTS, max_step=0.5))
    start = continuation.find_start(problem, [0.99, 0.5], 17.7, 300, 8)
    assert round(start.impacts_per_period * PERIODS) == 10
    orbits, found, _ = continuation.follow(problem, start, +1, 17.6, 17.8, 12)
    orbits = [start] + orbits
    counts = [round(orbit.impacts_per_period * PERIODS) for orbit in orbits]
    assert 11 in counts and set(counts) <= {10, 11}
    turn = counts.index(11)
    fewer, more = orbits[turn - 1], orbits[turn]
    grazes = [orbit for kind, orbit in found if kind == "grazing"]
    assert len(grazes) == 1
    graze = grazes[0]
    assert fewer.parameter < graze.parameter and more.parameter < graze.parameter  # the corner
    # no step along the 10-impact orbits went over the graze's parameter
    assert all(orbit.parameter < graze.parameter for orbit in orbits[:turn])
    end_state, impacts, top = _scipy_windowed_map(graze, _touch_time(fewer))
    assert np.max(np.abs(end_state - graze.state)) < 1e-7 * max(1.0, np.max(np.abs(graze.state)))
    assert impacts == 10
    assert top == pytest.approx(FIG1["Delta"], abs=1e-7)
    assert not more.stable


def _unlocatable(monkeypatch, bisection_too=False):
    """Make every graze fail to be located: Newton on the map without the impact (and, with
    bisection_too, the bisection on the impact count) returns nothing, as where they diverge."""
    from vrsweep.analysis import grazing

    monkeypatch.setattr(grazing, "locate_graze", lambda *args, **kwargs: None)
    if bisection_too:
        locate = continuation._locate
        monkeypatch.setattr(continuation, "_locate",
                            lambda *args: None if args[4] == "grazing" else locate(*args))


def _count(orbit):
    return round(orbit.impacts_per_period * PERIODS)


def test_a_graze_newton_cannot_locate_is_bisected_not_taken_for_a_jump(monkeypatch):
    """Down from g = 17.7 the period-3 orbit loses an impact at g = 17.6496 and another at 17.6172.
    Where Newton on the windowed map fails, the step over the graze was refused as a jump onto
    another branch, down to the smallest step, and the branch ended "keeps jumping to another
    branch" at 17.649647 (up to 0.7.1): a graze not located counted as proof of a jump. It is now
    bracketed by bisection on the impact count, and the branch goes on through both."""
    _unlocatable(monkeypatch)
    problem = _problem(1e-10)
    start = continuation.find_start(problem, [0.99, 0.5], 17.7, 300, 8)
    orbits, found, end = continuation.follow(problem, start, -1, 17.6, 17.8, 40)
    assert "jumping" not in end[1], end
    orbits = [start] + orbits
    assert {_count(orbit) for orbit in orbits} == {8, 9, 10}
    grazes = [orbit.parameter for kind, orbit in found if kind == "grazing"]
    assert len(grazes) == 2, found
    for before, after in zip(orbits, orbits[1:]):
        if _count(before) != _count(after):
            assert sum(after.parameter <= g <= before.parameter for g in grazes) == 1


def test_a_change_of_impacts_whose_graze_cannot_be_located_is_recorded_with_its_bracket(monkeypatch, tmp_path):
    """Where the bisection fails too, the change of the impact count between two orbits was
    dropped: no graze in the table, nothing on the figure. It is now an unlocated_grazing record
    (its orbit the one before the change), in the file, in info's lines (with the bracket: the
    next orbit's parameter) and on the figure (G?1)."""
    from click.testing import CliRunner

    from vrsweep.cli import main

    _unlocatable(monkeypatch, bisection_too=True)
    branch = tmp_path / "branch.h5"
    result = CliRunner().invoke(main, ["continue", "configs/fig1_continue.yaml", "-o", str(branch), "-q",
                                       "--set", "continuation.from=17.7", "--set", "continuation.to=17.64,17.7001",
                                       "--set", "continuation.max_step=0.05", "--set", "continuation.switch=false",
                                       "--set", "integration.rtol=1e-10", "--set", "integration.atol=1e-12"])
    assert result.exit_code == 0, result.output
    import vrsweep

    with vrsweep.open_results(branch) as ds:
        kinds = [str(kind) for kind in ds["bifurcation_kind"].values]
        assert kinds == ["unlocated_grazing"], kinds
        at = float(ds["bifurcation_parameter"].values[0])
        counts = np.round(ds["impacts_per_period"].values * PERIODS)
        k = int(np.flatnonzero(ds["parameter"].values == at)[0])
        neighbours = [j for j in (k - 1, k + 1) if 0 <= j < len(counts) and counts[j] != counts[k]]
        assert len(neighbours) == 1 and {counts[k], counts[neighbours[0]]} == {9, 10}
        other = float(ds["parameter"].values[neighbours[0]])
    assert 17.6496 - 1e-3 < min(at, other) < max(at, other) < 17.6496 + 1e-3
    info = CliRunner().invoke(main, ["info", str(branch)])
    assert info.exit_code == 0, info.output
    line = next(line for line in info.output.splitlines() if "unlocated_grazing" in line)
    assert "G?1" in line and "could not be located" in line and f"{other:.8g}"[:8] in line, line
    figure = CliRunner().invoke(main, ["plot", str(branch), "-o", str(tmp_path / "branch.png")])
    assert figure.exit_code == 0, figure.output
    curve = CliRunner().invoke(main, ["continue", str(branch), "--point", "0", "--along", "Omega", "--to", "3.9", "4.1",
                                      "-o", str(tmp_path / "curve.h5")])
    assert curve.exit_code == 2 and curve.output.strip().endswith(
        "could not be located (unlocated_grazing): it has no grazing orbit to start a curve from"), curve.output
    assert len(curve.output.strip().splitlines()) == 1


def _three_legs(g, state, touch, fine):
    """SciPy's real map of three slow periods from ``state``, with steps of at most ``fine`` within
    HALF_WINDOW of ``touch`` (where a slow impact's short flight past Delta must be seen) and 0.05
    elsewhere: (end state, [the impacts' speeds x'(-)])."""
    legs = ((0.0, touch - HALF_WINDOW, 0.05), (touch - HALF_WINDOW, touch + HALF_WINDOW, fine),
            (touch + HALF_WINDOW, PERIODS * SLOW_PERIOD, 0.05))
    speeds = []
    for t0, t1, max_step in legs:
        run = _real(g, state, t0, t1, max_step)
        speeds += list(run["v_before"])
        state = [run["x_final"], run["v_final"]]
    return np.array(state), speeds


def _scipy_monodromy(g, state, touch, fine, h=1e-7):
    """The Jacobian of SciPy's map by central differences."""
    columns = []
    for k in range(2):
        d = np.zeros(2)
        d[k] = h
        columns.append((_three_legs(g, state + d, touch, fine)[0] - _three_legs(g, state - d, touch, fine)[0]) / (2 * h))
    return np.array(columns).T


@pytest.mark.slow
def test_the_step_that_leaves_the_11_impact_orbits_crosses_their_graze_onto_the_free_side():
    """Past the corner at the end of the period-3 window the branch turns up in g on unstable orbits
    with 11 impacts whose 11th impact slows (u = 0.030 at g = 17.796388, mu = -67.6) and then one
    step lands on a stable orbit with 10 impacts at g = 17.798257, the graze recorded between at
    17.797473. A jump onto another branch? A straight line through u^2 puts the 11th impact's end
    at g = 17.7969, not at the graze. SciPy says no jump:
    - the graze is a fixed point of SciPy's windowed map touching Delta, and the 10-impact orbit
      after the step is on that map's branch from it: SciPy's fixed points of the real map at g
      between, each from the last, keep 10 impacts with the touch below Delta, and end on it;
    - the 11-impact orbits approach the same graze as Nordmark's square-root map says they must:
      in its normal form x' = mu - gamma sqrt(x), an impacting fixed point of speed u ~ sqrt(x) has
      multiplier -gamma / (2 sqrt(x)) and lies at mu = x + gamma sqrt(x) ~ u^2 (1 + 2 |multiplier|)
      from the graze: linear in u where |multiplier| >> 1 (here 60), whence the u^2 line's miss.
      SciPy's u and multiplier at two such orbits predict the ratio of their distances in g from
      the graze to 1 %; a graze at 17.7969 would be 5 % off.
    The start is the referee's own SciPy fixed point at g = 17.796388 (Newton on its own map)."""
    problem = _problem(1e-12)
    start, failure = continuation.correct(problem, np.array([-2.64913976, 2.10337494, 17.796388]), PERIODS)
    assert failure is None and _count(start) == 11
    after, found, _ = continuation.follow(problem, start, +1, 17.78, 17.8, 1)
    # an 11-impact orbit 6e-5 lower in g, by Newton at that g from the start's state
    earlier, failure = continuation.correct(problem, start.z - [0.0, 0.0, 6e-5], PERIODS)
    assert failure is None
    fewer = after[0]
    assert _count(fewer) == 10 and _count(earlier) == 11
    grazes = [orbit for kind, orbit in found if kind == "grazing"]
    assert len(grazes) == 1
    graze = grazes[0]
    assert start.parameter < graze.parameter < fewer.parameter
    touch = _touch_time(fewer)
    end_state, impacts, top = _scipy_windowed_map(graze, touch)
    assert np.max(np.abs(end_state - graze.state)) < 1e-7 * max(1.0, np.max(np.abs(graze.state)))
    assert impacts == 10 and top == pytest.approx(FIG1["Delta"], abs=1e-7)
    # The free side: natural continuation in g with SciPy's Newton, from the graze to `fewer`.
    state, touches = graze.state.copy(), []
    for g in np.linspace(graze.parameter, fewer.parameter, 4)[1:]:
        for _ in range(8):
            end, speeds = _three_legs(g, state, touch, 0.05)
            if np.max(np.abs(end - state)) < 1e-11:
                break
            state = state - np.linalg.solve(_scipy_monodromy(g, state, touch, 0.05) - np.eye(2), end - state)
        assert len(speeds) == 10
        window = _real(g, state, 0.0, touch + HALF_WINDOW, 0.05)["sol"](np.linspace(touch - HALF_WINDOW, touch + HALF_WINDOW, 2001))[0]
        touches.append(window.max())
    assert np.all(np.diff(touches) < 0) and touches[0] < FIG1["Delta"]
    assert np.max(np.abs(state - fewer.state)) < 1e-7
    # The impacting side: the normal form's ratio of distances from the graze.
    predicted = []
    for orbit in (earlier, start):
        end, speeds = _three_legs(orbit.parameter, orbit.state, touch, min(orbit.slowest_impact / 20.0, 0.05))
        assert len(speeds) == 11 and np.max(np.abs(end - orbit.state)) < 1e-7
        u = min(speeds)
        mu = np.linalg.eigvals(_scipy_monodromy(orbit.parameter, orbit.state, touch, u / 20.0))
        predicted.append(u ** 2 * (1.0 + 2.0 * np.max(np.abs(mu))))
    measured = (graze.parameter - earlier.parameter) / (graze.parameter - start.parameter)
    assert measured == pytest.approx(predicted[0] / predicted[1], rel=1e-2)


@pytest.fixture(scope="module")
def steep_branch():
    """Two orbits of the period-3 branch from the referee's SciPy fixed point at g = 17.799 (stable
    side, multiplier -2.156), up in g through its period doubling and fold: (problem, start,
    orbits, bifurcations, end)."""
    problem = _problem(1e-12)
    start, failure = continuation.correct(problem, np.array([-2.65006053, 2.10441267, 17.799]), PERIODS)
    assert failure is None and _count(start) == 10
    orbits, found, end = continuation.follow(problem, start, +1, 17.79, 17.81, 2)
    return problem, start, orbits, found, end


@pytest.mark.slow
def test_the_corrector_follows_a_branch_that_curves_steeply_in_g_through_its_doubling_and_fold(steep_branch):
    """Beyond the corner's graze the stable 10-impact orbits of the period-3 branch period-double at
    g = 17.79903 and fold at 17.79904 (a multiplier from -2.2 at 17.799 to +1 within 4e-5 in g).
    F_lam, a forward difference of 1e-6 * g = 1.8e-5 in g, spans that curvature: Newton failed at
    every step down to min_step and the branch ended at g = 17.798989 (newton_failed, residual
    1.6e-7; up to 0.7.1). The corrector now retries with a difference 1000 times shorter, and the
    branch goes through the doubling and the fold onto unstable orbits with 10 impacts back down
    in g. SciPy: the first orbit beyond is a fixed point of its map with 10 impacts and the same
    larger multiplier (1e-3). (The referee's SciPy orbits at fixed g, continued from 17.799 in steps
    of 4e-6, converge up to 17.79904, their impact times moving faster and faster: the fold.)"""
    problem, start, orbits, found, end = steep_branch
    assert "did not converge" not in end[1], end
    kinds = {kind: orbit.parameter for kind, orbit in found}
    assert set(kinds) == {"fold", "period_doubling"}, found
    assert 17.799 < kinds["period_doubling"] < kinds["fold"] < 17.79906
    beyond = orbits[0]
    assert beyond.parameter < kinds["fold"] and _count(beyond) == 10 and beyond.multipliers[0].real > 1.0
    touch = _touch_time(beyond)
    end_state, speeds = _three_legs(beyond.parameter, beyond.state, touch, 0.05)
    assert len(speeds) == 10
    assert np.max(np.abs(end_state - beyond.state)) < 1e-7 * max(1.0, np.max(np.abs(beyond.state)))
    mu = np.linalg.eigvals(_scipy_monodromy(beyond.parameter, beyond.state, touch, 0.05))
    assert np.max(np.abs(mu)) == pytest.approx(abs(beyond.multipliers[0]), rel=1e-3)


@pytest.mark.slow
def test_a_located_doubling_and_fold_have_their_multipliers_at_minus_and_plus_one(steep_branch):
    """The period doubling and the fold beyond the corner lie 1.1e-5 apart in g, inside the
    location's bracket in the parameter (1e-6 * g = 1.8e-5), and the multiplier moves 7e4 per unit
    g there: located to the parameter's bracket alone they were recorded with multipliers -0.989
    and 1.0097 (up to 0.7.2). A located point has its multiplier at its critical value to
    LOCATED_MULTIPLIER (1e-3). SciPy: each located orbit is a fixed point of its map, and its
    monodromy (central differences of 1e-8: at 1e-7 the map's curvature, d mu / d y ~ 5e4, costs
    2e-3) has a real multiplier within 1e-3 of -1 and of +1."""
    problem, _, _, found, _ = steep_branch
    located = {kind: orbit for kind, orbit in found}
    assert set(located) == {"fold", "period_doubling"}, found
    assert located["fold"].parameter - located["period_doubling"].parameter == pytest.approx(1.1e-5, rel=0.05)
    for kind, critical in (("period_doubling", -1.0), ("fold", 1.0)):
        orbit = located[kind]
        assert np.min(np.abs(orbit.multipliers - critical)) <= 1e-3, (kind, orbit.multipliers)
        touch = _touch_time(orbit)
        end_state, speeds = _three_legs(orbit.parameter, orbit.state, touch, 0.05)
        assert len(speeds) == 10 and np.max(np.abs(end_state - orbit.state)) < 1e-7
        mu = np.linalg.eigvals(_scipy_monodromy(orbit.parameter, orbit.state, touch, 0.05, h=1e-8))
        assert np.min(np.abs(mu - critical)) < 1e-3, (kind, mu)


@pytest.mark.slow
def test_the_doubling_beyond_the_corner_switches_onto_orbits_of_six_periods(steep_branch):
    """At the period doubling at g = 17.799031 the branch of six slow periods lives within 1e-5 of
    the doubling in state (its multiplier falls from +1 to 0.1 within 2e-5) and its g moves 1e-10
    there: the switch's first amplitude, 1e-4 * |y|, lay far outside it, and its corrector went to
    an orbit at g = 8.8 (up to 0.7.2: "no period-doubled branch"; the doubling was also located
    with its multiplier at -0.989). Now a 6-orbit is found and followed down in g, where the
    3-orbit is unstable (a supercritical flip). SciPy: two of its orbits are fixed points of SciPy's
    map of six slow periods (10 impacts in three periods, 20 in six) and not of its map of three
    (|P^3(y) - y| above 1e-5), so they are orbits of six periods, not the 3-orbit again."""
    from vrsweep.analysis import period_doubling

    problem, _, _, found, _ = steep_branch
    doubling = next(orbit for kind, orbit in found if kind == "period_doubling")
    branch, detail, _ = period_doubling.doubled_branch(problem, doubling, 17.7986, 17.79905, 12)
    assert branch is not None, detail
    six = [orbit for orbit in branch.orbits if orbit.parameter < doubling.parameter - 1e-6]
    assert branch.periods == 6 and len(six) >= 3
    assert all(orbit.parameter < doubling.parameter for orbit in branch.orbits[1:])
    for orbit in (six[0], six[len(six) // 2]):
        run = _real(orbit.parameter, orbit.state, 0.0, 6 * SLOW_PERIOD, 0.05)
        assert _impacts(run) == 20
        assert np.max(np.abs([run["x_final"], run["v_final"]] - orbit.state)) < 1e-7
        half = _real(orbit.parameter, orbit.state, 0.0, 3 * SLOW_PERIOD, 0.05)
        assert np.max(np.abs([half["x_final"], half["v_final"]] - orbit.state)) > 1e-5


@pytest.mark.slow
def test_the_doubling_of_the_11_impact_orbits_switches_onto_a_branch_that_leaves_it():
    """The 11-impact orbits past the corner double at g = 17.793014. The switch's first orbit lies
    8e-6 from the doubling, and the first step away from it landed on the period-3 branch, which
    passes there too, 2e-4 away: taken for the switched branch meeting its doubling, the branch
    ended at once with its first orbit (and up to 0.7.2 no orbit was found at all: the corrector
    went to g = 7.85). That step is now refused and retried shorter, and the branch of six periods
    is followed away from the doubling, up in g where the 3-orbit is unstable. SciPy: its last
    orbit is a fixed point of SciPy's map of six slow periods, with 22 impacts, and not of three."""
    from vrsweep.analysis import period_doubling

    # a short first step: one of 0.05 from here passes the doubling and the graze at 17.797473 at once
    problem = dataclasses.replace(_problem(1e-12), options=dict(continuation.DEFAULTS, max_step=0.05, initial_step=2e-5))
    # an 11-impact orbit of the branch below the doubling (multiplier -0.58), from the branch's state there
    start, failure = continuation.correct(problem, np.array([-2.64694289, 2.10048646, 17.793004]), PERIODS)
    assert failure is None and _count(start) == 11 and -1.0 < start.multipliers[0].real < 0.0
    _, found, _ = continuation.follow(problem, start, +1, 17.79, 17.80, 1)
    doubling = next(orbit for kind, orbit in found if kind == "period_doubling")
    # switched as `continue` does, its first step the default initial_step
    branch, detail, _ = period_doubling.doubled_branch(_problem(1e-12), doubling, 17.79, 17.80, 8)
    assert branch is not None, detail
    away = [orbit for orbit in branch.orbits if orbit.parameter > doubling.parameter + 1e-6]
    assert branch.periods == 6 and len(away) >= 3, branch.ends
    last = max(away, key=lambda orbit: orbit.parameter)
    run = _real(last.parameter, last.state, 0.0, 6 * SLOW_PERIOD, _resolving_step(last))
    assert _impacts(run) == 22
    assert np.max(np.abs([run["x_final"], run["v_final"]] - last.state)) < 1e-7
    half = _real(last.parameter, last.state, 0.0, 3 * SLOW_PERIOD, _resolving_step(last))
    assert np.max(np.abs([half["x_final"], half["v_final"]] - last.state)) > 1e-5


def test_a_doubling_and_a_fold_on_one_long_arc_are_both_located_with_critical_multipliers():
    """From g = 17.7 at max_step 0.5 (the docs' run) one step goes from the orbit at 17.798989
    (multiplier -2.34) to 17.798971 (+10.3) over the period doubling and the fold, 1.1e-5 apart in
    g. Within the location's bracket of 1.8e-5 in g the multiplier moves by 1.8 at the fold: up to
    0.7.2 both were recorded with multipliers 1.12 and -0.92, and a location that stops where the
    multiplier is 0.1 from critical records the fold unlocated. Both are located, each multiplier
    within 1e-3 of its critical value."""
    problem = _problem(1e-12)
    # the two orbits of that step, from the docs' run's states
    previous, failure = continuation.correct(problem, np.array([-2.6500579256, 2.1044122480, 17.798989128]), PERIODS)
    assert failure is None and previous.multipliers[0].real < -1.0
    current, failure = continuation.correct(problem, np.array([-2.6499159843, 2.1041701301, 17.798971060]), PERIODS)
    assert failure is None and current.multipliers[0].real > 1.0
    chord = current.z - previous.z
    tangent = continuation.tangent_of(previous, chord)
    found = continuation._detect(problem, previous, current, tangent, float(tangent @ chord), PERIODS)
    located = {kind: orbit for kind, orbit in found}
    assert set(located) == {"fold", "period_doubling"}, found
    assert located["period_doubling"].parameter < located["fold"].parameter
    assert np.min(np.abs(located["fold"].multipliers - 1.0)) <= 1e-3
    assert np.min(np.abs(located["period_doubling"].multipliers + 1.0)) <= 1e-3


def test_a_long_step_over_a_doubling_and_a_graze_locates_the_doubling():
    """From an 11-impact orbit past the corner (g = 17.793004, multiplier -0.58) one step of 0.05
    goes up in g over the orbits' period doubling at 17.793014 (the multiplier from -0.58 to -68,
    then to -145 as their 11th impact slows) and over their graze at 17.797473, onto the free
    side's 10-impact orbit (multiplier -0.07). det(M + I) has one sign at both ends: the doubling
    and the graze's jump undo each other, and up to 0.7.3 only the graze was recorded. Each side of
    the located graze is now tested on its own, up to that side's limit at the graze. SciPy: the
    located doubling is a fixed point of its map with 11 impacts, and its monodromy (central
    differences) has a multiplier within 1e-3 of -1."""
    problem = _problem(1e-12)  # max_step 0.05, initial_step 0.05
    start, failure = continuation.correct(problem, np.array([-2.64694289, 2.10048646, 17.793004]), PERIODS)
    assert failure is None and _count(start) == 11 and -1.0 < start.multipliers[0].real < 0.0
    orbits, found, _ = continuation.follow(problem, start, +1, 17.79, 17.80, 1)
    assert _count(orbits[0]) == 10 and orbits[0].parameter > 17.7975  # the one step passed both
    located = {kind: orbit for kind, orbit in found}
    assert set(located) == {"period_doubling", "grazing"}, found
    doubling = located["period_doubling"]
    assert 17.793004 < doubling.parameter < 17.79302 < located["grazing"].parameter
    assert np.min(np.abs(doubling.multipliers + 1.0)) <= 1e-3
    fine = _resolving_step(doubling)
    run = _real(doubling.parameter, doubling.state, 0.0, PERIODS * SLOW_PERIOD, fine)
    assert _impacts(run) == 11
    assert np.max(np.abs([run["x_final"], run["v_final"]] - doubling.state)) < 1e-7
    columns = []
    for k in range(2):
        d = np.zeros(2)
        d[k] = 1e-7
        ends = [_real(doubling.parameter, doubling.state + sign * d, 0.0, PERIODS * SLOW_PERIOD, fine)
                for sign in (1.0, -1.0)]
        columns.append((np.array([ends[0]["x_final"], ends[0]["v_final"]])
                        - np.array([ends[1]["x_final"], ends[1]["v_final"]])) / 2e-7)
    mu = np.linalg.eigvals(np.array(columns).T)
    assert np.min(np.abs(mu + 1.0)) < 1e-3, mu


def test_the_branch_switched_at_the_bubbles_first_doubling_goes_on_up_without_turning_back():
    """The branch of six slow periods born at the period-3 branch's doubling at g = 17.798688 curls
    within 1e-4 of it (its multiplier from +1 through -0.38 and back up to 0.29 by 17.798788). Its
    second step, from an orbit 5e-6 from the doubling, converged onto an orbit 1e-4 on (0.78 steps
    off the predictor), skipping the curl between, and the tangent there, oriented by the last one,
    pointed back along the branch: the branch walked back to its doubling and ended newton_failed
    there (up to 0.7.3). A step that lands more than half a step from its predictor is retried
    shorter, and the branch goes on up in g through the curl. SciPy: its orbits are fixed points of
    SciPy's map of six slow periods (20 impacts) and not of three."""
    from vrsweep.analysis import period_doubling

    problem = _problem(1e-12)
    doubling, failure = continuation.correct(
        problem, np.array([-2.6499651153970105, 2.10435423601687, 17.798688018805226]), PERIODS)
    assert failure is None and np.min(np.abs(doubling.multipliers + 1.0)) < 1e-3
    branch, detail, _ = period_doubling.doubled_branch(problem, doubling, 17.7986, 17.7991, 10)
    assert branch is not None, detail
    values = [orbit.parameter for orbit in branch.orbits]
    assert values[0] == doubling.parameter and len(values) >= 4, branch.ends
    assert np.all(np.diff(values) > 0.0), values  # away from the doubling, never back towards it
    for orbit in (branch.orbits[2], branch.orbits[-1]):
        run = _real(orbit.parameter, orbit.state, 0.0, 6 * SLOW_PERIOD, 0.05)
        assert _impacts(run) == 20
        assert np.max(np.abs([run["x_final"], run["v_final"]] - orbit.state)) < 1e-7
        half = _real(orbit.parameter, orbit.state, 0.0, 3 * SLOW_PERIOD, 0.05)
        assert np.max(np.abs([half["x_final"], half["v_final"]] - orbit.state)) > 1e-5


def test_the_period12_branch_keeps_to_its_own_orbits_and_scipy_confirms_them():
    """The branch of twelve slow periods born at the period-6 branch's doubling at g = 17.793026
    (44 impacts, its larger multiplier growing to -1e3) has, 2e-6 away in state, orbits whose
    large multiplier has the other sign (at g = 17.79326: -1483 on one, +1480 on the other).
    Steps of 1e-5 hopped between the two and recorded an unlocated fold and period doubling at each
    hop (17.793134, 17.793161, ... up to 0.7.3): the null vector of [M - I | F_lam] reverses
    across such a hop, which no step along one branch does (continuation._flips), and the step is
    retried shorter. SciPy: orbits of the branch are fixed points of SciPy's map of twelve slow
    periods with 44 impacts, and not of its map of six."""
    from vrsweep.analysis import period_doubling

    problem = _problem(1e-12)
    doubling, failure = continuation.correct(
        problem, np.array([-2.6469759712271563, 2.100529985398681, 17.793026432790715]), 6)
    assert failure is None and np.min(np.abs(doubling.multipliers + 1.0)) < 1e-3
    branch, detail, _ = period_doubling.doubled_branch(problem, doubling, 17.79, 17.80, 16)
    assert branch is not None and branch.periods == 12, detail
    assert not [kind for kind, _ in detail if kind.startswith("unlocated_")], detail
    values = [orbit.parameter for orbit in branch.orbits]
    assert values[-1] > 17.7931 and np.all(np.diff(values) > 0.0), values
    assert all(orbit.multipliers[0].real < -1.0 for orbit in branch.orbits[3:])
    for orbit in (branch.orbits[len(values) // 2], branch.orbits[-1]):
        run = _real(orbit.parameter, orbit.state, 0.0, 12 * SLOW_PERIOD, 0.01)
        assert _impacts(run) == 44
        assert np.max(np.abs([run["x_final"], run["v_final"]] - orbit.state)) < 1e-7
        half = _real(orbit.parameter, orbit.state, 0.0, 6 * SLOW_PERIOD, 0.01)
        assert np.max(np.abs([half["x_final"], half["v_final"]] - orbit.state)) > 1e-5
