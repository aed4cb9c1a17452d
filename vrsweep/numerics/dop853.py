"""DOP853 (Hairer's Dormand-Prince 8(5,3)): one step, error norm, step control, dense output.

The same interface as the DP5(4) functions of integrator.py, so that kernel.py runs either:

    dop853_step(rhs, t, y, f, h, coefficients, K, y_new, stage, scratch)     12 stages + FSAL
    dop853_error_norm(K, h, y, y_new, rtol, atol)                   Hairer's 5th/3rd-order blend
    dop853_dense(rhs, t, y, h, coefficients, K, y_new, dense, stage, scratch) -> extra RHS evaluations

Shapes: K (N_STAGES_EXTENDED, n): rows 0..11 the stages, row 12 = f(t + h, y_new) (first same as
last), rows 13..15 the three extra stages of the dense output, computed only when a step needs
dense output (an impact, a turning point, a sample). dense (n, DENSE_ORDER) holds the 7th-order
continuous extension in the power basis that integrator.dense_value evaluates,
y(t + theta h) = y + h theta sum_q dense[q] theta^q, so the impact and observer code is shared.

Modelled on scipy/integrate/_ivp/rk.py (class DOP853); coefficients in dop853_coefficients.py.
"""

import math

import numpy as np

from vrsweep.numerics.dop853_coefficients import A, C, D, E3, E5, N_STAGES, N_STAGES_EXTENDED
from vrsweep.numerics.rk45 import (
    ERR_PREVIOUS_FLOOR, MAX_FACTOR, MIN_FACTOR, N_CONTROLLED, N_DYNAMIC, N_INTERPOLATED, PI_BETA, SAFETY,
    growth_is_certain, growth_thresholds,
)
from vrsweep.numerics.jit import kernel_jit

ORDER = 8
ERROR_ESTIMATOR_ORDER = 7
DENSE_ORDER = 7  # polynomial degree 7 in theta: dense holds the coefficients of theta^1..theta^7
B = A[N_STAGES, :N_STAGES]
# Step control: exponent 1 / (estimator order + 1), with the same PI memory as DP5(4)
# (integrator.py). Hairer's DOP853 default is plain I control (beta = 0); on this oscillator its
# error estimate swings between steps (0.03 -> 1.5 at a 1.4x longer step) and 15-25 % of the
# steps were rejected; beta = 0.04 brought that to 1-8 % for about as many RHS evaluations.
ERROR_EXPONENT = 1.0 / (ERROR_ESTIMATOR_ORDER + 1)
PI_ALPHA = ERROR_EXPONENT - 0.75 * PI_BETA
# The tableau rows as contiguous float64 constants (numba freezes global arrays into the code).
A_STAGES = np.ascontiguousarray(A[:N_STAGES_EXTENDED, :N_STAGES_EXTENDED])
C_STAGES = np.ascontiguousarray(C)
B_STAGES = np.ascontiguousarray(B)
E3_STAGES = np.ascontiguousarray(E3)
E5_STAGES = np.ascontiguousarray(E5)
D_ROWS = np.ascontiguousarray(D)


# --- the step, written out stage by stage ---------------------------------------------------------
# dop853_step is generated below from the tableau: every weighted sum of stages is written out
# with its nonzero coefficients as literals, in the order of the stages, which is the order in
# which the loop over the tableau (skipping its zeros) added them, so the results are bit for bit
# those of the loop. Written out, a step costs 107 instead of 126 ns (benchmarks/README.md,
# issue 23 attempt 2): the loop tested every coefficient for zero at run time.
# Generated functions have no source file for numba's cache; they are inlined into the kernels
# (inline="always"), whose cache holds them, so they are compiled uncached themselves.


def _weighted_sum(weights, rows):
    """Source text of sum_r weights[r] K[rows[r], j] over the nonzero weights, as the loop summed."""
    terms = [f"{float(w)!r} * K[{r}, j]" for r, w in zip(rows, weights) if w != 0.0]
    return "(0.0 + " + " + ".join(terms) + ")"


def _stage_source(s):
    """Source lines of stage s: K[s] = rhs(t + c_s h, y + h sum_{r<s} a_sr K[r]).

    Only the components the right-hand side reads are formed (the first n_dynamic).
    """
    return [
        "    for j in range(n_dynamic):",
        f"        stage[j] = y[j] + h * {_weighted_sum(A_STAGES[s, :s], range(s))}",
        f"    rhs(t, h, {s}, {float(C_STAGES[s])!r}, stage, coefficients, K[{s}], scratch)",
    ]


def _generated(name, lines, namespace):
    # (named this module's: the GPU's kernel module imports it from here, cuda._import_line)
    namespace = {"__name__": __name__, **namespace}
    exec("\n".join(lines), namespace)  # noqa: S102 - source built above from the tableau only
    return kernel_jit(namespace[name], inline="always", cache=False)


_STEP_LINES = [
    "def dop853_step(rhs, t, y, f, h, coefficients, K, y_new, stage, scratch, n_dynamic=N_DYNAMIC):",
    '    """One 8th-order step of size h from (t, y) with f = rhs(t, y); K[N_STAGES] = f(t + h, y_new)."""',
    "    n = y.shape[0]",
    "    for j in range(n):",
    "        K[0, j] = f[j]",
]
for _s in range(1, N_STAGES):
    _STEP_LINES += _stage_source(_s)
_STEP_LINES += [
    "    for j in range(n):",
    f"        y_new[j] = y[j] + h * {_weighted_sum(B_STAGES, range(N_STAGES))}",
    f"    rhs(t, h, {N_STAGES}, {float(C_STAGES[N_STAGES])!r}, y_new, coefficients, K[{N_STAGES}], scratch)",
]
dop853_step = _generated("dop853_step", _STEP_LINES, {"N_DYNAMIC": N_DYNAMIC})

# The dense output's three extra stages (13..15), and the sums D K of its last four coefficient rows.
_EXTRA_STAGE_LINES = ["def _extra_stages(rhs, t, y, h, coefficients, K, stage, scratch, n_dynamic):"]
for _s in range(N_STAGES + 1, N_STAGES_EXTENDED):
    _EXTRA_STAGE_LINES += _stage_source(_s)
_extra_stages = _generated("_extra_stages", _EXTRA_STAGE_LINES, {})
_D_ROW_LINES = ["def _d_rows(K, j):",
                "    return (" + ", ".join(_weighted_sum(D_ROWS[q], range(N_STAGES_EXTENDED))
                                          for q in range(D_ROWS.shape[0])) + ")"]
_d_rows = _generated("_d_rows", _D_ROW_LINES, {})


@kernel_jit
def dop853_error_norm(K, h, y, y_new, rtol, atol):
    """Hairer's DOP853 error norm over the controlled components (x, v).

    err = |h| ||e5||^2 / sqrt(||e5||^2 + 0.01 ||e3||^2) / sqrt(n): the 5th-order estimate,
    damped where the 3rd-order one says the step is far outside its asymptotic regime.
    """
    err5_sq = 0.0
    err3_sq = 0.0
    for j in range(N_CONTROLLED):
        e5 = 0.0
        e3 = 0.0
        for r in range(N_STAGES + 1):
            e5 += E5_STAGES[r] * K[r, j]
            e3 += E3_STAGES[r] * K[r, j]
        scale = atol + rtol * max(abs(y[j]), abs(y_new[j]))
        e5 /= scale
        e3 /= scale
        err5_sq += e5 * e5
        err3_sq += e3 * e3
    if err5_sq == 0.0 and err3_sq == 0.0:
        return 0.0
    return abs(h) * err5_sq / math.sqrt((err5_sq + 0.01 * err3_sq) * N_CONTROLLED)


@kernel_jit
def dop853_accepted_step_factor(err, err_previous):
    """Growth factor after an accepted step (err <= 1): PI control, clipped."""
    if err == 0.0:
        return MAX_FACTOR
    factor = SAFETY * err ** -PI_ALPHA * max(err_previous, ERR_PREVIOUS_FLOOR) ** PI_BETA
    return min(MAX_FACTOR, max(MIN_FACTOR, factor))


DOP853_GROWTH_THRESHOLDS = growth_thresholds(PI_ALPHA, PI_BETA)


@kernel_jit
def dop853_certain_growth(err, err_previous):
    """dop853_accepted_step_factor(err, err_previous) >= 1 is certain (rk45.growth_is_certain)."""
    return growth_is_certain(err, err_previous, DOP853_GROWTH_THRESHOLDS)


@kernel_jit
def dop853_rejected_step_factor(err):
    """Shrink factor after a rejected step (err > 1), never growing."""
    return min(1.0, max(MIN_FACTOR, SAFETY * err ** -ERROR_EXPONENT))


@kernel_jit(inline="always")
def dop853_dense(rhs, t, y, h, coefficients, K, y_new, dense, stage, scratch, n_dynamic=N_DYNAMIC):
    """dense (n, 7): the 7th-order continuous extension of the step [t, t + h], in powers of theta.

    Needs K of the step (with its FSAL row) and computes the three extra stages 13..15.
    Returns the number of RHS evaluations spent (3).

    SciPy's form is y + theta (F0 + (1 - theta)(F1 + theta (F2 + (1 - theta)(F3 + theta (F4
    + (1 - theta)(F5 + theta F6)))))), F0..F2 from y, y_new, f, f_new and F3..F6 = h D K; it is
    multiplied out here into y + h theta sum_q dense[q] theta^q (no arrays: this runs at every
    impact and turning point).
    """
    _extra_stages(rhs, t, y, h, coefficients, K, stage, scratch, n_dynamic)
    for j in range(N_INTERPOLATED):
        delta_y = y_new[j] - y[j]
        f0 = delta_y
        f1 = h * K[0, j] - delta_y
        f2 = 2.0 * delta_y - h * (K[N_STAGES, j] + K[0, j])
        d3, d4, d5, d6 = _d_rows(K, j)
        f3 = h * d3
        f4 = h * d4
        f5 = h * d5
        f6 = h * d6
        # The nested form multiplied out (coefficients of theta^1 .. theta^7), over h.
        dense[j, 0] = (f0 + f1) / h
        dense[j, 1] = (f2 + f3 - f1) / h
        dense[j, 2] = (f4 + f5 - f2 - 2.0 * f3) / h
        dense[j, 3] = (f3 + f6 - 2.0 * f4 - 3.0 * f5) / h
        dense[j, 4] = (f4 + 3.0 * f5 - 3.0 * f6) / h
        dense[j, 5] = (3.0 * f6 - f5) / h
        dense[j, 6] = -f6 / h
    return N_STAGES_EXTENDED - N_STAGES - 1
