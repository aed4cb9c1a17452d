"""The tangent vectors jump where a written model's force jumps (sign): the saltation matrix of a
transversal crossing of a switching surface h(t, x, v) = 0,

    S = I + (f+ - f-) grad h^T / (grad h . f- + dh/dt),      f+- = (v, a+-),

applied where a step ends on the surface (kernel._integrate; codegen.switch_saltation derives
grad h and dh/dt with sympy; tangent.apply_switch_saltation). At a kink (abs, min, max: the force
is continuous) S = I.

The reference is SciPy's solve_ivp (DOP853, rtol 1e-13) restarted at each v = 0 by a terminal
event with the other side's force, carrying the variational equations of each side and applying,
at each crossing, the jump written here for h = v: dv += (a+ - a-) dv / a-. Its monodromy matrix
is checked against finite differences of the same map, which need no saltation formula at all.
"""

import math

import numpy as np
import pytest
import sympy
from scipy.integrate import solve_ivp
from test_written_kinks import friction_config

import vrsweep
from vrsweep.config import parse_config
from vrsweep.config.grid import Grid
from vrsweep.execution.sweep import integration_settings
from vrsweep.numerics import codegen, kernel
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.shooting import periodic_map
from vrsweep.results import Status

# Coulomb friction on the forced linear oscillator (tests/test_written_kinks.py's): at mu = 0.1 the
# force -x + F cos(omega t) at every turning point exceeds mu, so the mass never sticks and each
# crossing of v = 0 is transversal. Period 1; its multipliers are a complex pair of modulus 0.599
# (0.675 without the saltation matrices: the damping's exp(-zeta T) alone).
ZETA, MU, F, OMEGA = 0.05, 0.1, 1.0, 0.8
# A relay in x, -b*sign(x - d): a jump across a surface in x (grad h = (1, 0), S's term (a+ - a-) dx / v).
# Period 1, crossing x = d at speeds 1.70 and -1.71; det S = 1 there (the rate v is the same on both
# sides), so its multipliers' modulus is the damping's, but not the matrix: the trace is -0.290
# with the saltation matrices, 0.013 without.
B, D = 0.2, 0.3
PERIOD = 2 * math.pi / OMEGA
TRANSIENT = 200
FRICTION = friction_config(ZETA, MU, F, OMEGA, TRANSIENT)
RELAY = (FRICTION.replace("mu*sign(v)", "b*sign(x - d)")
         .replace(f"mu: {MU}", f"b: {B}, d: {D}"))
# Each model's surface h(x, v), its gradient (dh/dx, dh/dv; dh/dt = 0) and its force's side's constant:
# the test's own, for the reference's events and saltation matrices.
SURFACES = {
    "friction": (FRICTION, lambda x, v: v, (0.0, 1.0), MU),
    "relay": (RELAY, lambda x, v: x - D, (1.0, 0.0), B),
}


def _acceleration(t, x, v, side, jump):
    return -2 * ZETA * v - x - jump * side + F * math.cos(OMEGA * t)


def _rhs(t, y, side, jump):
    out = [y[1], _acceleration(t, y[0], y[1], side, jump)]
    for column in range(2):  # each side's variational equation: the jumping force is constant on it
        dx, dv = y[2 + 2 * column], y[3 + 2 * column]
        out += [dv, -dx - 2 * ZETA * dv]
    return out


def _run(case, t, t_end, y, saltation=True):
    """SciPy from (t, y) to t_end, y = (x, v, two tangent vectors), restarted at each crossing of
    the case's surface with the other side's force, each tangent vector jumped there by
    S = I + (f+ - f-) grad h^T / (grad h . f-), f+ - f- = (0, a+ - a-)."""
    _, surface, (h_x, h_v), jump = SURFACES[case]
    y = np.array(y, dtype=float)
    while t < t_end:
        h = surface(y[0], y[1])
        if h != 0.0:
            side = math.copysign(1.0, h)
        else:  # on the surface: the side both sides' fields head to (no sliding here)
            rates = [h_x * y[1] + h_v * _acceleration(t, y[0], y[1], side, jump) for side in (1.0, -1.0)]
            assert rates[0] * rates[1] > 0, "the reference does not slide"
            side = math.copysign(1.0, rates[0])
        event = lambda t, y, side, jump: surface(y[0], y[1])  # noqa: E731
        event.terminal = True
        event.direction = -side
        solution = solve_ivp(_rhs, (t, t_end), y, method="DOP853", rtol=1e-13, atol=1e-15, events=event,
                             args=(side, jump))
        if solution.status == 1:
            t, y = solution.t_events[0][0], solution.y_events[0][0].copy()
            if h_v:
                y[1] = 0.0
            else:
                y[0] = D
            if saltation:
                before = _acceleration(t, y[0], y[1], side, jump)
                after = _acceleration(t, y[0], y[1], -side, jump)
                rate = h_x * y[1] + h_v * before
                for column in range(2):
                    dx, dv = y[2 + 2 * column], y[3 + 2 * column]
                    y[3 + 2 * column] = dv + (after - before) * (h_x * dx + h_v * dv) / rate
        else:
            t, y = solution.t[-1], solution.y[:, -1].copy()
    return y


@pytest.fixture(scope="module", params=list(SURFACES))
def reference(request):
    """(case, the periodic orbit's state at t = nT, its monodromy matrix, the same without saltation)."""
    case = request.param
    start = _run(case, 0.0, TRANSIENT * PERIOD, [0.0, 0.3, 1.0, 0.0, 0.0, 1.0])[:2]

    def monodromy(saltation):
        end = _run(case, 0.0, PERIOD, [*start, 1.0, 0.0, 0.0, 1.0], saltation)
        assert np.all(np.abs(end[:2] - start) < 1e-11)  # periodic
        return np.array([[end[2], end[4]], [end[3], end[5]]])

    return case, start, monodromy(True), monodromy(False)


def _exponent(monodromy):
    return math.log(max(abs(np.linalg.eigvals(monodromy)))) / PERIOD


def test_the_references_saltation_is_the_derivative_of_its_map(reference):
    """The test's own check of its formula: central differences of the map of one period (no
    tangent vectors), 1e-6 apart, give the monodromy with saltation, not the one without."""
    case, start, monodromy, without = reference
    step = 1e-6
    columns = []
    for j in range(2):
        up, down = start.copy(), start.copy()
        up[j] += step
        down[j] -= step
        columns.append((_run(case, 0.0, PERIOD, [*up, 1, 0, 0, 1])[:2]
                        - _run(case, 0.0, PERIOD, [*down, 1, 0, 0, 1])[:2]) / (2 * step))
    differences = np.array(columns).T
    assert np.max(np.abs(differences - monodromy)) < 1e-7
    assert np.max(np.abs(differences - without)) > 1e-2


def test_which_switches_make_the_force_jump():
    """A jump needs a saltation matrix, a kink none: decided symbolically, on the surface."""
    x, v, t = sympy.symbols("x v t", real=True)
    d, k, mu, F_, w = sympy.symbols("p_d p_k p_mu p_F p_omega", real=True)

    def jumps(acceleration):
        switches = codegen.switching_functions(acceleration, (x, v, t))
        return sorted(str(switches[j]) for j in codegen.jump_switches(acceleration, switches, (x, v, t)))

    assert jumps(-x - mu * sympy.sign(v)) == ["v"]
    assert jumps(-x - mu * sympy.Abs(v) / v) == ["v"]  # a jump built from abs
    assert jumps(-x - k * sympy.Max(x - d, 0)) == []  # kinks: the force is continuous
    assert jumps(-x - k * v * sympy.sign(v) - k * sympy.Abs(sympy.Abs(x) - d)) == []
    assert jumps(-x - mu * sympy.sign(x**2 - d) - k * sympy.Max(sympy.Abs(x) - d, 0)) == ["-p_d + x**2"]
    assert jumps(-x - mu * sympy.Abs(x) * sympy.sign(v)) == ["v"]  # a jump but where x = 0
    assert jumps(-x - mu * sympy.sign(v - F_ * sympy.cos(w * t))) in (["-p_F*cos(p_omega*t) + v"],
                                                                       ["p_F*cos(p_omega*t) - v"])


def test_the_gradient_of_a_moving_surface_is_derived():
    """h = v - F cos(w t): dh/dt = F w sin(w t), in the generated code (no derivative by hand)."""
    model = parse_config(FRICTION.replace("sign(v)", "sign(v - F*cos(omega*t))"), "m.yaml").model
    text = codegen.source(model)
    body = text[text.index("def switch_saltation"):text.index("def barrier_force")]
    assert "dh_dt = p_F*p_omega*math.sin(p_omega*t)" in body
    smooth = codegen.source(parse_config(FRICTION.replace("mu*sign(v)", "mu*max(x, 0)"), "m.yaml").model)
    body = smooth[smooth.index("def switch_saltation"):smooth.index("def barrier_force")]
    assert "return False" in body and "apply_switch_saltation" not in body  # a kink: S = I


def test_the_monodromy_matrix_holds_each_crossings_saltation(reference):
    """The kernel's one-period tangent map (continuation's) at the reference's periodic point:
    without the saltation matrices (0.7.5) it was SciPy's map without them (to 7.6e-9 at rtol
    1e-8), 0.073 off in its entries for friction, 0.17 for the relay; now friction's is 7.1e-9 off
    at rtol 1e-8 and 7.0e-11 at 1e-10 (rk45; dop853: 1.3e-9 and 2.1e-11), the relay's 9.0e-9 and
    8.5e-11 (dop853: 5.1e-9 and 7.5e-11)."""
    case, start, monodromy, without = reference
    config = parse_config(SURFACES[case][0], "m.yaml")
    grid = Grid.from_config(config)
    coefficients = kernels_for(config.model).coefficients(grid.parameters_at(config, np.arange(1)))[0]
    errors = []
    for rtol in (1e-8, 1e-10):
        settings = integration_settings(config.integration)
        settings[kernel.RTOL], settings[kernel.ATOL] = rtol, rtol * 1e-2
        orbit = periodic_map(coefficients, start, settings, 1, model=config.model)
        assert orbit.status == Status.OK
        errors.append(np.max(np.abs(orbit.monodromy - monodromy)))
    assert errors[0] < 3e-8 and errors[1] < 3e-10, errors
    assert errors[1] < 1e-1 * errors[0], errors  # converging with rtol


def test_the_lyapunov_exponent_agrees_with_scipy(reference):
    """lambda_1 = log|mu_1| / T of the period-1 orbit: friction's -0.065237. Without the saltation
    matrices (0.7.5) the kernel gave the damping's -zeta, -0.0500000015 at rtol 1e-8: 1.5e-2 off
    at any rtol; now 1.5e-9 at rtol 1e-8 and 1.4e-11 at 1e-10 (rk45, in the same 23144 and 55242
    steps; dop853: 1.3e-10 and 2.1e-12). The relay's is the damping's with them or without (det S
    = 1): 1.6e-9 and 1.5e-11 (rk45; dop853: 3.2e-10 and 6.2e-12)."""
    case, _, monodromy, without = reference
    exponent = _exponent(monodromy)
    if case == "friction":
        assert abs(_exponent(without) - exponent) > 1e-2  # the saltation matters at this point
    errors = []
    for rtol in (1e-8, 1e-10):
        result = vrsweep.sweep(SURFACES[case][0], rtol=rtol, atol=rtol * 1e-2, lyapunov=True, progress=False)
        assert int(result.status) == Status.OK and int(result.period) == 1
        errors.append(abs(float(result.lyapunov) - exponent))
    assert errors[0] < 1e-8 and errors[1] < 1e-10, errors
    assert errors[1] < 1e-1 * errors[0], errors  # converging with rtol
