"""A symmetry-breaking pitchfork (a branch point) on a symmetric branch.

The Duffing oscillator between two stops of test_continuation_double_graze.py (its orbits
symmetric under x -> -x, t -> t + T/2), continued in omega at F = 0.4 on its symmetric period-1
orbits with an impact on each stop. Under the symmetry a real multiplier through +1 without a
fold is generic: two asymmetric branches (mirror images) are born and the symmetric one goes
on, unstable. There the fold test det(M - I) changes sign with the parameter not turning, so the
null vector of [M - I | F_lam] reverses; up to 0.7.8 the branch ended there, "the corrector keeps
hopping onto another family of orbits" (at omega = 1.0689639).

The test checks the located branch point against SciPy's own symmetric orbits (fsolve on a map
with impact events on both stops) on both sides of it: their largest real multiplier crosses +1
at the located omega, and they exist on both sides (the parameter does not turn there). With
--switch (analysis/branch_point.py) the asymmetric orbits born there are followed, each half a
branch of its own: SciPy's map returns to them, its flow does not take them to their mirror
images, and the mirror images are the other half's orbits.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

from vrsweep.analysis import branch_point, continuation
from vrsweep.config import load_config
from vrsweep.execution.continuation import run_continuation

ZETA, BETA, F, D, R = 0.05, 0.3, 0.4, 1.0, 0.7
CONFIG = """\
model:
  name: Duffing between two stops
  acceleration: "-2*zeta*v - x - beta*x**3 + F*cos(omega*t)"
  parameters: {zeta: 0.05, beta: 0.3, F: 0.4, omega: 1.1, d: 1.0, r: 0.7}
  barriers:
    - {position: d, side: above, restitution: r}
    - {position: -d, side: below, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
integration: {rtol: 1.0e-11, atol: 1.0e-13, transient_periods: 300}
continuation: {parameter: omega, from: 1.1, to: [1.05, 1.1], max_step: 0.05}
"""


@pytest.fixture(scope="module")
def switched(tmp_path_factory):
    path = tmp_path_factory.mktemp("branch_point_switched") / "config.yaml"
    path.write_text(CONFIG.replace("max_step: 0.05", "max_step: 0.005"))  # orbits enough on each half to check
    failures = []
    branches, found = run_continuation(load_config(path), switch=True, failures=failures)
    return branches, found, failures


@pytest.fixture(scope="module")
def branch(tmp_path_factory):
    path = tmp_path_factory.mktemp("branch_point") / "config.yaml"
    path.write_text(CONFIG)
    branches, found = run_continuation(load_config(path))
    return branches[0], found


def _flow(y0, omega, t0, t1, max_step=math.inf):
    """SciPy's flow from t0 to t1 with both stops (events, x' -> -r x'): (end state, impacts)."""
    def rhs(t, y):
        return [y[1], -2 * ZETA * y[1] - y[0] - BETA * y[0] ** 3 + F * math.cos(omega * t)]

    def top(t, y):
        return y[0] - D
    top.terminal, top.direction = True, 1.0

    def bottom(t, y):
        return y[0] + D
    bottom.terminal, bottom.direction = True, -1.0

    t, y, impacts = t0, np.array(y0, dtype=float), 0
    while True:
        solution = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=1e-12, atol=1e-14, events=(top, bottom),
                             max_step=max_step)
        if solution.status != 1:
            return solution.y[:, -1], impacts
        hit = 0 if solution.t_events[0].size else 1
        t = float(solution.t_events[hit][0])
        y = solution.y_events[hit][0].copy()
        y[0] = D if hit == 0 else -D
        y[1] = -R * y[1]
        impacts += 1


def _scipy_orbit(y_guess, omega):
    """SciPy's period-1 orbit near y_guess: (state, its largest real multiplier, half-period state)."""
    period = 2.0 * math.pi / omega
    y = fsolve(lambda y: _flow(y, omega, 0.0, period)[0] - y, y_guess, xtol=1e-13)
    h = 1e-6
    columns = [(_flow(y + h * e, omega, 0.0, period)[0] - _flow(y - h * e, omega, 0.0, period)[0]) / (2 * h)
               for e in np.eye(2)]
    mu = np.linalg.eigvals(np.array(columns).T)
    real = mu[np.abs(mu.imag) < 1e-9].real
    assert real.size, mu
    return y, float(real.max()), _flow(y, omega, 0.0, 0.5 * period)[0]


def test_the_symmetric_branch_goes_through_its_branch_point_where_scipy_puts_it(branch):
    orbits, found = branch
    # Up to 0.7.8: ended newton_failed, "the corrector keeps hopping onto another family of orbits".
    assert all(status == continuation.ENDED_RANGE for status, _ in orbits.ends.values()), orbits.ends
    points = [b.orbit for b in found if b.kind == continuation.BRANCH_POINT]
    assert len(points) == 1, [(b.kind, b.orbit.parameter) for b in found]
    assert not any(b.kind in ("fold", continuation.UNLOCATED_PREFIX + "fold") for b in found)
    point = points[0]
    assert abs(max(point.multipliers.real) - 1.0) <= continuation.LOCATED_MULTIPLIER
    assert continuation._sine_to_range(point) <= continuation.BRANCH_POINT_RANK
    # The branch goes on through it: orbits on both sides.
    assert min(o.parameter for o in orbits.orbits) < point.parameter - 0.01
    assert max(o.parameter for o in orbits.orbits) > point.parameter + 0.01
    # SciPy's symmetric orbits on both sides: the multiplier crosses +1 at the located omega.
    delta = 1e-4
    sides = []
    for omega in (point.parameter - delta, point.parameter + delta):
        y, mu, half = _scipy_orbit(point.state, omega)
        np.testing.assert_allclose(half, -y, rtol=0, atol=1e-9)  # symmetric: x -> -x after T/2
        assert _flow(y, omega, 0.0, 2.0 * math.pi / omega)[1] == 2
        sides.append(mu)
    assert (sides[0] - 1.0) * (sides[1] - 1.0) < 0.0, sides
    crossing = point.parameter - delta + 2 * delta * (1.0 - sides[0]) / (sides[1] - sides[0])
    assert abs(crossing - point.parameter) < 1e-6, (crossing, point.parameter, sides)
    # Measured: located at omega = 1.06896121, SciPy's crossing 3.8e-8 from it (multipliers 1.0036768
    # and 0.9963261 at -+1e-4), range sine 7.6e-5 (0.7.10's rank ratio 1.5e-5), multiplier 0.99999998.
    #
    # The branch's orbits on both sides are SciPy's symmetric orbits: its flow with both stops takes
    # each to its mirror image in half a period.
    near = sorted(orbits.orbits, key=lambda o: abs(o.parameter - point.parameter))[:4]
    assert {o.parameter < point.parameter for o in near} == {True, False}
    for orbit in near:
        period = 2.0 * math.pi / orbit.parameter
        np.testing.assert_allclose(_flow(orbit.state, orbit.parameter, 0.0, 0.5 * period)[0], -orbit.state,
                                   rtol=0, atol=1e-8)
    # The located orbit itself is fixed only along the null vectors to about the cube root of the
    # Newton tolerance (the pitchfork's normal form is cubic there, M - I singular): 2e-4 at 1e-11.
    period = 2.0 * math.pi / point.parameter
    np.testing.assert_allclose(_flow(point.state, point.parameter, 0.0, 0.5 * period)[0], -point.state,
                               rtol=0, atol=2e-4)


def _mirror(orbit):
    """SciPy's mirror image of ``orbit``: -(its state half a period later), the state at t = 0 of
    the orbit x -> -x, t -> t + T/2 maps it to."""
    return -_flow(orbit.state, orbit.parameter, 0.0, math.pi / orbit.parameter)[0]


def _distance_to_polyline(z, orbits):
    """The distance in (x, v, omega) from z to the polyline through ``orbits``, and the length of
    its nearest segment."""
    best = (np.inf, np.inf)
    for before, after in zip(orbits, orbits[1:]):
        segment = after.z - before.z
        s = float(np.clip((z - before.z) @ segment / (segment @ segment), 0.0, 1.0))
        best = min(best, (float(np.linalg.norm(before.z + s * segment - z)), float(np.linalg.norm(segment))))
    return best


def test_switching_at_the_branch_point_follows_the_asymmetric_orbits_and_their_mirror_images(switched):
    branches, found, failures = switched
    assert not failures, failures
    assert len(branches) == 3, [(len(b.orbits), b.ends) for b in branches]
    point = next(b.orbit for b in found if b.kind == continuation.BRANCH_POINT and b.branch == 0)
    # The pitchfork's vertex is no fold of the switched branches (and up to 0.7.12 nothing was switched).
    assert [b for b in found if b.branch > 0] == [], [(b.kind, b.branch, b.orbit.parameter) for b in found]
    halves = branches[1:]
    for half in halves:
        assert half.periods == 1
        assert half.orbits[0] is point
        assert half.ends["down"][0] == branch_point.ENDED_BRANCH_POINT, half.ends
        assert f"{point.parameter:.8g}" in half.ends["down"][1]
        # Each half ends where its second impact slows to zero: the multiplier grows like 1/u.
        assert half.ends["up"][0] == continuation.ENDED_GRAZING and "zero speed" in half.ends["up"][1], half.ends
        # A subcritical pitchfork: the asymmetric orbits lie on the side where the symmetric ones are
        # stable (above omega*), and are unstable.
        assert min(o.parameter for o in half.orbits) >= point.parameter - continuation.DEFAULTS["location_tolerance"]
        assert not any(o.stable for o in half.orbits[1:])
        # They leave the branch point with the parameter fixed to first order (lam - lam* ~ a^2).
        first = half.orbits[1]
        assert abs(first.parameter - point.parameter) < 0.05 * np.linalg.norm(first.state - point.state)
    # The two halves are one another's mirror images, so they end at one zero-speed impact: each
    # end is approached to continuation.min_step (1e-5). Up to 0.7.12 one half stepped from omega =
    # 1.0731461 over that end onto orbits of one impact (no window to locate a graze in) and went on
    # to 1.05 as if through a graze at 1.0738354.
    ends = [half.orbits[-1].parameter for half in halves]
    assert abs(ends[0] - ends[1]) <= 2 * continuation.DEFAULTS["min_step"], ends
    # SciPy, away from the branch point and from the zero-speed impact (where its events, without a
    # small max_step, miss the slow impact): its map returns to the orbit with two impacts, its flow
    # does not take the orbit to its mirror image, and that mirror image lies on the other half.
    checked = 0
    for this, other in (halves, halves[::-1]):
        sample = [o for o in this.orbits if point.parameter + 5e-4 < o.parameter < 1.0725]
        assert len(sample) >= 3
        for orbit in sample[::max(1, len(sample) // 3)]:
            end, impacts = _flow(orbit.state, orbit.parameter, 0.0, 2.0 * math.pi / orbit.parameter)
            assert impacts == 2
            np.testing.assert_allclose(end, orbit.state, rtol=0, atol=1e-8)
            mirror = _mirror(orbit)
            assert np.max(np.abs(mirror - orbit.state)) > 1e-2
            distance, segment = _distance_to_polyline(np.array([*mirror, orbit.parameter]), other.orbits)
            # The other half's polyline is its curve to within a sagitta, small against its segments.
            assert distance < 2e-2 * segment, (orbit.parameter, distance, segment)
            checked += 1
    assert checked >= 6
    # SciPy's monodromy of one asymmetric orbit (fsolve from vrsweep's state): the same orbit and
    # the same unstable multiplier.
    orbit = min(halves[0].orbits, key=lambda o: abs(o.parameter - 1.0715))
    y, mu, _ = _scipy_orbit(orbit.state, orbit.parameter)
    np.testing.assert_allclose(y, orbit.state, rtol=0, atol=1e-8)
    assert mu > 1.0
    assert abs(mu - max(orbit.multipliers.real)) < 1e-4 * mu, (mu, orbit.multipliers)


def test_the_branch_file_holds_the_branch_point_and_info_and_plot_show_it(tmp_path):
    from click.testing import CliRunner

    import vrsweep
    from vrsweep.cli import main

    config = tmp_path / "config.yaml"
    config.write_text(CONFIG)
    out = tmp_path / "branch.h5"
    result = CliRunner().invoke(main, ["continue", str(config), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(out) as ds:
        assert [str(kind) for kind in ds["bifurcation_kind"].values] == ["branch_point"]
        mu = ds["bifurcation_multiplier_real"].values[0]
        assert abs(mu.max() - 1.0) <= continuation.LOCATED_MULTIPLIER
    info = CliRunner().invoke(main, ["info", str(out)])
    assert info.exit_code == 0, info.output
    line = next(line for line in info.output.splitlines() if line.startswith("bifurcation:"))
    assert "branch_point at omega = 1.06896" in line and "BP1" in line, line
    figure = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "branch.png")])
    assert figure.exit_code == 0, figure.output
    # Not a kind curves follow (yet): one line, exit code 2.
    curve = CliRunner().invoke(main, ["continue", str(out), "--point", "0", "--along", "F", "--to", "0.35", "0.45",
                                      "-o", str(tmp_path / "curve.h5")])
    assert curve.exit_code == 2 and len(curve.output.strip().splitlines()) == 1, curve.output


def test_continue_switch_writes_both_halves_and_info_and_plot_read_them(tmp_path):
    from click.testing import CliRunner

    import vrsweep
    from vrsweep.cli import main

    config = tmp_path / "config.yaml"
    config.write_text(CONFIG)
    out = tmp_path / "branches.h5"
    result = CliRunner().invoke(main, ["continue", str(config), "--switch", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "no second branch" not in result.output
    with vrsweep.open_results(out) as ds:
        assert list(ds["branch_periods"].values) == [1, 1, 1]
        assert [str(s) for s in ds["branch_end_first_status"].values[1:]] == ["branch_point", "branch_point"]
        assert [str(kind) for kind in ds["bifurcation_kind"].values] == ["branch_point"]
    info = CliRunner().invoke(main, ["info", str(out)])
    assert info.exit_code == 0, info.output
    assert "branch 2:" in info.output and "meets the branch it was born on at its branch point" in info.output
    figure = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "branches.png")])
    assert figure.exit_code == 0, figure.output


def test_a_branch_point_with_no_second_branch_is_reported_once_and_the_run_goes_on(tmp_path, monkeypatch):
    """Where the quadratic form at the point is definite (no two real directions: an isolated
    point of F = 0 on the null space, not a crossing), nothing is switched, the command says so in
    one line, and the branch is written."""
    from click.testing import CliRunner

    import vrsweep
    from vrsweep.cli import main

    measured = branch_point.quadratic_form
    monkeypatch.setattr(branch_point, "quadratic_form",
                        lambda problem, point, periods: (np.eye(2), measured(problem, point, periods)[1]))
    config = tmp_path / "config.yaml"
    config.write_text(CONFIG)
    out = tmp_path / "branch.h5"
    result = CliRunner().invoke(main, ["continue", str(config), "--switch", "-o", str(out)])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if "no second branch" in line]
    assert len(lines) == 1, result.output  # one line for the point, not one per side
    assert lines[0].startswith("branch point at omega = 1.06896") and "no two real directions" in lines[0], lines
    with vrsweep.open_results(out) as ds:
        assert list(ds["branch_periods"].values) == [1]


@pytest.mark.parametrize("scale", [1e-6, 1e-3, 1.0, 1e3, 1e6])
def test_the_rank_test_does_not_depend_on_the_parameters_unit(scale):
    """[M - I | F_lam] at a fold (F_lam out of the range of M - I) and at a branch point (F_lam in
    it), with F_lam scaled as a parameter in another unit scales it. Up to 0.7.10 the test was the
    ratio of the singular values, which F_lam's size sets: the fold at scale 1e-3 (|F_lam| = 1e-3
    against |M - I| = 0.5) had a ratio of 1.2e-3 and was taken for a branch point."""
    from types import SimpleNamespace

    angle = 0.3
    rotation = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    monodromy = np.eye(2) + rotation @ np.diag([1e-9, -0.5]) @ rotation.T  # a multiplier at 1 + 1e-9
    singular_direction, range_direction = rotation[:, 0], rotation[:, 1]
    fold = SimpleNamespace(monodromy=monodromy,
                           parameter_derivative=scale * (0.6 * singular_direction + 0.8 * range_direction))
    branch_point = SimpleNamespace(monodromy=monodromy, parameter_derivative=scale * 0.7 * range_direction)
    # the sine of F_lam's angle to the range of M - I: 0.6 at the fold, 0 (to rounding) at the branch point
    assert continuation._sine_to_range(fold) == pytest.approx(0.6, rel=1e-6)
    assert continuation._sine_to_range(fold) > continuation.BRANCH_POINT_RANK
    assert continuation._sine_to_range(branch_point) <= 1e-12 < continuation.BRANCH_POINT_RANK

