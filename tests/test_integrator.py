"""The Runge-Kutta steps on their own (integrator.py, dop853.py): their order of convergence.

On the undamped linear oscillator x'' = -x from (x, v) = (1, 0), whose solution is
(cos t, -sin t), a method of order p run at a fixed step h has a global error C h^p: the slope
of log(error) against log(h) is p. The slopes are fitted by least squares over step sizes where
the error is far above rounding (1e-15 times the number of steps) and the leading term
dominates; the margin, 0.3, is well under the 1 that separates order p from p - 1 or p + 1, so a
wrong tableau entry (which drops the order to 1-4) fails. The same for the continuous
extensions over one step: local error at theta = 1/2 of order q + 1 for an extension of order q.
"""

import numpy as np
import pytest
from numba import njit

from vrsweep.numerics import dop853
from vrsweep.numerics import rk45 as integrator

SLOPE_MARGIN = 0.3
T_END = 4.0  # not a multiple of the period 2 pi: no error cancels by symmetry


@njit
def oscillator(t, h, node, c, y, coefficients, dydt, scratch):
    """rhs(t, h, node, c, y, coefficients, dydt, scratch) of x'' = -k x, k = coefficients[0]."""
    dydt[0] = y[1]
    dydt[1] = -coefficients[0] * y[0]


@njit
def fixed_steps(step, n_stages, y0, t_end, n_steps):
    """(x, v) at t_end after n_steps steps of size t_end / n_steps; FSAL: f of the next step is
    the step's last row K[n_stages]."""
    h = t_end / n_steps
    coefficients = np.array([1.0])
    scratch = np.empty(1)
    y = y0.copy()
    f = np.empty(2)
    oscillator(0.0, h, -1, 0.0, y, coefficients, f, scratch)
    K = np.empty((dop853.N_STAGES_EXTENDED, 2))  # room for either method's stages
    y_new = np.empty(2)
    stage = np.empty(2)
    for i in range(n_steps):
        step(oscillator, i * h, y, f, h, coefficients, K, y_new, stage, scratch)
        y[:] = y_new
        f[:] = K[n_stages]
    return y


@njit
def one_step_dense_value(step, dense_output, dense_order, y0, h, theta):
    """(x, v) of the continuous extension of one step of size h from t = 0, at t = theta h."""
    coefficients = np.array([1.0])
    scratch = np.empty(1)
    y = y0.copy()
    f = np.empty(2)
    oscillator(0.0, h, -1, 0.0, y, coefficients, f, scratch)
    K = np.empty((dop853.N_STAGES_EXTENDED, 2))
    y_new = np.empty(2)
    stage = np.empty(2)
    dense = np.empty((2, dense_order))
    step(oscillator, 0.0, y, f, h, coefficients, K, y_new, stage, scratch)
    dense_output(oscillator, 0.0, y, h, coefficients, K, y_new, dense, stage, scratch)
    return integrator.dense_value(dense, y, h, theta, 0), integrator.dense_value(dense, y, h, theta, 1)


def fitted_slope(step_sizes, errors):
    """Least-squares slope of log(error) against log(h)."""
    return np.polyfit(np.log(step_sizes), np.log(errors), 1)[0]


METHODS = {
    # name: (step, stages before FSAL, order, step counts over T_END, dense output, its degree)
    "dp54": (integrator.dp54_step, integrator.N_STAGES, integrator.ORDER, (16, 32, 64, 128),
             integrator.dp54_dense, integrator.DENSE_ORDER),
    "dop853": (dop853.dop853_step, dop853.N_STAGES, dop853.ORDER, (4, 8, 16),
               dop853.dop853_dense, dop853.DENSE_ORDER),
}


@pytest.mark.parametrize("method", METHODS)
def test_the_global_error_falls_as_h_to_the_order(method):
    step, n_stages, order, step_counts, _, _ = METHODS[method]
    y0 = np.array([1.0, 0.0])
    exact = np.array([np.cos(T_END), -np.sin(T_END)])
    errors = [np.max(np.abs(fixed_steps(step, n_stages, y0, T_END, n) - exact)) for n in step_counts]
    assert min(errors) > 1e-15 * max(step_counts) * 100, errors  # far above rounding
    slope = fitted_slope(T_END / np.array(step_counts), errors)
    assert abs(slope - order) < SLOPE_MARGIN, (slope, errors)


@pytest.mark.parametrize("method, step_sizes", [("dp54", (0.5, 0.25, 0.125, 0.0625)),
                                                 ("dop853", (1.0, 0.5, 0.25))])
def test_the_dense_output_error_over_one_step_falls_as_h_to_its_degree_plus_one(method, step_sizes):
    step, _, _, _, dense_output, dense_order = METHODS[method]
    y0 = np.array([1.0, 0.0])
    errors = []
    for h in step_sizes:
        x, v = one_step_dense_value(step, dense_output, dense_order, y0, h, 0.5)
        errors.append(max(abs(x - np.cos(h / 2)), abs(v + np.sin(h / 2))))
    assert min(errors) > 1e-13, errors
    slope = fitted_slope(np.array(step_sizes), errors)
    assert abs(slope - (dense_order + 1)) < SLOPE_MARGIN, (slope, errors)


@pytest.mark.parametrize("method", METHODS)
def test_a_step_is_exact_on_a_polynomial_of_the_methods_order(method):
    """x' = v, v' = t^(p-1): x and v are polynomials of degree p + 1 and p in t; a method of
    order p integrates v exactly (its quadrature is exact for degree p - 1 integrands)."""
    step, n_stages, order, _, _, _ = METHODS[method]

    @njit
    def power_of_t(t, h, node, c, y, coefficients, dydt, scratch):
        dydt[0] = y[1]
        dydt[1] = (t + c * h) ** (order - 1) if node >= 0 else t ** (order - 1)

    @njit
    def one_step(h):
        y = np.array([0.0, 0.0])
        f = np.empty(2)
        coefficients = np.empty(0)
        scratch = np.empty(1)
        power_of_t(0.0, h, 0, 0.0, y, coefficients, f, scratch)
        K = np.empty((dop853.N_STAGES_EXTENDED, 2))
        y_new = np.empty(2)
        stage = np.empty(2)
        step(power_of_t, 0.0, y, f, h, coefficients, K, y_new, stage, scratch)
        return y_new

    h = 0.75
    v = one_step(h)[1]
    assert v == pytest.approx(h ** order / order, rel=1e-14, abs=0)
