"""Grazing: where a periodic orbit starts to hit the barrier, located exactly and crossed.

At a grazing orbit the free motion touches x = Delta with zero velocity. The stroboscopic map
P^p is continuous there but not smooth: on the impacting side an orbit whose free motion would
have overshot the barrier by sigma hits it with speed u = sqrt(2 a sigma) (a = -x'' at the
touch), and the map gains a term proportional to u, the square root of a distance. Newton started
on the free side sees only the free map's Jacobian and does not cross into the square-root
region, so vrsweep handles grazing with two tools (docs/design.md, "Continuation of periodic
orbits", its part on grazing):

1. The barrier-free map P_free (the same oscillator with Delta -> infinity) is smooth through the
   graze, and so is its orbit's largest x, x_max_free. The grazing orbit solves
       P_free^p(y; lam) - y = 0,   Delta - x_max_free(y; lam) = 0
   three equations in z = (x, v, lam), by Newton (locate_graze): the parameter of grazing is
   known to the Newton tolerance, not to a continuation step.
2. The branch beyond, from the normal form of the map at the graze (Nordmark's square-root map):
   near z_g, with dz = z - z_g and the free side's linearisation,
       F_impacting(z) = F_free(z) + C u + O(u^2),   u^2 = kappa sigma(z),
       sigma(z) = x_max_free(z) - Delta = -gap(z)
   C (2,) and kappa = 2a are measured from one probe orbit that penetrates by about
   PROBE_PENETRATION (its impact speed u_1, its real and free maps: C = (P - P_free) / u_1,
   kappa = u_1^2 / sigma_1). The impacting fixed points then satisfy, to first order,
       [[M - I, F_lam], [grad gap]] dz = [-C u; -u^2 / kappa - gap(z_g)]
   a line of orbits leaving the graze in the direction J^-1 [-C; 0] as u grows from 0: whether
   lam grows or falls along it (the branch goes on, or folds back at a corner) is the sign of its
   last component. The predictor at a small u is corrected by the ordinary arclength corrector on
   the real map, where Newton's square-root basin is wide enough (it converges from sigma in
   (0, 4 sigma*)). Where the map beyond is steep (multipliers of order 1/u: the predictor's O(u^2)
   error is then as large as sigma) that basin is missed, and the branch is followed in u
   instead (correct_at_speed, at the end of this module). Coming the other way, from an
   impacting orbit whose one impact slows to zero,
   the graze is located the same way and the free branch leaves it along the free tangent,
   oriented away from the barrier.

Where the orbit has other impacts besides the grazing one (the impacting windows of Fig. 1, with
8 to 10 impacts in 3 slow periods), "free" means free of the grazing impact alone: the barrier is
made transparent in a short time window around the touch (numerics/settings.TRANSPARENT_FROM) and
kept everywhere else, and x_max_free is the largest x inside that window (graze_window). The
window is fixed while Newton moves the orbit; it is a quarter of the shortest forcing period
either side at most and under half the time to the nearest other impact, so the touch stays in it
and the other impacts out. A non-impacting orbit that starts to hit, or one whose only impact
slows to zero, needs no window: the whole barrier goes (Delta = inf). A graze too close to the
stroboscopic section t = 0 mod pT for a window has no such map; there the caller falls back on a
search around the grazing point (continuation.switch_at_grazing).
"""

import math
from dataclasses import dataclass

import numpy as np

from vrsweep.numerics.coefficients import (BARRIER, BARRIER_VALUES, N_BARRIERS, PERIOD, POSITION, SIDE,
                                           free_of_barriers, grazing_barrier, grazing_scale, only_barrier,
                                           shortest_period)
from vrsweep.numerics.shooting import periodic_map
from vrsweep.results import Status

# Relative steps of the forward differences of the gap Delta - x_max_free in (x, v, lam): x_max
# is the dense output's turning point, smooth in z to about the integration tolerance (1e-10
# relative), so a step of 1e-6 gives its gradient to ~1e-4, which Newton and the predictor need
# at most.
GAP_DIFFERENCE = 1e-6
# How far the probe orbit overshoots the barrier (relative to max(1, |Delta|)): deep enough that
# its impact speed (~1e-3) stands well above the solver's noise, shallow enough that the O(sigma)
# terms of the normal form stay 1e-3 of the square-root term.
PROBE_PENETRATION = 1e-6
MAX_GRAZE_ITERATIONS = 20
# Halvings of a Newton step of locate_graze that leaves the start's impacts (2^-6: a step of 0.01
# in the parameter comes down to 1.6e-4, closer than any two of Fig. 1's grazes).
MAX_GRAZE_HALVINGS = 6
# The transparent window either side of a touch: at most this share of the shortest forcing
# period (a shallow excursion past Delta lasts ~ sqrt(penetration), far less) ...
WINDOW_FORCING_SHARE = 0.25
# ... and under this share of the time to the orbit's nearest other impact.
WINDOW_IMPACT_SHARE = 0.45
# A graze of two stops at once (a double graze): an orbit symmetric under x -> -x, t -> t + T/2
# between stops at d and -d (a Duffing oscillator in a symmetric gap) touches both in the same
# orbit, and beyond it gains (or, from the other side, loses) both impacts at once. Another stop
# counts as touched by the located grazing orbit when its own gap is within this many Newton
# tolerances of 0 (the symmetric orbit's two gaps agree to about one: the orbit is converged to
# it) ...
TOUCH_TOLERANCES = 100.0
# ... and an impacting orbit's impacts slow down together when the fastest of them is within this
# factor of the slowest (the two impacts of a symmetric orbit have one speed, to its convergence).
SIMULTANEOUS_SPEEDS = 1.5


@dataclass
class Graze:
    """A located grazing orbit and the free map's linearisation there.

    z           (3,) x, v at t = 0 mod T and the parameter
    periods     p
    window      (t_from, t_to): where the barrier is transparent, or None: no barrier at all
    orbit_map   the free map's shooting.OrbitMap at z (no grazing impact; its x_max, or its
                window_x_max with a window, = Delta)
    jacobian    (3, 3) [[M - I, F_lam], [grad gap]] of [F_free; gap] in (x, v, lam)
    gap         Delta - x_max_free at z (within the Newton tolerance of 0)
    residual    max |P_free^p(y) - y| at z
    iterations  Newton iterations taken
    touches     the barriers (indices) the barrier-free grazing orbit touches when it touches
                more than one at once (a double graze: both stops of a symmetric orbit), else ()
    """
    z: np.ndarray
    periods: int
    window: object
    orbit_map: object
    jacobian: np.ndarray
    gap: float
    residual: float
    iterations: int
    touches: tuple = ()


def free_coefficients(coefficients):
    """The coefficient vector without the barrier (Delta -> infinity: the kernel never impacts)."""
    return free_of_barriers(coefficients)


def free_map(problem, state, value, periods, window=None):
    """P_free^p at (state, value): shooting.OrbitMap of the oscillator without the barrier, or
    with the barrier transparent in ``window`` (t_from, t_to) only."""
    if window is None:
        return periodic_map(free_coefficients(problem.coefficients(value)), state, problem.settings, periods,
                            problem.method, model=problem.model)
    return periodic_map(problem.coefficients(value), state, problem.settings, periods, problem.method,
                        model=problem.model,
                        transparent=window)


def barrier(problem, value):
    return grazing_barrier(problem.coefficients(value))


def scale(problem, value):
    return grazing_scale(problem.coefficients(value))


def barrier_gaps(coefficients, orbit_map):
    """Per barrier of the coefficient vector, how far inside it the orbit of ``orbit_map`` stays:
    position - x_max for a barrier above, x_min - position for one below (0: it touches)."""
    gaps = []
    for b in range(int(coefficients[N_BARRIERS])):
        position = coefficients[BARRIER + BARRIER_VALUES * b + POSITION]
        above = coefficients[BARRIER + BARRIER_VALUES * b + SIDE] > 0.0
        gaps.append(position - orbit_map.x_max if above else orbit_map.x_min - position)
    return np.array(gaps)


def _touches(problem, z, orbit_map, tolerance):
    """The barriers the barrier-free orbit at z touches, when it touches more than one (else ())."""
    coefficients = problem.coefficients(z[2])
    scale = max(1.0, float(np.max(np.abs(coefficients[BARRIER + POSITION::BARRIER_VALUES][
        :int(coefficients[N_BARRIERS])]), initial=0.0)))
    touched = tuple(int(b) for b in np.flatnonzero(np.abs(barrier_gaps(coefficients, orbit_map))
                                                    <= TOUCH_TOLERANCES * tolerance * scale))
    return touched if len(touched) > 1 else ()


def free_top(orbit_map, window):
    """x_max_free: the free map's largest x, in the window if there is one."""
    return orbit_map.x_max if window is None else orbit_map.window_x_max


def graze_window(problem, orbit_map, value, periods, touch_time):
    """The transparent window around a touch at ``touch_time`` in [0, pT] of an orbit whose
    OrbitMap is ``orbit_map`` (the impact there, if any, is left out of "other impacts"), or None
    when the touch is too close to the stroboscopic section t = 0 mod pT for one."""
    coefficients = problem.coefficients(value)
    slow_period = coefficients[PERIOD]
    shortest = shortest_period(coefficients)
    half = WINDOW_FORCING_SHARE * shortest
    orbit_period = periods * slow_period
    others = orbit_map.impact_times
    distances = np.abs(others - touch_time)
    distances = np.minimum(distances, orbit_period - distances)  # the orbit is pT-periodic
    distances = distances[distances > 1e-9 * orbit_period]       # the touch's own impact
    if distances.size:
        half = min(half, WINDOW_IMPACT_SHARE * float(np.min(distances)))
    if touch_time - half < 0.0 or touch_time + half > orbit_period:
        return None
    return (touch_time - half, touch_time + half)


def _free_system(problem, z, periods, window=None):
    """[F_free; gap] at z (3,) and the free OrbitMap, or (None, map) when it failed to integrate."""
    orbit_map = free_map(problem, z[:2], z[2], periods, window)
    if orbit_map.status != Status.OK:
        return None, orbit_map
    gap = barrier(problem, z[2]) - free_top(orbit_map, window)
    return np.array([*(orbit_map.end_state - z[:2]), gap]), orbit_map


def _free_jacobian(problem, z, periods, value_at_z, orbit_map, window):
    """(3, 3) Jacobian of [F_free; gap]: the monodromy for the state block, forward differences
    for the parameter column and for the gap's row."""
    jacobian = np.zeros((3, 3))
    jacobian[:2, :2] = orbit_map.monodromy - np.eye(2)
    for column in range(3):
        step = GAP_DIFFERENCE * max(1.0, abs(z[column]))
        moved = z.copy()
        moved[column] += step
        value, _ = _free_system(problem, moved, periods, window)
        if value is None:
            return None
        difference = (value - value_at_z) / step
        if column == 2:
            jacobian[:2, 2] = difference[:2]
        jacobian[2, column] = difference[2]
    return jacobian


def locate_graze(problem, z_guess, periods, tolerance, window=None):
    """The grazing orbit near z_guess (3,): Newton on [P_free^p(y) - y; Delta - x_max_free] = 0
    until every component is within ``tolerance``; the free map is barrier-free, or with the
    barrier transparent in ``window`` only (graze_window).

    Returns a Graze, or None when Newton does not converge (no graze nearby, or the free motion
    escapes where the real one impacts).
    """
    z = np.array(z_guess, dtype=float)
    value, orbit_map = _free_system(problem, z, periods, window)
    if value is None:
        return None
    impacts = len(orbit_map.impact_times)
    for iteration in range(1, MAX_GRAZE_ITERATIONS + 1):
        jacobian = _free_jacobian(problem, z, periods, value, orbit_map, window)
        if jacobian is None:
            return None
        if np.max(np.abs(value)) <= tolerance:
            return Graze(z=z, periods=periods, window=window, orbit_map=orbit_map, jacobian=jacobian,
                         gap=float(value[2]),
                         residual=float(np.max(np.abs(value[:2]))), iterations=iteration,
                         touches=() if window is not None else _touches(problem, z, orbit_map, tolerance))
        step = _newton_step(jacobian, -value)
        if step is None:
            return None
        # The windowed map is smooth only while the impacts outside the window stay the same ones:
        # a full step from an orbit 0.008 below the touch at the end of Fig. 1's period-3 window
        # (g = 17.7866) lands at g = 17.8034, where two of those impacts are gone, and Newton
        # diverges from there; the graze (g = 17.796) was then missed and a continuation step
        # passed it unseen. The step is halved until it stays on the start's piece of the map.
        for halving in range(MAX_GRAZE_HALVINGS + 1):
            trial = z + step * 0.5 ** halving
            trial_value, trial_map = _free_system(problem, trial, periods, window)
            if trial_value is not None and len(trial_map.impact_times) == impacts:
                break
        else:
            return None
        z, value, orbit_map = trial, trial_value, trial_map
    return None


def impacting_direction(problem, graze):
    """The normal form at the graze: (unit direction (3,) of the impacting branch as u grows,
    predictor(u) -> z (3,), |dz/du| at u = 0), or None when the probe orbit does not gain exactly
    one impact over the free map's, in the window, as the normal form assumes (one impact on each
    touched stop at a double graze: _double_normal_form)."""
    if graze.touches:
        return _double_normal_form(problem, graze)
    probed = _probe(problem, graze)
    if probed is None:
        return None
    z_g = graze.z
    value, real, free = probed
    speed = _grazing_impact_speed(real, graze.window)
    if not speed > 0.0:
        return None
    sigma = -value[2]
    if not sigma > 0.0:
        return None
    jump = (real.end_state - free.end_state) / speed     # C
    kappa = speed * speed / sigma                        # 2 a
    try:
        direction = np.linalg.solve(graze.jacobian, np.array([-jump[0], -jump[1], 0.0]))
        curvature = np.linalg.solve(graze.jacobian, np.array([0.0, 0.0, -1.0 / kappa]))
    except np.linalg.LinAlgError:
        return None  # the graze is also a fold of the free map: a codimension-two point

    def predictor(u):
        return z_g + u * direction + (u * u + graze.gap * kappa) * curvature

    predictor.kappa = kappa  # for onto_speed
    return direction / np.linalg.norm(direction), predictor, np.linalg.norm(direction)


def impacting_monodromy(problem, graze):
    """The monodromy of the map with the grazing impact, next to the graze on its impacting side:
    the probe orbit's (impacting_direction's, penetration PROBE_PENETRATION), or None where the
    probe does not gain exactly one impact. Its saltation term grows like 1/u, u ~ 1e-3 the probe
    impact's speed, so one multiplier is of order 1/u and the other of order u: the signs of
    det(M - I) and det(M + I) there are the limits of the impacting side's at the graze, which
    the continuation's test functions need on that side of it (continuation._detect). At a
    double graze, the real map's at the normal form's predictor a little beyond (both impacts)."""
    if graze.touches:
        normal_form = _double_normal_form(problem, graze)
        if normal_form is None:
            return None
        speed = math.sqrt(normal_form[1].kappa * PROBE_PENETRATION * scale(problem, graze.z[2]))
        probe = normal_form[1](speed)
        real = periodic_map(problem.coefficients(probe[2]), probe[:2], problem.settings, graze.periods,
                            problem.method, model=problem.model)
        if real.status != Status.OK or real.impacts != graze.orbit_map.impacts + len(graze.touches):
            return None
        return real.monodromy.copy()
    probed = _probe(problem, graze)
    return None if probed is None else probed[1].monodromy.copy()


def _probe(problem, graze):
    """(the free system's value, the real map, the free map) at the probe: the graze's point moved
    PROBE_PENETRATION into the impacting side, or None where the real map does not gain exactly
    one impact over the free map's there (the normal form's assumption)."""
    z_g = graze.z
    gradient = graze.jacobian[2]
    penetration = PROBE_PENETRATION * scale(problem, z_g[2])
    probe = z_g - (penetration + graze.gap) * gradient / (gradient @ gradient)
    real = periodic_map(problem.coefficients(probe[2]), probe[:2], problem.settings, graze.periods, problem.method,
                        model=problem.model)
    value, free = _free_system(problem, probe, graze.periods, graze.window)
    if value is None or real.status != Status.OK or real.impacts != free.impacts + 1:
        return None
    return value, real, free


def _double_normal_form(problem, graze):
    """impacting_direction at a graze of two stops at once (graze.touches: both gaps 0 at z_g).

    Beyond it the map gains one impact on each stop, F = F_free + C1 u1 + C2 u2 (each stop's
    square-root term, its own C_b and kappa_b measured by a probe with that stop alone in effect,
    only_barrier), with the two gaps -u_b^2 / kappa_b. Each impact also moves the rest of the
    orbit by O(u), and so the other stop's gap by D_ab u_b (measured on the same probe): without
    that term the first-order system had no solution with both speeds positive (r = -2.6 for the
    symmetric Duffing oscillator, whose branch beyond has u2 = u1). Parameterised by the first
    stop's speed u1 = u, with u2 = r u + s u^2: to first order
        [[M - I, F_lam, C2], [grad gap1, D_12], [grad gap2, 0]] [dz1; r] = [-C1; 0; -D_21]
    (a branch with both impacts needs r > 0), to second order the same matrix times [dz2; s] is
    [0; 0; -1 / kappa1; -r^2 / kappa2] (the cross terms' own second order left to the corrector),
    and the gaps' residue at z_g (within the tolerance) is taken up by a constant dz0. The single
    graze's formula is the same with one gap row and no C2.
    Returns (unit dz1, predictor(u) -> z, |dz1|) or None (a probe that does not gain its one impact,
    r <= 0: no branch beyond touches both stops, or a singular matrix)."""
    z_g, periods = graze.z, graze.periods
    coefficients = problem.coefficients(z_g[2])
    first_above = [b for b in graze.touches
                   if coefficients[BARRIER + BARRIER_VALUES * b + SIDE] > 0.0][:1]
    order = first_above + [b for b in graze.touches if b not in first_above]
    if len(order) != 2:
        return None

    def gaps_at(z):
        orbit_map = free_map(problem, z[:2], z[2], periods)
        if orbit_map.status != Status.OK:
            return None, orbit_map
        return barrier_gaps(problem.coefficients(z[2]), orbit_map)[order], orbit_map

    gaps, _ = gaps_at(z_g)
    if gaps is None:
        return None
    gradients = np.zeros((2, 3))
    for column in range(3):
        step = GAP_DIFFERENCE * max(1.0, abs(z_g[column]))
        moved = z_g.copy()
        moved[column] += step
        there, _ = gaps_at(moved)
        if there is None:
            return None
        gradients[:, column] = (there - gaps) / step
    jumps, kappas, crossed = [], [], []
    for k, b in enumerate(order):
        gradient = gradients[k]
        penetration = PROBE_PENETRATION * max(1.0, abs(coefficients[BARRIER + BARRIER_VALUES * b + POSITION]))
        probe = z_g - (penetration + gaps[k]) * gradient / (gradient @ gradient)
        real = periodic_map(only_barrier(problem.coefficients(probe[2]), b), probe[:2], problem.settings, periods,
                            problem.method, model=problem.model)
        probe_gaps, free = gaps_at(probe)
        if probe_gaps is None or real.status != Status.OK or real.impacts != free.impacts + 1:
            return None
        speed, sigma = real.slowest_impact, -probe_gaps[k]
        if not (speed > 0.0 and sigma > 0.0):
            return None
        jumps.append((real.end_state - free.end_state) / speed)
        kappas.append(speed * speed / sigma)
        # The impact on this stop moves the rest of the orbit by O(u), and with it the other
        # stop's gap: a first-order term of that gap (which is itself O(u^2) on the branch).
        other = 1 - k
        crossed.append((barrier_gaps(problem.coefficients(probe[2]), real)[order[other]] - probe_gaps[other]) / speed)
    matrix = np.zeros((4, 4))
    matrix[:2, :3] = graze.jacobian[:2]
    matrix[:2, 3] = jumps[1]
    matrix[2:, :3] = gradients
    matrix[2, 3] = crossed[1]   # the second stop's impact on the first stop's gap, per unit of u2
    try:
        first = np.linalg.solve(matrix, np.array([-jumps[0][0], -jumps[0][1], 0.0, -crossed[0]]))
        ratio = first[3]
        second = np.linalg.solve(matrix, np.array([0.0, 0.0, -1.0 / kappas[0], -ratio * ratio / kappas[1]]))
        constant = np.linalg.solve(matrix, np.array([0.0, 0.0, -gaps[0], -gaps[1]]))
    except np.linalg.LinAlgError:
        return None
    if not ratio > 0.0:
        return None
    direction = first[:3]

    def gaps_without(z, k):
        """Stop order[k]'s gap on the map with the other stop in effect: what the real orbit's
        speed on that stop follows (u_k^2 = -kappa_k gap), its other impact's effect included."""
        only = periodic_map(only_barrier(problem.coefficients(z[2]), order[1 - k]), z[:2], problem.settings,
                            periods, problem.method, model=problem.model)
        if only.status != Status.OK:
            return None
        return barrier_gaps(problem.coefficients(z[2]), only)[order[k]]

    def predictor(u):
        """The normal form's point at u1 = u, moved (Newton-chord, minimum-norm steps) to where
        each stop's gap on the map without it is -u_b^2 / kappa_b: the expansion's O(u^2) error
        in z is an O(u) error in the speeds (the square root; and the other impact's effect on a
        gap is O(u^2) beyond its linear term), and Newton on the real map then started with one
        impact missing (u = 0.02 at the symmetric Duffing oscillator's graze). The chord's rows are
        the gaps' gradients plus the other impact's term through its speed (D kappa grad / 2u)."""
        z = z_g + constant[:3] + u * direction + u * u * second[:3]
        speeds = np.array([u, ratio * u])
        target = -speeds ** 2 / np.array(kappas)
        chord = np.array([gradients[k] - crossed[1 - k] * kappas[1 - k] * gradients[1 - k] / (2.0 * speeds[1 - k])
                          for k in range(2)])
        pseudo_inverse = np.linalg.pinv(chord)
        for _ in range(6):
            there = [gaps_without(z, k) for k in range(2)]
            if any(gap is None for gap in there):
                break
            miss = np.array(there) - target
            if np.max(np.abs(miss)) <= 1e-3 * np.min(np.abs(target)):
                break
            z = z - pseudo_inverse @ miss
        return z

    predictor.kappa = kappas[0]
    predictor.ratio = ratio  # u2 / u1 to first order (1 on a symmetric orbit)
    return direction / np.linalg.norm(direction), predictor, np.linalg.norm(direction)


def _grazing_impact_speed(real, window):
    """The speed of the one impact the real map has where the free map has none (NaN if not one)."""
    if window is None:
        return real.slowest_impact if real.impacts == 1 else np.nan
    inside = (real.impact_times >= window[0]) & (real.impact_times < window[1])
    return float(real.impact_speeds[inside][0]) if np.count_nonzero(inside) == 1 else np.nan


def free_direction(graze):
    """Unit tangent (3,) of the free branch at the graze, pointing away from the barrier."""
    tangent = np.cross(graze.jacobian[0], graze.jacobian[1])
    tangent /= np.linalg.norm(tangent)
    return tangent if graze.jacobian[2] @ tangent > 0.0 else -tangent


def graze_site(problem, orbit_map, value, periods, proximity):
    """Which graze an orbit (its OrbitMap at parameter ``value``) is next to, if any:
    (side, window), side "free" when one of its smooth maxima is about to touch the barrier (it
    gains an impact beyond), "impacting" when its slowest impact is about to stop (it loses that
    impact beyond), window as locate_graze takes it; or None (not within ``proximity``, relative
    to max(1, |Delta|), or a touch too close to t = 0 mod pT for a window).

    An impact at speed u penetrates about u^2 / (2 a), a ~ 1, so u^2 and the smooth maximum's
    distance from Delta are compared on one scale; the nearer graze is taken.
    """
    delta = barrier(problem, value)
    length = scale(problem, value)
    touch = (delta - orbit_map.free_x_max) / length
    stop = orbit_map.slowest_impact ** 2 / length if orbit_map.impacts else np.inf
    if not min(touch, stop) < proximity:
        return None
    if touch <= stop:
        if orbit_map.impacts == 0:
            return "free", None
        window = graze_window(problem, orbit_map, value, periods, orbit_map.free_x_max_time)
        return None if window is None else ("free", window)
    if orbit_map.impacts == 1 or _slowing_together(orbit_map):
        return "impacting", None
    time = float(orbit_map.impact_times[np.argmin(orbit_map.impact_speeds)])
    window = graze_window(problem, orbit_map, value, periods, time)
    return None if window is None else ("impacting", window)


def locate_at_site(problem, z, periods, tolerance, site, impacts, orbit_map_of):
    """locate_graze at a graze_site (side, window) of the orbit at z with ``impacts`` impacts in its
    periods (``orbit_map_of()`` its OrbitMap, asked for only where needed).
    Impacts that slow down together (_slowing_together) are taken out at once, on the barrier-free
    map; where the orbit located there touches only one stop after all (not a double graze), the
    slowest impact is taken out alone in its window and the graze located again, as for any orbit
    with other impacts."""
    side, window = site
    located = locate_graze(problem, z, periods, tolerance, window)
    if side != "impacting" or window is not None or impacts < 2 or (located is not None and located.touches):
        return located
    orbit_map = orbit_map_of()
    if orbit_map.impacts > 1:
        time = float(orbit_map.impact_times[np.argmin(np.abs(orbit_map.impact_speeds))])
        window = graze_window(problem, orbit_map, z[2], periods, time)
        located = None if window is None else locate_graze(problem, z, periods, tolerance, window)
    return located


def _slowing_together(orbit_map):
    """An orbit whose impacts all slow down at once, one on each stop (a double graze ahead, from
    its impacting side): the map without them is the barrier-free map. Up to 0.7.7 the slowest was
    windowed alone and the other kept, and the 'graze' located was that of another orbit (the
    symmetric Duffing oscillator between stops at +-1: F = 0.24384 for 0.24591)."""
    speeds = np.abs(orbit_map.impact_speeds)
    return (orbit_map.impacts == 2 and np.min(speeds) > 0.0
            and np.max(speeds) <= SIMULTANEOUS_SPEEDS * np.min(speeds)
            and orbit_map.impact_speeds[0] * orbit_map.impact_speeds[1] < 0.0)


# --- the branch beyond a steep graze, parameterised by the new impact's speed --------------------
#
# Beyond a graze the map is F(z) = Phi(z, u(z)), Phi smooth in (z, u) and u(z) = sqrt(kappa
# sigma(z)) the new impact's speed (Nordmark's normal form: F_free(z) + C u + O(u^2)). Its
# Jacobian carries C du/dz, and du/dz = kappa grad sigma / (2 u) grows like 1/u: next to the graze
# the impacting map has a multiplier of order |C| kappa / u (-24 at u = 0.01 beyond Fig. 1's
# g = 17.8973, 1.4e4 beyond g = 45.122 at Omega = 5) and curves like 1/u^3, so Newton on F alone
# diverges from any predictor whose error in sigma is not far below sigma ~ u^2 itself. The curve of impacting orbits is smooth in u, though (the
# desingularised map: sigma = u^2 / kappa), and so is the system
#     P^p(y; lam) - y = 0,   u(z)^2 - u_*^2 = 0
# at a fixed speed u_*, three equations in z = (x, v, lam). Its second equation is
# kappa(z) sigma(z) - u_*^2: smooth in z, with gradient kappa grad sigma of order one, so Newton
# meets it in one step from any sigma > 0; and the steep rank-one part C du/dz of the first two
# rows is the third row times C / (2u): a row operation removes it, so Newton's step is that of
# the smooth system [F_free + C u_*; kappa sigma - u_*^2] up to O(u) terms. The branch beyond is
# then followed by marching u_* up from small values (continuation.march_in_speed).

# The Jacobian is taken by differences in a basis fitted to the square root: d3 across the level
# sets of u^2 (a unit change of u^2 along it) and d1, d2 along them. Along d1, d2 the speed u
# stays put to first order and F is smooth: central differences of length SPEED_ALONG * u (the
# level sets curve, and u moves by O(h^2 / u)). Along d3 F is steep (C / 2u per unit of u^2):
# central differences that change u^2 by SPEED_ACROSS * u^2, short enough to keep the impact
# and the 1/u^3 curvature out. Newton meets the u^2 equation in one step (it is smooth), after
# which the d3 component of its steps, and so the error of the steep column, is small: the
# iteration's rate is set by the smooth columns. The map is known to about |mu| times the
# integration tolerance (the new impact's speed carries the solver's error in x divided by u),
# which the differences' lengths stay well above.
SPEED_ALONG = 1e-2
SPEED_ACROSS = 0.1
MAX_SPEED_ITERATIONS = 12


def _speed_system(problem, z, periods, window):
    """[P^p(y) - y; u^2] (3,) at z on the real map and the OrbitMap, or None when it failed or
    the new impact is missing (the point fell on the free side)."""
    real = periodic_map(problem.coefficients(z[2]), z[:2], problem.settings, periods, problem.method,
                        model=problem.model)
    if real.status != Status.OK or real.stuck_time > 0.0:
        return None
    speed = _grazing_impact_speed(real, window)
    if not speed > 0.0:
        return None
    return np.array([*(real.end_state - z[:2]), speed * speed]), real


def _speed_jacobian(problem, z, periods, window, value, impacts):
    """(3, 3) Jacobian of _speed_system's vector at z (its value ``value``), by differences in the
    basis of the comment above; None when a difference point leaves the impacting side."""
    def at(point):
        there = _speed_system(problem, point, periods, window)
        return None if there is None or there[1].impacts != impacts else there[0]

    squared = value[2]
    gradient = np.zeros(3)  # of u^2: smooth, a forward difference that keeps the impact
    for column in range(3):
        there, step = None, SPEED_ACROSS * squared
        for _ in range(8):  # either way, shorter until the difference keeps the new impact
            for signed in (step, -step):
                moved = z.copy()
                moved[column] += signed
                there = at(moved)
                if there is not None:
                    break
            if there is not None:
                break
            step *= 0.1
        if there is None:
            return None
        gradient[column] = (there[2] - squared) / signed
    norm = np.linalg.norm(gradient)
    if not norm > 0.0:
        return None
    across = gradient / (norm * norm)          # u^2 grows by one along it
    along = np.linalg.svd(gradient[None, :])[2][1:]  # orthonormal, with gradient . d = 0
    basis = np.column_stack([along[0], along[1], across])
    lengths = (SPEED_ALONG * np.sqrt(squared), SPEED_ALONG * np.sqrt(squared), SPEED_ACROSS * squared)
    columns = np.zeros((3, 3))
    for k in range(3):
        length = lengths[k]
        for _ in range(6):
            plus, minus = at(z + length * basis[:, k]), at(z - length * basis[:, k])
            # The level sets of u^2 curve: where they curve strongly (|grad u^2| ~ 6e3 at Omega = 5,
            # g = 45.122) even a short step along one leaves it, and u with it; shorter then.
            if (plus is not None and minus is not None
                    and max(abs(plus[2] - squared), abs(minus[2] - squared)) <= SPEED_ACROSS * squared):
                break
            length *= 0.1
        if plus is None or minus is None:
            return None
        columns[:, k] = (plus - minus) / (2.0 * length)
    return columns @ np.linalg.inv(basis)      # back to (x, v, lam)


def onto_speed(problem, graze, z_guess, speed, kappa, iterations=4):
    """z_guess moved along the gap's gradient at the graze until the free map (without the new
    impact) overshoots the barrier by sigma = speed^2 / kappa, where the real orbit hits it at
    about ``speed``: the normal form's predictor is off by O(u^2) in z, and where the gap's
    second derivatives are large (the period-1 orbit at Omega = 5, g = 45.122: |grad gap| ~ 70)
    that is O(1) of sigma itself, on either side of the barrier. The free map is smooth there
    (Newton-chord steps, the gradient kept from the graze). Returns z, or z_guess when the free map
    fails."""
    z = np.array(z_guess, dtype=float)
    gradient = graze.jacobian[2]
    target = speed * speed / kappa
    for _ in range(iterations):
        value, _ = _free_system(problem, z, graze.periods, graze.window)
        if value is None:
            return np.array(z_guess, dtype=float)
        sigma = -value[2]
        if abs(sigma - target) <= 1e-3 * target:
            break
        z = z - (target - sigma) * gradient / (gradient @ gradient)
    return z


def correct_at_speed(problem, z_guess, periods, window, speed, tolerance):
    """The impacting orbit whose new impact (the grazing one: alone, or in ``window``) has speed
    ``speed``: Newton on [P^p(y) - y; u^2 - speed^2] = 0 in z = (x, v, lam) from z_guess.

    Returns (z, OrbitMap, residual max |P^p(y) - y|, iterations, the Jacobian (3, 3) of
    [P^p(y) - y; u^2]) or None.
    """
    z = np.array(z_guess, dtype=float)
    target = speed * speed
    for iteration in range(1, MAX_SPEED_ITERATIONS + 1):
        here = _speed_system(problem, z, periods, window)
        if here is None:
            return None
        value, real = here
        jacobian = _speed_jacobian(problem, z, periods, window, value, real.impacts)
        if jacobian is None:
            return None
        residual = float(np.max(np.abs(value[:2])))
        if residual <= tolerance and abs(value[2] - target) <= 1e-6 * target:
            return z, real, residual, iteration, jacobian
        step = _newton_step(jacobian, -np.array([value[0], value[1], value[2] - target]))
        if step is None:
            return None
        z = z + step
    return None


def _newton_step(jacobian, rhs):
    """The solution of ``jacobian @ step = rhs``, or None where the matrix is singular or the
    step is not finite: the corrector then gives up rather than step into NaN."""
    try:
        step = np.linalg.solve(jacobian, rhs)
    except np.linalg.LinAlgError:
        return None
    return step if np.all(np.isfinite(step)) else None
