"""Kinks of a written acceleration (abs, max, min, sign) located as events: a step that crosses one
is cut to end on it (kernel._integrate, codegen.switching_functions), so the method keeps its order
on each smooth side and R and the Lyapunov exponent converge with the tolerance.

The reference is SciPy's solve_ivp (DOP853, rtol 1e-13) restarted at each crossing of the kink by
a terminal event, with its own right-hand side of each side (no max() in it), written here.

Located on the GPU too (the same loop, given the model's switch_signs: test_gpu.py). Not yet
located: the jumps of sign (see codegen.switching_functions: located so, friction's R got worse). And the tangent vectors still
see the kink's side at a step's first and last stages by rounding (the Jacobian jumps there even
where the acceleration is continuous): lambda_1 of the spring below scatters by ~1e-6 at any rtol
(it did before too), within its lyapunov_err at rtol 1e-10, not always at 1e-9.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import vrsweep
from vrsweep.config import parse_config
from vrsweep.numerics import codegen

# The bilinear spring: a second spring of stiffness k engages at x = d. Period 1 at these values
# (real Floquet multipliers -0.636 and -0.717: the exponent is not the damping's -zeta).
ZETA, K, D, F, OMEGA = 0.05, 3.0, 0.5, 1.0, 0.8
TRANSIENT, MEASURED = 200, 20
BILINEAR = f"""
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)"
  parameters: {{zeta: {ZETA}, k: {K}, d: {D}, F: {F}, omega: {OMEGA}}}
  period: "2*pi/omega"
  response: {{frequency: omega, scale: F}}
initial: {{x: 0.0, v: 0.0}}
integration: {{transient_periods: {TRANSIENT}, measure_periods: {MEASURED}}}
"""


def _bilinear_reference(tangents=False):
    """(R over the measured periods, the one-period monodromy matrix at the transient's end)."""
    period = 2 * math.pi / OMEGA

    def rhs(t, y, engaged):
        x, v = y[0], y[1]
        stiffness = 1.0 + (K if engaged else 0.0)
        spring = K * D if engaged else 0.0  # -x - k (x - d) = -(1 + k) x + k d
        out = [v, -2 * ZETA * v - stiffness * x + spring + F * math.cos(OMEGA * t),
               x * math.sin(OMEGA * t), x * math.cos(OMEGA * t)]
        for column in range(2):  # the variational equation of each side, continuous across
            dx, dv = y[4 + 2 * column], y[5 + 2 * column]
            out += [dv, -stiffness * dx - 2 * ZETA * dv]
        return out

    def run(t, t_end, y):
        while t < t_end:
            engaged = y[0] > D or (y[0] == D and y[1] > 0)
            event = lambda t, y, engaged: y[0] - D  # noqa: E731
            event.terminal = True
            event.direction = -1 if engaged else 1
            solution = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-13, atol=1e-15, events=event,
                                 args=(engaged,))
            if solution.status == 1:
                t, y = solution.t_events[0][0], solution.y_events[0][0].copy()
                y[0] = D
            else:
                t, y = solution.t[-1], solution.y[:, -1].copy()
        return y

    start = np.array([0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0])
    y = run(0.0, TRANSIENT * period, start)
    y[2:4] = 0.0
    y[4:] = [1.0, 0.0, 0.0, 1.0]
    after_one = run(TRANSIENT * period, (TRANSIENT + 1) * period, y.copy())
    monodromy = np.array([[after_one[4], after_one[6]], [after_one[5], after_one[7]]])
    end = run(TRANSIENT * period, (TRANSIENT + MEASURED) * period, y)
    window = MEASURED * period
    R = math.hypot(2 * end[2] / window, 2 * end[3] / window) / F
    return R, monodromy


def test_the_switching_functions_are_the_arguments_of_each_kink():
    def switches(acceleration):
        model = parse_config(BILINEAR.replace("-2*zeta*v - x - k*max(x - d, 0) + F*cos(omega*t)", acceleration),
                             "m.yaml").model
        acceleration, _, _, _, state = codegen.derived(model)
        return [str(s) for s in codegen.switching_functions(acceleration, state)]

    assert switches("-x - k*max(x - d, 0)") in (["-d + x"], ["d - x"], ["p_d - x"], ["-p_d + x"])
    # abs: its argument; a surface twice (abs(x), abs(-x)) is one; sign's jump is not located
    assert switches("-x - k*abs(x)*x - zeta*sign(v) + F*abs(-x)") == ["x"]
    # min and max of the state: the difference of their arguments, one surface
    assert len(switches("-x + min(x, v) - max(v, x) + zeta")) == 1
    # a kink in the parameters alone is none in time; a smooth model has none
    assert switches("-x + abs(F)*cos(omega*t) + max(k, d)") == []
    assert switches("-2*zeta*v - x + F*cos(omega*t)") == []


def test_a_bilinear_springs_response_converges_with_the_tolerance():
    """Stepped over, the kink left R 1.5e-6 off at rtol 1e-6 (rk45; the orbit not even found
    periodic, period 0) and 1.5e-10 at 1e-10, R_err 2.1e-6 and 2.6e-10 covering neither; located,
    1.5e-8 and 3.6e-12: of the order of rtol, as a smooth model's. (dop853: 1.2e-7 and 9.0e-12
    before, 4.8e-9 and 1.0e-12 now; not compiled here, for the suite's time.)"""
    R_reference, monodromy = _bilinear_reference()
    period = 2 * math.pi / OMEGA
    # the reference's own check: the damping's Liouville determinant exp(-2 zeta T)
    assert np.linalg.det(monodromy) == pytest.approx(math.exp(-2 * ZETA * period), rel=1e-10)
    for rtol, bound in ((1e-6, 1e-7), (1e-10, 3e-11)):
        result = vrsweep.sweep(BILINEAR, rtol=rtol, atol=rtol * 1e-2, progress=False)
        assert int(result.period) == 1
        assert abs(float(result.R) - R_reference) < bound, (rtol, float(result.R) - R_reference)
