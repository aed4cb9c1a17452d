"""Bifurcation curves in a parameter plane: folds, period doublings and grazings in two parameters.

A bifurcation point located on a branch (analysis/continuation.py) is followed in a second
parameter. With z = (x, v, lam1, lam2), y = (x, v) and P^p the stroboscopic map of p slow
periods (numerics/shooting.py), each curve is the solution set of three equations
(docs/design.md, "Bifurcation curves in two parameters", derives them):

    fold             P^p(y) - y = 0,       det(M - I) = 0        (a multiplier at +1)
    period doubling  P^p(y) - y = 0,       det(M + I) = 0        (a multiplier at -1)
    grazing          P_free^p(y) - y = 0,  Delta - x_max_free = 0

M = dP^p/dy the monodromy; P_free the map of the same oscillator without the barrier
(grazing.free_coefficients: Delta = inf, the kernel then never impacts) and x_max_free its
largest x over the p periods, from the kernel's dense-output turning points: grazing.py's system
with lam2 free (a grazing curve starts from grazing.locate_graze at the start's lam2). On a
grazing curve the free orbit is the real one and touches the barrier with zero velocity.

Three equations in four unknowns: a curve, followed by pseudo-arclength continuation as
continuation.follow follows a branch: predictor along the unit tangent (the null vector of the
3 x 4 Jacobian), corrector by damped Newton on the three equations and t . (z - z_pred) = 0,
adaptive step within [min_step, max_step], both directions from the start.

Jacobian: the (x, v) columns of the first two rows are M - I from the tangent kernel; every
other entry (the parameter columns of P^p, and the whole row of the test function, whose
derivatives would need the second variational equation, or of x_max) by central differences
(_difference_step says why the step is what it is). Like F_lam in continuation.py they set
Newton's rate and the predictor only, never the converged point, which is checked by the
residuals alone.

A curve ends (status, one-line reason) at the end of either parameter's range (left_range) or at
the edge of the model's domain (domain_edge: the step that leaves either is bisected to min_step,
so the last point lies at the edge: continuation.approach_edge), when it reaches max_points, when
Newton fails at the smallest step, or at a codimension-two point where the augmented system stops
describing the curve:
    fold_grazing, period_doubling_grazing
                   on a fold or period-doubling curve, the orbit starts (or stops) hitting the
                   barrier: its impact count changes between two points (located by bisection
                   on the arc), or Newton fails next to the barrier (_near_barrier: within the
                   difference steps' reach of it, or an impact that slow), where the point is
                   extrapolated to the barrier (_extrapolate_to_barrier). The map is only
                   piecewise smooth there; the curve ends.
Recorded as special points, the curve going on through them (the augmented system stays
regular there):
    cusp           on a fold curve, the fold's quadratic coefficient a = w . (d2 P^p [q, q]) / 2
                   (q, w: right and left null vectors of M - I) changes sign (the second-
                   derivative test, located by regula falsi); there the curve's projection on
                   the parameter plane turns back (its tangent's parameter part vanishes:
                   tests/test_curves.py checks the cusp is the curve's extreme point in both).
                   Not detected within three difference steps of the barrier.
    fold_grazing, period_doubling_grazing
                   on a grazing curve, the free orbit's det(M - I) or det(M + I) changes sign:
                   the grazing curve meets the fold or period-doubling curve there.
Nothing here raises on a numerical failure; bad requests raise UsageError.

Limits: a curve cannot start, or pass, within a difference step (0.1 eps^(1/3) relative: 0.0018
in g = 18 at rtol 1e-9) of a graze, where the displaced maps impact and the Jacobian is lost; the
graze of an impacting orbit (an impact slowing to zero) is not followed as a grazing curve.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vrsweep.analysis import continuation, grazing
from vrsweep.analysis.diagnostics import orbit_gain
from vrsweep.errors import UsageError
from vrsweep.numerics import model as model_metadata
from vrsweep.numerics.coefficients import grazing_barrier, grazing_scale
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.settings import ATOL, RTOL
from vrsweep.numerics.shooting import periodic_map

KINDS = ("fold", "period_doubling", "grazing")
ENDED_RANGE = "left_range"
ENDED_MAX_POINTS = "max_points"
ENDED_NEWTON = "newton_failed"
ENDED_INTEGRATION = "integration_failed"
ENDED_STICKING = "sticking"
ENDED_INTERRUPTED = continuation.ENDED_INTERRUPTED  # a signal: the points so far are kept
ENDED_DOMAIN = continuation.ENDED_DOMAIN  # the next point outside the model's domain (config/domains.py)
# The steps of a curve run by vrsweep continue: at most this fraction of either parameter's range,
# so that a curve across its range has at least 1/RANGE_FRACTION points whatever max_step allows
# (a curve in e over [0.9, 0.97] had 2 points at the default max_step 0.5).
RANGE_FRACTION = 1.0 / 40
GRAZING_MEETING = {"fold": "fold_grazing", "period_doubling": "period_doubling_grazing"}
# An orbit within this distance of the barrier (relative to max(1, Delta)) is next to a graze
# (or within the Jacobian's reach of it: _near_barrier).
GRAZING_PROXIMITY = continuation.GRAZING_PROXIMITY
STEP_GROWTH = continuation.STEP_GROWTH
MAX_HALVINGS = continuation.MAX_HALVINGS
EASY_NEWTON = continuation.EASY_NEWTON


def _difference_step(settings):
    """The relative step of every central difference here: DIFFERENCE_FACTOR eps^(1/3).

    The differenced quantities (P^p, det(M -/+ I), x_max) are computed to about the integration
    tolerance eps = max(rtol, atol) (the tangent equations are integrated with the state, and
    x_max comes from the dense output, both to the step's error control). A central difference
    with step h errs by about h^2 |f'''| / 6 (truncation) plus eps / h (the values' errors),
    smallest at h = (3 eps / |f'''|)^(1/3). |f'''| is not of order 1 for these maps: for the
    original model's period-3 orbit with 8 impacts near g = 15.7, Delta = 2.61, the x column of
    P^3 differenced at h = 3.5e-3 (eps^(1/3) |x| at rtol 1e-9) is 0.8 % off the tangent kernel's
    (|f'''| ~ 4e3), and Newton on the fold system converged only linearly, by a factor 0.3 per
    iteration: the 2 x 2 block M - I is singular at a fold, so the other rows' errors weigh
    through a condition number of ~900. DIFFERENCE_FACTOR = 0.1 is the optimum for |f'''| ~ 3e3;
    for a smooth orbit (|f'''| ~ 1) it costs a derivative error of 10 eps^(2/3) (1e-5 at
    eps = 1e-9) where 1e-6 was possible, which Newton's quadratic phase does not notice.
    """
    return DIFFERENCE_FACTOR * float(np.cbrt(max(settings[RTOL], settings[ATOL], 1e-15)))


DIFFERENCE_FACTOR = 0.1


@dataclass
class CurveProblem:
    """What is followed: the model's parameters (name -> value), the model, the two parameters
    (lam1: the branch's, lam2: the one along which the point moves), the kernel settings, the
    integration method and the continuation options (continuation.DEFAULTS' keys)."""
    parameters: dict
    model: object  # "original", "effective" or a written model (numerics.models.kernels_for)
    names: tuple
    settings: np.ndarray
    method: str = "rk45"
    options: dict = field(default_factory=lambda: dict(continuation.DEFAULTS))
    # domain({name: value, ...}) -> None inside the model's domain, else why not (the config's own
    # rule, config/domains.domain_test, passed in by execution); None: no edge.
    domain: object = None
    # A step moves either parameter by at most this fraction of its range (RANGE_FRACTION); None:
    # only max_step bounds it.
    range_fraction: float = None

    def __post_init__(self):
        self.names = tuple(self.names)
        self.settings = np.asarray(self.settings, dtype=np.float64)
        self.step = _difference_step(self.settings)

    def coefficients(self, values, free=False):
        """The kernel's coefficient vector at (lam1, lam2) = values; without the barrier if free."""
        coefficients = kernels_for(self.model).coefficients(dict(self.parameters, **dict(zip(self.names, values))))
        return grazing.free_coefficients(coefficients) if free else coefficients

    def delta(self, values):
        return grazing_barrier(self.coefficients(values))

    def scale(self, values):
        """grazing_scale at (lam1, lam2): the length of the grazing tests."""
        return grazing_scale(self.coefficients(values))

    def one_parameter(self, lam2):
        """The ContinuationProblem in lam1 at fixed lam2 (for the one-parameter test functions)."""
        return continuation.ContinuationProblem(dict(self.parameters, **{self.names[1]: float(lam2)}), self.model,
                                                self.names[0], self.settings, self.method, dict(self.options))


def check_pair(parameters, model, names, max_period=continuation.DEFAULTS["max_period"]):
    """Refuse a pair the model cannot follow: the same parameter twice, an unknown one, or (original
    model) Omega or omega moving, or a forcing that does not repeat within ``max_period`` slow
    periods (continuation.check_commensurate, with both parameters moving)."""
    first, second = names
    known = getattr(model, "parameter_names", model_metadata.PARAMETER_NAMES)  # a written model's own
    for key, name in (("first", first), ("second", second)):
        if name not in known:
            raise UsageError.naming("{along} = {name} is not a parameter of the model; parameters: {names}",
                                    {"along": f"continuation.parameters ({key})"}, name=name,
                                    names=", ".join(known))
    if first == second:
        raise UsageError.naming("{along} = {name} is the branch's own parameter: choose another one to move "
                                "the point along", {"along": "along"}, name=second)
    if model == "original" and second in ("Omega", "omega"):
        raise UsageError.naming(
            "{along} = {name} cannot move in the original model: its fast forcing repeats only where "
            "Omega/omega is a ratio of whole numbers, which a moving {name} leaves at once; follow "
            "the point in {name} in the effective model (no fast force) instead", {"along": "along"}, name=second)
    continuation.check_commensurate(parameters, model, names, max_period)


@dataclass
class CurvePoint:
    """One converged point of a curve.

    values (2,) the two parameters; state (2,) y at t = 0 mod T; monodromy (2, 2) of the map the
    curve is defined with (the free map for grazing); the rest as continuation.Orbit's fields.
    """
    kind: str
    values: np.ndarray
    state: np.ndarray
    periods: int
    monodromy: np.ndarray
    R: float
    impacts_per_period: float
    x_max: float
    barrier_distance: float
    slowest_impact: float      # smallest impact speed |x'(-)| (inf without impacts)
    residual: float
    newton_iterations: int
    jacobian: np.ndarray       # (3, 4) derivative of the three equations at the point
    cusp_test: float = np.nan  # fold curves only: the fold's quadratic coefficient (_cusp_test)
    fold_left: np.ndarray = None  # fold curves only: (2,) left null vector of M - I

    @property
    def z(self):
        return np.concatenate([self.state, self.values])

    @property
    def multipliers(self):
        """(2,) complex: the Floquet multipliers of the curve's map, larger modulus first."""
        mu = np.linalg.eigvals(self.monodromy).astype(complex)
        return mu[np.argsort(-np.abs(mu), kind="stable")]


@dataclass
class Curve:
    kind: str
    periods: int
    points: list
    ends: dict  # "first"/"last" -> (status, reason)


@dataclass
class SpecialPoint:
    """A codimension-two point: its kind (fold_grazing, period_doubling_grazing, cusp), the curve
    point it was located at or next to, and its parameters (2,): the point's, or extrapolated to
    the barrier when Newton could not get closer (follow)."""
    kind: str
    point: CurvePoint
    curve: int = 0
    values: np.ndarray = None

    def __post_init__(self):
        if self.values is None:
            self.values = self.point.values.copy()


# --- the augmented systems --------------------------------------------------------------------
def _map(problem, z, periods, free):
    return periodic_map(problem.coefficients(z[2:], free), z[:2], problem.settings, periods, problem.method,
                        model=problem.model)


def _failure(orbit_map):
    return continuation._failure(orbit_map)


def _equations(problem, kind, z, periods):
    """(G (3,), the OrbitMap, failure or None): the augmented system's value at z."""
    orbit_map = _map(problem, z, periods, kind == "grazing")
    failure = _failure(orbit_map)
    if failure:
        return None, orbit_map, failure
    if kind == "grazing":
        test = problem.delta(z[2:]) - orbit_map.x_max
    else:
        sign = -1.0 if kind == "fold" else 1.0
        test = float(np.linalg.det(orbit_map.monodromy + sign * np.eye(2)))
    return np.concatenate([orbit_map.end_state - z[:2], [test]]), orbit_map, None


def _jacobian(problem, kind, z, periods, orbit_map):
    """(3, 4) dG/dz: M - I for the state columns of P^p (tangent kernel), central differences for
    the rest (module doc). None if a displaced map fails (e.g. sticks)."""
    jacobian = np.empty((3, 4))
    for column in range(4):
        h = problem.step * max(1.0, abs(z[column]))
        shift = np.zeros(4)
        shift[column] = h
        plus, _, failure_plus = _equations(problem, kind, z + shift, periods)
        minus, _, failure_minus = _equations(problem, kind, z - shift, periods)
        if failure_plus or failure_minus:
            return None
        jacobian[:, column] = (plus - minus) / (2.0 * h)
    jacobian[:2, :2] = orbit_map.monodromy - np.eye(2)
    return jacobian


def _tolerance(problem, z):
    return problem.options["newton_tolerance"] * max(1.0, float(np.max(np.abs(z[:2]))))


def _location_tolerance(problem, z):
    return problem.options["location_tolerance"] * max(1.0, float(np.max(np.abs(z))))


def _point(problem, kind, z, periods, orbit_map, residual, iterations, jacobian):
    delta = problem.delta(z[2:])
    R, _ = orbit_gain(problem.coefficients(z[2:]), periods, orbit_map.R, orbit_map.Q_amplitude)
    point = CurvePoint(kind=kind, values=z[2:].copy(), state=z[:2].copy(), periods=periods,
                       monodromy=orbit_map.monodromy.copy(), R=R,
                       impacts_per_period=orbit_map.impacts / periods, x_max=orbit_map.x_max,
                       barrier_distance=delta - orbit_map.x_max, slowest_impact=orbit_map.slowest_impact,
                       residual=residual, newton_iterations=iterations,
                       jacobian=jacobian)
    if kind == "fold":
        point.cusp_test, point.fold_left = _cusp_test(problem, z, periods, orbit_map)
    return point


def correct(problem, kind, z_guess, periods, tangent, z_predicted):
    """Damped Newton on [G(z); tangent . (z - z_predicted)] = 0 (continuation.correct's damping).

    Converged when |P^p(y) - y| and the arclength condition are within newton_tolerance and the
    Newton step is within location_tolerance (the test function has no natural scale; the step
    is how far z still is from the curve). Returns (CurvePoint, None) or (None, (status, reason)).
    """
    z = np.array(z_guess, dtype=float)
    previous_z, previous_merit, last_step, halvings = None, np.inf, None, 0
    residual = np.inf
    for iteration in range(1, problem.options["max_newton_iterations"] + 1):
        values, orbit_map, failure = _equations(problem, kind, z, periods)
        arc = float(tangent @ (z - z_predicted))
        merit = np.inf if failure else float(np.max(np.abs(values))) + abs(arc)
        if previous_z is not None and not merit < previous_merit and halvings < MAX_HALVINGS:
            last_step = 0.5 * last_step  # damped Newton, as continuation.correct
            z = previous_z + last_step
            halvings += 1
            continue
        if failure:
            return None, failure
        halvings = 0
        previous_z, previous_merit = z.copy(), merit
        jacobian = _jacobian(problem, kind, z, periods, orbit_map)
        if jacobian is None:
            return None, (ENDED_STICKING, "a neighbouring orbit sticks to the barrier or fails to integrate")
        system = np.vstack([jacobian, tangent])
        try:
            step = np.linalg.solve(system, -np.concatenate([values, [arc]]))
        except np.linalg.LinAlgError:
            return None, (ENDED_NEWTON, "singular augmented Jacobian")
        if not np.all(np.isfinite(step)):
            return None, (ENDED_NEWTON, "non-finite Newton step")
        residual = float(np.max(np.abs(values[:2])))
        tolerance = _tolerance(problem, z)
        # At least one Newton step: a predictor within location_tolerance of the curve is still
        # only that close, and one more step makes it (quadratically) much closer.
        if (iteration > 1 and residual <= tolerance and abs(arc) <= tolerance
                and np.max(np.abs(step)) <= _location_tolerance(problem, z)):
            point = _point(problem, kind, z, periods, orbit_map, residual, iteration, jacobian)
            off = _off_the_bifurcation(problem, point)
            if off:
                return None, (ENDED_NEWTON, off)
            return point, None
        last_step = step
        z = z + step
    iterations = problem.options["max_newton_iterations"]
    return None, (ENDED_NEWTON, f"Newton did not converge in {iterations} iterations (residual {residual:.2g})")


# A converged point must be the bifurcation it claims to this accuracy: a multiplier within this of
# +1 or -1, or (grazing) the orbit's maximum within this (relative to max(1, Delta)) of the barrier.
# Newton's step criterion alone can be met where the test function jumps (a huge difference
# quotient makes a small step out of a large value): at the original model's period doubling next
# to a graze (g = 18.13, Omega = 4) it "converged" with a multiplier at -1.012. A true point, located
# to location_tolerance (1e-6), is within |d mu / dz| 1e-6 of it, far inside.
CLAIM_TOLERANCE = 1e-3


def _off_the_bifurcation(problem, point):
    """None, or why ``point`` is not the bifurcation its curve claims (CLAIM_TOLERANCE)."""
    if point.kind == "grazing":
        scale = problem.scale(point.values)
        if abs(point.barrier_distance) > CLAIM_TOLERANCE * scale:
            return f"converged {point.barrier_distance:.2g} from the barrier: not a graze"
        return None
    target = 1.0 if point.kind == "fold" else -1.0
    distance = float(np.min(np.abs(point.multipliers - target)))
    if distance > CLAIM_TOLERANCE:
        return (f"converged where det(M {'-' if target > 0 else '+'} I) jumps: no multiplier within "
                f"{CLAIM_TOLERANCE:g} of {target:+g} (the nearest {distance:.2g} away)")
    return None


def tangent_of(point, previous=None):
    """Unit null vector (4,) of the point's 3 x 4 Jacobian, oriented along ``previous``."""
    _, _, rows = np.linalg.svd(point.jacobian)
    tangent = rows[-1] / np.linalg.norm(rows[-1])
    if previous is not None and tangent @ previous < 0.0:
        tangent = -tangent
    return tangent


def _cusp_test(problem, z, periods, orbit_map):
    """(a, w): the fold's quadratic coefficient a = w . (dM[q] q) and the left null vector w (2,).

    q, w: right and left null vectors of M - I (singular vectors of its smallest singular
    value), unit length. d2 P^p [q, q] = (dM/dy . q) q, the derivative of the kernel's monodromy
    along q by a central difference (an error eps / h, not the eps / h^2 of differencing P^p
    twice). a is even in q; its sign follows w's, which the caller keeps continuous along the
    curve (_orient). a vanishes at a cusp.
    """
    left, _, right = np.linalg.svd(orbit_map.monodromy - np.eye(2))
    q, w = right[-1], left[:, -1]
    h = problem.step * max(1.0, float(np.max(np.abs(z[:2]))))
    shift = np.concatenate([h * q, [0.0, 0.0]])
    plus, minus = _map(problem, z + shift, periods, False), _map(problem, z - shift, periods, False)
    if _failure(plus) or _failure(minus):
        return np.nan, w
    derivative = (plus.monodromy - minus.monodromy) @ q / (2.0 * h)
    return float(w @ derivative), w


def _orient(point, reference):
    """Flip a fold point's left null vector (and with it its cusp test) to agree with reference's."""
    if point.fold_left is not None and reference.fold_left is not None and point.fold_left @ reference.fold_left < 0.0:
        point.fold_left = -point.fold_left
        point.cusp_test = -point.cusp_test
    return point


# --- following a curve -------------------------------------------------------------------------
def start_point(problem, kind, state, values, periods):
    """The curve's point at lam2 = values[1], Newton from the one-parameter point (state, values[0]).

    Returns (CurvePoint, None) or (None, (status, reason))."""
    z = np.concatenate([np.asarray(state, dtype=float), np.asarray(values, dtype=float)])
    if kind == "grazing":
        # The one-parameter graze at this lam2, by grazing.locate_graze (the same two equations
        # with lam2 fixed), so that the curve starts on the graze itself.
        one = problem.one_parameter(z[3])
        graze = grazing.locate_graze(one, z[:3], periods, _tolerance(problem, z))
        if graze is not None:
            z[:3] = graze.z
    return correct(problem, kind, z, periods, np.array([0.0, 0.0, 0.0, 1.0]), z)


def _inside(problem, point, ranges):
    return all(low <= value <= high for value, (low, high) in zip(point.values, ranges))


def _outside_domain(problem, point):
    """None where both parameters at ``point`` lie inside the model's domain, else why not."""
    return None if problem.domain is None else problem.domain(dict(zip(problem.names, map(float, point.values))))


def _longest_step(problem, tangent, ranges):
    """The arclength that moves either parameter along ``tangent`` by range_fraction of its range."""
    if problem.range_fraction is None:
        return np.inf
    return min((problem.range_fraction * (high - low)) / abs(t) if t != 0.0 else np.inf
               for t, (low, high) in zip(tangent[2:], ranges))


def _range_reason(problem, point, ranges):
    for name, value, (low, high) in zip(problem.names, point.values, ranges):
        if not low <= value <= high:
            return f"{name} left [{low:g}, {high:g}]"
    return ""


def _where(problem, point):
    return ", ".join(f"{name} = {value:.8g}" for name, value in zip(problem.names, point.values))


def _turned_back(previous, point, tangent, step):
    chord = point.z - previous.z
    return chord @ tangent <= 0.0 or np.linalg.norm(chord) > 3.0 * step


def _near_barrier(problem, point):
    """Close enough to a graze that the Jacobian's displaced maps (steps of problem.step relative,
    1.2e-3 in g = 27 at rtol 1e-10) may cross it: a free orbit within ten difference steps of the
    largest coordinate, or GRAZING_PROXIMITY, of the barrier; an impacting one whose slowest impact is as
    slow as continuation's test of the same (v < sqrt(GRAZING_PROXIMITY max(1, Delta)): it would
    have penetrated about v^2 / 2 without the barrier). Not the difference steps' reach for
    impacting orbits: an orbit of the paper's parameters (g = 9.7, a period doubling) whose
    impacts stay at 0.078 was called a graze with it."""
    scale = problem.scale(point.values)
    if point.impacts_per_period > 0:
        return point.slowest_impact < np.sqrt(GRAZING_PROXIMITY * scale)
    reach = max(GRAZING_PROXIMITY * scale, 10.0 * problem.step * max(1.0, float(np.max(np.abs(point.z)))))
    return point.barrier_distance < reach


def _clearance(point):
    """A measure of the distance from the graze that is linear in the parameters near it: the
    barrier distance of a free orbit, the squared slowest impact speed of an impacting one."""
    return point.barrier_distance if point.impacts_per_period == 0 else point.slowest_impact ** 2


def _locate_impact_change(problem, kind, previous, tangent, step):
    """Bisection on the arc from ``previous`` for where the impact count changes, to
    location_tolerance. Returns the last point on ``previous``'s side (the graze approached from
    the side whose map is smooth), or None."""
    low, high = 0.0, step
    best = None
    tolerance = _location_tolerance(problem, previous.z)
    while high - low > tolerance:
        s = 0.5 * (low + high)
        z_predicted = previous.z + s * tangent
        point, failure = correct(problem, kind, z_predicted, previous.periods, tangent, z_predicted)
        if failure or point.impacts_per_period != previous.impacts_per_period:
            high = s
        else:
            low, best = s, point
    return best if best is not None else previous


def _locate_sign_change(problem, kind, previous, tangent, step, function, a, b):
    """Illinois regula falsi on the arc for a zero of ``function`` (CurvePoint -> float) with
    values a at previous and b at s = step, to location_tolerance in z (continuation.locate_on_arc).
    The point nearest, or None; a non-finite value ends the search at its point."""
    tolerance = _location_tolerance(problem, previous.z)

    def point_at(s):
        z_predicted = previous.z + s * tangent
        return correct(problem, kind, z_predicted, previous.periods, tangent, z_predicted)

    def value_of(point):
        value = function(point)
        return value if np.isfinite(value) else 0.0

    return continuation.locate_on_arc(point_at, value_of, step, a, b, lambda low, high, value: high - low <= tolerance,
                                      40)


def _free_determinant(sign):
    def test(point):
        return float(np.linalg.det(point.monodromy + sign * np.eye(2)))
    return test


def _cusp_value(reference):
    def test(point):
        return _orient(point, reference).cusp_test
    return test


def _specials(problem, kind, previous, point, tangent, step):
    """Special points between two consecutive points: a list of (kind, CurvePoint), and the end
    (status, reason) when one of them ends the curve (else None)."""
    found = []
    if kind in GRAZING_MEETING and point.impacts_per_period != previous.impacts_per_period:
        graze = _locate_impact_change(problem, kind, previous, tangent, step)
        special = GRAZING_MEETING[kind]
        found.append((special, graze))
        side = "starts" if previous.impacts_per_period == 0 else "stops"
        return found, (special, f"the {kind.replace('_', ' ')} orbit {side} hitting the barrier at "
                                f"{_where(problem, graze)}: the map is only piecewise smooth there")
    tests = []
    if kind == "fold":
        tests.append(("cusp", _cusp_value(previous)))
    if kind == "grazing":
        tests += [("fold_grazing", _free_determinant(-1.0)), ("period_doubling_grazing", _free_determinant(1.0))]
    if kind == "fold" and min(previous.barrier_distance, point.barrier_distance) < 3.0 * problem.step:
        tests = []  # the cusp test's displaced maps may hit the barrier: its sign means nothing
    for special, function in tests:
        a, b = function(previous), function(point)
        if np.isfinite(a) and np.isfinite(b) and a * b < 0.0:
            located = _locate_sign_change(problem, kind, previous, tangent, step, function, a, b)
            if located is not None:
                found.append((special, located))
    return found, None


def follow(problem, kind, start, direction, ranges, max_points, progress=None):
    """Points from ``start`` (excluded), lam2 increasing at first when direction = +1.

    ranges: ((low1, high1), (low2, high2)). Returns (points, specials [(kind, CurvePoint)], (status, reason)).
    """
    options = problem.options
    tangent = tangent_of(start)
    if tangent[3] * direction < 0.0 or (tangent[3] == 0.0 and tangent[2] * direction < 0.0):
        tangent = -tangent
    step = options["initial_step"]
    current = start
    points, specials = [], []
    while True:
        if len(points) >= max_points:
            return points, specials, (ENDED_MAX_POINTS, f"{max_points} points reached")
        step = min(step, _longest_step(problem, tangent, ranges))
        z_predicted = current.z + step * tangent
        point, failure = correct(problem, kind, z_predicted, start.periods, tangent, z_predicted)
        edge = None
        if failure is None and not _turned_back(current, point, tangent, step) and (
                not _inside(problem, point, ranges) or _outside_domain(problem, point) is not None):
            # The step left a range or the model's domain: the curve is followed to that edge
            # (its last point within min_step of it), and ends there saying which it was.
            outside = _outside_domain(problem, point)
            edge = (ENDED_DOMAIN, outside) if outside else (ENDED_RANGE, _range_reason(problem, point, ranges))

            def point_at(s, current=current, tangent=tangent):
                z = current.z + s * tangent
                found, failed = correct(problem, kind, z, start.periods, tangent, z)
                if failed or _turned_back(current, found, tangent, s):
                    return None, failed or (ENDED_NEWTON, "the corrector jumped to another curve")
                return found, None

            landed_step, landed = continuation.approach_edge(
                step, options["min_step"], point_at,
                lambda found: _inside(problem, found, ranges) and _outside_domain(problem, found) is None)
            if landed is None:
                return points, specials, _edge_end(problem, edge, current)
            step, point = landed_step, landed
        if failure is not None or _turned_back(current, point, tangent, step):
            step *= 0.5
            if step < options["min_step"]:
                status, reason = failure or (ENDED_NEWTON, "the corrector keeps jumping to another curve")
                if kind in GRAZING_MEETING and _near_barrier(problem, current):
                    # Within a difference step of the barrier the displaced maps impact and the
                    # Jacobian is lost; the graze is where the barrier distance, smooth on this
                    # side, extrapolates to zero from the last two points.
                    status = GRAZING_MEETING[kind]
                    values = _extrapolate_to_barrier(points, start, current)
                    specials.append((status, current, values))
                    near = (f"distance {current.barrier_distance:.2g}" if current.impacts_per_period == 0
                            else f"slowest impact {current.slowest_impact:.2g}")
                    reason = f"{reason} next to the barrier ({near} at {_where(problem, current)})"
                    if values is not None:
                        reason += "; the orbit grazes at about " + ", ".join(
                            f"{n} = {v:.8g}" for n, v in zip(problem.names, values))
                    return points, specials, (status, reason)
                return points, specials, (status, f"{reason} at {_where(problem, current)} with the smallest step")
            continue
        _orient(point, current)
        new_tangent = tangent_of(point, tangent)
        # Inside both ranges and the domain here (a step beyond was shortened to the edge above):
        # the special points on the arc are all inside too.
        found, end = _specials(problem, kind, current, point, tangent, step)
        specials.extend(found)
        if end is not None:
            return points, specials, end
        points.append(point)
        if progress is not None:
            try:
                progress(point)
            except KeyboardInterrupt as interrupt:  # a stop asked for: what is followed so far is kept
                return points, specials, (ENDED_INTERRUPTED, f"stopped by {interrupt or 'SIGINT'} at "
                                                             f"{_where(problem, point)}")
        if edge is not None:
            return points, specials, _edge_end(problem, edge, point)
        if point.newton_iterations <= EASY_NEWTON:
            step = min(step * STEP_GROWTH, options["max_step"])
        current, tangent = point, new_tangent


def _edge_end(problem, edge, last):
    """(status, reason) of a curve that ends at the edge of a range or of the domain after ``last``."""
    status, reason = edge
    if status == ENDED_DOMAIN:  # worded as a branch's (continuation._domain_end)
        return status, f"stops at {_where(problem, last)}, the edge of the model's domain: beyond it {reason}"
    return status, f"{reason}; the last point at {_where(problem, last)}"


def _extrapolate_to_barrier(points, start, current):
    """(2,) the parameters where _clearance, linear through the last two points, reaches 0, when
    that is within one more chord of ``current``; else None (too far to trust a line)."""
    before = points[-2] if len(points) >= 2 else start
    if before is current or before.impacts_per_period != current.impacts_per_period:
        return None
    d0, d1 = _clearance(before), _clearance(current)
    if not d0 > d1 > 0.0 or d1 > d0 - d1:
        return None
    return current.values + (current.values - before.values) * d1 / (d0 - d1)


def continue_curve(problem, kind, start, ranges, max_points=None, progress=None):
    """The curve through ``start`` both ways within ``ranges``. Returns (Curve, [SpecialPoint])."""
    max_points = problem.options["max_points"] if max_points is None else max_points
    down, specials_down, end_down = follow(problem, kind, start, -1, ranges, max_points // 2, progress)
    if end_down[0] == ENDED_INTERRUPTED:  # stopped: the other way is not followed
        up, specials_up, end_up = [], [], (ENDED_INTERRUPTED, "not followed: the run was stopped before")
    else:
        up, specials_up, end_up = follow(problem, kind, start, +1, ranges, max_points - max_points // 2, progress)
    points = list(reversed(down)) + [start] + up
    specials = [SpecialPoint(special[0], special[1], values=special[2] if len(special) > 2 else None)
                for special in specials_down + specials_up]
    return Curve(kind, start.periods, points, {"first": end_down, "last": end_up}), specials
