"""Branch switching at a period doubling: the branch of 2p slow periods born where a real Floquet
multiplier of a p-periodic orbit passes through -1.

At a period doubling (lam*, y*) of P^p the monodromy M has the eigenvalue -1 with eigenvector w.
The p-orbit is also a fixed point of P^2p, whose monodromy M^2 has the eigenvalue +1 along w: a
pitchfork of P^2p. The 2p-orbit leaves it in the direction (w, 0) in (x, v, lam), with the
parameter changing only at second order (lam - lam* ~ a^2, a its amplitude along w; the two
points y, P^p(y) of one 2p-orbit are a = +/-eps). So (docs/design.md, "Period-doubling branch
switching"):

- predictor z = (y* + eps w, lam*), eps in SWITCH_AMPLITUDES (relative to max(1, |y*|));
- corrector: continuation.correct on P^2p with the arclength condition along t = (w, 0), which
  fixes the amplitude along w at eps and leaves the parameter free;
- the result is the 2p-orbit born here only when it lies within NEAR_AMPLITUDES amplitudes of
  the doubling point and is not the p-orbit: |P^p(y) - y| must exceed GENUINE_DISTANCE times the
  Newton tolerance (the corrector could otherwise land on the p-branch, which also crosses the
  predictor's plane);
- then the 2p-branch is followed both ways with continuation.follow. The way back towards the
  period doubling meets the p-branch there: it stops (status "period_doubling") when the
  amplitude along w changes sign on a step whose chord passes the doubling point, or when an
  orbit is a p-orbit again (within a step of a doubling: meeting that doubling), and the doubling
  point itself (as a 2p-orbit) is the branch's first point.

analysis/switching.py repeats this on the new branches' own period doublings while 2p <=
max_period (a cascade). A doubling point that an earlier switched branch already reached (a
period-doubling "bubble" closes on the p-branch at its second doubling) is not switched twice.
"""

import dataclasses

import numpy as np

from vrsweep.analysis import continuation
from vrsweep.results import Status

ENDED_PERIOD_DOUBLING = "period_doubling"
# Amplitudes along w of the first 2p-orbit, relative to max(1, |y*|): the smallest that converges
# onto a genuine 2p-orbit next to the doubling wins (the pitchfork's corrector is conditioned like
# eps, and its basin shrinks with the curvature of the 2p-branch: at one phase of the original
# model's orbit of period 2 at g = 17.833 only 1e-4 converges; at the doubling of Fig. 1's
# period-3 branch at g = 17.799031, where the multiplier moves 7e4 per unit g, the 2p-orbit's own
# multiplier falls from +1 to 0.1 within 2e-5 of the doubling in state, and only 3e-6 converges
# onto an orbit Newton's tolerance tells from the p-orbit: up to 0.7.2 no 2p-orbit was found
# there).
SWITCH_AMPLITUDES = (1e-6, 3e-6, 1e-5, 1e-4, 1e-3, 4e-3, 1.6e-2)
# The pitchfork's corrector is conditioned like eps: at the smallest amplitudes Newton converges
# linearly, in up to 30 iterations at g = 17.799031; it gets this many times max_newton_iterations.
SWITCH_NEWTON_FACTOR = 4
# ... and it is accepted only this many amplitudes from the doubling point in (x, v, lam): a
# corrector that wandered to another orbit far away did not find the 2p-branch born here.
NEAR_AMPLITUDES = 4.0
# A 2p-orbit is genuine (not the p-orbit) when |P^p(y) - y| exceeds GENUINE_DISTANCE Newton
# tolerances, or GENUINE_MARGIN times what a p-orbit converged as a 2p-orbit could show
# (_is_p_orbit); an orbit on the switched branch that is neither is the p-orbit again.
GENUINE_DISTANCE = 1e3
GENUINE_MARGIN = 10.0
# A located doubling is switched only when a real multiplier is this close to -1 (a sign change of
# det(M + I) across a grazing, where the monodromy jumps, is not a period doubling). Not tighter:
# the doubling is located to location_tolerance in the parameter, and where the multiplier moves
# fast (next to a graze: -1.3 to -0.7 within 1e-4 in g) that leaves it a few 1e-2 from -1.
MULTIPLIER_TOLERANCE = 0.1


def doubling_vectors(orbit):
    """(w, u): the unit right eigenvector of the orbit's monodromy for its multiplier nearest -1,
    and the left one scaled so that u . w = 1 (u . dy is the amplitude of dy along w). (2,) each."""
    values, vectors = np.linalg.eig(orbit.monodromy)
    nearest = int(np.argmin(np.abs(values + 1.0)))
    w = np.real(vectors[:, nearest])
    w /= np.linalg.norm(w)
    left_values, left_vectors = np.linalg.eig(orbit.monodromy.T)
    u = np.real(left_vectors[:, int(np.argmin(np.abs(left_values + 1.0)))])
    return w, u / (u @ w)


def is_doubling(orbit):
    """True when a real multiplier of ``orbit`` lies within MULTIPLIER_TOLERANCE of -1."""
    mu = orbit.multipliers
    real = np.abs(mu.imag) <= 1e-12 * np.maximum(1.0, np.abs(mu))
    return bool(np.any(real & (np.abs(mu.real + 1.0) < MULTIPLIER_TOLERANCE)))


def distance_from_p_orbit(problem, orbit, periods):
    """max |P^periods(y) - y| at the orbit's state and parameter (inf if the map fails)."""
    orbit_map = continuation.evaluate(problem, orbit.state, orbit.parameter, periods)
    if orbit_map.status != Status.OK:
        return np.inf
    return float(np.max(np.abs(orbit_map.end_state - orbit.state)))


def _genuine_threshold(problem, state):
    return GENUINE_DISTANCE * continuation._tolerance(problem, state)


def _is_p_orbit(problem, orbit, periods):
    """Whether ``orbit``, a converged 2p-orbit, is the p-orbit again (as far as the Newton
    tolerance can tell). A point y = y_p + delta w by the p-orbit y_p passes the 2p corrector when
    its residual r = |P^2p(y) - y| = |mu_p^2 - 1| |delta w| is below the tolerance, and then
    |P^p(y) - y| = |mu_p - 1| |delta w| ~ 2 r / |mu_p^2 - 1|, where mu_p^2 is the multiplier of
    its M^2p nearest +1: up to 1000 tolerances next to a doubling, where mu_p ~ -1. A genuine
    2p-orbit of amplitude a has |P^p(y) - y| ~ 2a. So: the p-orbit when |P^p(y) - y| is below
    GENUINE_DISTANCE tolerances and below GENUINE_MARGIN times 2 r / |mu - 1|. (Up to 0.7.2 the
    first bound alone: a 2p-orbit of amplitude below 1000 tolerances, 2.6e-5 at Fig. 1's g =
    17.799, where the 2p-branch lives within 1e-5 of its doubling, counted as the p-orbit.)"""
    distance = distance_from_p_orbit(problem, orbit, periods)
    if distance > _genuine_threshold(problem, orbit.state):
        return False
    mu = orbit.multipliers
    gap = float(np.min(np.abs(mu - 1.0)))
    residual = max(orbit.residual, np.finfo(float).eps * max(1.0, float(np.max(np.abs(orbit.state)))))
    return not (gap > 0.0 and distance > GENUINE_MARGIN * 2.0 * residual / gap)


def first_doubled_orbit(problem, doubling):
    """The 2p-orbit next to the period doubling ``doubling`` (an Orbit of period p): (Orbit of
    period 2p, None) or (None, reason)."""
    w, _ = doubling_vectors(doubling)
    tangent = np.array([w[0], w[1], 0.0])
    scale = max(1.0, float(np.max(np.abs(doubling.state))))
    iterations = SWITCH_NEWTON_FACTOR * problem.options["max_newton_iterations"]
    patient = dataclasses.replace(problem, options=dict(problem.options, max_newton_iterations=iterations))
    reason = "no 2p-orbit found next to the period doubling"
    for amplitude in SWITCH_AMPLITUDES:
        for sign in (1.0, -1.0):
            z_predicted = doubling.z + sign * amplitude * scale * tangent
            orbit, failure = continuation.correct(patient, z_predicted, 2 * doubling.periods, tangent, z_predicted)
            if failure is not None:
                reason = failure[1]
                continue
            if np.linalg.norm(orbit.z - doubling.z) > NEAR_AMPLITUDES * amplitude * scale:
                reason = f"the corrector went to an orbit at {problem.parameter} = {orbit.parameter:.8g}"
                continue
            if not _is_p_orbit(problem, orbit, doubling.periods):
                return orbit, None
            reason = "the corrector returned to the period-p orbit"
    return None, reason


def _back_on_the_p_branch(problem, doublings, periods):
    """follow's stop test on a switched branch: (status, reason) once the branch is back on the
    p-branch, at one of its period doublings ``doublings`` (Orbits of period ``periods``) or
    anywhere else, else None. Returns (stop, met): ``met`` collects the doublings it stopped at."""
    name = problem.parameter
    frames = [(doubling, doubling_vectors(doubling)[1]) for doubling in doublings]
    met = []

    def stop(previous, orbit):
        chord = np.linalg.norm(orbit.z - previous.z)
        # (continuation.REFUSED, reason) refuses the step: follow retries it shorter.
        for doubling, u in frames:
            # The amplitude along w from the p-branch; the p-branch's own drift with the parameter
            # is of second order in it.
            a_previous = float(u @ (previous.state - doubling.state))
            a_now = float(u @ (orbit.state - doubling.state))
            if a_previous * a_now <= 0.0 and _passes_by(previous.z, orbit.z, doubling.z):
                met.append(doubling)
                return (ENDED_PERIOD_DOUBLING, f"meets the period-{periods} branch at its period doubling "
                                               f"at {name} = {doubling.parameter:.8g}")
        if _is_p_orbit(problem, orbit, periods):
            # The corrector crossed onto the p-branch itself; next to a doubling (within the
            # step just taken) that is the pitchfork's crossing too.
            nearest = min(doublings, key=lambda d: np.linalg.norm(previous.z - d.z))
            if (nearest.z - previous.z) @ (orbit.z - previous.z) <= 0.0:
                # A step away from the doubling that lands on the p-branch, which passes there too,
                # jumped off this branch (at the doubling at g = 17.793014 of Fig. 1's period-3
                # branch the first step went from amplitude 8e-6 to a p-orbit 2e-4 away, and the
                # branch ended at once, up to 0.7.2): retried shorter.
                return (continuation.REFUSED, f"the corrector lands on the period-{periods} branch at "
                                              f"{name} = {orbit.parameter:.8g}, away from its doubling")
            if np.linalg.norm(previous.z - nearest.z) <= chord:
                met.append(nearest)
                return (ENDED_PERIOD_DOUBLING, f"meets the period-{periods} branch at its period doubling "
                                               f"at {name} = {nearest.parameter:.8g}")
            return (ENDED_PERIOD_DOUBLING, f"returns to a period-{periods} orbit at {name} = {orbit.parameter:.8g}")
        return None
    return stop, met


# A fold of the 2p-branch this close to its doubling (in location tolerances) is the pitchfork.
BIRTH_TOLERANCE = 10
# Through the pitchfork, a step from amplitude a1 > 0 to a2 < 0 passes the doubling point at a
# distance of second order in the a's; a chord that misses it by more than this fraction of its
# length crossed a = 0 elsewhere.
PASSING_FRACTION = 0.1


def _passes_by(z_from, z_to, point):
    """True when the segment [z_from, z_to] passes within PASSING_FRACTION of its length of point."""
    chord = z_to - z_from
    length = np.linalg.norm(chord)
    if length == 0.0:
        return np.linalg.norm(point - z_from) == 0.0
    s = np.clip((point - z_from) @ chord / (length * length), 0.0, 1.0)
    return bool(np.linalg.norm(z_from + s * chord - point) <= PASSING_FRACTION * length)


def doubled_branch(problem, doubling, lo, hi, max_points, progress=None, doublings=None):
    """The 2p-branch born at the period doubling ``doubling`` (Orbit of period p), followed both
    ways within [lo, hi]: (Branch, [(kind, Orbit)], [the doublings it met]) or (None, reason, []).

    ``doublings``: every period doubling of the p-branch (default: this one); the switched branch
    stops where it meets any of them. The branch's first point is ``doubling`` itself taken as a
    2p-orbit, and its first end has status "period_doubling"; the other end is wherever
    continuation.follow stops (another doubling of the same p-branch, for a bubble).
    """
    start, reason = first_doubled_orbit(problem, doubling)
    if start is None:
        return None, reason, []
    stop, met = _back_on_the_p_branch(problem, doublings or [doubling], doubling.periods)
    ways = []
    for direction in (-1, +1):
        before = len(met)
        if ways and ways[0][2][0] == continuation.ENDED_INTERRUPTED:  # stopped: the other way is not followed
            ways.append(([], [], (continuation.ENDED_INTERRUPTED, "not followed: the run was stopped before"), []))
            continue
        orbits, bifurcations, end = continuation.follow(problem, start, direction, lo, hi, max_points // 2,
                                                        progress, stop=stop)
        ways.append((orbits, bifurcations, end, met[before:]))
    # The way that met this doubling goes first, reversed, after the doubling point itself.
    if any(d is doubling for d in ways[1][3]) and not any(d is doubling for d in ways[0][3]):
        ways.reverse()
    (back, back_bifurcations, back_end, back_met), (away, away_bifurcations, away_end, _) = ways
    orbits = list(reversed(back)) + [start] + away
    if any(d is doubling for d in back_met):
        # The doubling point itself, as a 2p-orbit (not corrected again: M^2 - I is singular there).
        orbit_map = continuation.evaluate(problem, doubling.state, doubling.parameter, 2 * doubling.periods)
        if orbit_map.status == Status.OK:
            residual = float(np.max(np.abs(orbit_map.end_state - doubling.state)))
            orbits.insert(0, continuation._orbit(problem, doubling.state, doubling.parameter, 2 * doubling.periods,
                                                 orbit_map, residual, 0, doubling.parameter_derivative))
    branch = continuation.Branch(periods=2 * doubling.periods, orbits=orbits,
                                 ends={"down": back_end, "up": away_end})
    return branch, without_birth_folds(problem, doubling, back_bifurcations + away_bifurcations), met


def without_birth_folds(problem, doubling, bifurcations):
    """``bifurcations`` [(kind, Orbit)] of the 2p-branch born at ``doubling`` without the "fold" at
    its birth (also a branch switched to at a branch point, ``doubling`` that point: the
    pitchfork's vertex, branch_point.py): there the 2p-orbit's monodromy M^2 has the multiplier +1 (the pitchfork), so
    det(M - I) changes sign too; that is the doubling point itself, not a fold of the 2p-branch
    (nor a branch point of it, which continuation._detect may call it: the parameter does not turn)."""
    birth = BIRTH_TOLERANCE * problem.options["location_tolerance"] * max(1.0, abs(doubling.parameter))
    return [(kind, orbit) for kind, orbit in bifurcations
            if not (kind in ("fold", "branch_point") and abs(orbit.parameter - doubling.parameter) <= birth)]
