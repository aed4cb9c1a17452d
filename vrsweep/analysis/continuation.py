"""Continuation of periodic orbits, stable and unstable, with their Floquet multipliers.

An orbit of p slow periods is a fixed point of P^p, P the stroboscopic map y = (x, v) at
t = 0 mod T (numerics/shooting.py). The branch is the curve F(y, lam) = P^p(y; lam) - y = 0 in
(x, v, lam), followed by pseudo-arclength continuation (docs/design.md, "Continuation of periodic
orbits", derives all of it):

- predictor: z = z_k + s t_k, t_k the unit tangent (null vector of dF = [M - I | F_lam]);
- corrector: Newton on [F(z); t_k . (z - z_pred)] = 0, the 3x3 Jacobian [[M - I, F_lam], [t_k]],
  M the monodromy from the tangent equations through the saltation matrices;
- F_lam by a forward difference in the parameter (why not the variational equation: see the
  design doc; it only sets the Newton convergence rate and the predictor, never the converged
  point, whose accuracy is the residual |F| alone);
- the step s grows by STEP_GROWTH after an easy correction and halves after a failed one, within
  [min_step, max_step];
- Floquet multipliers: the eigenvalues of M; stable when both |mu| < 1.

Bifurcations between consecutive points are detected by sign changes of test functions and
located on the arc between them (the same corrector at a shorter step) by the Illinois variant of
regula falsi until the parameter is known to location_tolerance (grazing: below):
    fold             det(M - I)  (a real multiplier through +1)
    period doubling  det(M + I)  (a real multiplier through -1)
    Neimark-Sacker   det(M) - 1  while the multipliers are a complex pair
    grazing          a smooth maximum of x touches the barrier (the orbit gains an impact), or
                     an impact slows to zero (it loses one): located by Newton on the fixed
                     point of the map without that one impact, its largest x at Delta
                     (grazing.py: no barrier, or the barrier transparent in a window around the
                     touch, the orbit's other impacts kept), when the corrector fails next to
                     such an orbit or steps over the graze (the impact count changes).

At a graze the map has a square-root term and Newton from one side does not reach the other:
the branch is carried across by grazing.py's normal form (cross_grazing); where the map beyond is
steep (multipliers of order 1/u, u the new impact's speed) the branch beyond is followed in u
itself until the ordinary corrector holds again (march_in_speed). Where no window fits
(a touch at the stroboscopic section t = 0 mod pT) the graze is only bracketed and the branch
beyond is searched for around it (switch_at_grazing); when none is found the branch ends with
status "grazing".

Nothing here raises on a numerical failure: a branch ends with a status and a one-line reason.
Bad requests (a chaotic start, an incommensurate forcing) raise UsageError (exit code 2).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from vrsweep.analysis import grazing
from vrsweep.analysis.commensurate import RATIO_TOLERANCE, check_commensurate  # noqa: F401 - continuation's rule
from vrsweep.analysis.diagnostics import detect_period, orbit_gain
from vrsweep.errors import UsageError
from vrsweep.numerics import kernel
from vrsweep.numerics.coefficients import N_BARRIERS, PERIOD, barrier_position, grazing_barrier
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.settings import CONTINUATION_DEFAULTS
from vrsweep.numerics.shooting import periodic_map
from vrsweep.numerics.trajectory import simulate
from vrsweep.results import Status

# Coefficient vectors a ContinuationProblem keeps (cleared when full).
COEFFICIENT_CACHE = 64
# The config's continuation section's defaults (docs/continuation.md).
DEFAULTS = dict(CONTINUATION_DEFAULTS)
STEP_GROWTH = 1.5
# Damped Newton: a step that does not reduce |F| + |arclength condition| is halved this many times.
MAX_HALVINGS = 6
# Newton steps counted as an easy correction (the step may grow after it).
EASY_NEWTON = 3
# Relative size of the parameter's forward difference (F_lam), and how many times it is tried
# 100 times shorter when both directions straddle a graze.
PARAMETER_DIFFERENCE = 1e-6
PARAMETER_DIFFERENCE_TRIES = 3
# Where Newton fails, it is tried again with the parameter's difference this much shorter (correct):
# at rtol 1e-12 a difference of 1e-9 * lam still holds F_lam to about 1e-3 * |y| / |lam|.
SHORT_DIFFERENCE = 1e-3
# An impact slower than sqrt(SLOW_IMPACT * max(1, |Delta|)) makes the map curve like 1/u^3 in the
# parameter: F_lam is then a central difference (_parameter_derivative).
SLOW_IMPACT = 0.1
# Periods integrated after the transient to detect the start's period.
START_STROBE_PERIODS = 64
# Loose on purpose: a weakly stable orbit (|mu| = 0.96 at the hysteresis example's g = 23) is still
# 1e-4 from its fixed point after 200 periods; the period found is only Newton's candidate, and
# Newton's convergence on P^p is what proves the orbit.
START_PERIOD_TOLERANCE = 1e-3
# _graze_between's verdicts on a step that is refused: it landed on another branch, or a graze it
# passes (or may pass) could not be located. A step refused as UNLOCATED down to min_step is taken
# all the same, with an UNLOCATED_GRAZING record where its impact count changes (follow).
JUMP = "jump"
UNLOCATED = "unlocated"
# The record of a change of the impact count between two consecutive orbits whose graze could not
# be located (Newton on the map without that impact, and the bisection on the count, failed): its
# orbit is the step's first one, the graze lies between it and the branch's next orbit. Kept, not
# dropped, so that info and the figure show where the branch is not smooth (docs/continuation.md).
# Likewise a fold, period doubling or Neimark-Sacker point whose test function changes sign between
# two consecutive orbits away from any graze, where the corrector failed at the first point of the
# location: "unlocated_fold" ... , its orbit the step's first one (it was dropped without a word).
UNLOCATED_PREFIX = "unlocated_"  # as the branch file names them (store/branch_file.UNLOCATED)
UNLOCATED_GRAZING = UNLOCATED_PREFIX + "grazing"
# follow's stop(previous, orbit) may refuse a step with (REFUSED, reason): retried shorter.
REFUSED = "refused"
# Branch ends
ENDED_RANGE = "left_range"
ENDED_MAX_POINTS = "max_points"
ENDED_NEWTON = "newton_failed"
ENDED_STICKING = "sticking"
ENDED_INTEGRATION = "integration_failed"
ENDED_GRAZING = "grazing"
# Stopped by a signal (progress raised KeyboardInterrupt): the orbits so far are kept and written,
# the file marked incomplete (vrsweep continue; execution/signals.GracefulStop).
ENDED_INTERRUPTED = "interrupted"
# The next point would lie outside the model's domain (e above one, c or Omega at or below zero, a
# written model's rule broken: config/domains.py): the branch ends at its last point inside.
ENDED_DOMAIN = "domain_edge"
POINT_FIELDS = ("parameter", "x", "v", "R", "Q_amplitude", "impacts_per_period", "x_max",
                "slowest_impact", "residual", "newton_iterations")


@dataclass
class Orbit:
    """One converged point of a branch: the fixed point y of P^p at parameter value lam."""
    parameter: float
    state: np.ndarray          # (2,)
    periods: int
    monodromy: np.ndarray      # (2, 2)
    R: float
    Q_amplitude: float
    impacts_per_period: float
    x_max: float
    slowest_impact: float
    residual: float            # |P^p(y) - y|, max norm
    newton_iterations: int
    parameter_derivative: np.ndarray = field(default=None)  # (2,) F_lam
    free_x_max: float = -np.inf  # the largest smooth maximum of x (no impact there)

    @property
    def multipliers(self):
        """(2,) complex: the Floquet multipliers, larger modulus first."""
        mu = np.linalg.eigvals(self.monodromy).astype(complex)
        return mu[np.argsort(-np.abs(mu), kind="stable")]

    @property
    def stable(self):
        return bool(np.all(np.abs(self.multipliers) < 1.0))

    @property
    def z(self):
        return np.array([self.state[0], self.state[1], self.parameter])


@dataclass
class Branch:
    """Orbits in order along the arc; status/reason say why the branch ends (each end)."""
    periods: int
    orbits: list
    ends: dict  # "down"/"up" -> (status, reason)


@dataclass
class Bifurcation:
    kind: str           # fold, period_doubling, neimark_sacker, grazing
    orbit: Orbit
    branch: int = 0


@dataclass(frozen=True)
class ContinuationProblem:
    """What is continued: the model's parameters (a mapping name -> value), the model, which
    parameter moves, the kernel settings vector and the integration method. Frozen: its
    coefficient vectors are kept (coefficients), so a changed problem is a new one
    (dataclasses.replace)."""
    parameters: dict
    model: object  # "original", "effective" or a written model (numerics.models.kernels_for)
    parameter: str
    settings: np.ndarray
    method: str = "rk45"
    options: dict = field(default_factory=lambda: dict(DEFAULTS))
    # domain({name: value}) -> None inside the model's domain, else why not (one line): the
    # config's own rule (config/domains.domain_test), which execution passes in; None: no edge.
    domain: object = field(default=None, compare=False)
    # The last coefficient vectors built: Newton, its parameter derivative and the graze checks ask
    # for the same few values again and again, and building one costs ~30 us (a quarter of a
    # whole branch's time at the hysteresis example). Read-only use: the kernel never writes it.
    _built: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def coefficients(self, value):
        built = self._built.get(value)
        if built is None:
            if len(self._built) >= COEFFICIENT_CACHE:
                self._built.clear()
            built = self._built[value] = kernels_for(self.model).coefficients(
                dict(self.parameters, **{self.parameter: value}))
        return built


def outside(problem, value):
    """None where the continued parameter at ``value`` is inside the model's domain, else why not."""
    return None if problem.domain is None else problem.domain({problem.parameter: float(value)})


def approach_edge(step, min_step, point_at, inside):
    """The point nearest an edge (of the domain, or a range) on the arc s in (0, step) whose end
    lies beyond it: bisection on s until the bracket is below ``min_step``, the last point inside
    kept. point_at(s) -> (point, failure); inside(point) -> bool. Returns (s, point) or (None,
    None) when no corrected point inside is found (the arc's start is already that close).
    Shared by branches (follow) and curves (curves.follow)."""
    low, high, best = 0.0, step, None
    while high - low > min_step:
        s = 0.5 * (low + high)
        point, failure = point_at(s)
        if failure is None and inside(point):
            low, best = s, point
        else:
            high = s
    return (low, best) if best is not None else (None, None)


def evaluate(problem, state, value, periods):
    """P^p and its monodromy at (state, value): the shooting.OrbitMap."""
    return periodic_map(problem.coefficients(value), state, problem.settings, periods, problem.method,
                        model=problem.model)


def _failure(orbit_map):
    """None, or (status, reason) when the map's integration cannot serve continuation."""
    if orbit_map.status != Status.OK:
        return ENDED_INTEGRATION, f"integration stopped: {orbit_map.status.name.lower()}"
    if orbit_map.stuck_time > 0.0:
        # Not a numerical failure: the shooting map has no sticking phases (a stuck mass's monodromy
        # is 0 there); "singular" sent users looking for a defect in a valid orbit.
        return ENDED_STICKING, ("the orbit sticks to the barrier for part of its period: continuation follows only "
                                "orbits that do not stick (sweep or simulate it instead)")
    return None


def _parameter_derivative(problem, state, value, periods, orbit_map, relative=None):
    """F_lam = d P^p / d lam by a forward difference (module doc), on the same side of every
    graze as the orbit: a difference whose other end gains or loses an impact measures the jump,
    not the derivative (next to a graze an orbit can be 1e-6 from it in lam, the difference's own
    size), so it is taken backwards, or shorter, until both ends have the same impacts.

    Beyond a graze, while the new impact is slow (speed u), the map curves like 1/u^3 in lam
    (grazing.py's square root): a forward difference of 1e-6 * lam is then off by O(1) (at Fig.
    1's g = 17.8978, u = 0.11: 258 for 437 in one component), enough for Newton to diverge with
    multipliers of only -4.4. There the difference is central (its error goes with the square of
    the step), when both ends keep the orbit's impacts."""
    relative = PARAMETER_DIFFERENCE if relative is None else relative
    step = relative * max(1.0, abs(value))
    scale = grazing.scale(problem, value)
    if orbit_map.slowest_impact ** 2 < SLOW_IMPACT * scale:
        ends = [evaluate(problem, state, value + direction * step, periods) for direction in (1.0, -1.0)]
        if not any(_failure(end) or end.impacts != orbit_map.impacts for end in ends):
            return (ends[0].end_state - ends[1].end_state) / (2.0 * step)
    for _ in range(PARAMETER_DIFFERENCE_TRIES):
        for direction in (1.0, -1.0):
            moved = evaluate(problem, state, value + direction * step, periods)
            if not _failure(moved) and moved.impacts == orbit_map.impacts:
                return (moved.end_state - orbit_map.end_state) / (direction * step)
        step *= 0.01
    # Every difference straddles a graze (or fails): the forward one, as before; only the
    # predictor and Newton's rate depend on it, never a converged point.
    step = relative * max(1.0, abs(value))
    moved = evaluate(problem, state, value + step, periods)
    if _failure(moved):
        step = -step
        moved = evaluate(problem, state, value + step, periods)
    return (moved.end_state - orbit_map.end_state) / step


def _orbit(problem, state, value, periods, orbit_map, residual, iterations, derivative=None):
    R, Q_amplitude = orbit_gain(problem.coefficients(value), periods, orbit_map.R, orbit_map.Q_amplitude)
    return Orbit(parameter=float(value), state=np.array(state, dtype=float), periods=periods,
                 monodromy=orbit_map.monodromy.copy(), R=R, Q_amplitude=Q_amplitude,
                 impacts_per_period=orbit_map.impacts / periods, x_max=orbit_map.x_max,
                 slowest_impact=orbit_map.slowest_impact, residual=residual, newton_iterations=iterations,
                 parameter_derivative=derivative, free_x_max=orbit_map.free_x_max)


def _tolerance(problem, state):
    return problem.options["newton_tolerance"] * max(1.0, float(np.max(np.abs(state))))


def correct(problem, z_guess, periods, tangent=None, z_predicted=None, short_difference=False):
    """Newton on F = 0, with the arclength condition tangent . (z - z_predicted) = 0 when tangent is
    given, else at the fixed parameter z_guess[2]. Returns (Orbit, None) or (None, (status, reason)).

    With ``short_difference`` (follow's step along the branch and the arc's points that locate a
    bifurcation on it; a crossing's or a march's
    correctors keep their own rules), where Newton does not converge it is tried once more with F_lam's difference
    SHORT_DIFFERENCE times shorter: where the map curves steeply in lam (Fig. 1's period-3
    branch at g = 17.799, a period doubling and a fold 1e-5 apart, the multiplier moving 2.5e4 per
    unit g) the difference of 1.8e-5 in g spans the curvature, F_lam is wrong, and Newton failed
    at every step down to min_step: the branch ended there (newton_failed, up to 0.7.1)."""
    orbit, failure = _newton(problem, z_guess, periods, tangent, z_predicted, None)
    if (short_difference and orbit is None and failure[0] == ENDED_NEWTON
            and failure[1].startswith("Newton did not converge")):
        retried, _ = _newton(problem, z_guess, periods, tangent, z_predicted, PARAMETER_DIFFERENCE * SHORT_DIFFERENCE)
        if retried is not None:
            return retried, None
    return orbit, failure


def _newton(problem, z_guess, periods, tangent, z_predicted, relative):
    """correct's Newton, F_lam's difference ``relative`` (None: PARAMETER_DIFFERENCE)."""
    z = np.array(z_guess, dtype=float)
    failure = None
    residual = np.inf
    previous_z, previous_merit, last_step, halvings = None, np.inf, None, 0
    for iteration in range(1, problem.options["max_newton_iterations"] + 1):
        orbit_map = evaluate(problem, z[:2], z[2], periods)
        failure = _failure(orbit_map)
        residual_vector = orbit_map.end_state - z[:2]
        arc_now = 0.0 if tangent is None else float(tangent @ (z - z_predicted))
        merit = np.inf if failure else float(np.max(np.abs(residual_vector))) + abs(arc_now)
        if previous_z is not None and not merit < previous_merit and halvings < MAX_HALVINGS:
            # Damped Newton: near grazing the map is only piecewise smooth (the monodromy jumps
            # where an impact appears), and a full step can land where the Jacobian no longer
            # holds; halve it back towards the last iterate.
            last_step *= 0.5
            z = previous_z + last_step
            halvings += 1
            continue
        if failure:
            return None, failure
        halvings = 0
        previous_z, previous_merit = z.copy(), merit
        residual = float(np.max(np.abs(residual_vector)))
        jacobian_state = orbit_map.monodromy - np.eye(2)
        if tangent is None:
            if residual <= _tolerance(problem, z[:2]):
                derivative = _parameter_derivative(problem, z[:2], z[2], periods, orbit_map, relative)
                return _orbit(problem, z[:2], z[2], periods, orbit_map, residual, iteration, derivative), None
            try:
                step = np.linalg.solve(jacobian_state, -residual_vector)
            except np.linalg.LinAlgError:
                return None, (ENDED_NEWTON, "singular Jacobian at the start (a fold?)")
            last_step = np.concatenate([step, [0.0]])
            z = z + last_step
            continue
        derivative = _parameter_derivative(problem, z[:2], z[2], periods, orbit_map, relative)
        arc = float(tangent @ (z - z_predicted))
        if residual <= _tolerance(problem, z[:2]) and abs(arc) <= _tolerance(problem, z[:2]):
            return _orbit(problem, z[:2], z[2], periods, orbit_map, residual, iteration, derivative), None
        jacobian = np.zeros((3, 3))
        jacobian[:2, :2] = jacobian_state
        jacobian[:2, 2] = derivative
        jacobian[2] = tangent
        try:
            step = np.linalg.solve(jacobian, -np.concatenate([residual_vector, [arc]]))
        except np.linalg.LinAlgError:
            return None, (ENDED_NEWTON, "singular extended Jacobian")
        if not np.all(np.isfinite(step)):
            return None, (ENDED_NEWTON, "non-finite Newton step")
        last_step = step
        z = z + step
    iterations = problem.options["max_newton_iterations"]
    return None, (ENDED_NEWTON, f"Newton did not converge in {iterations} iterations (residual {residual:.2g})")


def tangent_of(orbit, previous=None):
    """Unit null vector of [M - I | F_lam] (cross product of its two rows), oriented along previous."""
    rows = np.zeros((2, 3))
    rows[:, :2] = orbit.monodromy - np.eye(2)
    rows[:, 2] = orbit.parameter_derivative
    tangent = np.cross(rows[0], rows[1])
    tangent /= np.linalg.norm(tangent)
    if previous is not None and tangent @ previous < 0.0:
        tangent = -tangent
    return tangent


# --- test functions ------------------------------------------------------------------------------
def _fold_test(orbit):
    return float(np.linalg.det(orbit.monodromy - np.eye(2)))


def _doubling_test(orbit):
    return float(np.linalg.det(orbit.monodromy + np.eye(2)))


def _torus_test(orbit):
    mu = orbit.multipliers
    if abs(mu[0].imag) <= 1e-12 * max(1.0, abs(mu[0])):
        return np.nan  # real multipliers: no Neimark-Sacker here
    return float(np.linalg.det(orbit.monodromy) - 1.0)


TEST_FUNCTIONS = {"fold": _fold_test, "period_doubling": _doubling_test, "neimark_sacker": _torus_test}
# A located fold, period doubling or Neimark-Sacker point has its critical multiplier this close
# to its critical value (a real one to +1 or -1, the modulus of a complex pair to 1): the location
# narrows past location_tolerance in the parameter until it is. A bracket in the parameter alone
# is not enough where the multiplier moves fast: on Fig. 1's period-3 branch at g = 17.799 it
# moves 7e4 per unit g, and a period doubling and a fold 1.1e-5 apart in g, inside the bracket of
# 1e-6 * g = 1.8e-5, were recorded with multipliers -0.989 and 1.0097 (up to 0.7.2). The
# multiplier of a corrected orbit is known far better (its noise there, at rtol 1e-12: ~5e-5).
LOCATED_MULTIPLIER = 1e-3
# Iterations of the location after the parameter's bracket is narrow, while the multiplier is not
# yet within LOCATED_MULTIPLIER: regula falsi on a smooth root needs a few; more means no root.
EXTRA_LOCATION_ITERATIONS = 20
# How near its critical value a multiplier of a point located where the arc crosses a graze must
# be to be a bifurcation at all (_detect): across a graze the test functions jump with the
# monodromy (a free orbit's 0.57 +- 0.64i to an impacting one's -10.9), and a sign change may be
# that jump, where the multiplier never comes near its critical value.
CRITICAL_DISTANCE = 0.1


def locate_on_arc(point_at, value_of, step, f_low, f_high, narrow, iterations, illinois=True):
    """The point on an arc s in (0, step) where ``value_of`` changes sign, from its values f_low at
    s = 0 and f_high at s = step: the Illinois variant of regula falsi (illinois=False: bisection).

    point_at(s) -> (point, failure) corrects the arc's point at s onto the curve; value_of(point)
    -> float; narrow(low, high, value) -> True once the bracket is narrow enough. Returns the
    point where the value is 0, else the last point corrected (None before the first), stopping
    at the first failure. Shared by branches (_locate) and bifurcation curves (curves.py).
    """
    low, high, side, best = 0.0, step, 0, None
    true_low, true_high = f_low, f_high  # the values themselves (Illinois halves f_low, f_high)
    for _ in range(iterations):
        s = 0.5 * (low + high)
        if illinois:
            secant = (low * f_high - high * f_low) / (f_high - f_low)
            if low < secant < high:
                s = secant
        point, failure = point_at(s)
        if failure:
            return best
        best = point
        value = value_of(point)
        if value == 0.0:
            return point
        if np.sign(value) == np.sign(f_low):
            low, f_low, true_low = s, value, value
            if side == -1 and illinois:
                f_high *= 0.5  # Illinois: the end that stays is halved
            side = -1
        else:
            high, f_high, true_high = s, value, value
            if side == 1 and illinois:
                f_low *= 0.5
            side = 1
        if narrow(low, high, value):
            if illinois and true_low != true_high:
                # One last point at the straight line's root through the bracket's two corrected
                # ends, kept where it is nearer the root: the bracket is narrow in the parameter,
                # the value at its last end need not be (the hysteresis example's fold was left at
                # a multiplier 2.6e-5 from +1, its bracket's other end 2.5e-5 on the other side).
                root = (low * true_high - high * true_low) / (true_high - true_low)
                if low < root < high:
                    point, failure = point_at(root)
                    if not failure and abs(value_of(point)) < abs(value):
                        return point
            break
    return best


def _locate(problem, start, tangent, step, kind, value_start, value_end, periods, across_graze=False, low=0.0,
            impacts=None):
    """The orbit on the arc from ``start`` (low < s < step along tangent) where the test function of
    ``kind`` vanishes, by Illinois regula falsi (grazing: bisection on the impact count), to
    location_tolerance in the parameter and, for a fold, period doubling or Neimark-Sacker point,
    until its critical multiplier is within LOCATED_MULTIPLIER of its critical value (_located;
    at most EXTRA_LOCATION_ITERATIONS more; ``across_graze``: the arc crosses a graze, and a
    multiplier CRITICAL_DISTANCE or more from critical once the parameter is narrow is the
    monodromy's jump, not looked at further; ``impacts``: the arc lies on one side of a graze with
    these impacts per period, and an orbit with others, or farther from its predictor than the
    arc is long, is another branch's, a failure of the corrector here: from Fig. 1's graze at g =
    39.844991 the arc's plane met orbits of 4 impacts at g = 38.5). Returns the Orbit nearest the
    root, or None."""
    tolerance = problem.options["location_tolerance"] * max(1.0, abs(start.parameter))
    last = [None]  # the last orbit corrected on the arc
    extra = [0]

    def point_at(s):
        z_predicted = start.z + (low + s) * tangent
        orbit, failure = correct(problem, z_predicted, periods, tangent, z_predicted, short_difference=True)
        if failure is None and impacts is not None and (
                orbit.impacts_per_period != impacts or np.linalg.norm(orbit.z - z_predicted) > step - low):
            return None, (ENDED_NEWTON, "the corrector went to another branch")
        last[0] = orbit
        return orbit, failure

    def narrow(low, high, value):
        if (high - low) <= 1e-14 * step:
            return True
        # The parameter interval between the bracket's ends: tangent[2] * (high - low) to first order;
        # at a fold the parameter turns (its tangent component is near zero there), so the arc itself
        # is narrowed (the hysteresis example's fold was left with its multiplier 2.6e-5 from +1, at
        # a bracket of 1e-4 along the arc, when a refused step shifted its bracket).
        spread = (high - low) if kind == "fold" else abs(tangent[2]) * (high - low)
        if not (spread <= tolerance or (kind != "grazing" and abs(value) <= 1e-12)):
            return False
        if kind == "grazing":
            return True
        distance = critical_distance(kind, last[0])
        if distance <= LOCATED_MULTIPLIER or (across_graze and distance >= CRITICAL_DISTANCE):
            # Located; or, across a graze, the multiplier nowhere near critical with the parameter
            # pinned: the monodromy's jump, not a root that more iterations would reach. (Away from
            # grazes a root is narrowed on even from far: at the fold at g = 17.799042 the
            # multiplier moves 1.8 within the parameter's bracket.)
            return True
        extra[0] += 1
        return extra[0] > EXTRA_LOCATION_ITERATIONS

    if kind == "grazing":
        # -1 on the start's side (the same impact count), +1 beyond
        return locate_on_arc(point_at, lambda orbit: -1.0 if orbit.impacts_per_period == value_start else 1.0,
                             step - low, -1.0, 1.0, narrow, 60, illinois=False)
    return locate_on_arc(point_at, TEST_FUNCTIONS[kind], step - low, value_start, value_end, narrow,
                         60 + EXTRA_LOCATION_ITERATIONS)


def critical_distance(kind, orbit):
    """How far the multiplier of a fold, period doubling or Neimark-Sacker point ``orbit`` lies
    from its critical value: the real multiplier nearest +1 (fold) or -1 (period doubling) from
    it, or the complex pair's modulus from 1 (inf where there is no such multiplier)."""
    mu = orbit.multipliers
    real = np.abs(mu.imag) <= 1e-9 * np.maximum(1.0, np.abs(mu))
    if kind in ("fold", "period_doubling"):
        target = 1.0 if kind == "fold" else -1.0
        distances = np.abs(mu.real[real] - target)
        return float(distances.min()) if distances.size else np.inf
    return abs(abs(mu[0]) - 1.0) if not real[0] else np.inf


def _located(kind, orbit):
    """Whether a fold, period doubling or Neimark-Sacker point is located: its critical multiplier
    within LOCATED_MULTIPLIER of the critical value."""
    return critical_distance(kind, orbit) <= LOCATED_MULTIPLIER


def _graze_limits(problem, previous, current, graze):
    """The limits at the located grazing.Graze ``graze`` of the two sides of a step across it from
    ``previous`` to ``current``: (the grazing Orbit with the monodromy of previous's side, with
    that of current's side), the free map's on the side without the grazing impact, the probe's
    on the side with it (one multiplier of order 1/u there). None where the impacting side's
    limit is not known."""
    free_limit = _graze_orbit(problem, graze)
    impacting = grazing.impacting_monodromy(problem, graze)
    if impacting is None:
        return None
    impacting_limit = Orbit(**dict(vars(free_limit), monodromy=impacting))
    if previous.impacts_per_period < current.impacts_per_period:
        return free_limit, impacting_limit
    return impacting_limit, free_limit


def _detect_on_pieces(problem, pieces, periods, before):
    """Folds, period doublings and Neimark-Sacker points on smooth pieces of a branch that meet
    at a graze: each piece (start Orbit, unit direction, low, high, the test functions' orbit at
    low, at high, the branch's orbit on its side) is the arc start.z + s * direction, low < s < high, on one side of the graze,
    its end at the graze carrying that side's limit (_graze_limits). On one side the test
    functions are continuous, so a sign change is a bifurcation: located, or recorded as not
    located with ``before`` (the branch's orbit before the step) as its orbit."""
    found = []
    for kind, test in TEST_FUNCTIONS.items():
        for start, direction, low, high, first, last, side in pieces:
            a, b = test(first), test(last)
            if np.isfinite(a) and np.isfinite(b) and a * b < 0.0:
                orbit = _locate(problem, start, direction, high, kind, a, b, periods, True, low=low,
                                impacts=side.impacts_per_period)
                if orbit is not None and _located(kind, orbit):
                    found.append((kind, orbit))
                else:
                    found.append((UNLOCATED_PREFIX + kind, before))
    return found


def _detect_crossing(problem, previous, graze, passed, periods):
    """Bifurcations on the way cross_grazing took from ``previous`` through the located
    grazing.Graze ``graze`` onto the orbits ``passed`` beyond it (in order; several after a march
    in the new impact's speed): on the chord from previous to the graze, with previous's side's
    limit there, on the chord from the graze to the first orbit beyond, with that side's limit,
    and between consecutive orbits beyond (_detect). The branch turns at the graze (a corner), so
    each piece has its own direction. Up to 0.7.4 nothing was looked for: Fig. 1's period-1 branch
    crossed its graze at g = 39.844991 onto an orbit past a period doubling and a fold 3e-4 away
    and recorded neither. Returns [(kind, Orbit)], the graze itself not included."""
    found = []
    first = passed[0]
    graze_orbit = _graze_orbit(problem, graze)
    limits = _graze_limits(problem, previous, first, graze)
    pieces = []
    for start, end, first_limit, last_limit in ((previous, graze_orbit, previous, None if limits is None else limits[0]),
                                                (graze_orbit, first, None if limits is None else limits[1], first)):
        chord = end.z - start.z
        length = float(np.linalg.norm(chord))
        if length > 0.0:
            pieces.append((start, chord / length, 0.0, length, first_limit, last_limit,
                           previous if start is previous else first))
    if limits is not None:
        found += _detect_on_pieces(problem, pieces, periods, previous)
    else:
        # The impacting side's limit is not known (the probe does not gain one impact): the test
        # functions are compared across the corner, and a sign change is kept only where a
        # multiplier comes near critical (the monodromy's jump at the graze is no bifurcation).
        for kind, test in TEST_FUNCTIONS.items():
            a, b = test(previous), test(first)
            if np.isfinite(a) and np.isfinite(b) and a * b < 0.0:
                found.append((UNLOCATED_PREFIX + kind, previous))
    for before, after in zip(passed, passed[1:]):
        chord = after.z - before.z
        length = float(np.linalg.norm(chord))
        if length > 0.0:
            found += _detect(problem, before, after, chord / length, length, periods)
    return found


def _detect(problem, previous, current, tangent, step, periods, graze=None, branch_point=None):
    """Bifurcations on the arc between two consecutive orbits: a list of (kind, Orbit).
    graze: the graze between them that _graze_between located, if any; branch_point: the branch
    point follow located between them (_branch_point), which is the fold test's sign change."""
    found = []
    if branch_point is not None:
        found.append((BRANCH_POINT, branch_point))
    # Across a graze the test functions jump with the multipliers (a free orbit's 0.57 +- 0.64i to
    # an impacting one's -10.9): a sign change there may be the jump, which regula falsi brackets
    # as if it were a root. What it locates is a bifurcation only if a multiplier is critical there.
    crosses_graze = graze is not None or previous.impacts_per_period != current.impacts_per_period
    # With the graze located, each side of it is smooth, and its test functions are compared on
    # each side up to the graze: the jump at the graze can undo a sign change (a period doubling
    # of Fig. 1's 11-impact orbits at g = 17.793014, -0.58 to -68, then their graze at 17.797473,
    # -145 to a free side's -0.07: the same sign of det(M + I) at both ends of one long step, and
    # the doubling was not seen, up to 0.7.3).
    limits = None
    if graze is not None and previous.impacts_per_period != current.impacts_per_period:
        s_graze = float(tangent @ (graze.z - previous.z))
        if 0.0 < s_graze < step:
            limits = _graze_limits(problem, previous, current, graze)
    if limits is not None:
        pieces = [(previous, tangent, 0.0, s_graze, previous, limits[0], previous),
                  (previous, tangent, s_graze, step, limits[1], current, current)]
        found += _detect_on_pieces(problem, pieces, periods, previous)
        found.append(("grazing", _graze_orbit(problem, graze)))
        return found
    for kind, test in TEST_FUNCTIONS.items():
        if kind == "fold" and branch_point is None and not crosses_graze and _flips(previous, current, tangent):
            # The parameter does not turn: a branch point, not a fold (follow refuses a hop; a
            # step to the range's end is not looked at there).
            branch_point = _branch_point(problem, previous, current, tangent, step, periods)
            if branch_point is not None:
                found.append((BRANCH_POINT, branch_point))
        if kind == "fold" and branch_point is not None:
            continue
        a, b = test(previous), test(current)
        if np.isfinite(a) and np.isfinite(b) and a * b < 0.0:
            orbit = _locate(problem, previous, tangent, step, kind, a, b, periods, crosses_graze)
            if orbit is not None and _located(kind, orbit):
                found.append((kind, orbit))
            elif not crosses_graze or (orbit is not None and critical_distance(kind, orbit) < CRITICAL_DISTANCE):
                # A sign change with no point whose multiplier is critical (the corrector failed on
                # the arc, or the location stalled short of LOCATED_MULTIPLIER): recorded, never
                # given a location it does not have. Across a graze a sign change whose multiplier
                # never comes near critical is the monodromy's jump, not a bifurcation.
                found.append((UNLOCATED_PREFIX + kind, previous))
    if graze is not None:
        found.append(("grazing", _graze_orbit(problem, graze)))
    elif previous.impacts_per_period != current.impacts_per_period:
        # No map without the new impact (no room for a window, or Newton on it failed): bisection on
        # the impact count; where that fails too, the change is recorded all the same, bracketed by
        # the two orbits (UNLOCATED_GRAZING), never dropped.
        orbit = _locate(problem, previous, tangent, step, "grazing", previous.impacts_per_period, 1.0, periods)
        found.append(("grazing", orbit) if orbit is not None else (UNLOCATED_GRAZING, previous))
    return found


def _bends(before, previous, current):
    """True when the response R at ``current`` is off the secant through ``before`` and
    ``previous`` (carried along the arclength) by more than BEND_TOLERANCE * max(1, |R|): the step
    was too long for the branch's curvature, or landed on another branch with the same impact
    count (a coarse step at the end of Fig. 1's period-3 window passes two grazes and a fold at
    once and lands on an orbit whose R is twice the secant's)."""
    expected = _along_secant(before, previous, current, before.R if before else None, previous.R)
    return expected is not None and abs(current.R - expected) > BEND_TOLERANCE * max(1.0, abs(previous.R))


def _along_secant(before, previous, current, value_before, value_previous):
    """A quantity's value at ``current`` on the secant through its values at ``before`` and
    ``previous``, carried along the arclength in (x, v, parameter); None without a secant."""
    if before is None:
        return None
    span = np.linalg.norm(previous.z - before.z)
    if not span > 0.0:
        return None
    return value_previous + (value_previous - value_before) * np.linalg.norm(current.z - previous.z) / span


def _gaps(problem, orbit):
    """(distance of the highest smooth maximum below Delta, slowest impact speed): what reaches
    0 at a graze of either kind."""
    top = orbit.x_max if orbit.impacts_per_period == 0 else orbit.free_x_max
    return _barrier(problem, orbit) - top, orbit.slowest_impact


def _same_touch(window, other):
    """Two windows (or None: no barrier at all) around the same touch: each one's centre inside
    the other."""
    if window is None or other is None:
        return window is None and other is None
    return other[0] < 0.5 * (window[0] + window[1]) < other[1] and window[0] < 0.5 * (other[0] + other[1]) < window[1]


def _heading_for_graze(problem, before, previous, current):
    """True when either gap of _gaps, extrapolated along the secant through ``before`` and
    ``previous``, would be below zero at ``current``: the step may have passed a graze that the
    previous orbit was not yet close to (long steps)."""
    if before is None:
        return False
    for gap_before, gap_previous in zip(_gaps(problem, before), _gaps(problem, previous)):
        if np.isfinite(gap_before) and np.isfinite(gap_previous):
            expected = _along_secant(before, previous, current, gap_before, gap_previous)
            if expected is not None and expected < 0.0:
                return True
    return False


def _graze_between(problem, previous, current, before=None, memo=None):
    """Where the corrector stepped from ``previous`` to an orbit with another impact count:
    (the grazing.Graze located between them, or None; the verdict on the step: None (it stands),
    JUMP (it landed on another branch) or UNLOCATED (a graze it may pass could not be located)).

    A graze on the arc is located on the map without the impact that appeared (or went), from the
    side without it, and must lie between the two parameters; when it does not, the corrector
    jumped onto another branch that happens to lie near (next to a grazing corner, the stable
    branch on the free side and the unstable one beyond are a square root apart), and the step is
    refused; so is a step over two grazes at once (each is crossed and located on its own at a
    shorter step). Without a window no graze can be located: the step is UNLOCATED, retried
    shorter, and stands only at min_step, where _detect brackets the change. With the same impact
    count on both sides, a step from next to a graze (or heading for one: ``before``, the orbit
    before ``previous``, gives the trend) that passes the graze's parameter has jumped too: beyond
    a graze the orbit has one impact more or less, so an orbit there with the same count belongs to
    another branch (the end of Fig. 1's period-3 window, g = 17.796, has one 0.002 away). ``memo``
    (a dict kept along the branch) holds the graze such a check located last: the next steps
    towards the same touch reuse it.
    """
    if previous.impacts_per_period == current.impacts_per_period:
        site = _graze_site(problem, previous, JUMP_PROXIMITY)
        if site is None and _heading_for_graze(problem, before, previous, current):
            site = _graze_site(problem, previous, np.inf)
        if site is None:
            return None, None
        memo = {} if memo is None else memo
        known = memo.get("graze")
        if (known is not None and memo.get("impacts") == previous.impacts_per_period
                and _same_touch(known.window, site[1])):
            located = known
        else:
            located = grazing.locate_at_site(problem, previous.z, previous.periods, _tolerance(problem, previous.state),
                                             site, round(previous.impacts_per_period * previous.periods),
                                             lambda: evaluate(problem, previous.state, previous.parameter,
                                                              previous.periods))
            memo.update(graze=located, impacts=previous.impacts_per_period)
        if located is None:
            # Not located is not "not there": a step that the gaps' trend says passes a graze is
            # refused (retried shorter, so that it stops short of the graze: from closer, the graze
            # is located) rather than taken as one that passes none (up to 0.7.1).
            return None, UNLOCATED if _heading_for_graze(problem, before, previous, current) else None
        passed = (located.z[2] - previous.parameter) * (current.parameter - located.z[2]) > 0.0
        # Passing the graze's parameter is a jump only where the step passes by the grazing orbit
        # itself: an orbit far from it (0.05 in state beyond Fig. 1's g = 39.844991, after a fold)
        # may cross that parameter value on its own branch, with the same impacts.
        return None, JUMP if passed and _passes_near(located.z, previous.z, current.z) else None
    free_side, impacting_side = sorted((previous, current), key=lambda orbit: orbit.impacts_per_period)
    gained = round((impacting_side.impacts_per_period - free_side.impacts_per_period) * free_side.periods)
    # Two at once only from a free orbit onto both stops (a double graze, checked below).
    if gained > 2 or (gained == 2 and free_side.impacts_per_period != 0):
        return None, JUMP
    window = _new_impact_window(problem, free_side, impacting_side)
    if window is False:
        # No window fits, so no graze is located here, and nothing says the step did not jump:
        # it is retried shorter and stands only at min_step, where _detect brackets the change
        # (one step of 0.07 from the asymmetric orbit at omega = 1.0731461 of the two-stop Duffing
        # oscillator's pitchfork, two impacts a period, landed on an orbit of one at omega =
        # 1.0305 and was taken, up to 0.7.12; its branch ends at a zero-speed impact at 1.0742503).
        return None, UNLOCATED
    located = grazing.locate_graze(problem, free_side.z, free_side.periods, _tolerance(problem, free_side.state),
                                   window)
    if located is None:
        # Newton on the map without the new impact failed: that says nothing about a jump (until
        # 0.7.1 it was taken for one, and the branch ended "keeps jumping to another branch").
        return None, UNLOCATED
    if not (min(previous.parameter, current.parameter) <= located.z[2] <= max(previous.parameter, current.parameter)):
        return None, JUMP
    if gained != max(1, len(located.touches)):
        return None, JUMP  # two impacts gained where the graze touches one stop, or one at a double graze
    if _same_graze(problem, located, (memo or {}).get("crossed")):
        return None, JUMP  # back over the graze the branch has just crossed (follow)
    return located, None


def _same_graze(problem, located, other):
    """Whether two located grazing.Graze (either may be None) are one, to location_tolerance."""
    if located is None or other is None:
        return False
    return bool(np.max(np.abs(located.z - other.z))
                <= problem.options["location_tolerance"] * max(1.0, float(np.max(np.abs(other.z)))))


def _passes_near(point, start, end):
    """Whether ``point`` lies within one step length |end - start| of the segment from ``start`` to
    ``end`` (in z = x, v, parameter): a step that long could have passed by it."""
    segment = end - start
    length = np.linalg.norm(segment)
    along = 0.0 if length == 0.0 else float(np.clip((point - start) @ segment / length ** 2, 0.0, 1.0))
    return np.linalg.norm(point - (start + along * segment)) <= length


def _new_impact_window(problem, free_side, impacting_side):
    """The window grazing.locate_graze takes for the one impact that ``impacting_side`` has and
    ``free_side`` lacks (None: no barrier at all, 0 against 1 impact), or False when no window
    fits."""
    periods = free_side.periods
    if free_side.impacts_per_period == 0:
        return None
    free_map = evaluate(problem, free_side.state, free_side.parameter, periods)
    impacting_map = evaluate(problem, impacting_side.state, impacting_side.parameter, periods)
    if _failure(free_map) or _failure(impacting_map):
        return False
    # The new impact: the one farthest in time from every impact of the free side.
    orbit_period = periods * problem.coefficients(free_side.parameter)[PERIOD]
    gaps = np.abs(impacting_map.impact_times[:, None] - free_map.impact_times[None, :])
    gaps = np.minimum(gaps, orbit_period - gaps).min(axis=1)
    touch_time = float(impacting_map.impact_times[np.argmax(gaps)])
    window = grazing.graze_window(problem, free_map, free_side.parameter, periods, touch_time)
    return False if window is None else window


def _graze_orbit(problem, located):
    """The Orbit of a grazing.Graze (its free map's measures: the touch costs no impact)."""
    return _orbit(problem, located.z[:2], located.z[2], located.periods, located.orbit_map, located.residual,
                  located.iterations, located.jacobian[:2, 2].copy())


def follow(problem, start, direction, lo, hi, max_points, progress=None, stop=None):
    """Orbits from ``start`` (excluded) in ``direction`` (+1: parameter increasing at first).

    stop(previous, orbit): None, or the (status, reason) that ends the branch before ``orbit``
    (analysis/period_doubling.py: a switched branch back on the branch it was born on), or
    (REFUSED, reason): ``orbit`` is not on this branch, and the step is retried shorter (down to
    min_step, where the branch ends newton_failed with that reason).

    Returns (orbits, bifurcations [(kind, Orbit)], (status, reason)).
    """
    options = problem.options
    tangent = tangent_of(start)
    if tangent[2] * direction < 0.0:
        tangent = -tangent
    step = options["initial_step"]
    current = start
    orbits, bifurcations = [], []
    tried_crossing = False  # from this ``current``
    failed_crossing = False  # a crossing failed and the branch has stayed near that graze since
    before = None  # the orbit before ``current``
    memo = {}  # the graze the last jump check located (_graze_between)
    grazing_reason = None
    strayed = False  # a step from ``current`` was refused as too long for its curvature (_strays, _flips)
    while True:
        if len(orbits) >= max_points:
            return orbits, bifurcations, (ENDED_MAX_POINTS, f"{max_points} points reached")
        z_predicted = current.z + step * tangent
        orbit, failure = correct(problem, z_predicted, start.periods, tangent, z_predicted, short_difference=True)
        edge = None
        if failure is None and outside(problem, orbit.parameter) is not None:
            # Beyond the model's domain (e > 1 gains energy at each impact, R = |Q|/c has no
            # meaning at c <= 0): the branch ends at the last orbit inside, found on this arc.
            edge = outside(problem, orbit.parameter)

            def point_at(s, current=current, tangent=tangent):
                z = current.z + s * tangent
                found, failed = correct(problem, z, start.periods, tangent, z)
                if failed or _turned_back(current, found, tangent, s):
                    return None, failed or (ENDED_NEWTON, "the corrector jumped to another branch")
                return found, None

            step, orbit = approach_edge(step, options["min_step"], point_at,
                                        lambda found: outside(problem, found.parameter) is None)
            if orbit is None:
                return orbits, bifurcations, _domain_end(problem, current, edge)
            z_predicted = current.z + step * tangent
        crossed = False
        if failure is not None or _turned_back(current, orbit, tangent, step):
            step *= 0.5
            near = _near_grazing(problem, current)
            if near and not (tried_crossing or failed_crossing) and (
                    _graze_site(problem, current) is not None or step < options["min_step"]):
                # The square-root singularity of grazing: Newton from this side cannot reach the
                # other (module doc); the graze is located and crossed from its normal form.
                tried_crossing = True
                graze, beyond, new_tangent, grazing_reason, located_graze = cross_grazing(problem, current, tangent)
                if graze is not None:
                    _record_graze(problem, bifurcations, graze)
                if _same_graze(problem, located_graze, memo.get("crossed")):
                    # Back over the graze just crossed, to the side the branch came from: the
                    # corrector failed on the steep side beyond it, which shorter steps follow
                    # (beyond the symmetric Duffing oscillator's double graze at F = 0.2459, from
                    # u = 0.0145 this went back onto the free orbits the branch had come up).
                    beyond, grazing_reason = [], "the branch beyond the graze it crossed could not be followed"
                crossed = bool(beyond)
                orbit = beyond[-1] if crossed else None
                # The same graze, located again from a closer orbit, is crossed no better: the
                # crossing starts from the located graze, not from here.
                failed_crossing = not crossed
            if not crossed:
                if step >= options["min_step"]:
                    continue
                if near:
                    if grazing_reason is None and not (tried_crossing or failed_crossing):
                        grazing_reason = "no branch beyond the graze was found"
                    touch, speed = _gaps(problem, current)
                    side = "touches the barrier" if speed ** 2 > touch else "impacts at zero speed"
                    reason = (f"the orbit {side} at {problem.parameter} = {current.parameter:.8g}; "
                              f"{grazing_reason or 'no branch beyond the graze was found'}")
                    return orbits, bifurcations, (ENDED_GRAZING, reason)
                status, reason = failure or (ENDED_NEWTON, "the corrector keeps jumping to another branch")
                # Where steps from here were refused as too long for the branch's curvature, the
                # branch is there and curves on a scale below min_step (Fig. 1's bubble of six
                # periods at g = 17.798772: SciPy's orbits go on, steps of 2e-6 follow it).
                curl = (f"; the branch curves here on a scale below min_step = {options['min_step']:g} (steps from "
                        "this orbit were refused as too long for its curvature): a smaller continuation.min_step "
                        "may follow it" if strayed else "")
                # A corrector that fails at every step down to min_step may converge at a smaller one:
                # Fig. 1's bubble of six periods ends so 1e-5 short of its other doubling, which
                # min_step = 1e-6 reaches (docs/continuation.md). Say where the lever is, unless
                # the orbit's impact lies on the section, where no step carries the branch over.
                section = _section_note(problem, current)
                if status == ENDED_NEWTON and not curl and not section:
                    curl = (f"; a smaller continuation.min_step (now {options['min_step']:g}) may carry the branch "
                            "further")
                reason = (f"{reason} at {problem.parameter} = {current.parameter:.8g} with the smallest step"
                          f"{curl}{section}")
                return orbits, bifurcations, (status, reason)
        else:
            located, verdict = _graze_between(problem, current, orbit, before, memo)
            if verdict is not None and step * 0.5 >= options["min_step"]:
                step *= 0.5
                continue
            if verdict == JUMP:
                return orbits, bifurcations, (ENDED_NEWTON, f"the corrector keeps jumping to another branch at "
                                                            f"{problem.parameter} = {current.parameter:.8g}")
            # verdict UNLOCATED at the smallest step: the step stands; a change of the impact count
            # in it is recorded as a graze not located (_detect).
            if _bends(before, current, orbit) and step * 0.5 >= options["min_step"]:
                step *= 0.5
                continue
            new_tangent = tangent_of(orbit, tangent)
        ended = None if stop is None else stop(current, orbit)
        if ended is not None and ended[0] == REFUSED:  # not this branch's orbit: retried shorter
            if not crossed and step * 0.5 >= options["min_step"]:
                step *= 0.5
                continue
            return orbits, bifurcations, (ENDED_NEWTON, f"{ended[1]} with the smallest step")
        if ended is not None:
            return orbits, bifurcations, ended
        # After stop: a switched branch that meets its doubling (a corner there) ends, not retried.
        hop = not crossed and _flips(current, orbit, tangent)
        branch_point = None
        if hop and not _strays(current, orbit, z_predicted, step):
            # The fold test changed sign and the parameter did not turn: a hop, or a branch point
            # (a pitchfork of a symmetric branch), where the null space is two-dimensional and
            # the branch goes on through it. Located, a branch point has [M - I | F_lam] of rank 1.
            branch_point = _branch_point(problem, current, orbit, tangent, step, start.periods)
            hop = branch_point is None
        if not crossed and (_strays(current, orbit, z_predicted, step) or hop) and step * 0.5 >= options["min_step"]:
            step *= 0.5
            strayed = True
            continue
        if hop:
            # Still a hop at the smallest step: another family lies closer than min_step tells apart.
            # Taken, the step recorded the hop as an unlocated fold and period doubling (six such
            # pairs on Fig. 1's period-12 branch beyond g = 17.793242, up to 0.7.4) and went on
            # along orbits of both families in turn; the branch ends here instead, saying why.
            return orbits, bifurcations, (
                ENDED_NEWTON, f"the corrector keeps hopping onto another family of orbits at {problem.parameter} = "
                              f"{current.parameter:.8g}: the step's orbit reverses the null vector of [M - I | F_lam] "
                              f"and its fold test changes sign, which no step along one branch does, down to "
                              f"min_step = {options['min_step']:g}; a smaller continuation.min_step may tell the two "
                              f"apart")
        if not lo <= orbit.parameter <= hi:
            if crossed:  # the orbits a march in the new impact's speed found inside the range are kept
                kept = [passed for passed in beyond[:-1] if lo <= passed.parameter <= hi]
                if kept and located_graze is not None:
                    _record_found(problem, bifurcations, _detect_crossing(problem, current, located_graze, kept,
                                                                          start.periods))
                orbits.extend(kept)
                return orbits, bifurcations, (ENDED_RANGE, f"{problem.parameter} left [{lo:g}, {hi:g}] beyond a "
                                                           f"graze, where no orbit at its end is looked for")
            end, reason = _range_end(problem, current, orbit, tangent, lo, hi, before, memo)
            if end is not None:
                end_orbit, s_end, located = end
                ended = None if stop is None else stop(current, end_orbit)
                if ended is not None and ended[0] == REFUSED:  # not this branch's: the branch ends before it
                    return orbits, bifurcations, (ENDED_RANGE, f"{problem.parameter} left [{lo:g}, {hi:g}]; {ended[1]}")
                if ended is not None:
                    return orbits, bifurcations, ended
                _record_found(problem, bifurcations,
                              _detect(problem, current, end_orbit, tangent, s_end, start.periods, located))
                orbits.append(end_orbit)
                if progress is not None:
                    try:
                        progress(end_orbit)
                    except KeyboardInterrupt as interrupt:  # a stop asked for: the other way is not followed
                        return orbits, bifurcations, (ENDED_INTERRUPTED, f"stopped by {interrupt or 'SIGINT'} at "
                                                                         f"{problem.parameter} = {end_orbit.parameter:.8g}")
            return orbits, bifurcations, (ENDED_RANGE, reason)
        if outside(problem, orbit.parameter) is not None:  # e.g. an orbit beyond a graze: never kept
            return orbits, bifurcations, _domain_end(problem, current, outside(problem, orbit.parameter))
        if crossed:
            step = options["initial_step"]
            memo.clear()  # the graze just crossed is no test of the next step's ...
            if located_graze is not None:  # ... except that no step goes back over it (_graze_between)
                memo["crossed"] = located_graze
                _record_found(problem, bifurcations, _detect_crossing(problem, current, located_graze, beyond,
                                                                      start.periods))
        else:
            _record_found(problem, bifurcations, _detect(problem, current, orbit, tangent, step, start.periods, located,
                                                         branch_point))
            if orbit.newton_iterations <= EASY_NEWTON:
                step = min(step * STEP_GROWTH, options["max_step"])
        if crossed:  # the orbits a march in the new impact's speed found on the way (march_in_speed)
            orbits.extend(passed for passed in beyond[:-1] if lo <= passed.parameter <= hi)
        orbits.append(orbit)
        if progress is not None:
            try:
                progress(orbit)
            except KeyboardInterrupt as interrupt:  # a stop asked for: what is followed so far is kept
                return orbits, bifurcations, (ENDED_INTERRUPTED, f"stopped by {interrupt or 'SIGINT'} at "
                                                                 f"{problem.parameter} = {orbit.parameter:.8g}")
        if edge is not None:
            return orbits, bifurcations, _domain_end(problem, orbit, edge)
        # No secant through a graze's corner for the next step's _bends: the branch is not smooth there.
        before, current, tangent = (None if crossed else current), orbit, new_tangent
        tried_crossing = strayed = False
        failed_crossing = failed_crossing and _near_grazing(problem, orbit)
        if not crossed and not _near_grazing(problem, orbit, JUMP_PROXIMITY):
            memo.pop("crossed", None)  # away from the graze crossed: a loop may come back to it
        if not failed_crossing:
            grazing_reason = None


def _range_end(problem, current, beyond, tangent, lo, hi, before, memo):
    """The orbit at the end of the range [lo, hi] that the step from ``current`` (inside) to
    ``beyond`` (outside) passes: Newton at that end's parameter from the chord's point there, kept
    when it lies by the chord (within its length) and the step to it is one the branch takes (no
    jump, _graze_between). Returns ((Orbit, its arclength along ``tangent``, the graze located on
    the way or None) or None, the branch end's reason). A user asking for [a, b] gets
    the branch's orbit at b, not the last one before it: a first step of initial_step from the
    start could leave a narrow range with nothing kept (up to 0.7.2)."""
    name = problem.parameter
    bound = hi if beyond.parameter > hi else lo
    if current.parameter == bound:  # the branch's last orbit is that end's already (a start there)
        return None, f"{name} reached the end of [{lo:g}, {hi:g}] at {name} = {bound:g}"
    if outside(problem, bound) is not None:
        return None, f"{name} left [{lo:g}, {hi:g}]; its end {name} = {bound:g} lies outside the model's domain"
    fraction = (bound - current.parameter) / (beyond.parameter - current.parameter)
    guess = current.z + fraction * (beyond.z - current.z)
    guess[2] = bound  # exactly: a fraction's roundoff would leave it 1e-16 outside
    orbit, failure = correct(problem, guess, current.periods)
    if failure is not None:
        return None, (f"{name} left [{lo:g}, {hi:g}] between {name} = {current.parameter:.8g} and "
                      f"{beyond.parameter:.8g}; the orbit at {name} = {bound:g} did not converge: {failure[1]}")
    chord = np.linalg.norm(beyond.z - current.z)
    located, verdict = _graze_between(problem, current, orbit, before, memo)
    if np.linalg.norm(orbit.z - guess) > chord or verdict is not None:
        return None, (f"{name} left [{lo:g}, {hi:g}] between {name} = {current.parameter:.8g} and "
                      f"{beyond.parameter:.8g}; Newton at {name} = {bound:g} went to another orbit")
    s_end = float(tangent @ (orbit.z - current.z))
    if not s_end > 0.0:
        return None, (f"{name} left [{lo:g}, {hi:g}] between {name} = {current.parameter:.8g} and "
                      f"{beyond.parameter:.8g}; Newton at {name} = {bound:g} went back along the branch")
    return (orbit, s_end, located), f"{name} reached the end of [{lo:g}, {hi:g}] at {name} = {bound:g}"


def _domain_end(problem, last, reason):
    """The (status, reason) of a branch whose next orbit lies outside the model's domain."""
    return ENDED_DOMAIN, (f"stops at {problem.parameter} = {last.parameter:.8g}, the edge of the model's domain: "
                          f"beyond it {reason}")


def _record_found(problem, bifurcations, found):
    """Append _detect's [(kind, Orbit)], each graze once (_record_graze)."""
    for kind, orbit in found:
        if kind == "grazing":
            _record_graze(problem, bifurcations, orbit)
        else:
            bifurcations.append((kind, orbit))


def _record_graze(problem, bifurcations, graze):
    """Append a grazing orbit unless the same graze (its parameter within location_tolerance) is
    already there: the corrector can meet one graze several times as it closes in on it."""
    tolerance = problem.options["location_tolerance"] * max(1.0, abs(graze.parameter))
    if not any(kind == "grazing" and abs(orbit.parameter - graze.parameter) <= tolerance
               for kind, orbit in bifurcations):
        bifurcations.append(("grazing", graze))


def cross_grazing(problem, near, tangent):
    """Locate the graze next to ``near`` (an Orbit on either side of it) and step across.

    Returns (the grazing Orbit or None, the Orbits beyond in order along the branch (empty when
    none), the last one's tangent, a one-line reason when there are none, the located
    grazing.Graze or None: follow looks for bifurcations on the way through it, _detect_crossing). Where the ordinary
    corrector fails from the normal form's predictor (the map beyond is steep: Fig. 1's period-2
    branch at g = 17.8973) the branch beyond is followed in the new impact's speed (march_in_speed),
    several orbits at once. The map without the grazing impact is the barrier-free map, or
    the map with the barrier transparent in a window around the touch where the orbit has other
    impacts (grazing.graze_site); a touch with no room for a window is only recorded where the
    corrector gave up, and the branch beyond is searched for around it (switch_at_grazing).
    """
    periods = near.periods
    site = _graze_site(problem, near)
    if site is None:
        switched = switch_at_grazing(problem, near, tangent)
        if switched is None:
            return near, [], None, "no branch beyond the graze was found", None
        return near, [switched[0]], switched[1], None, None
    side, window = site
    located = grazing.locate_at_site(problem, near.z, periods, _tolerance(problem, near.state), site,
                                     round(near.impacts_per_period * periods),
                                     lambda: evaluate(problem, near.state, near.parameter, periods))
    window = window if located is None else located.window
    if located is None:
        free = "barrier-free" if window is None else "windowed"
        return None, [], None, f"the grazing orbit could not be located (Newton on the {free} map failed)", None
    graze = _graze_orbit(problem, located)
    lengths = [problem.options["initial_step"] * factor for factor in CROSSING_DISTANCES]
    impacts_near = round(near.impacts_per_period * periods)
    touched = max(1, len(located.touches))  # a double graze gains or loses an impact on each stop
    double = _double_graze_words(problem, located)
    if side == "free":
        normal_form = grazing.impacting_direction(problem, located)
        if normal_form is None:
            if double:
                return graze, [], None, f"{double}: the orbits beyond, with an impact on each, were not found", None
            return graze, [], None, "the orbit beyond the graze does not gain one impact, as its normal form needs", None
        direction, predictor, speed_scale = normal_form
        candidates = [predictor(length / speed_scale) for length in lengths]
        beyond, impacts_beyond = "impacting", impacts_near + touched
    else:
        direction = grazing.free_direction(located)
        candidates = [located.z + length * direction for length in lengths]
        beyond, impacts_beyond = "free", impacts_near - touched
    for z_predicted in candidates:
        if double and side == "free":
            orbit = _with_more_iterations(problem, DOUBLE_GRAZE_ITERATIONS, _corrected_forward, problem, z_predicted,
                                          periods, direction, located.z, impacts_beyond)
        else:
            orbit = _corrected_forward(problem, z_predicted, periods, direction, located.z, impacts_beyond)
        if orbit is not None:
            return graze, [orbit], tangent_of(orbit, direction), None, located
    if side == "free" and not double:  # the march follows one new impact's speed
        marched = march_in_speed(problem, located, predictor, impacts_beyond)
        if marched:
            return graze, marched[0], marched[1], None, located
    if double:
        return graze, [], None, f"{double}: no {beyond} orbit converged beyond it", None
    return graze, [], None, f"no {beyond} orbit converged beyond the graze", None


# Beyond a double graze the map has two square roots, one per stop, and the damped corrector
# halves its steps many times before it closes in: from the normal form's predictor at u = 0.015
# (the symmetric Duffing oscillator between stops at +-1, F = 0.2297) it converges in 40
# iterations and not in 12. The crossing's corrector gets this many times the configured number.
DOUBLE_GRAZE_ITERATIONS = 4


def _with_more_iterations(problem, factor, function, *args):
    """``function(*args)`` with the corrector allowed ``factor`` times max_newton_iterations."""
    configured = problem.options["max_newton_iterations"]
    problem.options["max_newton_iterations"] = factor * configured
    try:
        return function(*args)
    finally:
        problem.options["max_newton_iterations"] = configured


def _double_graze_words(problem, located):
    """'the orbit touches both stops at once (x = 1 and x = -1), a double graze' for a graze of
    several stops (grazing.Graze.touches), else ''."""
    if not located.touches:
        return ""
    coefficients = problem.coefficients(located.z[2])
    where = " and ".join(f"x = {barrier_position(coefficients, b):.8g}" for b in located.touches)
    return f"the orbit touches both stops at once ({where}), a double graze"


# The march in the new impact's speed u beyond a steep graze (march_in_speed): from u =
# SPEED_START * sqrt(max(1, |Delta|)), where the map is known well enough for the Newton tolerance
# (its noise is about |mu| times the integration's, and |mu| ~ 1/u), growing by SPEED_GROWTH (a
# failed point is retried at the square root of the growth, the first at a faster u, SPEED_RETRIES
# times in all), until the orbits
# are no longer near the graze for follow's checks (u^2 >= JUMP_PROXIMITY * max(1, |Delta|)) and
# the ordinary corrector converges from the last one, a chord further on; at most
# SPEED_MAX_POINTS orbits.
SPEED_START = 1e-2
SPEED_GROWTH = 1.5
SPEED_RETRIES = 3
SPEED_MAX_POINTS = 40


def march_in_speed(problem, graze, predictor, impacts_beyond):
    """The impacting branch beyond a graze, parameterised by its new impact's speed u:
    ([Orbit] with u growing, the last one's tangent) or None when no orbit converged.

    Each orbit is grazing.correct_at_speed's, from the normal form's predictor at the first u and
    from the quadratic (then linear) extrapolation in u of the orbits before (the branch is smooth
    in u, grazing.py), each moved first to where the free map overshoots the barrier as that u
    needs (grazing.onto_speed). Bifurcations between these orbits are looked for by follow
    (_detect_crossing), and recorded as not located where the arc's corrector, which locates
    them, fails, as it does here. The march hands over to follow once the
    ordinary corrector converges from its last orbit onto the same branch, forward. Where it never
    does (multipliers of 10^3 and more all along: the original model at Omega = 5 beyond g =
    45.122) the march goes on while it converges, and follow ends the branch after its last orbit.
    """
    periods, window = graze.periods, graze.window
    scale = grazing.scale(problem, graze.z[2])
    tolerance = _tolerance(problem, graze.z[:2])
    speeds, points, orbits = [], [], []
    speed, growth, retries = SPEED_START * math.sqrt(scale), SPEED_GROWTH, 0
    handover = None
    while len(orbits) < SPEED_MAX_POINTS:
        if len(points) >= 3:
            guess = np.array([np.polyval(np.polyfit(speeds[-3:], [p[i] for p in points[-3:]], 2), speed)
                              for i in range(3)])
        elif len(points) == 2:
            guess = points[-1] + (points[-1] - points[-2]) * (speed - speeds[-1]) / (speeds[-1] - speeds[-2])
        else:
            guess = predictor(speed)
        guess = grazing.onto_speed(problem, graze, guess, speed, predictor.kappa)
        found = grazing.correct_at_speed(problem, guess, periods, window, speed, tolerance)
        if found is None or found[1].impacts != impacts_beyond:
            if retries >= SPEED_RETRIES:
                break
            retries += 1
            if speeds:
                growth = math.sqrt(growth)
                speed = speeds[-1] * growth
            else:  # no orbit yet: the first u a little faster, where the map is less steep
                speed *= SPEED_GROWTH
            continue
        z, real, residual, iterations, jacobian = found
        orbit = _orbit(problem, z[:2], z[2], periods, real, residual, iterations, jacobian[:2, 2].copy())
        speeds.append(speed)
        points.append(z)
        orbits.append(orbit)
        if len(points) >= 2:
            chord = points[-1] - points[-2]
            ahead = _ordinary_step(problem, orbit, chord, impacts_beyond)
            if ahead is not None:
                handover = (len(orbits), ahead)
                if speed * speed >= JUMP_PROXIMITY * scale:
                    break
        speed *= growth
    if handover is not None:
        count, tangent = handover
        return orbits[:count], tangent
    if len(orbits) < 2:
        return None
    chord = points[-1] - points[-2]
    return orbits, chord / np.linalg.norm(chord)


def _ordinary_step(problem, orbit, chord, impacts):
    """The tangent at ``orbit`` (along ``chord``) when the arclength corrector converges from it
    a chord further on, with the same impacts and forward; else None."""
    length = float(np.linalg.norm(chord))
    tangent = tangent_of(orbit, chord / length)
    z_predicted = orbit.z + length * tangent
    ahead = _corrected_forward(problem, z_predicted, orbit.periods, tangent, orbit.z, impacts)
    return None if ahead is None else tangent


def _corrected_forward(problem, z_predicted, periods, direction, origin, impacts):
    """The arclength corrector's orbit from ``z_predicted`` (on the plane normal to ``direction``)
    when it converges with ``impacts`` impacts in its ``periods`` and lies ahead of ``origin``
    along ``direction``; else None."""
    orbit, failure = correct(problem, z_predicted, periods, direction, z_predicted)
    if (failure is None and round(orbit.impacts_per_period * periods) == impacts
            and (orbit.z - origin) @ direction > 0.0):
        return orbit
    return None



# An orbit is near grazing when its highest free maximum is this close to Delta (relative), or
# its slowest impact this slow (relative to the orbit's speed scale max(1, |v|)).
GRAZING_PROXIMITY = 1e-3
# A step with the same impact count on both sides is checked for a graze passed in between (a
# jump to another branch, _graze_between) when its first orbit is this close to one: ten times
# GRAZING_PROXIMITY, as steps near such orbits are still up to 1e-2 long in g (Fig. 1's g = 17.79).
JUMP_PROXIMITY = 1e-2
# An orbit's x at the section this near a barrier (relative to max(1, |position|)) has its impact
# on the section, for _section_note: the last orbits before such an end lie within 1e-5.
SECTION_PROXIMITY = 1e-4
# A step whose R leaves the secant of the last two points by this much (relative to max(1, |R|)) is
# retried at half the length (_bends): smooth stretches of a branch leave it by ~(step/radius)^2.
BEND_TOLERANCE = 0.1
# Arclength distances from a graze at which the branch beyond is looked for, relative to the
# initial step: the first that converges onto the other side wins.
CROSSING_DISTANCES = (1.0, 0.25, 0.0625, 0.015625)
# Radii (in (x, v, parameter)) of the spheres of predictors searched for the branch beyond a graze.
GRAZING_SEARCH_RADII = (1e-3, 4e-3, 1.6e-2)


def _section_note(problem, orbit):
    """What a branch's end adds when its last orbit sits on a barrier at the stroboscopic section:
    an impact at t = 0 mod pT, where the section's fixed point jumps from the state before the
    impact to the state after it (x = Delta, v -> -e v). The branch cannot be followed through
    that jump in this section; the orbit itself goes on (a sweep shows it)."""
    coefficients = problem.coefficients(orbit.parameter)
    for barrier in range(int(coefficients[N_BARRIERS])):
        position = float(barrier_position(coefficients, barrier))
        if abs(orbit.state[0] - position) <= SECTION_PROXIMITY * max(1.0, abs(position)):
            return (f"; there an impact lies on the stroboscopic section t = 0 mod pT (x = {orbit.state[0]:.8g}, "
                    f"the barrier at {position:.8g}), where the section's point jumps from before the impact "
                    "to after it: the branch cannot follow the orbit through (docs/continuation.md, "
                    "\"An impact at the section\")")
    return ""


def _barrier(problem, orbit):
    return grazing_barrier(problem.coefficients(orbit.parameter))


def _near_grazing(problem, orbit, proximity=GRAZING_PROXIMITY):
    """A smooth maximum of x within proximity * max(1, |Delta|) of the barrier (an impact is about
    to appear), or an impact slower than the root of that: reached with a speed v, an impact
    penetrates about v^2 / (2 a), a ~ 1, so both are one scale (grazing.graze_site's)."""
    touch, speed = _gaps(problem, orbit)
    scale = grazing.scale(problem, orbit.parameter)
    return touch < proximity * scale or speed ** 2 < proximity * scale


def _graze_site(problem, orbit, proximity=GRAZING_PROXIMITY):
    """grazing.graze_site of an orbit: (side, window) or None."""
    if not _near_grazing(problem, orbit, proximity):
        return None  # no graze near: spare the kernel call
    orbit_map = evaluate(problem, orbit.state, orbit.parameter, orbit.periods)
    if _failure(orbit_map):
        return None
    return grazing.graze_site(problem, orbit_map, orbit.parameter, orbit.periods, proximity)


def _search_directions():
    """The 26 unit vectors towards the neighbours of a cube's centre (any direction is within 35
    degrees of one of them)."""
    directions = []
    for i in (-1, 0, 1):
        for j in (-1, 0, 1):
            for k in (-1, 0, 1):
                if (i, j, k) != (0, 0, 0):
                    directions.append(np.array([i, j, k], dtype=float) / np.sqrt(i * i + j * j + k * k))
    return directions


def switch_at_grazing(problem, graze, tangent):
    """The branch beyond a grazing orbit: (Orbit with another impact count, its tangent) or None.

    Beyond a graze the map has a square-root term, F = A dz + C sqrt(sigma) (sigma the
    penetration), so the continuing branch leaves the grazing point at a corner, in a direction
    tangent to the grazing surface (docs/design.md). It is found by the arclength corrector on
    planes at distance rho from the grazing point, normal to each of 26 directions. Best effort,
    for the grazes grazing.py's normal form does not cover (an orbit with other impacts besides
    the grazing one): Newton started on the wrong side of the graze sees the smooth side's
    Jacobian only; when nothing is found the branch ends with status "grazing".
    """
    for radius in GRAZING_SEARCH_RADII:
        for direction in _search_directions():
            if direction @ tangent < -0.9:
                continue  # straight back along the branch we came on
            z_predicted = graze.z + radius * direction
            orbit, failure = correct(problem, z_predicted, graze.periods, direction, z_predicted)
            if failure is None and orbit.impacts_per_period != graze.impacts_per_period:
                chord = orbit.z - graze.z
                return orbit, tangent_of(orbit, chord / np.linalg.norm(chord))
    return None


# A step is retried shorter where its orbit lies further than this many step lengths from the
# predictor: the branch curves within the step by about twice that in radians, and the corrector
# may have converged onto a part of it that curls back past the predictor's plane, not onto the
# continuation of the arc, where the tangent, oriented by the last one, points back along the
# branch. A switched branch of Fig. 1's six slow periods at g = 17.79869 went from an orbit
# 5e-6 from its doubling to one 1e-4 on (0.78 steps off the predictor), skipping the curl between
# (its multiplier from 0.9 through -0.38 and back to 0.29), turned back there and walked back to
# its doubling, where it ended newton_failed (up to 0.7.3). Across a graze the branch has a
# corner (not checked there).
MAX_DEVIATION = 0.5


def _strays(previous, orbit, z_predicted, step):
    """True when a step between orbits of one impact count lands more than MAX_DEVIATION steps
    from its predictor: too long for the branch's curvature (follow retries it shorter)."""
    if previous.impacts_per_period != orbit.impacts_per_period:
        return False
    return float(np.linalg.norm(orbit.z - z_predicted)) > MAX_DEVIATION * step


def _flips(previous, orbit, tangent):
    """True when a step between orbits of one impact count reverses the null vector of [M - I | F_lam]
    relative to the arc's tangent: along one smooth branch that vector (the cross product of the
    rows, whose parameter component is det(M - I)) turns continuously and keeps its orientation,
    through folds too; it reverses only at a branch point or where the corrector went onto another
    branch (next to Fig. 1's period-12 orbits at g = 17.79326 one lies 2e-6 away with its large
    multiplier of the other sign, -1483 for +1480, and steps of 1e-5 hopped between the two,
    recording an unlocated fold and period doubling at each hop, up to 0.7.3). Only where the fold's
    test function changes sign too (a hop's signature: a fold passed without the parameter turning):
    next to a branch point (a switched branch's birth, the pitchfork) the vector turns fast and its
    orientation says nothing."""
    if previous.impacts_per_period != orbit.impacts_per_period or _fold_test(previous) * _fold_test(orbit) >= 0.0:
        return False
    return float(tangent @ _raw_tangent(previous)) * float(tangent @ _raw_tangent(orbit)) < 0.0


# A located sign change of the fold test is a branch point when [M - I | F_lam] has rank 1 there:
# F_lam lies in the range of M - I (at a fold it does not, and the rank stays 2). Measured as the
# sine of F_lam's angle to that range, |u . F_lam| / |F_lam| with u the left singular vector of
# M - I's smaller singular value: free of the parameter's unit. (Up to 0.7.10 it was the ratio of
# [M - I | F_lam]'s singular values, which F_lam's size sets: a fold in a parameter whose unit
# moves the orbit little, |F_lam| = 1e-3 against |M - I| = 0.5, had the ratio 2e-3 and was taken
# for a branch point.) On the symmetric Duffing oscillator's branch in omega (F = 0.4) the located
# branch point at omega = 1.0689612 has a sine of 7.6e-5 (the old ratio 1.5e-5).
BRANCH_POINT_RANK = 1e-2
BRANCH_POINT = "branch_point"


def _sine_to_range(orbit):
    """How far [M - I | F_lam] is from rank 1: the sine of the angle between F_lam and the range of
    M - I (0: in it, a branch point; a fold's is of order 1). 0 where F_lam = 0 (the parameter
    moves no orbit) or M = I."""
    jump = orbit.monodromy - np.eye(2)
    derivative = np.asarray(orbit.parameter_derivative, dtype=float)
    size = float(np.linalg.norm(derivative))
    left, singular, _ = np.linalg.svd(jump)
    if size == 0.0 or singular[0] == 0.0:
        return 0.0
    return abs(float(left[:, 1] @ derivative)) / size


def _branch_point(problem, previous, orbit, tangent, step, periods):
    """The branch point between ``previous`` and ``orbit`` (a step along which the fold test changes
    sign and the parameter does not turn, _flips): the fold test's root on the arc, located as a
    fold is (to location_tolerance, its multiplier within LOCATED_MULTIPLIER of +1), where
    [M - I | F_lam] has rank 1 (BRANCH_POINT_RANK). None where there is no such point: a hop onto
    another family, whose orbits the arc's corrector meets in turn with no root between them."""
    if previous.impacts_per_period != orbit.impacts_per_period:
        return None
    located = _locate(problem, previous, tangent, step, "fold", _fold_test(previous), _fold_test(orbit), periods,
                      impacts=previous.impacts_per_period)
    if located is None or not _located("fold", located) or _sine_to_range(located) > BRANCH_POINT_RANK:
        return None
    return located


def _raw_tangent(orbit):
    rows = np.zeros((2, 3))
    rows[:, :2] = orbit.monodromy - np.eye(2)
    rows[:, 2] = orbit.parameter_derivative
    return np.cross(rows[0], rows[1])


def _turned_back(previous, orbit, tangent, step):
    """A corrected point that went backwards or far off the predictor: a jump to another branch."""
    chord = orbit.z - previous.z
    return chord @ tangent <= 0.0 or np.linalg.norm(chord) > 3.0 * step


def find_start(problem, initial_state, value, transient_periods, max_period):
    """The orbit reached from ``initial_state`` at ``value``: integrate the transient, detect its
    period p as sweeps do (diagnostics.detect_period) and converge Newton on P^p. Raises
    UsageError for a non-periodic start or one above max_period."""
    settings = np.array(problem.settings, dtype=float)
    settings[kernel.TRANSIENT_PERIODS] = transient_periods
    settings[kernel.MEASURE_PERIODS] = START_STROBE_PERIODS
    run = simulate(problem.coefficients(value), initial_state, settings, method=problem.method, model=problem.model)
    if run.status != Status.OK:
        raise UsageError.naming("the start at {name} = {value} failed to integrate: {status}",
                                  name=problem.parameter, value=f"{value:g}", status=run.status.name.lower())
    strobe = run.period_records[-START_STROBE_PERIODS:]
    period = int(detect_period(strobe[None, :, kernel.REC_X], strobe[None, :, kernel.REC_V],
                               max(max_period, 1), START_PERIOD_TOLERANCE)[0])
    # A forcing that repeats after q slow periods (Omega/omega = p/q) closes orbits only after a
    # multiple of q: P^p of another p is no return map, and its fixed point no orbit.
    forcing = check_commensurate(dict(problem.parameters, **{problem.parameter: value}), problem.model,
                                 problem.parameter, max_period)
    if period and period % forcing:
        period = math.lcm(period, forcing)
        period = period if period <= max_period else 0
    if period == 0:
        raise UsageError.naming(
            "no periodic orbit of at most {limit} {periods} at the start ({name} = {value}): the motion "
            "is chaotic, quasi-periodic, of a longer period or not yet settled; try another start value "
            "({from_key}), a longer transient (integration.transient_periods) or a larger {max_period}",
            {"max_period": "continuation.max_period", "from_key": "continuation.from"},
            limit=max_period, name=problem.parameter, value=f"{value:g}",
            periods="slow periods" if isinstance(problem.model, str) else "periods T")
    state = strobe[-1, [kernel.REC_X, kernel.REC_V]]
    orbit, failure = correct(problem, np.array([state[0], state[1], value]), period)
    if failure:
        raise UsageError.naming("the start orbit of period {period} did not converge at {name} = {value}: "
                                  "{reason}", period=period, name=problem.parameter, value=f"{value:g}",
                                  reason=failure[1])
    return orbit


def continue_branch(problem, start, lo, hi, max_points=None, progress=None):
    """The branch through ``start`` both ways within [lo, hi]. Returns (Branch, [Bifurcation]).

    progress(orbit): called after each orbit; a KeyboardInterrupt it raises (a signal) ends the
    branch there with ENDED_INTERRUPTED at both ends not reached, keeping the orbits followed."""
    max_points = problem.options["max_points"] if max_points is None else max_points
    down, bif_down, end_down = follow(problem, start, -1, lo, hi, max_points // 2, progress)
    if end_down[0] == ENDED_INTERRUPTED:  # stopped: the other way is not followed
        up, bif_up, end_up = [], [], (ENDED_INTERRUPTED, "not followed: the run was stopped before")
    else:
        up, bif_up, end_up = follow(problem, start, +1, lo, hi, max_points - max_points // 2, progress)
    orbits = list(reversed(down)) + [start] + up
    bifurcations = [Bifurcation(kind, orbit) for kind, orbit in bif_down + bif_up]
    bifurcations.sort(key=lambda b: b.orbit.parameter)
    return Branch(periods=start.periods, orbits=orbits, ends={"down": end_down, "up": end_up}), bifurcations


def interrupted(branch) -> bool:
    """Whether a Branch was stopped by a signal (continue_branch's progress) before it ended."""
    return any(end[0] == ENDED_INTERRUPTED for end in branch.ends.values())

