"""impact.find_crossing on its own, on dense outputs built by hand.

A step's continuous extension is x(theta) = x0 + h theta sum_q dense[X, q] theta^q (see
integrator.dense_value); here x(theta) is a chosen polynomial in the step fraction theta and v is
its time derivative, (1/h) dx/dtheta, so each case is a motion whose crossings are known exactly.
Coefficients are binary fractions, so "exactly at the barrier" is exact in floating point.
"""

import numpy as np
import pytest

from vrsweep.numerics.impact import (
    BARRIER_SCAN_POINTS, IMPACT, MAX_DEGREE, N_BRACKET, NO_IMPACT, THETA_TOLERANCE, TURNING_POINT, UNRESOLVED, V, X,
    bernstein_coefficients, bracket_size, find_crossing, first_reach, locate_root,
)
from vrsweep.numerics.rk45 import dense_value

DELTA = 1.0
DEGREE = 4  # dense outputs of DP5(4)'s shape (2, 4): x up to theta^4
# Values past a bracket's end, which find_crossing must never write: a GPU thread's bracket is
# exactly bracket_size(degree) long, and numba checks no bounds.
GUARD = 8


def motion(x_coefficients, h=0.5, degree=DEGREE):
    """(dense, y, y_new, h) of x(theta) = sum_k a_k theta^k (a_0 first), v = (1/h) dx/dtheta.

    degree: of the dense output's shape, 4 as DP5(4)'s, 7 as DOP853's."""
    a = np.zeros(degree + 1)
    a[:len(x_coefficients)] = x_coefficients
    b = np.array([(k + 1) * a[k + 1] for k in range(degree)] + [0.0]) / h  # v(theta) coefficients
    dense = np.empty((2, degree))
    dense[X] = a[1:] / h
    dense[V] = b[1:] / h
    y = np.array([a[0], b[0]])
    y_new = np.array([a.sum(), b.sum()])
    return dense, y, y_new, h


def crossing(x_coefficients, pushed=False, h=0.5, degree=DEGREE):
    dense, y, y_new, h = motion(x_coefficients, h, degree)
    bracket = np.full(bracket_size(degree) + GUARD, -7.0)
    verdict = find_crossing(dense, y, y_new, h, DELTA, pushed, bracket)
    np.testing.assert_array_equal(bracket[bracket_size(degree):], -7.0)
    return verdict, bracket[:bracket_size(degree)], (dense, y, h)


def test_the_built_motions_are_what_they_say():
    dense, y, _, h = motion([0.75, 1.0, -1.0])
    for theta in (0.0, 0.3, 0.5, 1.0):
        assert dense_value(dense, y, h, theta, X) == pytest.approx(0.75 + theta - theta ** 2, abs=1e-15)
        assert dense_value(dense, y, h, theta, V) == pytest.approx((1.0 - 2.0 * theta) / h, abs=1e-15)


def test_a_crossing_within_the_step_is_an_impact_located_to_rounding():
    # x = 0.75 + 0.5 theta reaches Delta at theta = 1/2 and ends above it
    verdict, bracket, (dense, y, h) = crossing([0.75, 0.5])
    assert verdict == IMPACT
    assert (bracket[0], bracket[1]) == (0.0, 1.0)
    assert np.isnan(bracket[TURNING_POINT])
    theta = locate_root(dense, y, h, X, DELTA, bracket[0], bracket[1])
    assert abs(theta - 0.5) <= 2 * THETA_TOLERANCE
    assert dense_value(dense, y, h, theta, X) >= DELTA  # the located state is on the far side


def test_a_turning_point_far_below_the_barrier_is_no_impact_proven_without_locating_it():
    # x = 0.5 + theta - theta^2: a maximum 0.75 < Delta at theta = 1/2 (v goes + to -); its
    # Bernstein coefficients (1/2, 1, 1/2) - Delta are all below zero, so nothing is located
    # (records.update_extremes locates it for the period's x_max)
    verdict, bracket, _ = crossing([0.5, 1.0, -1.0])
    assert verdict == NO_IMPACT
    assert np.isnan(bracket[TURNING_POINT])


def test_a_step_that_stays_below_and_turns_nowhere_is_no_impact():
    verdict, bracket, _ = crossing([0.5, 0.25])
    assert verdict == NO_IMPACT and np.isnan(bracket[TURNING_POINT])


def test_an_excursion_past_the_barrier_within_one_step_is_an_impact():
    # x = 0.5 + 2.5 theta - 2.5 theta^2: above Delta on (0.2764, 0.7236), back at 0.5 at the end;
    # the step's ends are both below the barrier: only the turning point shows the impact.
    verdict, bracket, (dense, y, h) = crossing([0.5, 2.5, -2.5])
    assert verdict == IMPACT
    assert bracket[0] == 0.0
    assert bracket[1] == pytest.approx(0.5, abs=1e-14) == bracket[TURNING_POINT]
    theta = locate_root(dense, y, h, X, DELTA, bracket[0], bracket[1])
    assert theta == pytest.approx((1 - np.sqrt(1 - 4 * 0.5 / 2.5)) / 2, abs=1e-12)  # the first crossing


def test_a_grazing_touch_of_the_barrier_is_an_impact_and_a_near_miss_is_not():
    # x = 0.75 + theta - theta^2 touches Delta exactly at theta = 1/2 (v = 0 there)
    verdict, bracket, _ = crossing([0.75, 1.0, -1.0])
    assert verdict == IMPACT
    assert bracket[1] == pytest.approx(0.5, abs=1e-14)
    # 2^-20 lower: a maximum just below the barrier
    verdict, bracket, _ = crossing([0.75 - 2.0 ** -20, 1.0, -1.0])
    assert verdict == NO_IMPACT
    assert bracket[TURNING_POINT] == pytest.approx(0.5, abs=1e-14)


def test_from_the_barrier_a_return_within_the_step_is_an_impact_between_scan_points():
    # a rebound: x = 1 - theta + theta^2 leaves Delta and is back on it at theta = 1
    verdict, bracket, _ = crossing([1.0, -1.0, 1.0])
    assert verdict == IMPACT
    assert (bracket[0], bracket[1]) == ((BARRIER_SCAN_POINTS - 1) / BARRIER_SCAN_POINTS, 1.0)


def test_from_the_barrier_leaving_and_returning_unseen_by_the_scan_is_unresolved():
    # x = 1 + theta (theta - 1/16): below Delta only on (0, 1/16), before the first scan point
    # 1/8, then above it: the step is too long to see the mass leave. The kernel retries shorter.
    verdict, _, (dense, y, h) = crossing([1.0, -1.0 / 16, 1.0])
    assert dense_value(dense, y, h, 1.0 / 32, X) < DELTA  # it does leave
    assert verdict == UNRESOLVED


def test_resting_on_the_barrier_and_pushed_into_it_is_an_impact_at_the_start():
    # v = 0 at the start and x creeping above Delta: sticking if the force presses into the barrier
    verdict, bracket, _ = crossing([1.0, 0.0, 2.0 ** -10], pushed=True)
    assert verdict == IMPACT and (bracket[0], bracket[1]) == (0.0, 0.0)
    verdict, _, _ = crossing([1.0, 0.0, 2.0 ** -10], pushed=False)
    assert verdict == UNRESOLVED


def test_a_release_that_stays_on_the_barrier_to_rounding_is_no_impact():
    verdict, _, _ = crossing([1.0])  # x == Delta throughout, v = 0
    assert verdict == NO_IMPACT


# --- long steps: the Bernstein test sees what the step's ends do not (issue 23) ------------------
# Every case for both dense-output shapes (degree 4 as rk45's, 7 as dop853's); Delta = 1.
every_shape = pytest.mark.parametrize("degree", [4, 7])


def first_crossing(x_coefficients, degree):
    """find_crossing's verdict and, for an impact, the located theta (as the kernel locates it)."""
    verdict, bracket, (dense, y, h) = crossing(x_coefficients, degree=degree)
    if verdict != IMPACT:
        return verdict, None, (dense, y, h)
    if bracket[0] < bracket[1]:
        theta = locate_root(dense, y, h, X, DELTA, bracket[0], bracket[1])
    else:
        theta = bracket[1]
    return verdict, theta, (dense, y, h)


def below_before(dense, y, h, theta, points=2001):
    """x < Delta on a fine grid of [0, theta): nothing earlier was skipped."""
    grid = np.linspace(0.0, theta, points)[:-1]
    return all(dense_value(dense, y, h, t, X) < DELTA for t in grid)


# x - 1 = -(theta - 1/2)^2 (1 + 8 theta) = -1/4 - theta + 7 theta^2 - 8 theta^3: falls from 3/4 (v < 0),
# turns at theta = 1/12, rises to touch the barrier at theta = 1/2 and falls to -5/4 (v < 0). Both
# ends far below, both velocities negative: no end value or velocity sign shows the touch.
TOUCH_INSIDE = [0.75, -1.0, 7.0, -8.0]


@every_shape
def test_a_touch_between_two_step_ends_far_below_the_barrier_is_an_impact(degree):
    dense, y, y_new, h = motion(TOUCH_INSIDE, degree=degree)
    assert y[X] == 0.75 and y_new[X] == -1.25 and y[V] < 0 and y_new[V] < 0
    verdict, theta, _ = first_crossing(TOUCH_INSIDE, degree)
    assert verdict == IMPACT
    assert theta == pytest.approx(0.5, abs=1e-7)  # a double root: located to sqrt(rounding)


@every_shape
def test_a_near_miss_inside_a_long_step_is_no_impact_and_a_near_hit_is(degree):
    miss = [TOUCH_INSIDE[0] - 2.0 ** -20] + TOUCH_INSIDE[1:]  # the maximum 2^-20 below the barrier
    verdict, _, _ = first_crossing(miss, degree)
    assert verdict == NO_IMPACT
    hit = [TOUCH_INSIDE[0] + 2.0 ** -20] + TOUCH_INSIDE[1:]  # 2^-20 past it: a short excursion
    verdict, theta, (dense, y, h) = first_crossing(hit, degree)
    assert verdict == IMPACT
    # the first crossing: x - 1 = -(theta - 1/2)^2 (1 + 8 theta) + 2^-20, just before 1/2
    assert dense_value(dense, y, h, theta, X) == pytest.approx(DELTA, abs=1e-14)
    assert 0.5 - 2e-3 < theta < 0.5
    assert below_before(dense, y, h, theta)


def _double_touch(shift):
    """x - 1 = -16 (theta - 1/4)^2 (theta - 3/4)^2 + shift(theta): power coefficients, a_0 first."""
    quartic = -16.0 * np.polynomial.polynomial.polymul([3 / 16, -1.0, 1.0], [3 / 16, -1.0, 1.0])
    quartic[:len(shift)] += shift
    quartic[0] += DELTA
    return list(quartic)


@every_shape
def test_a_double_touch_inside_one_step_is_an_impact_at_the_first(degree):
    # touches at 1/4 and 3/4, between ends 7/16 below the barrier
    verdict, theta, (dense, y, h) = first_crossing(_double_touch([]), degree)
    assert verdict == IMPACT
    assert theta == pytest.approx(0.25, abs=1e-7)


@every_shape
def test_of_two_excursions_in_one_step_the_first_is_taken(degree):
    # both maxima 2^-12 past the barrier: the crossing just before 1/4, not the one before 3/4
    verdict, theta, (dense, y, h) = first_crossing(_double_touch([2.0 ** -12]), degree)
    assert verdict == IMPACT
    assert 0.25 - 0.02 < theta < 0.25
    assert dense_value(dense, y, h, theta, X) == pytest.approx(DELTA, abs=1e-14)
    assert below_before(dense, y, h, theta)


@every_shape
def test_a_near_miss_then_a_crossing_in_one_step_is_the_crossing(degree):
    # shift 2^-12 (2 theta - 1): the first maximum 2^-13 short of the barrier, the second past it
    verdict, theta, (dense, y, h) = first_crossing(_double_touch([-(2.0 ** -12), 2.0 ** -11]), degree)
    assert verdict == IMPACT
    assert 0.5 < theta < 0.75
    assert dense_value(dense, y, h, theta, X) == pytest.approx(DELTA, abs=1e-14)
    assert below_before(dense, y, h, theta)


@every_shape
def test_a_touch_at_the_step_end_is_an_impact_there(degree):
    # x = 3/4 + theta/2 - theta^2/4 rises to the barrier at theta = 1 with v = 0 there
    verdict, theta, (dense, y, h) = first_crossing([0.75, 0.5, -0.25], degree)
    assert verdict == IMPACT and theta == 1.0
    # and crossing it at the end, with speed: x = 3/4 + theta/4 (the end exactly on the barrier)
    verdict, theta, _ = first_crossing([0.75, 0.25], degree)
    assert verdict == IMPACT and theta == 1.0
    # short of it at the end by 2^-30: no impact
    verdict, _, _ = first_crossing([0.75 - 2.0 ** -30, 0.5, -0.25], degree)
    assert verdict == NO_IMPACT


@every_shape
def test_a_start_within_rounding_below_the_barrier_moving_away_is_no_impact(degree):
    # x = 1 - 2^-51 - theta^2 / 4: at rest a few units of the last place below the barrier, then
    # falling. The start is within the Bernstein rounding slack of Delta, but the step only moves
    # away from it: no touch (found by hypothesis: taking it for an impact at v = 0 made the
    # saltation divide by zero and the Lyapunov exponent NaN).
    start = DELTA - 2.0 ** -51
    verdict, _, _ = first_crossing([start, 0.0, -0.25], degree)
    assert verdict == NO_IMPACT
    # the same start rising by more than rounding, to 2^-40 past the barrier, is an impact
    verdict, theta, (dense, y, h) = first_crossing([start, 2.0 ** -38, -(2.0 ** -39)], degree)
    assert verdict == IMPACT and 0.0 < theta < 1.0
    assert dense_value(dense, y, h, theta, X) >= DELTA


@every_shape
def test_far_below_the_barrier_is_proven_at_once(degree):
    # oscillating far below (three turning points): every Bernstein coefficient is below Delta
    dense, y, _, h = motion([0.0, 1.0, -6.0, 10.0, -5.0], degree=degree)
    coefficients = np.empty(degree + 1)
    bernstein_coefficients(dense, y, h, X, DELTA, coefficients)
    assert coefficients.max() < 0.0
    assert first_crossing([0.0, 1.0, -6.0, 10.0, -5.0], degree)[0] == NO_IMPACT


@every_shape
def test_bernstein_coefficients_are_those_of_the_polynomial(degree):
    # the Bernstein form evaluated at any theta is the power form's value
    from math import comb
    x = [0.3, -0.7, 2.1, -1.1, 0.4, 0.05, -0.02, 0.01][:degree + 1]
    dense, y, _, h = motion(x, degree=degree)
    coefficients = np.empty(degree + 1)
    assert bernstein_coefficients(dense, y, h, X, DELTA, coefficients) == degree
    for theta in (0.0, 0.17, 0.5, 0.93, 1.0):
        bernstein = sum(comb(degree, i) * theta ** i * (1 - theta) ** (degree - i) * coefficients[i]
                        for i in range(degree + 1))
        assert bernstein == pytest.approx(dense_value(dense, y, h, theta, X) - DELTA, abs=1e-14)


def test_the_cheap_exclusion_bounds_a_closed_form_step_from_above():
    # hermite_reach from the ends of x = 0.5 sin(t) over a step of 2 (a long step, a maximum
    # inside): its estimate is above the true maximum 0.5, and it excludes a barrier at 0.7
    # (0.2 above; its margin is generous at so long a step) but not one at 0.51
    from vrsweep.numerics.impact import hermite_reach
    t0, h = 0.4, 2.0
    ends = [(0.5 * np.sin(t), 0.5 * np.cos(t), -0.5 * np.sin(t)) for t in (t0, t0 + h)]
    (x0, v0, a0), (x1, v1, a1) = ends
    assert hermite_reach(x0, v0, a0, x1, v1, a1, h, 0.0) >= 0.5
    assert hermite_reach(x0, v0, a0, x1, v1, a1, h, 0.7) < 0.0
    assert hermite_reach(x0, v0, a0, x1, v1, a1, h, 0.51) >= 0.0


# --- first_reach's walk over pieces: no stack, the same pieces in the same order ----------------

def _stack_walk(dense, y, h, delta, coefficients):
    """first_reach as version 0.6.0 wrote it, with a stack of pieces (plain Python here): the
    reference its stackless walk must agree with to the last bit. Returns (verdict, low, high,
    turning point)."""
    from vrsweep.numerics.impact import (
        BERNSTEIN_ROUNDING, MAX_SUBDIVISIONS, _difference_shape, _sign_changes, locate_maximum,
    )

    def halve(c):
        right = list(c)
        left = [right[0]]
        for level in range(1, len(c)):
            for i in range(len(c) - level):
                right[i] = 0.5 * (right[i] + right[i + 1])
            left.append(right[0])
        return left, right

    n = len(coefficients) - 1
    size = abs(y[X]) + abs(delta)
    for i in range(1, n + 1):
        size += abs(h * dense[X, i - 1])
    slack = BERNSTEIN_ROUNDING * size
    turning = np.nan
    if max(coefficients) < -slack:
        return NO_IMPACT, None, None, turning
    stack = [(list(coefficients), 0.0, 0)]
    while stack:
        piece, low, depth = stack.pop()
        width = 0.5 ** depth
        high = low + width if depth > 0 else 1.0
        if max(piece) < -slack:
            continue
        as_array = np.array(piece)
        if dense_value(dense, y, h, high, X) >= delta and (_sign_changes(as_array, n) <= 1
                                                            or depth >= MAX_SUBDIVISIONS):
            return IMPACT, low, high, turning
        shape = _difference_shape(as_array, n)
        if shape == 0:
            continue
        if shape == 1 or depth >= MAX_SUBDIVISIONS:
            top = locate_maximum(dense, y, h, X, low, high)
            if depth == 0 and shape == 1:
                turning = top
            value = dense_value(dense, y, h, top, X)
            if value >= delta or (value >= delta - slack and value - y[X] > slack):
                return IMPACT, low, top, turning
            continue
        left, right = halve(piece)
        stack.append((right, low + 0.5 * width, depth + 1))
        stack.append((left, low, depth + 1))
    return NO_IMPACT, None, None, turning


@pytest.mark.parametrize("degree", [4, 7])
def test_the_stackless_walk_finds_what_a_stack_of_pieces_finds_to_the_last_bit(degree):
    """Polynomials with up to `degree` roots just below, on and just past the barrier (several
    touches and near misses in one step), the hardest case for the walk: its verdict, bracket and
    turning point are the reference's exactly, and nothing is written past bracket_size(degree),
    the bracket a GPU thread keeps (one for all barriers, of its method's size)."""
    assert N_BRACKET == bracket_size(MAX_DEGREE)  # the CPU's brackets hold any degree's
    rng = np.random.default_rng(20261126 + degree)
    walked = 0
    for _ in range(400):
        # x - Delta = -A prod (theta - r_i)^2 (i < degree / 2) + a small shift: touches at the r_i
        roots = np.sort(rng.uniform(0.0, 1.0, degree // 2))
        poly = np.array([-rng.uniform(0.5, 8.0)])
        for r in roots:
            poly = np.polynomial.polynomial.polymul(poly, [r * r, -2.0 * r, 1.0])
        poly[0] += rng.choice([-1.0, 1.0]) * 2.0 ** -rng.integers(8, 52) + DELTA
        shift = rng.normal(0.0, 2.0 ** -rng.integers(10, 40), 2)
        poly[:2] += shift
        if poly[0] >= DELTA:
            continue
        dense, y, y_new, h = motion(list(poly), degree=degree)
        coefficients = np.empty(degree + 1)
        bernstein_coefficients(dense, y, h, X, DELTA, coefficients)
        verdict, low, high, turning = _stack_walk(dense, y, h, DELTA, list(coefficients))
        bracket = np.full(bracket_size(degree) + GUARD, -7.0)
        bracket[3:3 + degree + 1] = coefficients
        got = first_reach(dense, y, h, DELTA, bracket[3:3 + degree + 1], bracket)
        np.testing.assert_array_equal(bracket[bracket_size(degree):], -7.0)
        bracket_turning = bracket[TURNING_POINT] if bracket[TURNING_POINT] != -7.0 else np.nan
        assert got == verdict
        if verdict == IMPACT:
            assert (bracket[0], bracket[1]) == (low, high)
        np.testing.assert_array_equal(bracket_turning, turning)
        walked += 1
    assert walked > 200



def test_a_force_that_only_touches_zero_keeps_the_mass_and_one_that_pulls_releases_it_at_the_root():
    """impact.release_time on the bouncing ball's force on the table, 1 - Gamma cos t, from t = 1 in
    scans of 2 pi / 64. At Gamma = 1 it touches 0 at t = 2 pi (1 - cos t is 0 in doubles within
    1.5e-8 of it, and at the double nearest 2 pi, where the kernel's scan lands as a period ends)
    and presses again, so the ball stays. At Gamma > 1 it pulls from t = 2 pi - arccos(1/Gamma) on,
    and the release is the first t found past that root. (A pull shorter than a scan,
    arccos(1/Gamma) < pi / 64 below Gamma = 1.0122, may be stepped over: docs/models.md,
    max_step.)"""
    import math

    import numba

    from vrsweep.numerics.impact import release_time

    @numba.njit
    def force(t, c, barrier):  # into the table, as barrier_force's are
        return 1.0 - c[0] * math.cos(t)

    @numba.njit
    def scan(c, t_limit):
        return release_time(force, 0, 1.0, t_limit, c, 2 * math.pi / 64, 10_000)

    ball = np.array([1.0])
    assert force(2 * math.pi, ball, 0) == 0.0  # the touch, as the scan meets it
    for t_limit in (2 * math.pi, 1.0 + 2 * math.pi):
        t, _ = scan(ball, t_limit)
        assert t == t_limit + 1.0  # still stuck at the end (up to 0.7.17: let go at t = 2 pi)
    for gamma in (1.02, 1.1, 1.5):
        c = np.array([gamma])
        t, _ = scan(c, 1.0 + 2 * math.pi)
        assert force(t, c, 0) < 0.0 <= force(np.nextafter(t, 0.0), c, 0), gamma  # to the last bit
        assert t == pytest.approx(2 * math.pi - math.acos(1.0 / gamma), rel=1e-14), gamma
