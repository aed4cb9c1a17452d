"""Lyapunov exponents of the impact oscillator: variational equations, saltation, renormalisation.

The largest exponent is the mean exponential growth rate of a tangent vector u = (dx, dv)
carried along the trajectory (docs/design.md, "Lyapunov exponents", derives every formula):

- between impacts, u' = J(x, v, t) u with the Jacobian of the flow J = [[0, 1], [da/dx, da/dv]],
  a = x'' the model's acceleration; for the paper's family
      J = [[0, 1], [-(2 gamma x v + k + 3 alpha x^2), -gamma (x^2 - mu)]]          (eq2.1, eq2.10)
  (rhs.py), for a written model derived symbolically (written.py)
  integrated with the motion, in the same Runge-Kutta steps (kernel.py);
- at an impact (x = Delta, v- > 0 -> v+ = -e v-, eq2.2; a barrier below is the same seen in -x)
  u jumps by the saltation matrix
      S = [[-e, 0], [(a+ + e a-) / v-, -e]],   det S = e^2,
  a- and a+ the accelerations just before and after the impact;
- where a written model's acceleration jumps across a switching surface h = 0 (sign(v)), u jumps
  by that crossing's saltation matrix, S = I + (f+ - f-) grad h^T / (grad h . f- + dh/dt)
  (apply_switch_saltation); at a kink (abs, min, max: the force is continuous) S = I;
- while stuck on the barrier the state is (Delta, 0) whatever it was before: the tangent map
  of the flow over a sticking interval is zero, and u collapses to zero (the exponent of a
  point that sticks in the measurement window is -inf, exactly);
- every slow period the two tangent vectors are orthonormalised (Gram-Schmidt): the log of the
  first one's length is that period's stretch, the log of the parallelogram's area the sum of
  both exponents' contributions (Benettin et al. 1980); earlier within a period when a vector
  leaves [1/TANGENT_RANGE, TANGENT_RANGE], the logs then summed over the period.

State layout: state.py (TANGENT); per-period records: kernel.REC_LOG_STRETCH, REC_LOG_AREA.
"""

import math

from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.state import N_TANGENT_VECTORS, TANGENT


@kernel_jit
def apply_jacobian(y, dv_dx, dv_dv, dydt):
    """dydt[tangent] = J u for both tangent vectors, J = [[0, 1], [dv_dx, dv_dv]]: the model's
    right-hand side computes d(x'')/dx and d(x'')/dv at the state (rhs.py, a written model's)."""
    for i in range(N_TANGENT_VECTORS):
        dx = y[TANGENT + 2 * i]
        dv = y[TANGENT + 2 * i + 1]
        dydt[TANGENT + 2 * i] = dv
        dydt[TANGENT + 2 * i + 1] = dv_dx * dx + dv_dv * dv


@kernel_jit
def seed_tangents(y):
    """The tangent vectors as the unit vectors along x and v."""
    for i in range(N_TANGENT_VECTORS):
        y[TANGENT + 2 * i] = 1.0 if i == 0 else 0.0
        y[TANGENT + 2 * i + 1] = 1.0 if i == 1 else 0.0


@kernel_jit
def collapse_tangents(y):
    """Sticking: the state is (Delta, 0) whatever it was before, so every tangent vector is 0."""
    for j in range(TANGENT, TANGENT + 2 * N_TANGENT_VECTORS):
        y[j] = 0.0


@kernel_jit
def slide_tangents(y, both):
    """Sliding on a surface v = c, c a constant (a written model's Filippov sliding, kernel.py): the
    entry's saltation matrix S = I + (f_s - f-) grad h^T / (grad h . f-), f_s = (c, 0) the sliding
    field, is diag(1, 0): a neighbour displaced by dv reaches the surface a little earlier or later
    and slides from there, at the same speed. Along the surface x' = c whatever x, so u = (dx, 0)
    stays; the exit's S is I (the side it leaves to has the sliding field where it lets go).

    both: each vector is mapped (a period's raw map, continuation's monodromy). Otherwise the map
    has rank one: the first vector keeps the image (the second's where the first has none) and the
    second is 0, so that the area's log, the sum of the exponents, is -inf exactly, as after sticking,
    not the log of a rounding."""
    if both:
        for i in range(N_TANGENT_VECTORS):
            y[TANGENT + 2 * i + 1] = 0.0
        return
    if y[TANGENT] == 0.0:
        y[TANGENT] = y[TANGENT + 2]
    y[TANGENT + 1] = 0.0
    y[TANGENT + 2] = 0.0
    y[TANGENT + 3] = 0.0


@kernel_jit
def apply_saltation(y, v_before, acceleration_before, acceleration_after, restitution):
    """u -> S u at an impact with x'(-) = v_before > 0 (module doc; eq2.2).

    The coupling term: a trajectory displaced by dx < 0 reaches the barrier tau = -dx / v- after
    the nominal one, gaining a- tau in speed before its reflection while the reflected nominal
    one gains a+ tau: dv+ = -e dv - (a+ + e a-) tau.
    """
    coupling = (acceleration_after + restitution * acceleration_before) / v_before
    for i in range(N_TANGENT_VECTORS):
        dx = y[TANGENT + 2 * i]
        dv = y[TANGENT + 2 * i + 1]
        y[TANGENT + 2 * i] = -restitution * dx
        y[TANGENT + 2 * i + 1] = coupling * dx - restitution * dv


@kernel_jit
def apply_switch_saltation(y, dh_dx, dh_dv, rate, jump):
    """u -> S u where the flow crosses a switching surface h(t, x, v) = 0 on which the acceleration
    jumps by ``jump`` = a+ - a- (a written model's sign(v); codegen._switch_saltation_body):
        S = I + (f+ - f-) grad h^T / (grad h . f- + dh/dt),   f+- = (v, a+-),
    the saltation matrix of a transversal crossing (Aizerman-Gantmacher; Filippov). rate is
    grad h . f- + dh/dt = dh_dx v + dh_dv a- + dh_dt, the rate at which the trajectory from the
    side it left crosses the surface. A neighbour displaced by u meets the surface
    tau = -(grad h . u) / rate later, and over tau it moves with the other side's field: its
    velocity gains (a- - a+) tau. Only v's component jumps (f+ - f- = (0, a+ - a-))."""
    factor = jump / rate
    for i in range(N_TANGENT_VECTORS):
        dx = y[TANGENT + 2 * i]
        dv = y[TANGENT + 2 * i + 1]
        y[TANGENT + 2 * i + 1] = dv + factor * (dh_dx * dx + dh_dv * dv)


@kernel_jit
def record_monodromy(row, y):
    """The 2x2 matrix whose columns are the two tangent vectors, row-major into row (4,).

    Seeded with the unit vectors at a period's start (seed_tangents), it is that period's
    tangent map, the saltation matrices of its impacts included (continuation's monodromy).
    """
    row[0] = y[TANGENT]
    row[1] = y[TANGENT + 2]
    row[2] = y[TANGENT + 1]
    row[3] = y[TANGENT + 3]


# Within a period the tangent vectors are renormalised early once a component leaves this range
# (a damping of 30 over a slow period of 57 shrinks them by e^-1700, far below the smallest double).
TANGENT_RANGE = 1e30


@kernel_jit
def tangents_out_of_range(y):
    """Whether a tangent vector has grown beyond TANGENT_RANGE or shrunk below its inverse."""
    for i in range(N_TANGENT_VECTORS):
        size = max(abs(y[TANGENT + 2 * i]), abs(y[TANGENT + 2 * i + 1]))
        if size > TANGENT_RANGE or 0.0 < size < 1.0 / TANGENT_RANGE:
            return True
    return False


@kernel_jit
def renormalise_tangents(y):
    """Gram-Schmidt on the two tangent vectors; returns (log stretch, log area) since the last call.

    The vectors were orthonormal at the last call, so the first one's length is the stretch of
    the direction the flow favours, and the product of the two lengths after orthogonalisation
    the factor by which areas grew. A vector of length zero (after sticking) gives -inf and is
    seeded again, so that the next period measures afresh.
    """
    a = TANGENT
    b = TANGENT + 2
    length_1 = math.hypot(y[a], y[a + 1])
    if not (length_1 > 0.0 and math.isfinite(length_1)):
        log_stretch = -math.inf if length_1 == 0.0 else math.nan
        seed_tangents(y)
        return log_stretch, log_stretch
    y[a] /= length_1
    y[a + 1] /= length_1
    projection = y[a] * y[b] + y[a + 1] * y[b + 1]
    y[b] -= projection * y[a]
    y[b + 1] -= projection * y[a + 1]
    length_2 = math.hypot(y[b], y[b + 1])
    if not (length_2 > 0.0 and math.isfinite(length_2)):
        y[b] = -y[a + 1]  # any unit vector orthogonal to the first
        y[b + 1] = y[a]
        return math.log(length_1), (-math.inf if length_2 == 0.0 else math.nan)
    y[b] /= length_2
    y[b + 1] /= length_2
    return math.log(length_1), math.log(length_1) + math.log(length_2)
