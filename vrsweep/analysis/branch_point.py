"""Branch switching at a branch point: the second branch of orbits of the same p slow periods
through a point where [M - I | F_lam] has rank 1 (continuation.BRANCH_POINT).

At a branch point z* = (y*, lam*) of F(y, lam) = P^p(y; lam) - y the null space of dF = [M - I |
F_lam] is two-dimensional, and two branches cross there, each along its own direction in it. On
a branch of orbits symmetric under x -> -x, t -> t + T/2 it is the symmetry-breaking pitchfork:
the branch followed goes on, and the second is the branch of asymmetric orbits, the mirror images
of one another on its two halves (lam - lam* ~ a^2, a the asymmetry). The second direction comes
from the algebraic bifurcation equation (docs/design.md, "Branch switching at a branch point"):

- psi, the left null vector of dF, and (n1, n2) an orthonormal basis of its null space;
- on the null space, psi . F(z* + a n1 + b n2) = (1/2) Q(a, b) + O(3), Q the quadratic form
  psi . d2F[n, n], measured by central second differences of psi . F (SECOND_DIFFERENCES, so that
  the located point's own error, which is first order, cancels);
- the two branches leave z* along the two real roots of Q(a, b) = 0; the one nearer the chord of
  the branch followed is that branch, the other is the branch switched to, t_new.

The first orbit on it is corrected from z* + eps t_new with the arclength condition along u, the
unit vector of the null space orthogonal to the branch followed: the branch followed crosses that
plane only at second order, far from the predictor, and the branch switched to at first order, at
the predictor. eps is the smallest of SWITCH_AMPLITUDES times SEPARATION sqrt(tol / |Q(t_new,
t_old)|) that converges next to its predictor: below that the orbits within Newton's tolerance of
F = 0 on the plane (about tol / (eps |Q(t_new, t_old)|) along the branch followed) would not be
much shorter than eps, and the corrector would accept the predictor itself, on neither branch.

The branch switched to is followed both ways with continuation.follow from that orbit: away from
z*, and back to it, where it ends (status "branch_point"), z* itself its first point. From z* -
eps t_new the same gives its other half, a branch of its own: on a symmetric branch the mirror
images of the first half's orbits, the same in R, drawn over it. (Followed on, the first half
would go back through z*, where its parameter turns, lam - lam* ~ a^2, and on along the second.)
A switched branch that meets another branch point of the branch it was born on (a bubble of
asymmetric orbits) ends there too; that branch point is not switched again.
"""

import dataclasses
import math

import numpy as np

from vrsweep.analysis import continuation, period_doubling
from vrsweep.results import Status

ENDED_BRANCH_POINT = "branch_point"
# Relative step of the central second differences of psi . F (relative to max(1, |y*|, |lam*|)),
# tried shorter where a point of the stencil has another impact count than the branch point
# (the map is only piecewise smooth: the second difference across a graze is no curvature).
SECOND_DIFFERENCES = (1e-3, 1e-4, 1e-5)
# eps's floor, in units of sqrt(tol / |Q(t_new, t_old)|): Newton's tolerance band across the
# branch followed, tol / (eps |Q(t_new, t_old)|) on either side, is then eps / SEPARATION^2.
SEPARATION = 16.0
# eps, in units of that floor (and at least 1e-6 of max(1, |y*|)), tried in turn.
SWITCH_AMPLITUDES = (1.0, 3.0, 10.0, 30.0, 100.0)
# The corrected first orbit must lie within this share of eps of its predictor: the predictor
# is on the switched branch to second order.
NEAR_PREDICTOR = 0.5
# The corrector at the smallest eps converges linearly at first (the Jacobian nearly singular):
# it gets this many times max_newton_iterations.
SWITCH_NEWTON_FACTOR = 4


def _null_space(orbit):
    """(psi, basis): the unit left null vector of dF = [M - I | F_lam] at ``orbit`` (2,) and an
    orthonormal basis of its two-dimensional null space (3, 2), from the singular value
    decomposition (at a branch point its second singular value is zero to the location's error)."""
    jacobian = np.zeros((2, 3))
    jacobian[:, :2] = orbit.monodromy - np.eye(2)
    jacobian[:, 2] = orbit.parameter_derivative
    left, _, right = np.linalg.svd(jacobian)
    return left[:, 1], right[1:].T


def _scale(orbit):
    return max(1.0, float(np.max(np.abs(orbit.z))))


def quadratic_form(problem, point, periods):
    """(Q, basis): the 2x2 matrix of psi . d2F on the null space's ``basis`` (3, 2) at ``point``,
    or (None, reason). Central second differences along n1, n2 and (n1 + n2)/sqrt 2 at the first
    of SECOND_DIFFERENCES whose stencil keeps the branch point's impact count."""
    psi, basis = _null_space(point)
    n1, n2 = basis[:, 0], basis[:, 1]
    reason = "the map could not be evaluated around the branch point"
    for relative in SECOND_DIFFERENCES:
        h = relative * _scale(point)
        values = {}
        for name, direction in (("11", n1), ("22", n2), ("12", (n1 + n2) / math.sqrt(2.0))):
            sides = []
            for sign in (1.0, -1.0):
                z = point.z + sign * h * direction
                orbit_map = continuation.evaluate(problem, z[:2], z[2], periods)
                if orbit_map.status != Status.OK:
                    break
                if orbit_map.impacts / periods != point.impacts_per_period:
                    reason = "an impact appears or goes within the second differences around the branch point"
                    break
                sides.append(float(psi @ (orbit_map.end_state - z[:2])))
            if len(sides) < 2:
                break
            values[name] = sides
        if len(values) < 3:
            continue
        centre_map = continuation.evaluate(problem, point.state, point.parameter, periods)
        if centre_map.status != Status.OK:
            return None, reason
        centre = float(psi @ (centre_map.end_state - point.state))

        def second(name):
            return (values[name][0] + values[name][1] - 2.0 * centre) / (h * h)
        q11, q22 = second("11"), second("22")
        q12 = second("12") - 0.5 * (q11 + q22)  # Q(n1 + n2)/2 = (q11 + 2 q12 + q22)/2
        form = np.array([[q11, q12], [q12, q22]])
        if not np.all(np.isfinite(form)):
            return None, "the map's second differences around the branch point are not finite"
        return form, basis
    return None, reason


def switching_directions(problem, point, chord, periods):
    """(t_old, t_new, u, cross) at the branch point ``point``: the unit directions (3,) of the
    branch followed (the root of Q nearer ``chord``, the chord of the branch's orbits on either
    side of the point) and of the branch switched to, u the unit null vector orthogonal to t_old
    (oriented along t_new), and cross = Q(t_new, t_old); or (None, reason)."""
    form, basis = quadratic_form(problem, point, periods)
    if form is None:
        return None, basis
    # Roots of Q(c) = c . form c on the unit circle c = (cos phi, sin phi): the eigenvectors of form
    # are its axes, and Q = l1 cos^2 + l2 sin^2 in them, zero where tan^2 = -l1 / l2.
    eigenvalues, axes = np.linalg.eigh(form)
    if eigenvalues[0] * eigenvalues[1] >= 0.0:
        return None, "the quadratic form of the branch point has no two real directions (not a crossing of two branches)"
    slope = math.sqrt(-eigenvalues[0] / eigenvalues[1])
    roots = [axes @ np.array([1.0, sign * slope]) for sign in (1.0, -1.0)]
    roots = [basis @ (c / np.linalg.norm(c)) for c in roots]
    along = np.asarray(chord, dtype=float) / np.linalg.norm(chord)
    old_index = int(np.argmax([abs(float(r @ along)) for r in roots]))
    t_old, t_new = roots[old_index], roots[1 - old_index]
    u = t_new - (t_new @ t_old) * t_old
    u /= np.linalg.norm(u)
    c_old, c_new = basis.T @ t_old, basis.T @ t_new
    return (t_old, t_new, u, float(c_new @ form @ c_old)), None


def first_switched_orbit(problem, point, directions, periods, side):
    """The first orbit of the branch switched to at ``point`` (switching_directions' result) on
    ``side`` (+1: along t_new, -1: against it): (Orbit, None) or (None, reason)."""
    t_old, t_new, u, cross = directions
    t_new, u = side * t_new, side * u
    tolerance = continuation._tolerance(problem, point.state)
    floor = max(1e-6 * _scale(point), SEPARATION * math.sqrt(tolerance / max(abs(cross), 1e-300)))
    iterations = SWITCH_NEWTON_FACTOR * problem.options["max_newton_iterations"]
    patient = dataclasses.replace(problem, options=dict(problem.options, max_newton_iterations=iterations))
    reason = "no orbit of the second branch found next to the branch point"
    for amplitude in SWITCH_AMPLITUDES:
        eps = amplitude * floor
        # z* + eps t_new, scaled onto the plane u . (z - z*) = eps (u . t_new of eps)
        z_predicted = point.z + eps * t_new / float(u @ t_new)
        plane = point.z + eps * u
        orbit, failure = continuation.correct(patient, z_predicted, periods, u, plane)
        if failure is not None:
            reason = failure[1]
            continue
        if np.linalg.norm(orbit.z - z_predicted) > NEAR_PREDICTOR * eps:
            reason = (f"the corrector went to an orbit at {problem.parameter} = {orbit.parameter:.8g}, "
                      f"not next to the branch point")
            continue
        return orbit, None
    return None, reason


def _chord_through(branch, point):
    """The chord of ``branch``'s consecutive orbits whose segment passes nearest ``point``."""
    orbits = branch.orbits
    best, chord = np.inf, None
    for before, after in zip(orbits, orbits[1:]):
        segment = after.z - before.z
        length = float(segment @ segment)
        if length == 0.0:
            continue
        s = min(1.0, max(0.0, float((point.z - before.z) @ segment) / length))
        distance = float(np.linalg.norm(before.z + s * segment - point.z))
        if distance < best:
            best, chord = distance, segment
    return chord


def _meets_branch_points(problem, point, u, others):
    """follow's stop test on a switched branch: it ends where a step passes back through its birth
    ``point`` (the sign of u . (z - z*), its amplitude across the branch followed, changes on a
    chord that passes by z*: period_doubling's test) or passes one of the parent branch's
    ``others`` branch points (a bubble). Returns (stop, met): ``met`` collects the branch points
    it stopped at, ``point`` too."""
    met = []
    passes_by = period_doubling._passes_by

    def stop(previous, orbit):
        crosses = float(u @ (previous.z - point.z)) * float(u @ (orbit.z - point.z)) <= 0.0
        if crosses and passes_by(previous.z, orbit.z, point.z):
            reached = [point]
        else:
            reached = [other for other in others if passes_by(previous.z, orbit.z, other.z)]
        if not reached:
            return None
        met.append(reached[0])
        return (ENDED_BRANCH_POINT, f"meets the branch it was born on at its branch point at "
                                    f"{problem.parameter} = {reached[0].parameter:.8g}")
    return stop, met


def switched_branch(problem, point, parent, lo, hi, max_points, progress=None, others=(), side=1):
    """The half on ``side`` (+1 or -1, module doc) of the second branch through the branch point
    ``point`` (an Orbit) of the Branch ``parent``, followed both ways within [lo, hi], ``point``
    its first orbit: (Branch, [(kind, Orbit)], [branch points met]) or (None, reason, []).
    ``others``: the parent's other branch points, where the switched branch ends too."""
    periods = point.periods
    chord = _chord_through(parent, point)
    if chord is None:
        return None, "the branch has no orbits on either side of the branch point", []
    directions, reason = switching_directions(problem, point, chord, periods)
    if directions is None:
        return None, reason, []
    start, reason = first_switched_orbit(problem, point, directions, periods, side)
    if start is None:
        return None, reason, []
    stop, met = _meets_branch_points(problem, point, directions[2], [o for o in others if o is not point])
    ways = []
    for direction in (-1, +1):
        before = len(met)
        if ways and ways[0][2][0] == continuation.ENDED_INTERRUPTED:
            ways.append(([], [], (continuation.ENDED_INTERRUPTED, "not followed: the run was stopped before"), []))
            continue
        orbits, found, end = continuation.follow(problem, start, direction, lo, hi, max_points // 2, progress,
                                                 stop=stop)
        ways.append((orbits, found, end, met[before:]))
    # The way back to the branch point first, ``point`` itself its first orbit (as a doubled
    # branch's first orbit is its doubling point: not corrected again, dF has rank 1 there).
    if any(m is point for m in ways[1][3]):
        ways.reverse()
    (back, back_found, back_end, back_met), (away, away_found, away_end, _) = ways
    orbits = list(reversed(back)) + [start] + away
    if any(m is point for m in back_met):
        orbits.insert(0, point)
    branch = continuation.Branch(periods=periods, orbits=orbits, ends={"down": back_end, "up": away_end})
    # The pitchfork's vertex is a fold of the switched branch at its birth: not one of its bifurcations.
    found = period_doubling.without_birth_folds(problem, point, back_found + away_found)
    return branch, found, [m for m in met if m is not point]
