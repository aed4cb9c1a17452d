"""Kinks (abs, max, min) and jumps (sign) of a written acceleration located as events: a step that
crosses one is cut to end on it (kernel._integrate, codegen.switching_functions), and the steps on
either side of the surface hold each switch on one side for all their stages (the frozen mode,
codegen.frozen_acceleration), so the method keeps its order on each smooth side, and R and the
Lyapunov exponent converge with the tolerance.

The references are SciPy's solve_ivp (DOP853, rtol 1e-13) restarted at each crossing of a
switching surface by a terminal event, with its own right-hand side of each side (no max() or
sign() in it), written here.

Located on the GPU too (the same loop, given the model's switch_signs: test_gpu.py).
"""

import math

import numpy as np
import pytest
import sympy
from scipy.integrate import solve_ivp

import vrsweep
from vrsweep.config import parse_config
from vrsweep.numerics import codegen

from reference import forced_with_a_surface

# The bilinear spring: a second spring of stiffness k engages at x = d. Period 1 at these values
# (real Floquet multipliers -0.636 and -0.717: the exponent is not the damping's -zeta).
ZETA, K, D, F, OMEGA = 0.05, 3.0, 0.5, 1.0, 0.8
TRANSIENT, MEASURED = 200, 20
# With a stop out of reach (x <= 1000; the orbit stays below 3): the parameters, in their order,
# and the stop of test_written_models' LINEAR_WITH_A_KINK, so that both compile one kernel (the
# suite's time is mostly compiling). A stop never near changes no step.
BILINEAR = f"""
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)"
  parameters: {{k: {K}, d: {D}, zeta: {ZETA}, F: {F}, omega: {OMEGA}, Delta: 1000.0, r: 0.8}}
  barriers: [{{position: Delta, side: above, restitution: r}}]
  period: "2*pi/omega"
  response: {{frequency: omega, scale: F}}
initial: {{x: 0.0, v: 0.0}}
integration: {{transient_periods: {TRANSIENT}, measure_periods: {MEASURED}}}
"""


def _bilinear_reference():
    """(R over the measured periods, the one-period monodromy matrix at the transient's end).
    Engaged (side +1): -x - k (x - d), stiffness -(1 + k); the variational equation of each side."""
    return forced_with_a_surface(lambda x, side: -x - (K * (x - D) if side > 0 else 0.0),
                                 lambda x, side: -1.0 - (K if side > 0 else 0.0), D,
                                 ZETA, F, OMEGA, TRANSIENT, MEASURED)


def test_the_switching_functions_are_the_arguments_of_each_kink():
    def switches(acceleration):
        model = parse_config(BILINEAR.replace("-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)", acceleration),
                             "m.yaml").model
        acceleration, _, _, _, state = codegen.derived(model)
        return [str(s) for s in codegen.switching_functions(acceleration, state)]

    assert switches("-x - k*max(x - d, 0)") in (["-d + x"], ["d - x"], ["p_d - x"], ["-p_d + x"])
    # abs and sign: their arguments; a surface twice (abs(x), abs(-x), sign(-x)) is one
    assert sorted(switches("-x - k*abs(x)*x - zeta*sign(v) + F*abs(-x) + sign(-x)")) == ["v", "x"]
    # min and max of the state: the difference of their arguments, one surface
    assert len(switches("-x + min(x, v) - max(v, x) + zeta")) == 1
    # a kink in the parameters alone is none in time; a smooth model has none
    assert switches("-x + abs(F)*cos(omega*t) + max(k, d)") == []
    assert switches("-2*zeta*v - x + F*cos(omega*t)") == []


def test_constant_multiples_of_a_switching_function_are_one_surface():
    """A nested max of x + k*v (k = 0..9) has the pair differences -v, -2*v, ..., -9*v: one surface,
    v = 0. Taken as nine, they flipped together, a corner of nine switches at every crossing, and
    codegen spent minutes in sympy on the sides' products (8 arguments: 20 s; now under a second).
    The frozen acceleration holds the side's argument: x + 9v above, x below."""
    nested = "x"
    for k in range(1, 10):
        nested = f"max({nested}, x + {k}*v)"
    model = parse_config(BILINEAR.replace("-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)", nested), "m.yaml").model
    acceleration, _, _, _, state = codegen.derived(model)
    switches = codegen.switching_functions(acceleration, state)
    assert [str(s) for s in switches] in (["v"], ["-v"])
    assert codegen.jump_switches(acceleration, switches, state) == []  # a kink: max is continuous
    frozen, (side,) = codegen.frozen_acceleration(acceleration, switches)
    x, v, _ = state
    above = 1 if str(switches[0]) == "v" else -1  # the side m on which v > 0
    assert sympy.simplify(frozen.subs(side, above) - (x + 9 * v)) == 0
    assert sympy.simplify(frozen.subs(side, -above) - x) == 0
    # a multiple by a number, written otherwise: abs(2*x - 2), sign(1 - x), max(0.5*x, 0.5) are x = 1
    model = parse_config(BILINEAR.replace("-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)",
                                          "-x + abs(2*x - 2) + sign(1 - x) + max(0.5*x, 0.5)"), "m.yaml").model
    acceleration, _, _, _, state = codegen.derived(model)
    assert len(codegen.switching_functions(acceleration, state)) == 1
    # a parameter's multiple is not: k*v and v are one surface only where k != 0, unknown here
    model = parse_config(BILINEAR.replace("-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)",
                                          "-x - sign(k*v) - sign(v)"), "m.yaml").model
    acceleration, _, _, _, state = codegen.derived(model)
    assert len(codegen.switching_functions(acceleration, state)) == 2


def test_a_bilinear_springs_response_converges_with_the_tolerance():
    """Stepped over, the kink left R 1.5e-6 off at rtol 1e-6 (rk45; the orbit not even found
    periodic, period 0) and 1.5e-10 at 1e-10, R_err 2.1e-6 and 2.6e-10 covering neither; located,
    1.5e-8 and 3.6e-12: of the order of rtol, as a smooth model's; with the frozen mode (0.7.5)
    2.5e-8 and 3.6e-12 in 11877 and 61469 steps (16239 and 70276 before: the stages no longer
    straddle the kink, so fewer steps are rejected at it). (dop853: 1.2e-7 and 9.0e-12 stepped
    over, 4.8e-9 and 1.0e-12 located (0.7.4) in 11885 and 19326 steps, 3.3e-8 and 1.9e-12 in 4411
    and 10566 steps frozen; not compiled here, for the suite's time.)"""
    R_reference, monodromy = _bilinear_reference()
    period = 2 * math.pi / OMEGA
    # the reference's own check: the damping's Liouville determinant exp(-2 zeta T)
    assert np.linalg.det(monodromy) == pytest.approx(math.exp(-2 * ZETA * period), rel=1e-10)
    for rtol, bound in ((1e-6, 1e-7), (1e-10, 3e-11)):
        result = vrsweep.sweep(BILINEAR, rtol=rtol, atol=rtol * 1e-2, progress=False)
        assert int(result.period) == 1
        assert abs(float(result.R) - R_reference) < bound, (rtol, float(result.R) - R_reference)


def test_a_bilinear_springs_lyapunov_exponent_converges_with_the_tolerance():
    """The tangent vectors see each step's side of the kink (the frozen mode's Jacobian), not the
    side rounding puts a step's first and last stages at: the Jacobian jumps by k there, and one
    stage on the wrong side is an error of k times the step. lambda_1 scattered by about 1e-6 at
    any rtol (4.9e-6 at 1e-8, 1.1e-6 at 1e-10, rk45); now 1.6e-9 and 6.2e-12. The reference is
    the period-1 orbit's largest Floquet multiplier, log|mu_1| / T, from SciPy's monodromy."""
    _, monodromy = _bilinear_reference()
    period = 2 * math.pi / OMEGA
    exponent = math.log(max(abs(np.linalg.eigvals(monodromy)))) / period
    for rtol, bound in ((1e-8, 2e-8), (1e-10, 3e-11)):
        result = vrsweep.sweep(BILINEAR, rtol=rtol, atol=rtol * 1e-2, lyapunov=True, progress=False)
        assert abs(float(result.lyapunov) - exponent) < bound, (rtol, float(result.lyapunov) - exponent)


# Coulomb friction on the forced linear oscillator: a jump of the force at v = 0. At mu = 0.1 the
# force -x + F cos(omega t) at every turning point exceeds mu: the mass never sticks, and each
# crossing of v = 0 is transversal.
MU = 0.1


def friction_config(zeta=ZETA, mu=MU, F=F, omega=OMEGA, transient_periods=50):
    """The friction oscillator's config (test_written_saltation's too)."""
    return f"""
model:
  acceleration: "-2*zeta*v - x - mu*sign(v) + F*cos(omega*t)"
  parameters: {{zeta: {zeta}, mu: {mu}, F: {F}, omega: {omega}}}
  period: "2*pi/omega"
  response: {{frequency: omega, scale: F}}
initial: {{x: 0.0, v: 0.3}}
integration: {{transient_periods: {transient_periods}, measure_periods: 20}}
"""


FRICTION = friction_config()


def _friction_reference():
    """R over the 20 measured periods: SciPy with a terminal event at v = 0, restarted there with
    the other side's force (the side the force at v = 0 pushes the mass to)."""
    period = 2 * math.pi / OMEGA

    def rhs(t, y, side):
        x, v = y[0], y[1]
        return [v, -2 * ZETA * v - x - MU * side + F * math.cos(OMEGA * t), x * math.sin(OMEGA * t),
                x * math.cos(OMEGA * t)]

    def run(t, t_end, y):
        while t < t_end:
            side = 1.0 if y[1] > 0 else -1.0
            if y[1] == 0.0:  # on the surface: the side the force at rest pushes to (no sliding here)
                pull = -y[0] + F * math.cos(OMEGA * t)
                assert abs(pull) > MU, "the reference does not slide"
                side = math.copysign(1.0, pull)
            event = lambda t, y, side: y[1]  # noqa: E731
            event.terminal = True
            event.direction = -side
            solution = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-13, atol=1e-15, events=event,
                                 args=(side,))
            if solution.status == 1:
                t, y = solution.t_events[0][0], solution.y_events[0][0].copy()
                y[1] = 0.0
            else:
                t, y = solution.t[-1], solution.y[:, -1].copy()
        return y

    y = run(0.0, 50 * period, np.array([0.0, 0.3, 0.0, 0.0]))
    y[2:] = 0.0
    end = run(50 * period, 70 * period, y)
    window = 20 * period
    return math.hypot(2 * end[2] / window, 2 * end[3] / window) / F


def test_friction_is_integrated_as_a_smooth_oscillator_is():
    """Stepped over (0.7.4), each jump of -mu*sign(v) cost the controller a cascade of rejected
    steps creeping up to it: 8995 steps at rtol 1e-6 where the same oscillator without friction
    takes 3038. Located, the step that ends on v = 0 and the one that leaves it each evaluate one
    side's force (the frozen mode): 3225 steps, and R converges with rtol as a smooth model's
    does, against SciPy restarted at each v = 0 (rk45: 4.8e-7 at rtol 1e-6, 3.4e-11 at 1e-10; the
    oscillator without friction is itself 3.3e-7 and 1.6e-11 off)."""
    smooth = vrsweep.sweep(FRICTION, mu=0.0, rtol=1e-6, atol=1e-8, progress=False)
    result = vrsweep.sweep(FRICTION, rtol=1e-6, atol=1e-8, progress=False)
    assert int(result.status) == 0 and int(result.period) == 1
    assert int(result.n_steps) < 1.2 * int(smooth.n_steps), (int(result.n_steps), int(smooth.n_steps))
    R_reference = _friction_reference()
    errors = []
    for rtol in (1e-6, 1e-10):
        result = vrsweep.sweep(FRICTION, rtol=rtol, atol=rtol * 1e-2, progress=False)
        errors.append(abs(float(result.R) - R_reference))
    assert errors[0] < 1e-6 and errors[1] < 1e-10, errors
    assert errors[1] < 1e-3 * errors[0], errors  # converging with rtol


def test_a_sliding_motion_on_a_jump_is_followed_on_v_equal_c_and_a_status_elsewhere():
    """Where the force at v = 0 is weaker than mu, friction's field points into v = 0 from both
    sides: the mass sticks (a Filippov sliding motion). It ran to max_steps (20 million steps at the
    default budget), or through millions of steps chattering across v = 0; 0.7.5 ended it `sliding`
    at its first sticking; since 0.7.7 the kernel follows it on a surface v = c, c a constant
    (tests/test_written_sliding.py checks it against SciPy): at mu = 2 > F the mass stops for good.
    On any other surface, such as sliding-mode control's x + v = 0, the point still ends `sliding`,
    in a few dozen steps."""
    from vrsweep.results import Status

    for mu in (0.5, 2.0):
        result = vrsweep.sweep(FRICTION, mu=mu, max_steps=200000, progress=False)
        assert int(result.status) == Status.OK, (mu, int(result.status))
        if mu == 2.0:  # (at mu = 0.5 the mass sticks in the transient only)
            assert float(result.stuck_fraction) > 0.99, float(result.stuck_fraction)
    with pytest.warns(RuntimeWarning, match="sliding"):
        result = vrsweep.sweep(FRICTION.replace("mu*sign(v)", "mu*sign(x + v)"), mu=2.0, max_steps=200000,
                               progress=False)
    assert int(result.status) == Status.SLIDING, int(result.status)
    assert int(result.n_steps) < 1000


# A spring with a clearance, stiffened beyond |x| = d on both sides (two kinks: max and min), in a
# gap between two stops at -Delta and Delta: period 1 at F = 1.5, an impact on each stop a period.
CLEARANCE = dict(zeta=0.05, k=3.0, d=0.5, F=1.5, omega=0.8, Delta=1.0, r=0.8)
TWO_SIDED = """
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0) - k*min(x + d, 0) + F*cos(omega*t)"
  parameters: {zeta: 0.05, k: 3.0, d: 0.5, F: 1.5, omega: 0.8, Delta: 1.0, r: 0.8}
  barriers: [{position: Delta, side: above, restitution: r}, {position: -Delta, side: below, restitution: r}]
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
integration: {transient_periods: 150, measure_periods: 20}
"""


def _two_sided_reference():
    """(R over the 20 measured periods, impacts per period): SciPy with terminal events at the
    kinks x = d and x = -d (restarted with the other region's spring) and at the stops (v -> -r v)."""
    zeta, k, d, F_, omega, delta, r = (CLEARANCE[name] for name in ("zeta", "k", "d", "F", "omega", "Delta", "r"))
    period = 2 * math.pi / omega

    def rhs(t, y, region):
        x, v = y[0], y[1]
        spring = -x - (k * (x - d) if region > 0 else (k * (x + d) if region < 0 else 0.0))
        return [v, -2 * zeta * v + spring + F_ * math.cos(omega * t), x * math.sin(omega * t),
                x * math.cos(omega * t)]

    # the surfaces that bound each region (beyond d, beyond -d, between) and the way out of it
    bounds = {1: ((d, -1), (delta, 1)), -1: ((-d, 1), (-delta, -1)), 0: ((d, 1), (-d, -1))}
    counted = [0]

    def run(t, t_end, y):
        while t < t_end:
            x, v = y[0], y[1]
            region = 1 if (x > d or (x == d and v > 0)) else (-1 if (x < -d or (x == -d and v < 0)) else 0)
            events = []
            for level, direction in bounds[region]:
                event = (lambda level: lambda t, y, region: y[0] - level)(level)
                event.terminal = True
                event.direction = direction
                events.append(event)
            solution = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-13, atol=1e-15, events=events,
                                 args=(region,))
            if solution.status == 1:
                which = min((times[0], i) for i, times in enumerate(solution.t_events) if len(times))[1]
                t, y = solution.t_events[which][0], solution.y_events[which][0].copy()
                y[0] = bounds[region][which][0]
                if abs(y[0]) == delta:
                    y[1] = -r * y[1]
                    counted[0] += 1
            else:
                t, y = solution.t[-1], solution.y[:, -1].copy()
        return y

    y = run(0.0, 150 * period, np.zeros(4))
    y[2:] = 0.0
    counted[0] = 0
    end = run(150 * period, 170 * period, y)
    window = 20 * period
    return math.hypot(2 * end[2] / window, 2 * end[3] / window) / F_, counted[0] / 20


def test_two_stops_and_two_kinks_agree_with_scipy():
    """Kinks and impacts on both sides in one orbit: R, the impacts per period and both stops
    reached, against SciPy with events at the kinks and the stops (rk45: 2.6e-8 at rtol 1e-6,
    1.0e-11 at 1e-10)."""
    R_reference, impacts = _two_sided_reference()
    assert impacts == 2.0
    for rtol, bound in ((1e-6, 2e-7), (1e-10, 5e-11)):
        result = vrsweep.sweep(TWO_SIDED, rtol=rtol, atol=rtol * 1e-2, progress=False)
        assert int(result.status) == 0 and int(result.period) == 1
        assert float(result.impacts_per_period) == impacts
        assert float(result.x_max) == CLEARANCE["Delta"] and float(result.x_min) == -CLEARANCE["Delta"]
        assert abs(float(result.R) - R_reference) < bound, (rtol, float(result.R) - R_reference)
