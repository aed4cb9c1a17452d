"""Impacts with the barrier at x = Delta: event location on the dense output, sticking.

Roots are located on the step's continuous extension (integrator.dense_value) in the step
fraction theta in [0, 1]; the kernel then reaches the impact state with an exact step.

Whether a step that starts below the barrier reaches it is decided on the dense output's
polynomial p(theta) - Delta in Bernstein form (docs/design.md, "Events on the interpolant"): a
polynomial lies within the convex hull of its Bernstein coefficients, so all of them below zero
proves that p stays below the barrier over the whole step, however long the step and however
many turning points it holds. Otherwise the step is halved (de Casteljau) until each piece is
either proven below, holds exactly one crossing (one sign change), or has one maximum (one sign
change of the coefficients' differences), which is then located and compared with Delta. So a
graze between two step ends far below the barrier is found, and a near miss is not an impact.
"""

import math

import numpy as np

from vrsweep.numerics.rk45 import dense_value
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.state import V, X


# Step fraction to which roots are located: the impact time is then known to ~1e-15 h.
THETA_TOLERANCE = 1e-15
MAX_ROOT_ITERATIONS = 200
# A step that starts on the barrier is scanned at this many interior points for a return to it:
# a slow rebound can leave and come back within one step, with x(t + h) < Delta (a graze).
BARRIER_SCAN_POINTS = 8
NO_CROSSING = -1.0
# find_crossing's bracket: (theta_low, theta_high, the turning point it located), then the step's
# Bernstein coefficients and first_reach's workspace (so that the kernel's hot loop allocates
# nothing): a piece and the halves of a piece while it is halved, each n + 1 values for a dense
# output of degree n, one after the other. first_reach walks its pieces without a stack (each piece
# is recomputed from the step's coefficients), so a bracket is bracket_size(n) values: 23 with rk45
# (degree 4), 35 with dop853 (7). A GPU thread keeps one, of its method's size, in local memory,
# where up to 0.6.2 a stack of pieces took 7.7 kB and up to 0.6.6 two brackets of the largest size
# (one per barrier) 624 bytes (benchmarks/README.md).
TURNING_POINT = 2
BERNSTEIN = 3                    # the step's coefficients, then the piece, then its two halves


def bracket_size(degree):
    """A bracket's length for dense outputs of the given degree (DENSE_ORDER, the dense array's columns)."""
    return BERNSTEIN + 4 * (degree + 1)


# find_crossing's verdicts.
NO_IMPACT = 0
IMPACT = 1
UNRESOLVED = 2  # left the barrier and came back between scan points: retry with a shorter step


# Bisections of a step fraction for a switching function's sign change: 2**-60 of a step.
SWITCH_BISECTIONS = 60


@kernel_jit(inline="always")
def locate_switch(switch_signs, signs, dense, y, t, h, coefficients):
    """The first step fraction theta in (0, 1] past which the signs of the model's switching
    functions (switch_signs(t, x, v, coefficients), a bit each) differ from ``signs`` on the dense
    output: bisection on the bits, which needs no derivative and, being a comparison of bit
    patterns, holds for any number of surfaces. Returns the upper end of the final bracket, so the
    located state is on the far side, as locate_root's."""
    theta_low = 0.0
    theta_high = 1.0
    for _ in range(SWITCH_BISECTIONS):
        theta = 0.5 * (theta_low + theta_high)
        if switch_signs(t + theta * h, dense_value(dense, y, h, theta, X), dense_value(dense, y, h, theta, V),
                        coefficients) != signs:
            theta_high = theta
        else:
            theta_low = theta
    return theta_high


@kernel_jit
def locate_root(dense, y, h, component, level, theta_low, theta_high):
    """theta in [theta_low, theta_high] where the interpolant's component crosses ``level``.

    Requires value(theta_low) < level <= value(theta_high) or the reverse; the Illinois
    variant of regula falsi keeps the bracket and converges superlinearly.
    Returns the upper end of the final bracket, so the located state is on the far side.
    """
    f_low = dense_value(dense, y, h, theta_low, component) - level
    f_high = dense_value(dense, y, h, theta_high, component) - level
    if f_high == 0.0:
        return theta_high
    side = 0
    for _ in range(MAX_ROOT_ITERATIONS):
        if theta_high - theta_low <= THETA_TOLERANCE:
            break
        theta = (theta_low * f_high - theta_high * f_low) / (f_high - f_low)
        if not (theta_low < theta < theta_high):
            theta = 0.5 * (theta_low + theta_high)
        f_mid = dense_value(dense, y, h, theta, component) - level
        if f_mid == 0.0:
            return theta
        if (f_mid < 0.0) == (f_low < 0.0):
            theta_low, f_low = theta, f_mid
            if side == -1:
                f_high *= 0.5
            side = -1
        else:
            theta_high, f_high = theta, f_mid
            if side == 1:
                f_low *= 0.5
            side = 1
    return theta_high


@kernel_jit
def _crossing_after_turning_point(dense, y, h, delta, theta_a, theta_b):
    """Upper bracket end for an excursion past Delta around a maximum of x.

    Called with v(theta_a) > 0 > v(theta_b) and x(theta_a) < Delta: locates the maximum of x
    and returns it as the upper end of a crossing bracket if it reaches Delta, else NO_CROSSING.
    """
    theta_turn = locate_root(dense, y, h, V, 0.0, theta_a, theta_b)
    if dense_value(dense, y, h, theta_turn, X) >= delta:
        return theta_turn
    return NO_CROSSING


# --- Bernstein form of the dense output ---------------------------------------------------------
# BERNSTEIN_FROM_POWER[n, i, k] = C(i, k) / C(n, k): the i-th Bernstein coefficient of degree n of a
# polynomial is sum_k BERNSTEIN_FROM_POWER[n, i, k] a_k, a_k its power-basis coefficients on [0, 1].
MAX_DEGREE = 8
# A bracket that holds any degree's (the CPU's callers allocate this one).
N_BRACKET = bracket_size(MAX_DEGREE)
BERNSTEIN_FROM_POWER = np.zeros((MAX_DEGREE + 1, MAX_DEGREE + 1, MAX_DEGREE + 1))
for _n in range(MAX_DEGREE + 1):
    for _i in range(_n + 1):
        for _k in range(_i + 1):
            BERNSTEIN_FROM_POWER[_n, _i, _k] = math.comb(_i, _k) / math.comb(_n, _k)
# Halvings of a step before a piece that is neither proven below the barrier nor simple (one
# crossing, or one maximum) is taken as touching it: 2^-40 of a step, far below THETA_TOLERANCE's
# reach of any physical time scale; a polynomial that stays this close to Delta over so short a
# piece without a crossing or a single maximum touches it to rounding.
MAX_SUBDIVISIONS = 40
# Rounding of Bernstein coefficients (and of halving them), relative to the sum of the magnitudes
# of the polynomial's terms: a few units of the last place.
BERNSTEIN_ROUNDING = 16 * 2.2e-16
# hermite_reach's margin: this many times the accelerations' share of the quintic interpolant.
HERMITE_MARGIN_FACTOR = 2.0


@kernel_jit
def bernstein_coefficients(dense, y, h, component, level, out):
    """out[:n + 1] = the Bernstein coefficients over theta in [0, 1] of dense_value(...) - level.

    dense (n_components, n): the continuous extension y + h theta sum_q dense[component, q] theta^q,
    a polynomial of degree n in theta. Returns n.
    """
    n = dense.shape[1]
    for i in range(n + 1):
        acc = y[component] - level  # a_0, with BERNSTEIN_FROM_POWER[n, i, 0] = 1
        for k in range(1, i + 1):
            acc += BERNSTEIN_FROM_POWER[n, i, k] * (h * dense[component, k - 1])
        out[i] = acc
    return n


@kernel_jit
def _derivative_value(dense, h, theta, component):
    """d/dtheta of the continuous extension at theta (Horner)."""
    order = dense.shape[1]
    acc = order * dense[component, order - 1]
    for q in range(order - 2, -1, -1):
        acc = acc * theta + (q + 1) * dense[component, q]
    return h * acc


@kernel_jit
def locate_maximum(dense, y, h, component, theta_low, theta_high):
    """The maximum of the component's polynomial in [theta_low, theta_high], where its derivative
    goes from >= 0 to <= 0 exactly once (Illinois on the derivative). Returns theta."""
    d_low = _derivative_value(dense, h, theta_low, component)
    d_high = _derivative_value(dense, h, theta_high, component)
    if d_low <= 0.0:
        return theta_low
    if d_high > 0.0:
        return theta_high
    if d_high == 0.0:
        # A stationary point at the end (a minimum, say, with the maximum inside): keep the
        # bracket's signs so that the root found is the one where the derivative turns negative.
        d_high = -1e-300
    side = 0
    for _ in range(MAX_ROOT_ITERATIONS):
        if theta_high - theta_low <= THETA_TOLERANCE:
            break
        theta = (theta_low * d_high - theta_high * d_low) / (d_high - d_low)
        if not (theta_low < theta < theta_high):
            theta = 0.5 * (theta_low + theta_high)
        d_mid = _derivative_value(dense, h, theta, component)
        if d_mid == 0.0:
            return theta
        if d_mid > 0.0:
            theta_low, d_low = theta, d_mid
            if side == -1:
                d_high *= 0.5
            side = -1
        else:
            theta_high, d_high = theta, d_mid
            if side == 1:
                d_low *= 0.5
            side = 1
    # The end with the larger value: the maximum is between them, to THETA_TOLERANCE.
    if dense_value(dense, y, h, theta_low, component) > dense_value(dense, y, h, theta_high, component):
        return theta_low
    return theta_high


@kernel_jit
def _sign_changes(c, n):
    """Sign changes in c[0..n], zeros counted as positive (reaching the level counts)."""
    changes = 0
    for i in range(n):
        if (c[i] >= 0.0) != (c[i + 1] >= 0.0):
            changes += 1
    return changes


@kernel_jit
def _difference_shape(c, n):
    """0: the differences c[i+1] - c[i] never change sign (monotone); 1: they go once from >= 0 to
    < 0 (a single maximum); 2: anything else."""
    changes = 0
    rising = c[1] - c[0] >= 0.0
    first_rising = rising
    for i in range(1, n):
        now = c[i + 1] - c[i] >= 0.0
        if now != rising:
            changes += 1
            rising = now
    if changes == 0:
        return 0
    if changes == 1 and first_rising:
        return 1
    return 2


@kernel_jit
def first_reach(dense, y, h, delta, coefficients, bracket):
    """Does the dense output's x reach Delta in the step, from x(0) < Delta? Fills bracket.

    coefficients: bernstein_coefficients of x - Delta over the step (n + 1,), already computed.
    Returns IMPACT with bracket (theta_low, theta_high) holding the first crossing (x(theta_low)
    < Delta <= x(theta_high), the values as dense_value computes them; theta_low == theta_high
    for a touch taken at one theta), or NO_IMPACT. bracket[TURNING_POINT] is the located maximum
    when the whole step has exactly one.

    A piece is proven below the barrier when its largest coefficient is below -slack, the
    rounding of the coefficients; within the slack (a touch to rounding), the decision is
    dense_value's at the located maximum, as for any other maximum.
    """
    n = coefficients.shape[0] - 1
    largest = coefficients[0]
    size = abs(y[X]) + abs(delta)
    for i in range(1, n + 1):
        largest = max(largest, coefficients[i])
        size += abs(h * dense[X, i - 1])
    slack = BERNSTEIN_ROUNDING * size
    if largest < -slack:
        return NO_IMPACT  # proven below the barrier over the whole step (the usual case)
    # Depth-first over halvings, left piece first, so the first crossing is the one found. Piece
    # (depth, index) is theta in [index, index + 1] / 2^depth; the walk needs no stack: after a
    # piece, climb while it is a right half, then take the next piece to the right. A piece's
    # coefficients are the step's halved along the bits of its index, the same halvings in the
    # same order as a stack of pieces would make, so the values are the same to the last bit.
    piece = bracket[BERNSTEIN + (n + 1):BERNSTEIN + 2 * (n + 1)]
    left = bracket[BERNSTEIN + 2 * (n + 1):BERNSTEIN + 3 * (n + 1)]
    right = bracket[BERNSTEIN + 3 * (n + 1):BERNSTEIN + 4 * (n + 1)]
    depth = 0
    index = 0
    while True:
        _piece_coefficients(coefficients, n, depth, index, piece, left, right)
        width = 0.5 ** depth
        low = index * width
        high = low + width if depth > 0 else 1.0
        largest = piece[0]
        for i in range(1, n + 1):
            largest = max(largest, piece[i])
        halve = False
        if largest < -slack:
            pass  # this piece is below the barrier
        # x(low) < Delta here: the pieces to its left were all below.
        elif dense_value(dense, y, h, high, X) >= delta and (_sign_changes(piece, n) <= 1
                                                              or depth >= MAX_SUBDIVISIONS):
            bracket[0] = low
            bracket[1] = high
            return IMPACT  # one crossing in [low, high] (or a touch at high): locate_root's
        else:
            shape = _difference_shape(piece, n)
            if shape == 1 or (shape != 0 and depth >= MAX_SUBDIVISIONS):
                theta_top = locate_maximum(dense, y, h, X, low, high)
                if depth == 0 and shape == 1:
                    bracket[TURNING_POINT] = theta_top
                top_value = dense_value(dense, y, h, theta_top, X)
                # A touch to rounding counts, unless the maximum is the step's start again (no
                # rise above x(0) beyond rounding): that point was judged as the previous step's
                # end, and a start within rounding of Delta that moves away (v <= 0) is no
                # impact; taking it for one would divide the saltation by a zero speed.
                if top_value >= delta or (top_value >= delta - slack and top_value - y[X] > slack):
                    bracket[0] = low
                    bracket[1] = theta_top
                    return IMPACT
                # else its single maximum is below the barrier: a near miss
            elif shape != 0:  # (0: monotone, with both ends below)
                halve = True
        if halve:
            depth += 1
            index *= 2  # its left half next
            continue
        while index % 2 == 1:
            index //= 2
            depth -= 1
        if depth == 0:
            return NO_IMPACT  # the whole step is done
        index += 1


@kernel_jit
def _halve(c, n, left, right):
    """de Casteljau at 1/2: the Bernstein coefficients c[0..n] of a piece -> those of its halves."""
    for i in range(n + 1):
        right[i] = c[i]
    left[0] = right[0]
    for level in range(1, n + 1):
        for i in range(n - level + 1):
            right[i] = 0.5 * (right[i] + right[i + 1])
        left[level] = right[0]


@kernel_jit
def _piece_coefficients(coefficients, n, depth, index, piece, left, right):
    """piece[0..n] = the Bernstein coefficients of piece (depth, index) of first_reach's walk:
    coefficients[0..n] (the whole step's) halved depth times, keeping the half that the bits of
    index name, from the most significant (left and right are workspace)."""
    for i in range(n + 1):
        piece[i] = coefficients[i]
    for level in range(depth - 1, -1, -1):
        _halve(piece, n, left, right)
        kept = right if (index >> level) & 1 else left
        for i in range(n + 1):
            piece[i] = kept[i]


@kernel_jit
def find_crossing(dense, y, y_new, h, delta, pushed_into_barrier, bracket):
    """Does x reach Delta within the step? If so, fill bracket = (theta_low, theta_high, .).

    bracket[TURNING_POINT] is the located maximum of x inside a step that starts below the
    barrier and has exactly one (NaN if none was located); bracket[BERNSTEIN:] is workspace.

    Cases (the state can never be above Delta at a step's start):
    - started below the barrier: the first theta where the dense output's x reaches Delta, found
      on its Bernstein form (first_reach): a crossing, or an excursion past Delta or a touch that
      returns below it within the step, however many turning points the step holds;
    - started on the barrier (after a rebound or a release): scan interior points for the
      first return to Delta after leaving it.
    Returns IMPACT (bracket[0] has x < Delta), NO_IMPACT, or UNRESOLVED when the step is too
    long to see the mass leave the barrier before it is back past it.
    ``pushed_into_barrier``: the force at (Delta, 0) at the step's start points into the barrier.
    """
    bracket[TURNING_POINT] = np.nan
    if y[X] < delta:
        # The dense output's x - Delta in Bernstein form: proven below, or its first crossing.
        n = bernstein_coefficients(dense, y, h, X, delta, bracket[BERNSTEIN:])
        verdict = first_reach(dense, y, h, delta, bracket[BERNSTEIN:BERNSTEIN + n + 1], bracket)
        if verdict == NO_IMPACT and y_new[X] >= delta:
            # The step ends on or past the barrier while its polynomial, to rounding, does not.
            bracket[0] = 0.0
            bracket[1] = 1.0
            return IMPACT
        return verdict

    # On the barrier: find where the mass has left it, then where it first comes back.
    theta_prev = 0.0
    v_prev = y[V]
    left = False
    for k in range(1, BARRIER_SCAN_POINTS + 1):
        theta = k / BARRIER_SCAN_POINTS
        x_k = y_new[X] if k == BARRIER_SCAN_POINTS else dense_value(dense, y, h, theta, X)
        v_k = y_new[V] if k == BARRIER_SCAN_POINTS else dense_value(dense, y, h, theta, V)
        if not left:
            if x_k < delta:
                left = True
        elif x_k >= delta:
            bracket[0] = theta_prev
            bracket[1] = theta
            return IMPACT
        elif v_prev > 0.0 and v_k < 0.0:
            theta_high = _crossing_after_turning_point(dense, y, h, delta, theta_prev, theta)
            if theta_high != NO_CROSSING:
                bracket[0] = theta_prev
                bracket[1] = theta_high
                return IMPACT
        theta_prev = theta
        v_prev = v_k
    if not left and y_new[X] > delta:
        if y[V] >= 0.0 and pushed_into_barrier:
            # Resting (or creeping) on the barrier and pressed into it: an impact at the
            # step's start with no speed, which the kernel turns into sticking.
            bracket[0] = 0.0
            bracket[1] = 0.0
            return IMPACT
        return UNRESOLVED
    # x == Delta to rounding (a release where the force has only just turned) is no impact.
    return NO_IMPACT


@kernel_jit
def hermite_reach(x0, v0, a0, x1, v1, a1, h, level):
    """A cheap estimate from above of max (x - level) over a step, from its ends alone.

    The quintic Hermite interpolant of (x, v, a) at both ends, in Bernstein form (its largest
    coefficient bounds it), plus twice its distance from the cubic Hermite one of (x, v) (the
    term the accelerations add, an estimate of what the interpolant's higher terms can add). A
    negative result lets the kernel skip the dense output of a step far below the barrier; the
    decision itself is always first_reach's, on the dense output.
    """
    hv0 = h * v0
    hv1 = h * v1
    b1 = x0 + hv0 / 5.0
    b2 = x0 + 0.4 * hv0 + h * h * a0 / 20.0
    b3 = x1 - 0.4 * hv1 + h * h * a1 / 20.0
    b4 = x1 - hv1 / 5.0
    # the cubic Hermite interpolant's Bernstein coefficients, raised to degree 5 (the ends and
    # b1, b4 are the same)
    c1 = x0 + hv0 / 3.0
    c2 = x1 - hv1 / 3.0
    e2 = (x0 + 6.0 * c1 + 3.0 * c2) / 10.0
    e3 = (3.0 * c1 + 6.0 * c2 + x1) / 10.0
    margin = max(abs(b2 - e2), abs(b3 - e3))
    top = max(max(x0, x1), max(max(b1, b2), max(b3, b4)))
    return top + HERMITE_MARGIN_FACTOR * margin - level


@kernel_jit(inline="always")  # a function passed to a call numba does not inline is a dynamic global: no cache
def release_time(barrier_force, barrier, t_start, t_limit, coefficients, scan_step, max_scans):
    """First t in (t_start, t_limit] where the force at the barrier pulls the mass away from it.

    barrier_force(t, coefficients, barrier): the model's acceleration of a mass at rest on that
    barrier, positive into it. The force is an explicit function of t, so it is scanned in steps of ``scan_step``
    (a fraction of the shortest forcing period, so no sign change is stepped over) and the
    sign change is bisected to rounding. Returns (t, scans): t = t_limit + 1 if the mass stays
    stuck, NaN if ``max_scans`` scan intervals did not reach either (a fast forcing period
    so short that the scan would never end, e.g. Omega = 1e12).

    The mass leaves where the force is negative, not where it is zero: a force that only touches
    zero and presses again (the bouncing ball at Gamma = 1, 1 - cos t, which rounds to 0 within
    1.5e-8 of each t = 2 pi k) leaves the mass at rest, where releasing it there logged an impact
    of speed 0 moments later, a rounding's worth of times a period (up to 0.7.17). Where the force
    does change sign nothing moves: the mass at rest under no force stays at rest until the pull.
    """
    t_a = t_start
    scans = 0
    while t_a < t_limit:
        if scans >= max_scans:
            return np.nan, scans
        scans += 1
        t_b = min(t_a + scan_step, t_limit)
        if barrier_force(t_b, coefficients, barrier) < 0.0:
            for _ in range(MAX_ROOT_ITERATIONS):
                t_mid = 0.5 * (t_a + t_b)
                if t_mid <= t_a or t_mid >= t_b:
                    break
                if barrier_force(t_mid, coefficients, barrier) < 0.0:
                    t_b = t_mid
                else:
                    t_a = t_mid
            return t_b, scans
        t_a = t_b
    return t_limit + 1.0, scans
