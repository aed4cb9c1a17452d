"""impact.find_crossing on its own, on dense outputs built by hand.

A step's continuous extension is x(theta) = x0 + h theta sum_q dense[X, q] theta^q (see
integrator.dense_value); here x(theta) is a chosen polynomial in the step fraction theta and v is
its time derivative, (1/h) dx/dtheta, so each case is a motion whose crossings are known exactly.
Coefficients are binary fractions, so "exactly at the barrier" is exact in floating point.
"""

import numpy as np
import pytest

from vrsweep.numerics.impact import (
    BARRIER_SCAN_POINTS, IMPACT, N_BRACKET, NO_IMPACT, THETA_TOLERANCE, TURNING_POINT, UNRESOLVED, V, X,
    find_crossing, locate_root,
)
from vrsweep.numerics.rk45 import dense_value

DELTA = 1.0
DEGREE = 4  # dense outputs of DP5(4)'s shape (2, 4): x up to theta^4


def motion(x_coefficients, h=0.5):
    """(dense, y, y_new, h) of x(theta) = sum_k a_k theta^k (a_0 first), v = (1/h) dx/dtheta."""
    a = np.zeros(DEGREE + 1)
    a[:len(x_coefficients)] = x_coefficients
    b = np.array([(k + 1) * a[k + 1] for k in range(DEGREE)] + [0.0]) / h  # v(theta) coefficients
    dense = np.empty((2, DEGREE))
    dense[X] = a[1:] / h
    dense[V] = b[1:] / h
    y = np.array([a[0], b[0]])
    y_new = np.array([a.sum(), b.sum()])
    return dense, y, y_new, h


def crossing(x_coefficients, pushed=False, h=0.5):
    dense, y, y_new, h = motion(x_coefficients, h)
    bracket = np.full(N_BRACKET, -7.0)
    verdict = find_crossing(dense, y, y_new, h, DELTA, pushed, bracket)
    return verdict, bracket, (dense, y, h)


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


def test_a_turning_point_below_the_barrier_is_no_impact_and_is_kept():
    # x = 0.5 + theta - theta^2: a maximum 0.75 < Delta at theta = 1/2 (v goes + to -)
    verdict, bracket, _ = crossing([0.5, 1.0, -1.0])
    assert verdict == NO_IMPACT
    assert bracket[TURNING_POINT] == pytest.approx(0.5, abs=1e-14)


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
