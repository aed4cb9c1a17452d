"""Isolated costs of the pieces of a dop853 kernel step (issue 23), in ns per call.

Run:  python benchmarks/kernel_pieces.py

Each piece runs N times in a numba loop on values taken from a real step (original model, g = 10,
h = 1/8 of the fast period); the loop's result is summed so that nothing is optimised away.
The calling thread's CPU time, best of 7.
"""

import sys
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vrsweep.numerics import dop853, kernel, rhs  # noqa: E402
from vrsweep.numerics.dop853 import dop853_accepted_step_factor, dop853_dense, dop853_error_norm, dop853_step  # noqa: E402
from vrsweep.numerics.impact import hermite_reach, locate_root  # noqa: E402
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients  # noqa: E402
from vrsweep.numerics.rhs import grid_step, oscillator_rhs, oscillator_rhs_rotated, prepare_rotations, rotation_scratch  # noqa: E402
from vrsweep.numerics.state import N_STATE, V  # noqa: E402

if __package__:  # python -m benchmarks.NAME, or imported
    from ._timing import best_of
else:  # python benchmarks/NAME.py: this folder is first on sys.path
    from _timing import best_of

N = 200_000


@njit
def time_pow(n, errs):
    acc = 0.0
    for i in range(n):
        acc += dop853_accepted_step_factor(errs[i & 1023], errs[(i + 1) & 1023])
    return acc


@njit
def _stepped(coefficients, y, h, scratch):
    """The work arrays of one DOP853 step of ``h`` from ``y``, that step taken: K (stages, 4),
    y_new (4,), stage (4,) and f (4,) = the RHS at y, which each piece below works on."""
    K = np.empty((dop853.N_STAGES_EXTENDED, N_STATE))
    y_new = np.empty(N_STATE)
    stage = np.empty(N_STATE)
    f = np.empty(N_STATE)
    oscillator_rhs(0.0, 0.0, -1, 0.0, y, coefficients, f, scratch)
    prepare_rotations(0.0, h, coefficients, scratch)
    dop853_step(oscillator_rhs_rotated, 0.0, y, f, h, coefficients, K, y_new, stage, scratch, 2)
    return K, y_new, stage, f


@njit
def time_step(n, coefficients, y, h, scratch):
    K, y_new, stage, f = _stepped(coefficients, y, h, scratch)
    acc = 0.0
    for i in range(n):
        dop853_step(oscillator_rhs_rotated, 0.0, y, f, h, coefficients, K, y_new, stage, scratch, 2)
        acc += y_new[0]
    return acc


@njit
def time_step_error(n, coefficients, y, h, scratch):
    K, y_new, _, _ = _stepped(coefficients, y, h, scratch)
    acc = 0.0
    for i in range(n):
        K[0, 0] += 1e-300
        acc += dop853_error_norm(K, h, y, y_new, 1e-4, 1e-6)
    return acc


@njit
def time_dense(n, coefficients, y, h, scratch):
    K, y_new, stage, _ = _stepped(coefficients, y, h, scratch)
    dense = np.empty((N_STATE, dop853.DENSE_ORDER))
    acc = 0.0
    for i in range(n):
        dop853_dense(oscillator_rhs_rotated, 0.0, y, h, coefficients, K, y_new, dense, stage, scratch, 2)
        acc += dense[0, 3]
    return acc


@njit
def time_locate(n, coefficients, y, h, scratch):
    K, y_new, stage, _ = _stepped(coefficients, y, h, scratch)
    dense = np.empty((N_STATE, dop853.DENSE_ORDER))
    dop853_dense(oscillator_rhs_rotated, 0.0, y, h, coefficients, K, y_new, dense, stage, scratch, 2)
    acc = 0.0
    for i in range(n):
        acc += locate_root(dense, y, h, V, 0.0, 0.0, 1.0)
    return acc


@njit
def time_rotations(n, coefficients, h, scratch):
    acc = 0.0
    for i in range(n):
        prepare_rotations(0.0, h * (1.0 - 1e-9 * (i & 7)) - 1e-12 * i, coefficients, scratch)
        acc += scratch[rhs.ROTATION + 5]
    return acc


@njit
def time_grid(n, h, scratch):
    acc = 0.0
    for i in range(n):
        acc += grid_step(h * (1.0 + 1e-3 * (i & 1)), scratch)
    return acc


@njit
def time_hermite(n, xs):
    acc = 0.0
    for i in range(n):
        acc += hermite_reach(xs[i & 1023], 0.3, -1.0, 0.5, -0.2, 0.5, 0.2, 1.0)
    return acc


def best(run):
    """ns per piece: the best of 7 timed calls of ``run`` (N pieces each), after one that compiles."""
    return best_of(run, repeats=7, warm_up=True)[0] / N * 1e9


def main():
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, Omega=4.0, g=10.0), "original")
    h_max = coefficients[kernel.MAX_STEP]
    scratch = rotation_scratch(h_max, dop853.C_STAGES)
    # a state off the turning point, v changing sign inside the step (a turning point)
    y = np.zeros(N_STATE)
    y[0], y[1] = -0.5, -0.3
    errs = np.random.default_rng(1).uniform(1e-3, 1e-2, 1024)
    print(f"PI factor (two pow):          {best(lambda: time_pow(N, errs)):6.1f} ns")
    print(f"bare DOP853 step (12 RHS):    {best(lambda: time_step(N, coefficients, y, h_max, scratch)):6.1f} ns")
    print(f"error norm:                   {best(lambda: time_step_error(N, coefficients, y, h_max, scratch)):6.1f} ns")
    print(f"dense output (3 RHS):         {best(lambda: time_dense(N, coefficients, y, h_max, scratch)):6.1f} ns")
    print(f"locate_root (turning point):  {best(lambda: time_locate(N, coefficients, y, h_max, scratch)):6.1f} ns")
    print(f"rotations for an off-grid h:  {best(lambda: time_rotations(N, coefficients, h_max * 0.77, scratch)):6.1f} ns")
    print(f"grid_step:                    {best(lambda: time_grid(N, h_max * 0.9, scratch)):6.1f} ns")
    print(f"hermite_reach:                {best(lambda: time_hermite(N, errs)):6.1f} ns")


if __name__ == "__main__":
    main()
