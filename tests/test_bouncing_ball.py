"""A ball on a vibrating table (vrsweep/examples/bouncing_ball.yaml): a stop that moves, written
in the height above it (docs/models.md, "A moving stop"), against the closed forms of its period-1
orbit and against a reference in the table's frame of the lab, whose flights are the exact parabolas
x = x0 + u (t - t0) - (t - t0)^2 / 2 and whose impacts are the roots of x(t) = Gamma cos(t)
(brentq): no ODE solver.

The period-1 orbit's impact map (time t, the ball's speed u after the impact) has the fixed point
u = pi (flight 2 pi), where the table moves up at s'(t) = pi (1 - r)/(1 + r) = FOLD; its Jacobian
[[1, 1 + r], [(1 + r) a, (1 + r)^2 a + r^2]], a = s''(t) = -sqrt(Gamma^2 - FOLD^2), has det r^2 and
multipliers mu^2 - (1 + r^2 + (1 + r)^2 a) mu + r^2 = 0: a fold where a = 0 (Gamma = FOLD) and a
period doubling where a = -2 (1 + r^2)/(1 + r)^2 (Gamma = DOUBLING).
"""

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import vrsweep
from vrsweep.analysis import continuation
from vrsweep.config import load_config
from vrsweep.numerics.coefficients import grazing_scale
from vrsweep.numerics.models import kernels_for
from vrsweep.results import Status

EXAMPLE = Path(__file__).resolve().parents[1] / "vrsweep" / "examples" / "bouncing_ball.yaml"
R = 0.5  # the example's restitution


def fold(r):
    return math.pi * (1 - r) / (1 + r)


def doubling(r):
    return math.hypot(fold(r), 2 * (1 + r * r) / (1 + r) ** 2)


FOLD, DOUBLING = fold(R), doubling(R)


def multipliers(gamma, r=R):
    """The period-1 orbit's two Floquet multipliers, by modulus."""
    a = -math.sqrt(gamma ** 2 - fold(r) ** 2)
    return sorted(np.roots([1.0, -(1 + r * r + (1 + r) ** 2 * a), r * r]), key=abs)


def lab_frame(gamma, r, v0, transient, measured):
    """(Qc, Qs) of the height y = x - Gamma cos(t) above the table and Qc of the ball's own x, over
    ``measured`` periods 2 pi after ``transient``, from y = 0, y' = v0 at t = 0 (eq3.1, eq3.2)."""
    t0, x0, u = 0.0, gamma, v0  # the table is at Gamma and at rest at t = 0
    start, end = 2 * math.pi * transient, 2 * math.pi * (transient + measured)
    qc = qs = qc_x = 0.0
    while t0 < end:
        def height(t, t0=t0, x0=x0, u=u):
            return x0 + u * (t - t0) - 0.5 * (t - t0) ** 2 - gamma * math.cos(t)

        step, t1 = 0.01, t0 + 0.01
        while height(t1) > 0.0:  # flights of the orbits here last about 2 pi: steps of 0.01 miss none
            t1 += step
        t1 = brentq(height, t1 - step, t1, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        a, b = max(t0, start), min(t1, end)
        if a < b:
            qc += quad(lambda t: height(t) * math.cos(t), a, b, epsabs=1e-14, epsrel=1e-13, limit=200)[0]
            qs += quad(lambda t: height(t) * math.sin(t), a, b, epsabs=1e-14, epsrel=1e-13, limit=200)[0]
            qc_x += quad(lambda t: (height(t) + gamma * math.cos(t)) * math.cos(t), a, b, epsabs=1e-14,
                         epsrel=1e-13, limit=200)[0]
        table_speed = -gamma * math.sin(t1)
        u = table_speed - r * (u - (t1 - t0) - table_speed)  # the relative speed reverses, times r
        t0, x0 = t1, gamma * math.cos(t1)
    window = end - start
    return 2 * qc / window, 2 * qs / window, 2 * qc_x / window


@pytest.mark.parametrize("method", ["rk45", "dop853"])
def test_the_ball_lies_below_gamma_1_and_bounces_once_a_period_as_the_closed_forms_say(tmp_path, method):
    text = EXAMPLE.read_text().replace("Gamma: {start: 0.9, stop: 2.0, num: 221}",
                                       "Gamma: [0.95, 1.0, 1.2, 1.45, 1.6]")
    text = text.replace("  transient_periods: 300", f"  transient_periods: 300\n  method: {method}\n  rtol: 1.0e-10")
    (tmp_path / "ball.yaml").write_text(text)
    result = vrsweep.sweep(str(tmp_path / "ball.yaml"), output=str(tmp_path / "ball.h5"), progress=False)
    assert [Status(int(s)) for s in result["status"].values] == [Status.OK] * 5
    # Up to Gamma = 1 the table never falls faster than gravity: the ball comes to rest on it and
    # lies there (at Gamma = 1 its pull 1 - cos t only touches zero once a period; up to 0.7.17 the
    # ball was let go there and met the table again at speed 0, 1.28 "impacts" a period)
    for gamma in (0.95, 1.0):
        lying = result.sel(Gamma=gamma)
        assert float(lying["stuck_fraction"]) == 1.0 and float(lying["impacts_per_period"]) == 0.0, gamma
        assert float(lying["R"]) == 0.0 and float(lying["x_max"]) == 0.0, gamma
    for gamma in (1.2, 1.45):
        point = result.sel(Gamma=gamma)
        assert int(point["period"]) == 1 and float(point["impacts_per_period"]) == 1.0
        for speed in ("impact_speed_min", "impact_speed_max"):  # relative to the table
            assert float(point[speed]) == pytest.approx(2 * math.pi / (1 + R), rel=1e-10)
        # the table meets the ball moving up at FOLD and slowing down (the stable one of two)
        assert float(point["impact_phase"]) == pytest.approx(2 * math.pi - math.asin(FOLD / gamma), abs=1e-10)
        qc, qs, qc_x = lab_frame(gamma, R, 2.0, 300, 64)
        assert float(point["R"]) == pytest.approx(math.hypot(qc, qs) / gamma, rel=1e-9)
        # the ball's own response: x = y + Gamma cos(t) adds Gamma to Qc (docs/models.md)
        assert float(point["Qc"]) + gamma == pytest.approx(qc_x, rel=1e-9)
    assert int(result.sel(Gamma=1.6)["period"]) == 2  # beyond DOUBLING = 1.5268


@pytest.mark.parametrize("gamma", [0.5, 1.0])
def test_a_ball_laid_on_the_table_lies_there_with_no_impact(gamma):
    """Laid on the table at t = 0 (y = 0, y' = 0), where its force on it, 1 - Gamma cos t, is 0 at
    Gamma = 1 and presses from there on: the ball is stuck from t = 0 to the end, and nothing hits
    the table (up to 0.7.17 a ball under no force was let fly, and met the table at speed 8e-25
    at t = 1.5e-8)."""
    from vrsweep.config import parse_config
    from vrsweep.numerics.trajectory import settings_vector, simulate

    config = parse_config(EXAMPLE.read_text(), "ball.yaml", [f"Gamma={gamma}", "initial.v=0"])
    coefficients = kernels_for(config.model).coefficients(config.parameters)
    settings = settings_vector(rtol=1e-10, atol=1e-12, transient_periods=2, measure_periods=2)
    run = simulate(coefficients, [0.0, 0.0], settings, method="rk45", model=config.model)
    assert run.status == Status.OK
    assert len(run.impacts) == 0, run.impacts
    assert run.sticks.tolist() == [[0.0, 4 * 2 * math.pi]]


def test_continuation_finds_the_fold_and_the_doubling_and_follows_them_in_r(tmp_path, invoke):
    branch = tmp_path / "branch.h5"
    done = invoke("continue", EXAMPLE, "-o", branch, "-q")
    assert done.exit_code == 0, done.output
    with h5py.File(branch, "r") as f:
        kinds = [k.decode() for k in f["bifurcation_kind"][()]]
        located = f["bifurcation_parameter"][()]
        assert kinds == ["fold", "period_doubling"], kinds
        assert located == pytest.approx([FOLD, DOUBLING], abs=1e-8)
        # through the fold onto the unstable orbits, to the end of the range both ways
        assert [s.decode() for s in (f["branch_end_first_status"][0], f["branch_end_last_status"][0])] == [
            "left_range", "left_range"]
        gammas, stable = f["parameter"][()], f["stable"][()]
        found = f["multiplier_real"][()] + 1j * f["multiplier_imag"][()]
    checked = 0
    for gamma, mu, is_stable in zip(gammas, found, stable):
        if is_stable and gamma > FOLD + 1e-3:  # the stable orbits: a = -sqrt(Gamma^2 - FOLD^2)
            expected = multipliers(gamma)
            assert sorted(mu, key=abs) == pytest.approx(expected, abs=1e-6), gamma
            checked += 1
    assert checked >= 8
    for point, form in ((0, fold), (1, doubling)):
        curve = tmp_path / f"curve{point}.h5"
        done = invoke("continue", branch, "--point", point, "--along", "r", "--to", 0.3, 0.8, "-o", curve, "-q")
        assert done.exit_code == 0, done.output
        with h5py.File(curve, "r") as f:
            gamma, r = f["Gamma"][()], f["r"][()]
        assert len(r) >= 20 and r.max() - r.min() > 0.1
        assert gamma == pytest.approx([form(value) for value in r], abs=1e-6)


def test_a_model_with_its_only_stop_below_is_near_a_graze_only_where_an_impact_is_slow():
    """Up to 0.7.14 the grazing tests' length was max(1, |Delta|) with Delta = +inf (no stop
    above), so every impact counted as slow and every orbit as next to a graze: the bouncing ball
    written with Gamma sin(t), whose fold puts its impact on the section t = 0, ended its branch
    there as "grazing: the orbit impacts at zero speed" at impacts of speed 4.19, and recorded a
    graze that is not there."""
    config = load_config(EXAMPLE)
    coefficients = kernels_for(config.model).coefficients(config.parameters)
    assert grazing_scale(coefficients) == 1.0
    problem = type("Problem", (), {"coefficients": staticmethod(lambda value: coefficients)})()

    def orbit(speed):
        return continuation.Orbit(parameter=1.25, state=np.zeros(2), periods=1, monodromy=np.eye(2), R=2.3,
                                  Q_amplitude=2.9, impacts_per_period=1.0, x_max=3.0, slowest_impact=speed,
                                  residual=0.0, newton_iterations=1, free_x_max=3.0)

    assert not continuation._near_grazing(problem, orbit(2 * math.pi / (1 + R)))
    assert continuation._near_grazing(problem, orbit(1e-3))


def test_a_stop_written_as_moving_says_how_to_write_it(tmp_path, invoke):
    text = EXAMPLE.read_text().replace("position: 0, side: below", 'position: "0.1*cos(t)", side: below')
    (tmp_path / "moving.yaml").write_text(text)
    done = invoke("validate", tmp_path / "moving.yaml")
    assert done.exit_code == 2
    lines = done.output.strip().splitlines()
    assert len(lines) == 1 and "model.barriers[0].position: depends on t" in lines[0], done.output
    assert 'y = x - s(t)' in lines[0] and '"A moving stop: write the model in the distance to it"' in lines[0]
    # a restitution or a period that depends on t keeps the plain message
    text = EXAMPLE.read_text().replace("restitution: r}", 'restitution: "r*cos(t)"}')
    (tmp_path / "restitution.yaml").write_text(text)
    done = invoke("validate", tmp_path / "restitution.yaml")
    assert done.exit_code == 2 and "depends on t" in done.output and "a stop that moves" not in done.output, done.output
