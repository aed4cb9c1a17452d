"""Plastic impacts (r = 0), chatter into sticking, and starts on a barrier, for written models.

The kernel against an independent SciPy reference written here, which models sticking explicitly:
at an impact whose rebound is slower than the stick speed while the force at rest on the stop
presses the mass into it, x is held at the stop and v at 0 up to the root of that force, found by
scanning and brentq; the quadratures of eq3.1-eq3.2 are added in closed form while stuck. And
against closed forms: the release of x'' = -2 zeta v - x + F cos(omega t) from x = Delta is at
F cos(omega t) = Delta, omega t = acos(Delta / F) (mod 2 pi).

The examples' own models run here (impact_linear, impact_two_sided), so no kernel is compiled
for this file alone.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from vrsweep.config import parse_config
from vrsweep.errors import ConfigError
from vrsweep.numerics import kernel
from vrsweep.numerics.coefficients import SCAN_STEP
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.trajectory import settings_vector, simulate
from vrsweep.results import Status

LINEAR = """\
model:
  acceleration: "-2*zeta*v - x + F*cos(omega*t + phi)"
  parameters: {zeta: 0.1, F: 1.0, omega: 0.8, phi: 0.0, Delta: 0.5, r: 0.0}
  barriers:
    - {position: Delta, side: above, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
"""

TWO_SIDED = """\
model:
  acceleration: "-2*zeta*v - x + F*cos(omega*t)"
  parameters: {zeta: 0.05, F: 1.0, omega: 0.7, Delta: 0.5, r: 0.3}
  barriers:
    - {position: Delta, side: above, restitution: r}
    - {position: -Delta, side: below, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
"""

STICK = 1e-7  # the stick speed of both (the default): flights slower than it rise 1e-14, near rounding
# and a rebound rising less than 16 ulps of max(1, |position|) sticks too: its flight is rounding
STICK_HEIGHT = 16 * 2.0 ** -52


def _run(text, n_transient, n_measure, overrides=(), method="rk45"):
    config = parse_config(text, "m.yaml", list(overrides))
    coefficients = kernels_for(config.model).coefficients(config.parameters)
    settings = settings_vector(rtol=1e-11, atol=1e-13, transient_periods=n_transient,
                               measure_periods=n_measure, stick_velocity=STICK)
    return config, simulate(coefficients, [config.initial["x"], config.initial["v"]], settings,
                            method=method, model=config.model)


def reference(acc, barriers, x0, v0, omega, n_transient, n_measure):
    """x'' = acc(t, x, v) with stops [(position, side, r)] (side +1: x <= position), sticking
    modelled explicitly. Returns |Q| over the window, impacts in the window, the smallest x in it,
    the stuck time in it, every stick (start, end) and every impact time."""
    T = 2 * math.pi / omega

    def rhs(t, y):
        return [y[1], acc(t, y[0], y[1]), y[0] * math.cos(omega * t), y[0] * math.sin(omega * t)]

    def pressed(t, position, side):
        return side * acc(t, position, 0.0) > 0.0

    def event(position, side):
        def reach(t, y):
            return side * (y[0] - position)
        reach.terminal, reach.direction = True, 1.0
        return reach

    events = [event(p, s) for p, s, _ in barriers]
    t, y = 0.0, np.array([x0, v0, 0.0, 0.0])
    start, end = n_transient * T, (n_transient + n_measure) * T
    q_start = np.zeros(2) if n_transient == 0 else None
    impacts, sticks, x_min = [], [], math.inf
    stuck_on = next((b for b in barriers if x0 == b[0] and v0 == 0.0 and pressed(0.0, b[0], b[1])), None)
    k = 1  # the period being integrated: its end is boundary = k T
    boundary = T
    while k <= n_transient + n_measure:
        if stuck_on is not None:
            position, side, _ = stuck_on
            s, scan = t, T / 256
            while pressed(s + scan, position, side):
                s += scan
            release = brentq(lambda u: side * acc(u, position, 0.0), s, s + scan, xtol=1e-15)
            while pressed(release, position, side):
                release = np.nextafter(release, math.inf)
            stop = min(release, boundary)
            y[2] += position * (math.sin(omega * stop) - math.sin(omega * t)) / omega
            y[3] += position * (math.cos(omega * t) - math.cos(omega * stop)) / omega
            sticks.append((t, stop))
            t = stop
            if stop == release:
                stuck_on = None
        else:
            kw = {}
            if any(y[0] == p for p, _, _ in barriers) and y[1] != 0.0:
                # leaving a stop: the first step ends inside the flight, else SciPy's event search
                # starts where the event function is 0 and returns the start itself
                kw["first_step"] = min(0.25 * abs(y[1]) / (abs(acc(t, y[0], y[1])) + 1e-300), boundary - t)
            solution = solve_ivp(rhs, (t, boundary), y, method="DOP853", rtol=1e-12, atol=1e-14,
                                 events=events, dense_output=True, **kw)
            if solution.t[-1] > start:
                times = np.linspace(max(t, start), solution.t[-1], 200)
                x, v = solution.sol(times)[:2]
                x_min = min(x_min, x.min())
                for i in np.nonzero((v[:-1] < 0) & (v[1:] >= 0))[0]:  # minima: located on the dense output
                    turn = brentq(lambda u: solution.sol(u)[1], times[i], times[i + 1], xtol=1e-14)
                    x_min = min(x_min, solution.sol(turn)[0])
            t, y = solution.t[-1], solution.y[:, -1].copy()
            if solution.status == 1:
                hit = next(i for i, e in enumerate(solution.t_events) if len(e))
                position, side, r = barriers[hit]
                y[0], y[1] = position, -r * y[1]
                impacts.append(t)
                if pressed(t, position, side) and (abs(y[1]) < STICK or y[1] ** 2 < 2 * side * acc(
                        t, position, 0.0) * STICK_HEIGHT * max(1.0, abs(position))):
                    y[1] = 0.0
                    stuck_on = barriers[hit]
        if t == boundary:
            if k == n_transient:
                q_start = y[2:].copy()
            k += 1
            boundary = k * T
    q = 2.0 / (n_measure * T) * (y[2:] - q_start)
    in_window = [s for s in sticks if s[0] >= start - 1e-9]
    return dict(Q=math.hypot(*q), impacts=sum(1 for s in impacts if s >= start), x_min=x_min,
                stuck=sum(b - a for a, b in in_window), sticks=sticks, impact_times=impacts)


def _merged(sticks):
    """The reference's sticks cut at period boundaries, joined back into intervals."""
    joined = []
    for a, b in sticks:
        if joined and abs(joined[-1][1] - a) < 1e-12:
            joined[-1][1] = b
        else:
            joined.append([a, b])
    return np.array(joined)


def _linear(p):
    return lambda t, x, v: -2 * p["zeta"] * v - x + p["F"] * math.cos(p["omega"] * t + p["phi"])


@pytest.mark.parametrize("F", [0.3, 1.0])
def test_a_plastic_impact_sticks_while_the_force_presses_and_matches_scipy(F):
    """r = 0: F = 0.3 never presses (the mass lands at rest and leaves at once), F = 1.0 sticks for
    a part of every period. R, impacts, x_min and the stuck time against the reference."""
    n_transient, n_measure = 30, 10
    config, run = _run(LINEAR, n_transient, n_measure, [f"F={F}"])
    assert run.status == Status.OK
    p = config.parameters
    ref = reference(_linear(p), [(p["Delta"], 1.0, 0.0)], 0.0, 0.0, p["omega"], n_transient, n_measure)
    window = run.period_records[n_transient:]
    assert run.summary[kernel.SUM_R] == pytest.approx(ref["Q"] / F, rel=1e-8)
    assert window[:, kernel.REC_IMPACTS].sum() == ref["impacts"] == n_measure
    assert window[:, kernel.REC_X_MIN].min() == pytest.approx(ref["x_min"], abs=1e-8)
    assert window[:, kernel.REC_STUCK_TIME].sum() == pytest.approx(ref["stuck"], abs=1e-8)
    assert (ref["stuck"] > 1.0) == (F == 1.0)


def test_a_plastic_impacts_release_is_where_the_force_lets_go_in_closed_form():
    """Released where -Delta + F cos(omega t) turns negative: omega t = acos(Delta / F) mod 2 pi;
    each stick starts at an impact, which the reference places to 1e-9."""
    config, run = _run(LINEAR, 0, 8)
    p = config.parameters
    assert run.status == Status.OK and len(run.sticks) == 9  # the last one lasts to the run's end
    phase = np.mod(p["omega"] * run.sticks[:-1, 1], 2 * math.pi)
    np.testing.assert_allclose(phase, math.acos(p["Delta"] / p["F"]), rtol=0, atol=1e-11)
    ref = reference(_linear(p), [(p["Delta"], 1.0, 0.0)], 0.0, 0.0, p["omega"], 0, 8)
    np.testing.assert_allclose(run.sticks[:, 0], _merged(ref["sticks"])[:, 0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.impacts[:, 2], 0.0, rtol=0, atol=0)  # plastic: nothing rebounds


@pytest.mark.parametrize("method", ["rk45", "dop853"])
def test_chatter_into_sticking_at_both_stops_matches_scipy(method):
    """r = 0.3 in a gap: the rebounds die out geometrically (a Zeno sequence), the mass sticks at
    the upper stop and then at the lower one. R, impacts, x_min and stuck time against the reference."""
    n_transient, n_measure = 20, 5
    config, run = _run(TWO_SIDED, n_transient, n_measure, method=method)
    p = config.parameters
    acc = lambda t, x, v: -2 * p["zeta"] * v - x + p["F"] * math.cos(p["omega"] * t)  # noqa: E731
    ref = reference(acc, [(p["Delta"], 1.0, p["r"]), (-p["Delta"], -1.0, p["r"])], 0.0, 0.0, p["omega"],
                    n_transient, n_measure)
    window = run.period_records[n_transient:]
    assert run.status == Status.OK
    assert window[:, kernel.REC_IMPACTS].sum() == ref["impacts"] > 10 * n_measure
    assert window[:, kernel.REC_X_MIN].min() == pytest.approx(ref["x_min"], abs=1e-9)
    assert window[:, kernel.REC_STUCK_TIME].sum() == pytest.approx(ref["stuck"], abs=1e-8)
    assert run.summary[kernel.SUM_R] == pytest.approx(ref["Q"] / p["F"], rel=1e-8)


# --- a start on a barrier ------------------------------------------------------------------------

def test_a_start_at_rest_pressed_onto_the_stop_is_stuck_from_t0_not_an_impact():
    """x(0) = Delta, v(0) = 0 with -Delta + F > 0: a mass laid on the stop stays there until
    omega t = acos(Delta / F); nothing hit it at t = 0 (before, the first step logged an impact
    of speed 0)."""
    config, run = _run(LINEAR, 0, 4, ["initial.x=0.5", "initial.v=0"])
    p = config.parameters
    assert run.status == Status.OK
    assert run.sticks[0, 0] == 0.0
    assert run.sticks[0, 1] == pytest.approx(math.acos(p["Delta"] / p["F"]) / p["omega"], abs=1e-12)
    assert run.impacts[0, 0] > run.sticks[0, 1]  # the first impact is the return after the release
    ref = reference(_linear(p), [(p["Delta"], 1.0, 0.0)], 0.5, 0.0, p["omega"], 0, 4)
    np.testing.assert_allclose(run.impacts[:, 0], ref["impact_times"], rtol=0, atol=1e-8)


def test_a_start_at_rest_under_no_force_is_stuck_until_the_force_pulls_and_then_moves_as_scipy():
    """x(0) = Delta, v(0) = 0 with F = Delta: the force at rest, -Delta + F cos(omega t), is 0 at
    t = 0 and pulls from there on. The mass under no force stays at rest until the pull (a zero
    keeps the mode, as at a release: impact.release_time), which in doubles begins where
    cos(omega t) falls below 1, 1.5e-8 / omega on; from there it moves as SciPy's free start does."""
    config, run = _run(LINEAR, 0, 4, ["initial.x=0.5", "initial.v=0", "F=0.5", "r=0.5"])
    p = config.parameters
    assert run.status == Status.OK
    assert run.sticks[0, 0] == 0.0 and 0.0 < run.sticks[0, 1] < 2e-8 / p["omega"]
    ref = reference(_linear(p), [(p["Delta"], 1.0, 0.5)], 0.5, 0.0, p["omega"], 0, 4)
    assert len(run.impacts) == len(ref["impact_times"]) > 0
    assert run.impacts[0, 0] > 0.1  # nothing at t = 0
    np.testing.assert_allclose(run.impacts[:, 0], ref["impact_times"], rtol=0, atol=1e-8)


@pytest.mark.parametrize("v0, F", [(0.0, 0.3), (-0.4, 1.0)])
def test_a_start_on_the_stop_leaving_it_matches_scipy(v0, F):
    """At rest with the force pulling away (-Delta + 0.3 < 0), or moving away: the state after a
    release or a rebound. Impact times against the reference."""
    config, run = _run(LINEAR, 0, 4, ["initial.x=0.5", f"initial.v={v0}", f"F={F}", "r=0.5"])
    p = config.parameters
    assert run.status == Status.OK
    ref = reference(_linear(p), [(p["Delta"], 1.0, 0.5)], 0.5, v0, p["omega"], 0, 4)
    assert len(run.impacts) == len(ref["impact_times"]) > 0
    assert run.impacts[0, 0] > 0.1  # nothing at t = 0
    np.testing.assert_allclose(run.impacts[:, 0], ref["impact_times"], rtol=0, atol=1e-8)


@pytest.mark.parametrize("text, overrides, field", [
    (LINEAR, ["initial.x=0.5", "initial.v=0.1"], "--set initial.v=0.1: initial.v: must be <= 0 where "
                                                 "the mass starts on a barrier (initial.x is on model.barriers[0] at 0.5)"),
    (TWO_SIDED, ["initial.x=-0.5", "initial.v=-0.1"], "--set initial.v=-0.1: initial.v: must be >= 0 where "
                                                      "the mass starts on a barrier (initial.x is on model.barriers[1] at -0.5)"),
    ("parameters: {Delta: 1.0}\ninitial: {x: 1.0, v: 0.2}\n", [],
     "m.yaml:2: initial.v: must be <= 0 where the mass starts on the barrier (x = Delta = 1.0)"),
])
def test_a_start_on_a_barrier_moving_into_it_is_refused_saying_why(text, overrides, field):
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "m.yaml", overrides)
    (problem,) = caught.value.problems
    assert problem.startswith(field), problem
    assert "the instant before an impact, not a state" in problem


@pytest.mark.parametrize("text, overrides", [
    (LINEAR, ["initial.x=0.5", "initial.v=0"]),
    (LINEAR, ["initial.x=0.5", "initial.v=-1"]),
    (TWO_SIDED, ["initial.x=-0.5", "initial.v=0.3"]),
    ("parameters: {Delta: 1.0}\ninitial: {x: 1.0, v: -0.2}\n", []),
    ("parameters: {Delta: 1.0}\nsweep: {x0: [0.0, 1.0], v0: [-1, 0]}\n", []),
])
def test_a_start_on_a_barrier_resting_or_leaving_is_accepted(text, overrides):
    parse_config(text, "m.yaml", overrides)


@pytest.mark.parametrize("text, expected", [
    (LINEAR.replace("initial: {x: 0.0, v: 0.0}", "initial: {x: 0.5}"),
     "m.yaml:8: initial.x: must be below model.barriers[0], or on it only at rest or moving away: the config "
     "gives no initial.v, and the default 0.5 moves into the barrier"),
    ("initial: {x: 1.0}\n", "m.yaml:1: initial.x: must be below parameters.Delta = 1.0, or on it only at rest or "
                            "moving away: the config gives no initial.v, and the default 0.5 moves into the barrier"),
])
def test_a_start_on_a_barrier_with_the_default_velocity_blames_the_position_written(text, expected):
    """initial.v = 0.5 is the default when only x is written: the line the user wrote is blamed."""
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "m.yaml")
    (problem,) = caught.value.problems
    assert problem.startswith(expected), problem


DIP = LINEAR.replace('"-2*zeta*v - x + F*cos(omega*t + phi)"', '"-2*zeta*v - x + F*cos(omega*t + phi) + F2*cos(9*omega*t)"') \
    .replace("phi: 0.0, Delta: 0.5", "phi: 0.0, F2: 0.3, Delta: 0.64")


def test_the_release_scan_follows_the_fastest_forcing_not_the_step_cap():
    """-Delta + cos(omega t) + 0.3 cos(9 omega t) at rest on the stop turns negative for 0.031 rad
    of omega t at a time (0.3482-0.3794, 5.9038-5.9350), shorter than the scan of max_step / 8 =
    T / 64 = 0.098 rad: the mass stayed stuck through both (stuck_fraction 0.216 for 0.196).
    Now the scan is 1/64 of the shortest forcing period, 2 pi / (9 omega), as the paper's models'
    is: every stick ends where that force turns negative, and none holds a moment where it is."""
    config, run = _run(DIP, 0, 6)
    p = config.parameters
    T = 2 * math.pi / p["omega"]

    def force(t):
        return -p["Delta"] + p["F"] * np.cos(p["omega"] * t) + p["F2"] * np.cos(9 * p["omega"] * t)

    assert run.status == Status.OK and len(run.sticks) > 6
    for start, end in run.sticks[:-1]:  # the last one may last to the run's end
        inside = np.linspace(start, end, 20000)[1:-1]
        assert np.all(force(inside) > 0.0), (start, end)
        assert force(end) == pytest.approx(0.0, abs=1e-12) and force(end + 1e-6) < 0.0
    phases = np.mod(p["omega"] * run.sticks[:-1, 1], 2 * math.pi)
    roots = [brentq(lambda u: force(u / p["omega"]), a, b, xtol=1e-14) for a, b in ((0.34, 0.35), (5.90, 5.91))]
    assert np.min(np.abs(phases[:, None] - np.array(roots)[None, :])) < 1e-9  # a short pull releases it
    vectors = kernels_for(config.model).coefficients(config.parameters)
    assert vectors[SCAN_STEP] == pytest.approx(2 * math.pi / (9 * p["omega"]) / 64, rel=1e-15)


POWER = """\
model:
  acceleration: "-2*zeta*v - x + F0 - F2*cos(omega*t + phi)**9"
  parameters: {zeta: 0.1, F0: 1.0, F2: 0.5005, omega: 0.8, phi: 1.0, Delta: 0.5, r: 0.0}
  barriers:
    - {position: Delta, side: above, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F0}
initial: {x: 0.0, v: 0.0}
"""


def test_the_release_scan_follows_a_power_of_a_cosine_at_its_highest_harmonic():
    """At rest on the stop the force 0.5 - 0.5005 cos(omega t + 1)**9 pulls away only where
    cos(...)**9 > 0.999, for 0.030 rad of omega t a period: shorter than a scan of 1/64 of
    2 pi / omega (0.098 rad), which was the step because cos(omega t + 1) was the only term
    found. The mass stayed stuck through 7 of the 8 pulls (2 impacts in 8 periods for the
    reference's 9, stuck 0.52 too long). cos**9 holds cos(9 (omega t + 1)): the scan is 1/64 of
    2 pi / (9 omega) (codegen.forcing_spectrum), and R, the impacts and the stuck time are the
    reference's."""
    n_transient, n_measure = 0, 8
    config, run = _run(POWER, n_transient, n_measure)
    p = config.parameters

    def acc(t, x, v):
        return -2 * p["zeta"] * v - x + p["F0"] - p["F2"] * math.cos(p["omega"] * t + p["phi"]) ** 9

    ref = reference(acc, [(p["Delta"], 1.0, 0.0)], 0.0, 0.0, p["omega"], n_transient, n_measure)
    window = run.period_records[n_transient:]
    assert run.status == Status.OK
    assert window[:, kernel.REC_IMPACTS].sum() == ref["impacts"] == 9
    assert window[:, kernel.REC_STUCK_TIME].sum() == pytest.approx(ref["stuck"], abs=1e-7)
    assert run.summary[kernel.SUM_R] == pytest.approx(ref["Q"] / p["F0"], rel=1e-9)
    vectors = kernels_for(config.model).coefficients(config.parameters)
    assert vectors[SCAN_STEP] == pytest.approx(2 * math.pi / (9 * p["omega"]) / 64, rel=1e-15)


@pytest.mark.parametrize("method", ["rk45", "dop853"])
def test_a_stiff_chatters_tail_sticks_where_its_flights_are_rounding(method):
    """F = 2e4 presses the mass into the stops with up to 2e4: a rebound at the stick speed 1e-7
    rises 2.5e-19, far below the position's ulp, and whether the next impact was seen at all was
    rounding: 178 impacts a period with rk45, 181 to 186 with dop853, 190 in the reference, for
    one orbit. A rebound rising less than 16 ulps of max(1, |position|) now sticks
    (kernel.STICK_HEIGHT): both methods and the reference, with the same rule, count 150 a period,
    with R and the stuck time the reference's."""
    n_transient, n_measure = 2, 3
    config, run = _run(TWO_SIDED, n_transient, n_measure, ["F=20000", "Delta=1.0", "omega=1.0", "r=0.8"],
                       method=method)
    p = config.parameters
    assert kernel.STICK_HEIGHT == STICK_HEIGHT

    def acc(t, x, v):
        return -2 * p["zeta"] * v - x + p["F"] * math.cos(p["omega"] * t)

    ref = reference(acc, [(p["Delta"], 1.0, p["r"]), (-p["Delta"], -1.0, p["r"])], 0.0, 0.0, p["omega"],
                    n_transient, n_measure)
    window = run.period_records[n_transient:]
    assert run.status == Status.OK
    assert list(window[:, kernel.REC_IMPACTS]) == [150.0] * n_measure
    assert ref["impacts"] == 150 * n_measure
    assert window[:, kernel.REC_STUCK_TIME].sum() == pytest.approx(ref["stuck"], abs=1e-8)
    assert run.summary[kernel.SUM_R] == pytest.approx(ref["Q"] / p["F"], rel=1e-10)
