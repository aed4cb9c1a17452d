"""The oscillator's right-hand sides, and the forcing's phases rotated to the stage times.

    x'' + gamma (x^2 - mu) x' + stiffness x + alpha x^3 = c cos(omega t) + g cos(Omega t)    # eq2.1, eq2.10

as a first-order system in the state vector of state.py (x, v, and the Fourier quadratures of
eq3.1-eq3.2 integrated with the motion), with the tangent vectors' variational equations
(tangent.py) when Lyapunov exponents are asked for. Every function has the signature the
Runge-Kutta steps call, ``rhs(t, h, node, c, y, coefficients, dydt, scratch)``, so the kernel
loop (kernel.py) takes them as arguments and numba inlines them.
"""

import math

import numpy as np

from vrsweep.numerics import dop853
from vrsweep.numerics.coefficients import HARMONIC
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.model import ALPHA, BIG_OMEGA, C, DELTA, G, GAMMA, MU, OMEGA, STIFFNESS
from vrsweep.numerics.state import QC_INTEGRAL, QS_INTEGRAL, V, X
from vrsweep.numerics.tangent import apply_jacobian


@kernel_jit
def oscillator_rhs(t, h, node, c, y, coefficients, dydt, scratch):
    """x'' + gamma (x^2 - mu) x' + k x + alpha x^3 = c cos(omega t) + g cos(Omega t), at t + c h.

    eq2.1 (mu = 1, k = -omega0^2) and eq2.10 (mu = K, k = wt2, g = 0) alike; the last two
    components accumulate the integrands of eq3.1 and eq3.2. The cosines are the library's at
    every evaluation (``node`` and ``scratch`` are unused): the rk45 kernel's stages, and every
    evaluation outside a step.
    """
    time = t + c * h
    omega_t = coefficients[OMEGA] * time
    # Without the fast forcing (the effective model) Omega may be anything, even overflow Omega t.
    cos_fast = math.cos(coefficients[BIG_OMEGA] * time) if coefficients[G] != 0.0 else 0.0
    _oscillator_derivative(y, coefficients, math.cos(omega_t), math.sin(omega_t), cos_fast, dydt)


@kernel_jit(inline="always")
def _oscillator_derivative(y, coefficients, cos_slow, sin_slow, cos_fast, dydt):
    x = y[X]
    v = y[V]
    forcing = coefficients[C] * cos_slow + coefficients[G] * cos_fast
    dydt[X] = v
    dydt[V] = (forcing - coefficients[GAMMA] * (x * x - coefficients[MU]) * v
               - coefficients[STIFFNESS] * x - coefficients[ALPHA] * x * x * x)
    dydt[QS_INTEGRAL] = x * sin_slow
    dydt[QC_INTEGRAL] = x * cos_slow


@kernel_jit(inline="always")
def oscillator_tangent(t, y, coefficients, dydt):
    """dydt[tangent] = J u (tangent.py); the forcing does not enter J, so t is unused."""
    x = y[X]
    v = y[V]
    gamma = coefficients[GAMMA]
    # d(v')/dx and d(v')/dv of x'' = c cos + g cos - gamma (x^2 - mu) v - k x - alpha x^3
    dv_dx = -(2.0 * gamma * x * v + coefficients[STIFFNESS] + 3.0 * coefficients[ALPHA] * x * x)
    dv_dv = -gamma * (x * x - coefficients[MU])
    apply_jacobian(y, dv_dx, dv_dv, dydt)


@kernel_jit
def oscillator_tangent_rhs(t, h, node, c, y, coefficients, dydt, scratch):
    """oscillator_rhs and the variational equations of the tangent vectors (tangent.py)."""
    oscillator_rhs(t, h, node, c, y, coefficients, dydt, scratch)
    oscillator_tangent(t + c * h, y, coefficients, dydt)


def paper_functions(tangents):
    """The paper's family's (rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface), as
    kernel._integrate takes them with the library's cosines (the GPU's line kernel, cuda.line_kernel; tests that drive the
    loop). Its acceleration is smooth: no switching functions."""
    model_rhs = oscillator_tangent_rhs if tangents else oscillator_rhs
    return model_rhs, oscillator_tangent, force_at_barrier, no_switches, no_saltation, no_sliding


@kernel_jit
def force_at_barrier(t, coefficients, barrier):
    """Acceleration of a mass resting at (Delta, 0): positive pushes it into the barrier (the
    family has one barrier, so ``barrier`` is 0).

    The damping term vanishes with the velocity, so only stiffness and forcing remain.
    """
    delta = coefficients[DELTA]
    return (coefficients[C] * math.cos(coefficients[OMEGA] * t)
            + coefficients[G] * math.cos(coefficients[BIG_OMEGA] * t)
            - coefficients[STIFFNESS] * delta - coefficients[ALPHA] * delta ** 3)


# The last value of every rhs scratch is the frozen mode of a model's switching functions
# (kernel._integrate holds it; codegen.frozen_acceleration reads it): -1, none held.
UNFROZEN = -1.0


@kernel_jit
def no_scratch(h_max):
    """The scratch of a method whose stages call the library: the frozen mode's value alone."""
    return np.full(1, UNFROZEN)


@kernel_jit
def no_preparation(t, h, coefficients, scratch):
    return


@kernel_jit
def no_preparations(t, h, coefficients, scratch, dense):
    """kernel._integrate's prepare for a method whose stages call the library: nothing."""
    return


@kernel_jit
def no_switches(t, x, v, coefficients):
    """The signs of a model's switching functions (kernel._integrate's switch_signs) for a model
    whose acceleration is smooth, as the paper's: none, the constant -1 (UNFROZEN), which LLVM
    inlines and folds away, so the kink location costs their kernels nothing. Not 0, the signs of a
    model whose switches are all negative: a rejected step is retried frozen on the side its
    switches give (kernel._integrate), and with 0 a smooth model's mode became 0.0 there, a frozen
    mode the loop then carried, which kept every frozen branch alive (GPU: 0 to 8 bytes of spills
    in the paper's rk45 kernel, 36 to 104 in a written one's, 0.7.7)."""
    return -1


@kernel_jit
def no_sliding(coefficients, crossing, what):
    """kernel._integrate's sliding_surface for a model with no surface it slides on (the paper's):
    NaN, no speed (a constant, folded away with the branch it guards)."""
    return math.nan


@kernel_jit
def no_saltation(t, y, coefficients, mode, crossing, acceleration_before, acceleration_after):
    """kernel._integrate's switch_saltation for a model with no jump of its force (the paper's, or
    a written one with kinks only): the tangent vectors are continuous across every surface, S = I.
    False: nothing changed (a constant, folded away with the branch it guards)."""
    return False


# --- the forcing's phases rotated to the stage times (the dop853 kernel) ------------------------
# At a stage time t + c h, cos(a + d) = cos a cos d - sin a sin d and sin(a + d) = sin a cos d
# + cos a sin d, with a = omega t (Omega t) at the step's start and d = omega c h (Omega c h).
# prepare_rotations computes the phases at t (library calls once per step) and the rotations of
# every node for the step size h; oscillator_rhs_rotated then costs a few multiplications where
# oscillator_rhs makes three library calls. Step sizes are rounded down to the grid
# h_max 2^(-k / STEP_LEVELS_PER_OCTAVE) (grid_step), whose rotations are tabulated once per point.
STEP_LEVELS_PER_OCTAVE = 16
N_STEP_LEVELS = 128
MAX_NODES = 16
ROTATION_VALUES = 4 * MAX_NODES  # cos, sin of omega c h and of Omega c h, per node
# The phases at the next step's start are the last step's rotated by its full step (a node c = 1),
# recomputed by the library every RESYNC_STEPS steps so that rounding cannot accumulate.
RESYNC_STEPS = 16
# scratch layout
PHASE_TIME, PHASE_STEP, COS_SLOW, SIN_SLOW, COS_FAST, SIN_FAST, FULL_STEP_NODE, ROTATED_STEPS = range(8)
# The nodes of the current step whose rotations are ready, and the step's own nodes (up to its last
# node c = 1, the FSAL one): the dense output's extra nodes after it are computed only when a dense
# output is asked for (prepare_step_rotations, prepare_rotations).
READY_NODES, STEP_NODES = 8, 9
ROTATION = 10                                        # the current step's rotations, per node
NODES = ROTATION + ROTATION_VALUES                   # the method's nodes c
STEP_GRID = NODES + MAX_NODES                        # the grid of step sizes
LEVEL_READY = STEP_GRID + N_STEP_LEVELS              # 1 once a grid step's rotations are tabulated
LEVEL_ROTATIONS = LEVEL_READY + N_STEP_LEVELS        # N_STEP_LEVELS x ROTATION_VALUES
N_ROTATION_SCRATCH = LEVEL_ROTATIONS + N_STEP_LEVELS * ROTATION_VALUES + 1  # + the frozen mode, last


@kernel_jit
def rotation_scratch(h_max, nodes):
    """oscillator_rhs_rotated's scratch for steps up to h_max of a method with these nodes."""
    scratch = np.empty(N_ROTATION_SCRATCH)  # 68 kB: only what is read before it is written is set
    scratch[:ROTATION] = 0.0
    scratch[PHASE_TIME] = np.nan  # READY_NODES 0: nothing prepared
    scratch[PHASE_STEP] = np.nan
    scratch[NODES:STEP_GRID] = 0.0
    scratch[LEVEL_READY:LEVEL_ROTATIONS] = 0.0
    scratch[FULL_STEP_NODE] = -1.0
    scratch[STEP_NODES] = MAX_NODES
    for node in range(nodes.shape[0]):
        scratch[NODES + node] = nodes[node]
        if nodes[node] == 1.0 and scratch[FULL_STEP_NODE] < 0.0:
            scratch[FULL_STEP_NODE] = node
        if nodes[node] == 1.0:
            scratch[STEP_NODES] = node + 1
    for k in range(N_STEP_LEVELS):
        scratch[STEP_GRID + k] = h_max * 2.0 ** (-k / STEP_LEVELS_PER_OCTAVE)
    scratch[N_ROTATION_SCRATCH - 1] = UNFROZEN
    return scratch


@kernel_jit
def dop853_rotation_scratch(h_max):
    """rotation_scratch for DOP853's nodes, the method whose stages rotate the phases."""
    return rotation_scratch(h_max, dop853.C_STAGES)


@kernel_jit
def grid_step(h, scratch):
    """The largest step size of the grid that is <= h; h itself below the grid (or if NaN)."""
    if h >= scratch[STEP_GRID]:
        return scratch[STEP_GRID]  # at the cap, as most steps are: what the search below returns
    if not (h >= scratch[STEP_GRID + N_STEP_LEVELS - 1]):
        return h
    k = int(math.ceil(STEP_LEVELS_PER_OCTAVE * math.log2(scratch[STEP_GRID] / h)))
    k = min(max(k, 0), N_STEP_LEVELS - 1)
    while k > 0 and scratch[STEP_GRID + k - 1] <= h:  # log2's rounding: take the largest <= h
        k -= 1
    while k < N_STEP_LEVELS - 1 and scratch[STEP_GRID + k] > h:
        k += 1
    return scratch[STEP_GRID + k]


@kernel_jit
def _grid_level(h, scratch):
    """k with h equal to the grid's k-th step size, or -1."""
    if not (scratch[STEP_GRID + N_STEP_LEVELS - 1] <= h <= scratch[STEP_GRID]):
        return -1
    k = int(round(STEP_LEVELS_PER_OCTAVE * math.log2(scratch[STEP_GRID] / h)))
    for j in (k, k - 1, k + 1):
        if 0 <= j < N_STEP_LEVELS and scratch[STEP_GRID + j] == h:
            return j
    return -1


@kernel_jit
def _rotations(h, coefficients, scratch, out, first, last):
    """cos and sin of omega c h and Omega c h for the nodes first..last - 1, into scratch[out:out + 64]
    (4 values per node). A node with the same c as the one before (DOP853's FSAL node) is copied."""
    omega = coefficients[HARMONIC]
    big_omega = coefficients[HARMONIC + 1]
    fast = big_omega != 0.0  # without the fast forcing Omega may be anything: left out (0)
    for node in range(first, last):
        if node > 0 and scratch[NODES + node] == scratch[NODES + node - 1]:
            for k in range(4):
                scratch[out + 4 * node + k] = scratch[out + 4 * node - 4 + k]
            continue
        dt = scratch[NODES + node] * h
        scratch[out + 4 * node] = math.cos(omega * dt)
        scratch[out + 4 * node + 1] = math.sin(omega * dt)
        scratch[out + 4 * node + 2] = math.cos(big_omega * dt) if fast else 0.0
        scratch[out + 4 * node + 3] = math.sin(big_omega * dt) if fast else 0.0


@kernel_jit
def prepare_rotations(t, h, coefficients, scratch):
    """Make scratch hold the phases at t and the rotations of every node for a step of size h
    (a step and its dense output)."""
    _prepare(t, h, coefficients, scratch, MAX_NODES)


@kernel_jit
def prepare_step_rotations(t, h, coefficients, scratch):
    """prepare_rotations for the step's own nodes only: the dense output's extra nodes wait for
    prepare_rotations. A step to an impact (Newton) or to a period's end is off the grid, and most
    of them need no dense output: 3 of 16 nodes' library calls saved."""
    _prepare(t, h, coefficients, scratch, int(scratch[STEP_NODES]))


@kernel_jit
def prepare_rotations_for(t, h, coefficients, scratch, dense):
    """kernel._integrate's prepare with the rotated phases: prepare_rotations for a step and its
    dense output (dense), prepare_step_rotations for the step alone. One function, so that the loop
    takes one argument for both (CPython passes a call of more than 30 arguments as *args, which
    numba cannot inline)."""
    if dense:
        _prepare(t, h, coefficients, scratch, MAX_NODES)
    else:
        _prepare(t, h, coefficients, scratch, int(scratch[STEP_NODES]))


@kernel_jit(inline="always")
def _prepare(t, h, coefficients, scratch, n_nodes):
    if t != scratch[PHASE_TIME]:
        full = int(scratch[FULL_STEP_NODE])
        if (t == scratch[PHASE_TIME] + scratch[PHASE_STEP] and full >= 0
                and scratch[ROTATED_STEPS] < RESYNC_STEPS):
            # The step just taken ended at t: rotate its start's phases by the whole step.
            r = ROTATION + 4 * full
            cos_slow = scratch[COS_SLOW] * scratch[r] - scratch[SIN_SLOW] * scratch[r + 1]
            sin_slow = scratch[SIN_SLOW] * scratch[r] + scratch[COS_SLOW] * scratch[r + 1]
            cos_fast = scratch[COS_FAST] * scratch[r + 2] - scratch[SIN_FAST] * scratch[r + 3]
            sin_fast = scratch[SIN_FAST] * scratch[r + 2] + scratch[COS_FAST] * scratch[r + 3]
            scratch[COS_SLOW] = cos_slow
            scratch[SIN_SLOW] = sin_slow
            scratch[COS_FAST] = cos_fast
            scratch[SIN_FAST] = sin_fast
            scratch[ROTATED_STEPS] += 1.0
        else:
            omega_t = coefficients[HARMONIC] * t
            scratch[COS_SLOW] = math.cos(omega_t)
            scratch[SIN_SLOW] = math.sin(omega_t)
            if coefficients[HARMONIC + 1] != 0.0:
                scratch[COS_FAST] = math.cos(coefficients[HARMONIC + 1] * t)
                scratch[SIN_FAST] = math.sin(coefficients[HARMONIC + 1] * t)
            scratch[ROTATED_STEPS] = 0.0
        scratch[PHASE_TIME] = t
    if h != scratch[PHASE_STEP]:
        level = _grid_level(h, scratch)
        if level < 0:  # a step clipped to a period's end, or to an impact
            _rotations(h, coefficients, scratch, ROTATION, 0, n_nodes)
            scratch[READY_NODES] = n_nodes
        else:
            table = LEVEL_ROTATIONS + level * ROTATION_VALUES
            if scratch[LEVEL_READY + level] == 0.0:
                _rotations(h, coefficients, scratch, table, 0, MAX_NODES)
                scratch[LEVEL_READY + level] = 1.0
            scratch[ROTATION:ROTATION + ROTATION_VALUES] = scratch[table:table + ROTATION_VALUES]
            scratch[READY_NODES] = MAX_NODES
        scratch[PHASE_STEP] = h
    elif scratch[READY_NODES] < n_nodes:  # the dense output of a step prepared for its own nodes
        _rotations(h, coefficients, scratch, ROTATION, int(scratch[READY_NODES]), n_nodes)
        scratch[READY_NODES] = n_nodes


@kernel_jit
def oscillator_rhs_rotated(t, h, node, c, y, coefficients, dydt, scratch):
    """oscillator_rhs at a stage node of a step prepared by prepare_rotations (t and h unused).

    No branch and no library call: with either, an evaluation cost as much as oscillator_rhs.
    """
    r = ROTATION + 4 * node
    cos_d = scratch[r]
    sin_d = scratch[r + 1]
    _oscillator_derivative(y, coefficients,
                           scratch[COS_SLOW] * cos_d - scratch[SIN_SLOW] * sin_d,
                           scratch[SIN_SLOW] * cos_d + scratch[COS_SLOW] * sin_d,
                           scratch[COS_FAST] * scratch[r + 2] - scratch[SIN_FAST] * scratch[r + 3],
                           dydt)


@kernel_jit
def oscillator_tangent_rhs_rotated(t, h, node, c, y, coefficients, dydt, scratch):
    """oscillator_rhs_rotated and the variational equations of the tangent vectors (tangent.py)."""
    oscillator_rhs_rotated(t, h, node, c, y, coefficients, dydt, scratch)
    oscillator_tangent(t, y, coefficients, dydt)
