"""One grid point: the integration loop of the impact oscillator with its observers.

The loop advances Runge-Kutta steps of the configured method (integration.method: rk45, the
Dormand-Prince 5(4) pair of rk45.py, or dop853, Hairer's 8(5,3) of dop853.py), stops
every step at the slow-period boundaries t = nT (T = 2 pi / omega) so that every period is
measured exactly, locates
impacts on the dense output (impact.py), applies the restitution law (eq2.2), and holds the
mass on the barrier while chatter has died out and the force presses it there (sticking); a
written model's mass rides a surface v = c of its force's jump while the force points into it
from both sides (Filippov sliding, stick-slip).

Observers are plain arrays the caller passes in, so one kernel serves a sweep (which only
needs the per-period records) and a trajectory (samples, impact and sticking logs): an
observer with zero length costs nothing. The kernel knows nothing of files or configs.

Fourier sums (eq3.1, eq3.2) are quadrature states integrated with the motion, so they are
as accurate as x itself; while stuck they are added in closed form. With integration.lyapunov
the state also carries two tangent vectors (tangent.py) and every period records their growth.

Array layouts: the state vector is state.py's; the settings vector is this module's (below);
the per-period record, the summary and the logs are records.py's (re-exported here as
kernel.REC_*, kernel.SUM_*); the coefficient vector is model.py's. The right-hand sides and the
forcing-phase rotations are rhs.py's.

``_integrate`` stays one function on purpose: it is the algorithm read top to bottom, and every
piece it calls that takes a model's or a method's function is inlined by numba (so that function
is a direct call); splitting its loop into functions that return several values would cost tuple
packing in the hottest path for no gain in clarity. The pieces that take arrays and numbers only
(records, tangent vectors, the frozen mode) are plain kernels, compiled once for every model:
numba copies an inlined callee's IR once per block with its whole scope, so each inlined piece
grew every kernel's compile (0.7.9: 29.5 s cold for the original model's rk45 sweep, 24.4 s
without them inlined; the same speed, benchmarks/README.md).
"""

import math

import numpy as np

from vrsweep.numerics import dop853
from vrsweep.numerics.dop853 import (
    dop853_accepted_step_factor, dop853_certain_growth, dop853_dense, dop853_error_norm, dop853_rejected_step_factor,
    dop853_step,
)
from vrsweep.numerics.impact import (
    IMPACT, MAX_ROOT_ITERATIONS, N_BRACKET, TURNING_POINT, UNRESOLVED, find_crossing, hermite_reach, locate_root, locate_switch,
    release_time,
)
from vrsweep.numerics.coefficients import (
    BARRIER, BARRIER_VALUES, MAX_STEP, N_BARRIERS, PERIOD, POSITION, RESPONSE_FREQUENCY,
    RESPONSE_SCALE, RESTITUTION, SCAN_STEP, SIDE,
)
from vrsweep.numerics.rk45 import (
    DENSE_ORDER, N_DYNAMIC, N_STAGES, ORDER, accepted_step_factor, certain_growth, dense_value, dp54_dense,
    dp54_step, error_norm, initial_step, rejected_step_factor,
)
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.model import ALPHA, BIG_OMEGA, C, DELTA, E, G, GAMMA, MU, OMEGA, STIFFNESS  # noqa: F401 - read as kernel.ALPHA ...
from vrsweep.results import Status
from vrsweep.numerics.records import (  # noqa: F401 - the layouts, read as kernel.REC_*, kernel.SUM_*
    N_RECORD, N_SUMMARY, REC_IMPACTS, REC_LOG_AREA, REC_LOG_STRETCH, REC_QC, REC_QS, REC_STUCK_TIME,
    REC_IMPACT_COS, REC_IMPACT_SIN, REC_IMPACT_SPEED_MAX, REC_IMPACT_SPEED_MIN, REC_IMPACT_SPEED_SUM,
    REC_V, REC_X, REC_X_MAX, REC_X_MIN, SUM_IMPACTS, SUM_IMPACTS_PER_PERIOD, SUM_LYAPUNOV,
    SUM_LYAPUNOV_SUM, SUM_QC, SUM_QS, SUM_Q_AMPLITUDE, SUM_R, SUM_REJECTED, SUM_RHS, SUM_STEPS,
    SUM_FREE_X_MAX, SUM_FREE_X_MAX_TIME, SUM_STICKS, SUM_T_FINAL, SUM_V_FINAL, SUM_WINDOW_X_MAX, SUM_X_FINAL, add_tangent_growth, close_period,
    emit_samples, emit_state, log_impact, log_stick_start, record_impact, start_period, summarize, update_extremes,
    window_top,
)
from vrsweep.numerics.rhs import (  # noqa: F401 - the rotation layout, read as kernel.* by tests
    COS_FAST, COS_SLOW, FULL_STEP_NODE, LEVEL_READY, LEVEL_ROTATIONS, MAX_NODES, NODES,
    N_ROTATION_SCRATCH, N_STEP_LEVELS, PHASE_STEP, PHASE_TIME, RESYNC_STEPS, ROTATED_STEPS, ROTATION,
    ROTATION_VALUES, SIN_FAST, SIN_SLOW, STEP_GRID, STEP_LEVELS_PER_OCTAVE, grid_step, no_preparation,
    no_preparations, no_saltation, no_sliding, no_switches, prepare_rotations_for, UNFROZEN,
    dop853_rotation_scratch, force_at_barrier, no_scratch, oscillator_rhs, oscillator_rhs_rotated, oscillator_tangent,
    oscillator_tangent_rhs, oscillator_tangent_rhs_rotated, prepare_rotations, prepare_step_rotations,
    rotation_scratch,
)
from vrsweep.numerics.settings import (  # noqa: F401 - the settings layout, read as kernel.*
    ATOL, DEFAULT_METHOD, DIVERGENCE_BOUND, MAX_IMPACTS_PER_PERIOD, MAX_STEPS, MEASURE_PERIODS, N_SETTINGS,
    RTOL, SETTING_DEFAULTS, SETTING_NAMES, STICK_VELOCITY, TRANSIENT_PERIODS, TRANSPARENT_FROM, TRANSPARENT_TO,
)
from vrsweep.numerics.state import N_STATE, N_STATE_WITH_TANGENTS, QC_INTEGRAL, QS_INTEGRAL, V, X
from vrsweep.numerics.tangent import (
    apply_saltation, collapse_tangents, record_monodromy, seed_tangents, slide_tangents, tangents_out_of_range,
)

# Impacts are decided on each step's dense output in Bernstein form (impact.find_crossing), which
# sees a graze between a step's ends however long the step: events need no step cap (up to version
# 0.1 a step was capped at 1/8 of the shortest forcing period so that a graze showed as one turning
# point). The cap that stays, coefficients[MAX_STEP], is for accuracy (benchmarks/README.md,
# "Steps without the cap"): without it the controller lets local errors grow to the tolerance,
# and R, a Fourier component about 1e-3 of x's size at g = 30, then needed rtol 1e-6 to 1e-7 and
# more steps than the capped run at rtol 1e-4. Each model sets its own (model.py's shares of the
# forcing periods for the paper's models; a written model's max_step).
# The exact step to an impact is Newton-refined until x is this close to Delta (relative).
IMPACT_POSITION_TOLERANCE = 1e-13
IMPACT_NEWTON_ITERATIONS = 3
# After a slow rebound, the first step covers at most this fraction of the predicted flight.
REBOUND_STEP_FRACTION = 0.25
# A step too long to resolve a departure from the barrier and return is retried this much shorter.
UNRESOLVED_STEP_FACTOR = 0.125
# A rebound at speed v against a force a (the acceleration of a mass at rest there, into the stop)
# rises v**2 / (2 a). Below this many ulps of max(1, |position|) its flight is rounding: x stays
# Delta or moves by an ulp, and whether the next impact is seen at all depends on the method's
# arithmetic. Against a = 2e4 a rebound at the stick speed 1e-7 rises 2.5e-19, and the Zeno tail
# from 1e-5 down gave 178 impacts a period with rk45, 181 to 186 with dop853, for one orbit
# (tests/test_written_sticking.py). Such a rebound sticks: the mass is at rest on the stop to rounding.
STICK_HEIGHT_ULPS = 16.0
STICK_HEIGHT = STICK_HEIGHT_ULPS * float(np.finfo(np.float64).eps)


# Each method's constants for _integrate: (grid_steps, hold_after_reject, initial_order, n_stages).
# grid_steps: step sizes are rounded down to the grid whose forcing rotations dop853's scratch
# tabulates; hold_after_reject: Hairer's DOP853 lets no step grow right after a rejection;
# initial_order: the order initial_step assumes; n_stages: the stages of a step (K[n_stages] is
# the derivative at its end). DOP853_RULES: dop853 with the library's cosines at every stage (no
# 68 kB rotation table: the GPU's, cuda.py).
RK45_RULES = (False, False, ORDER, N_STAGES)
DOP853_ROTATED_RULES = (True, True, dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES)
DOP853_RULES = (False, True, dop853.ERROR_ESTIMATOR_ORDER + 1, dop853.N_STAGES)
# method -> (rules, step, error norm, dense output, accepted / certain growth / rejected step
# factor, rows of K, dense output's order) for a loop whose stages call the model's right-hand side
# (no rotation table): the GPU's kernel (cuda.py) and the benchmarks that model it.
METHOD_PARTS = {
    "rk45": (RK45_RULES, dp54_step, error_norm, dp54_dense, accepted_step_factor, certain_growth,
             rejected_step_factor, N_STAGES + 1, DENSE_ORDER),
    "dop853": (DOP853_RULES, dop853_step, dop853_error_norm, dop853_dense, dop853_accepted_step_factor,
               dop853_certain_growth, dop853_rejected_step_factor, dop853.N_STAGES_EXTENDED, dop853.DENSE_ORDER),
}
# The rows of _integrate's vectors: the state y, the trial step's end y_new, a stage's state and
# the derivative f = y'(t).
Y_ROW, Y_NEW_ROW, STAGE_ROW, F_ROW = range(4)
N_VECTORS = 4


# gather_lanes(waiting)'s answers, at the start of each pass of _integrate's loop: APART, a
# thread alone (the CPU, or a GPU kernel that holds nothing back), whose step's branches follow it
# in the same pass; on a GPU that holds them (cuda.py, HOLD_LANES), HOLD: a lane waiting with a
# kept step waits on; RELEASE: the waiting lanes take their branches now, together.
APART, HOLD, RELEASE = -1, 0, 1
# What a held step waits to do (_integrate's `held`).
ACCEPTED, REACHED = 1, 2


@kernel_jit
def lanes_apart(waiting):
    """_integrate's gather_lanes on the CPU: a thread is alone, nothing to gather or hold."""
    return APART


# A switching surface crossed within this fraction of a step's start is crossed at the step's start:
# the step starts on it (a rounding from it).
SWITCH_SLIVER = 1e-9
# The acceleration jumps at a surface (sign) where the two sides' values at the located crossing
# differ by more than this share of the larger; at a kink (abs, min, max) they differ by rounding.
JUMP_TOLERANCE = 1e-9


@kernel_jit
def _hold_mode(scratch, mode):
    """The frozen mode the right-hand sides read (the scratch's last value; codegen._modes): the
    side of each switching function, a bit each, held for a whole step; UNFROZEN: none held."""
    scratch[scratch.shape[0] - 1] = mode


@kernel_jit
def _smallest_step(t, slow_period):
    """A step this short no longer moves t by more than a few units of its last place."""
    return 4.0 * 2.2e-16 * max(abs(t), slow_period)


# --- the paper's family (model.py, rhs.py), each method with and without the tangent vectors ------

@kernel_jit
def integrate_rk45(coefficients, initial_state, settings, period_records, summary,
                   sample_times, samples, impact_log, stick_log):
    """Integrate one point over transient + measurement periods. Returns a Status code.

    coefficients    (n_coefficients,)        a model's vector: the header of coefficients.py, then
                                              the model's block (model.kernel_coefficients)
    initial_state   (2,)                      x(0), v(0)
    settings        (N_SETTINGS,)            layout above
    period_records  (n_rows, N_RECORD)       the last n_rows periods' records, measure_periods <= n_rows
                                             <= n_periods (a sweep: measure_periods, a trajectory: all)
    summary         (N_SUMMARY,)             filled at the end; R, Qs, Qc NaN unless status OK
    sample_times    (n_samples,)             sorted times for dense samples (may be empty)
    samples         (n_samples, 2)           x, v at sample_times
    impact_log      (n_impact_log, 3)        t, v before, v after, for the first impacts
    stick_log       (n_stick_log, 2)         start and end of the first sticking intervals

    With Dormand-Prince 5(4) steps (integration.method: rk45, integrator.py), the library's
    cosines at every evaluation. Since version 0.2 steps are no longer capped at 1/8 of the
    shortest forcing period, so results differ from those of 0.1 (no longer bit for bit).
    """
    return _integrate(oscillator_rhs, oscillator_rhs, oscillator_tangent, force_at_barrier, no_switches, no_saltation, no_sliding, no_preparations,
                      RK45_RULES, dp54_step, error_norm, dp54_dense, accepted_step_factor, certain_growth,
                      rejected_step_factor, False, (np.empty((N_STAGES + 1, N_STATE)), np.empty((N_STATE, DENSE_ORDER)),
                      np.empty((N_VECTORS, N_STATE)), np.empty(N_BRACKET)), no_scratch(0.0),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)), lanes_apart)


@kernel_jit
def integrate_dop853(coefficients, initial_state, settings, period_records, summary,
                     sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with DOP853 steps (integration.method: dop853, dop853.py).

    Its stages evaluate the forcing by rotating the phases of the step's start (prepare_rotations,
    oscillator_rhs_rotated), on step sizes rounded down to their grid; other evaluations call the
    library (oscillator_rhs).
    """
    return _integrate(oscillator_rhs, oscillator_rhs_rotated, oscillator_tangent, force_at_barrier, no_switches, no_saltation, no_sliding, prepare_rotations_for,
                      DOP853_ROTATED_RULES, dop853_step, dop853_error_norm, dop853_dense,
                      dop853_accepted_step_factor, dop853_certain_growth, dop853_rejected_step_factor, False,
                      (np.empty((dop853.N_STAGES_EXTENDED, N_STATE)), np.empty((N_STATE, dop853.DENSE_ORDER)),
                      np.empty((N_VECTORS, N_STATE)), np.empty(N_BRACKET)),
                      dop853_rotation_scratch(coefficients[MAX_STEP]),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)), lanes_apart)


@kernel_jit
def integrate_rk45_lyapunov(coefficients, initial_state, settings, period_records, summary,
                            sample_times, samples, impact_log, stick_log):
    """integrate_rk45 with the tangent vectors (integration.lyapunov: true; tangent.py).

    The same steps, impacts and records as integrate_rk45 (the tangent vectors take no part in
    error control), plus REC_LOG_STRETCH, REC_LOG_AREA per period and SUM_LYAPUNOV, SUM_LYAPUNOV_SUM.
    It is integrate_rk45_monodromy keeping no period's map, called, not inlined: one compiled loop
    serves both (a model swept with exponents and continued compiles it once; the call is one per
    point, the same speed, benchmarks/README.md).
    """
    return integrate_rk45_monodromy(coefficients, initial_state, settings, period_records, summary,
                                    sample_times, samples, impact_log, stick_log, np.empty((0, 4)))


@kernel_jit
def integrate_dop853_lyapunov(coefficients, initial_state, settings, period_records, summary,
                              sample_times, samples, impact_log, stick_log):
    """integrate_dop853 with the tangent vectors (integration.lyapunov: true; tangent.py):
    integrate_dop853_monodromy keeping no period's map, as integrate_rk45_lyapunov."""
    return integrate_dop853_monodromy(coefficients, initial_state, settings, period_records, summary,
                                      sample_times, samples, impact_log, stick_log, np.empty((0, 4)))


@kernel_jit
def integrate_rk45_monodromy(coefficients, initial_state, settings, period_records, summary,
                             sample_times, samples, impact_log, stick_log, monodromy_log):
    """integrate_rk45_lyapunov that also returns each period's tangent map (continuation).

    monodromy_log (n_periods, 4): row k is the 2x2 matrix d y((k+1)T) / d y(kT) of period k,
    row-major (tangent.record_monodromy); the saltation matrix at every impact is in it, a sticking
    interval makes it zero. No renormalisation: one period's map stays far inside double range
    for the model's damping (tangent.py's TANGENT_RANGE is for runs of many periods).
    """
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs, oscillator_tangent, force_at_barrier, no_switches, no_saltation, no_sliding, no_preparations,
                      RK45_RULES, dp54_step, error_norm, dp54_dense, accepted_step_factor,
                      certain_growth, rejected_step_factor, True,
                      (np.empty((N_STAGES + 1, N_STATE_WITH_TANGENTS)), np.empty((N_STATE_WITH_TANGENTS, DENSE_ORDER)),
                      np.empty((N_VECTORS, N_STATE_WITH_TANGENTS)), np.empty(N_BRACKET)), no_scratch(0.0),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, monodromy_log, lanes_apart)


@kernel_jit
def integrate_dop853_monodromy(coefficients, initial_state, settings, period_records, summary,
                               sample_times, samples, impact_log, stick_log, monodromy_log):
    """integrate_rk45_monodromy with DOP853 steps."""
    return _integrate(oscillator_tangent_rhs, oscillator_tangent_rhs_rotated, oscillator_tangent, force_at_barrier, no_switches, no_saltation, no_sliding, prepare_rotations_for,
                      DOP853_ROTATED_RULES, dop853_step, dop853_error_norm, dop853_dense,
                      dop853_accepted_step_factor, dop853_certain_growth, dop853_rejected_step_factor, True,
                      (np.empty((dop853.N_STAGES_EXTENDED, N_STATE_WITH_TANGENTS)), np.empty((N_STATE_WITH_TANGENTS, dop853.DENSE_ORDER)),
                      np.empty((N_VECTORS, N_STATE_WITH_TANGENTS)), np.empty(N_BRACKET)),
                      dop853_rotation_scratch(coefficients[MAX_STEP]),
                      coefficients, initial_state, settings, period_records, summary,
                      sample_times, samples, impact_log, stick_log, monodromy_log, lanes_apart)


# integration.method -> the kernel. Each is compiled (or loaded from the cache) on its first call,
# so a run compiles only the method it uses.
INTEGRATORS = {"rk45": integrate_rk45, "dop853": integrate_dop853}
METHODS = tuple(INTEGRATORS)
# The same with the tangent vectors (integration.lyapunov: true).
LYAPUNOV_INTEGRATORS = {"rk45": integrate_rk45_lyapunov, "dop853": integrate_dop853_lyapunov}
# With each period's raw tangent map (continuation, numerics/shooting.py).
MONODROMY_INTEGRATORS = {"rk45": integrate_rk45_monodromy, "dop853": integrate_dop853_monodromy}


def integrator(method, lyapunov=False):
    """The kernel for an integration method, with or without the tangent vectors."""
    return (LYAPUNOV_INTEGRATORS if lyapunov else INTEGRATORS)[method]



# Inlined into each method's kernel above, so that the method's functions become direct calls
# (a function passed as a runtime value would be a "dynamic global" and could not be cached).
@kernel_jit(inline="always")
def _integrate(rhs, stage_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface, prepare, rules, step, step_error,
               dense_output, accepted_factor, certain_growth, rejected_factor, tangents, work, scratch, coefficients, initial_state, settings, period_records, summary,
               sample_times, samples, impact_log, stick_log, monodromy_log, gather_lanes):
    """The integration loop of every method; see integrate_rk45 for the arguments.

    rhs(t, h, node, c, y, coefficients, dydt, scratch) is the oscillator at t + c h; tangent(t, y,
    coefficients, dydt) its tangent product J u (tangent.apply_jacobian) and barrier_force(t,
    coefficients, b) the acceleration of a mass at rest on barrier b, positive into it;
    switch_signs(t, x, v, coefficients) the signs of the acceleration's switching functions, one
    bit each (codegen.switching_functions: the argument of abs and sign, the difference of min's
    and max's arguments), -1 (UNFROZEN) for a smooth one (rhs.no_switches), so that a step that crosses a kink
    or jump is cut to end on it (locate_switch) and the method's order holds on each side: the
    paper's family passes rhs.py's, a written model its generated ones (codegen.py);
    switch_saltation(t, y, coefficients, mode, crossing, a_before, a_after) jumps the tangent
    vectors in y by the saltation matrix of the crossed surfaces (bits ``crossing``) where the
    force jumps there (codegen._switch_saltation_body; tangent.apply_switch_saltation) and answers
    whether it changed them (rhs.no_saltation: never); sliding_surface(coefficients, crossing, what)
    says whether the surface of the switch bits ``crossing`` is one the loop slides on, s = gain (v -
    speed) with speed and gain constants: what = 0 gives the speed, 1 the gain, NaN for any other
    surface (codegen._sliding_surface_body; rhs.no_sliding: none); stage_rhs the
    same at a step's stages, after prepare(t, h, coefficients, scratch, dense) (dense: True before a
    dense output, which also prepares the dense output's extra stages), with scratch =
    the method's own (dop853_rotation_scratch(h_max), or no_scratch), whose last value is the
    frozen mode the right-hand sides read (_hold_mode: the side of each switching function held
    for the steps that end on a surface and leave it; rhs.UNFROZEN elsewhere). rules = (grid_steps,
    hold_after_reject, initial_order, n_stages), the method's constants (RK45_RULES ...): grid_steps
    rounds each step size down to grid_step's grid.
    step(stage_rhs, t, y, f, h, coefficients, K, y_new, stage, scratch, n_dynamic) fills K
    (K[n_stages] = f(t + h, y_new)) and y_new; step_error(K, h, y, y_new, rtol, atol) is the scaled
    error norm; certain_growth(err, err_previous) is True only where accepted_factor's result is
    certainly >= 1; dense_output(stage_rhs, t, y, h, coefficients, K, y_new, dense, stage, scratch,
    n_dynamic) fills dense and returns its extra RHS count. tangents: the state carries the
    tangent vectors (state.py) and the right-hand sides integrate them; n_dynamic is the number of
    state components the right-hand sides read. The work arrays are the caller's, so that the loop
    allocates nothing and compiles for a GPU thread as it does for a CPU one (cuda.py); work is the
    tuple (K, dense, vectors, bracket) (one argument: a call of more than 30 arguments is compiled by
    CPython as a call with *args, which numba cannot inline), K (rows,
    n_state) and dense (n_state, order), the method's; vectors (N_VECTORS, n_state), the state, the
    trial state, a stage's state and the derivative (rows Y_ROW ...); bracket (bracket_size(order)
    at least: N_BRACKET holds any method's), find_crossing's, which each barrier's test reuses.

    Each pass of the loop is one of: hold the mass on the barrier up to its release or the period's
    end; or carry it along a sliding surface v = c (a written model's friction: Filippov's sliding
    motion, x = x0 + c (t - t0)) up to its exit or the period's end, the same idea as a stick with
    the surface moving; or attempt a step, and if it is accepted and meets a barrier, locate the impact on its
    dense output; or take one Newton step of the exact step to a located impact (from the same t,
    at most IMPACT_NEWTON_ITERATIONS passes); or, on a GPU that holds branches back, wait with a
    kept step, or take its branches (below). A step accepted without an impact, or the impact's
    last Newton step, feeds the observers, and at an impact the restitution law applies or sticking
    starts. A pass that reaches the period's end closes the period. (The Newton steps are passes,
    not a loop inside one, so that on a GPU a warp's lanes take them with the others' steps.)

    monodromy_log (n, 4): with tangents, the raw one-period tangent map of each of the first n
    periods (record_monodromy); the tangent vectors then restart from the unit vectors every period
    instead of being renormalised. Length 0 (every kernel but the *_monodromy ones): unused.

    gather_lanes(waiting) is called at the start of every pass of the loop: on a GPU (cuda.py) it
    gathers the lanes of a warp that have drifted apart (one took an impact, another a rejected
    step), so that they take the next pass's step together; on the CPU it does nothing and answers
    APART (lanes_apart). A GPU kernel may also hold branches back: a lane whose step needs its
    rare branches (the dense output, the exact barrier test, the impact, a turning point, a sample)
    keeps the step and waits (waiting: True) while the vote answers HOLD, and takes them when it
    answers RELEASE, with the warp's other waiting lanes, so that the warp pays for them once
    rather than at every pass one of its lanes needs them. A held lane computes exactly what it
    would have computed at once: only when it does so changes, relative to the other lanes.
    """
    # The state components the right-hand sides read: x, v (the quadratures are read by nobody),
    # and the tangent vectors when they are integrated.
    n_dynamic = N_STATE_WITH_TANGENTS if tangents else N_DYNAMIC
    rtol = settings[RTOL]
    atol = settings[ATOL]
    n_transient = int(settings[TRANSIENT_PERIODS])
    n_periods = n_transient + int(settings[MEASURE_PERIODS])
    # period_records may hold only the last rows (a sweep keeps the measurement window's, so its
    # memory does not grow with the transient): period k is row max(k - first_row, 0), and the
    # transient's periods before the kept rows all reuse row 0 (start_period resets it).
    first_row = n_periods - period_records.shape[0]
    max_steps = settings[MAX_STEPS]
    max_impacts_per_period = settings[MAX_IMPACTS_PER_PERIOD]
    divergence_bound = settings[DIVERGENCE_BOUND]
    stick_velocity = settings[STICK_VELOCITY]
    n_barriers = int(coefficients[N_BARRIERS])
    response_frequency = coefficients[RESPONSE_FREQUENCY]
    # The transparent window (grazing.py; NaN: none, and every comparison with it is False).
    transparent_from = settings[TRANSPARENT_FROM]
    transparent_to = settings[TRANSPARENT_TO]
    has_window = transparent_from == transparent_from and transparent_to == transparent_to
    transparent = False
    window_x_max = -math.inf
    # Continuation (the *_monodromy kernels) also wants the orbit's highest smooth maximum.
    track_free_maxima = monodromy_log.shape[0] > 0
    free_x_max = -math.inf
    free_x_max_time = math.nan

    slow_period = coefficients[PERIOD]  # the stroboscopic period T
    h_max = coefficients[MAX_STEP]
    stick_scan_step = coefficients[SCAN_STEP]

    grid_steps, hold_after_reject, initial_order, n_stages = rules
    K, dense, vectors, bracket = work
    n_state = K.shape[1]
    y = vectors[Y_ROW]
    y_new = vectors[Y_NEW_ROW]
    stage = vectors[STAGE_ROW]
    f = vectors[F_ROW]
    for j in range(n_state):
        y[j] = 0.0

    y[X] = initial_state[0]
    y[V] = initial_state[1]
    if tangents:
        seed_tangents(y)
    t = 0.0
    # The frozen mode (switching functions, below): none held at the start.
    mode = UNFROZEN
    _hold_mode(scratch, mode)
    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
    n_rhs = 1
    h = initial_step(rhs, t, y, f, coefficients, rtol, atol, h_max, initial_order, scratch, y_new, stage)
    n_rhs += 1
    err_previous = 1.0
    n_steps = 0
    n_rejected = 0
    n_impacts = 0
    n_sticks = 0
    n_scans = 0
    retrying = False
    cut_at_switch = False  # the step being attempted was cut to end on a switching surface
    crossing = 0  # the bits of the switching functions that the cut step crosses at its end
    next_mode = UNFROZEN  # the mode from the accepted step's end on
    landed = False  # the step being attempted leaves a switching surface, frozen on the side it heads to
    jumped = False  # the acceleration jumps at that surface (sign), not only its slope (abs, min, max)
    unchecked = False  # the step being attempted is not tested for switches (a kink touched, below)
    # A located impact being reached: its Newton steps are passes of the loop (reaching), the trial
    # step's size and clipping, the barrier and what else the trial pass decided kept for them.
    reaching = False
    newton_steps = 0
    h_try = h_taken = 0.0
    clipped = impact = sampling = False
    hit = -1
    position = side = restitution = 1.0
    theta_turn = math.nan
    stuck = False
    stuck_at = 0  # the barrier that holds the mass while stuck
    # A Filippov sliding motion on a switching surface s = slide_gain (v - slide_speed) (the bit
    # slide_bit): from (slide_t0, slide_x0) the state is (slide_x0 + slide_speed (t - slide_t0),
    # slide_speed) while the field points into the surface from both sides.
    sliding = False
    slide_bit = 0
    slide_speed = slide_gain = slide_x0 = slide_t0 = 0.0
    # A step whose branches wait for the warp (on a GPU, gather_lanes): ACCEPTED, an accepted step
    # with `near` (bit b: barrier b's quick test could not clear it); REACHED, an impact's last
    # Newton step. On the CPU a step is never held: its branches follow it in the same pass.
    held = 0
    near = 0
    status = Status.OK

    period = 0
    t_boundary = slow_period
    start_period(period_records[0], y[X], tangents)
    next_sample = emit_state(sample_times, samples, 0, 0.0, y[X], y[V])
    # A start at rest on a barrier that the force does not pull away from is stuck from t = 0 (a
    # mass laid on the stop): no impact happened, where the first step would log one of speed 0.
    # Under no force at all it is stuck too, as a zero keeps a stuck mass (impact.release_time):
    # it leaves where the force pulls, and a force that presses next no longer logs that impact
    # (the bouncing ball laid on the table at Gamma = 1, up to 0.7.17).
    for barrier in range(n_barriers):
        slot = BARRIER + BARRIER_VALUES * barrier
        on_side = coefficients[slot + SIDE]
        if (not stuck and y[V] == 0.0 and on_side * y[X] >= on_side * coefficients[slot + POSITION]
                and barrier_force(t, coefficients, barrier) >= 0.0):
            stuck = True
            stuck_at = barrier
            n_sticks = log_stick_start(stick_log, n_sticks, t)
            if tangents:
                collapse_tangents(y)

    while True:
        vote = gather_lanes(held != 0)
        record = period_records[max(period - first_row, 0)]
        if stuck:
            # --- held at (Delta, 0) until the force lets go or the period ends ---
            held_at = coefficients[BARRIER + BARRIER_VALUES * stuck_at + POSITION]
            t_release, scans = release_time(barrier_force, stuck_at, t, t_boundary, coefficients, stick_scan_step,
                                            max_steps - n_scans)
            n_scans += scans
            if t_release != t_release:
                status = Status.MAX_STEPS  # the force scan has a budget of max_steps intervals too
                break
            t_end = min(t_release, t_boundary)
            _add_stuck_quadratures(y, held_at, response_frequency, t, t_end)
            next_sample = emit_state(sample_times, samples, next_sample, t_end, held_at, 0.0)
            record[REC_STUCK_TIME] += t_end - t
            t = t_end
            if t_release <= t_boundary:
                stuck = False
                if n_sticks - 1 < stick_log.shape[0]:
                    stick_log[n_sticks - 1, 1] = t
                rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                n_rhs += 1
                err_previous = 1.0
        elif sliding:
            # --- riding the surface v = slide_speed until the field on one side lets go (Filippov) ---
            t_exit, scans, leaves = _sliding_exit(rhs, switch_signs, t, t_boundary, slide_t0, slide_x0, slide_speed,
                                                  slide_gain, slide_bit, coefficients, y, f, scratch,
                                                  stick_scan_step, max_steps - n_scans)
            n_scans += scans
            n_rhs += 2 * (scans + 1)  # each scan's two fields, and the two at the start
            y[X] = slide_x0 + slide_speed * (t - slide_t0)  # the scan left its trial states in y
            y[V] = slide_speed
            if t_exit != t_exit:
                status = Status.MAX_STEPS  # the exit scan has a budget of max_steps intervals, as a stick's
                break
            t_end = min(t_exit, t_boundary)
            x_end = slide_x0 + slide_speed * (t_end - slide_t0)
            onto_barrier = False
            for barrier in range(n_barriers):
                slot = BARRIER + BARRIER_VALUES * barrier
                if coefficients[slot + SIDE] * (x_end - coefficients[slot + POSITION]) > 0.0:
                    onto_barrier = True
            if onto_barrier:
                status = Status.SLIDING  # carried onto a stop by the belt: not followed
                break
            _add_sliding_quadratures(y, slide_t0, slide_x0, slide_speed, response_frequency, t, t_end)
            while next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_end:
                samples[next_sample, 0] = slide_x0 + slide_speed * (sample_times[next_sample] - slide_t0)
                samples[next_sample, 1] = slide_speed
                next_sample += 1
            record[REC_STUCK_TIME] += t_end - t
            record[REC_X_MIN] = min(record[REC_X_MIN], x_end)
            record[REC_X_MAX] = max(record[REC_X_MAX], x_end)
            # Continuation's tops (grazing.py): on the surface x = x0 + c (t - t0) is monotone, so
            # its largest x is at an end, the entry for c <= 0 and the exit for c > 0. On a floor
            # (c = 0) a mass that sticks at the top of its swing has its maximum there, and the
            # steps on either side, ending and starting at v = 0, never showed v turning from + to
            # - (free_x_max was -inf on such an orbit, up to 0.7.7). The window's share is where
            # the segment overlaps it.
            if slide_speed > 0.0:
                t_top = t_end
                x_top = x_end
            else:
                t_top = t
                x_top = y[X]
            if has_window:
                t_low = max(t, transparent_from)
                t_high = min(t_end, transparent_to)
                if t_low <= t_high:
                    t_in = t_high if slide_speed > 0.0 else t_low
                    window_x_max = max(window_x_max, slide_x0 + slide_speed * (t_in - slide_t0))
            if track_free_maxima and x_top > free_x_max and not (
                    has_window and transparent_from <= t_top < transparent_to):
                free_x_max = x_top
                free_x_max_time = t_top
            t = t_end
            y[X] = x_end
            y[V] = slide_speed
            if leaves != 0 and t_exit <= t_boundary:
                # Off the surface on the side whose field no longer points into it, frozen there for
                # the step that leaves, as after a crossing. The tangent vectors go on unchanged:
                # that side's field equals the sliding one where it lets go, S = I.
                sliding = False
                if n_sticks - 1 < stick_log.shape[0]:
                    stick_log[n_sticks - 1, 1] = t
                others = switch_signs(t, x_end, slide_speed, coefficients) & ~slide_bit
                mode = float(others | slide_bit) if leaves > 0 else float(others)
                _hold_mode(scratch, mode)
                rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                n_rhs += 1
                landed = True
                jumped = True
                cut_at_switch = False
                unchecked = False
                err_previous = 1.0
        elif held and vote == HOLD:
            continue  # the kept step's branches wait for the warp's release
        else:
            if not held:
                if reaching:
                    # --- the impact's exact step: a Newton iterate of its size, from the same t ---
                    h_step = h_taken
                else:
                    # --- attempt a step ---
                    if n_steps >= max_steps:
                        status = Status.MAX_STEPS
                        break
                    if not (h > _smallest_step(t, slow_period)):
                        # An overflowing start (g = 1e200: the first step estimate is 0 or NaN) would
                        # otherwise take zero-length steps up to the step cap. An infinite derivative
                        # (a written 1/x at x = 0) makes the estimate 0 too: not a tolerance's fault.
                        finite = h == h and math.isfinite(f[X]) and math.isfinite(f[V])
                        status = Status.STEP_TOO_SMALL if finite else Status.NON_FINITE
                        break
                    h_try = min(h, h_max)
                    if grid_steps and not cut_at_switch:  # a step cut to a switch ends on it exactly
                        h_try = grid_step(h_try, scratch)  # a step size whose rotations are tabulated
                    if has_window:
                        # A step ends on each edge of the transparent window, so that each step is wholly
                        # inside it or outside (a sliver left before an edge is judged by its midpoint).
                        if t < transparent_from - _smallest_step(t, slow_period) and t + h_try > transparent_from:
                            h_try = transparent_from - t
                        elif t < transparent_to - _smallest_step(t, slow_period) and t + h_try > transparent_to:
                            h_try = transparent_to - t
                        transparent = transparent_from <= t + 0.5 * h_try < transparent_to
                    clipped = False
                    # land on the boundary, no sliver step after it (a step cut to a switch before it
                    # ends on the switch)
                    if t + 1.01 * h_try >= t_boundary and not (cut_at_switch and t + h_try < t_boundary):
                        h_try = t_boundary - t
                        clipped = True
                    h_step = h_try
                # One call of the step for both: on a GPU the lanes of a warp that reach an impact
                # take their Newton steps with the others' ordinary steps, not while those wait.
                prepare(t, h_step, coefficients, scratch, False)
                step(stage_rhs, t, y, f, h_step, coefficients, K, y_new, stage, scratch, n_dynamic)
                n_rhs += n_stages
                if reaching:
                    # Newton on x(t + h) = Delta, at most IMPACT_NEWTON_ITERATIONS steps (eq2.2's impact)
                    newton_steps += 1
                    miss = y_new[X] - position
                    if not (abs(miss) <= IMPACT_POSITION_TOLERANCE * max(1.0, abs(position))
                            or side * y_new[V] <= 0.0):
                        h_corrected = h_taken - miss / y_new[V]
                        if 0.0 < h_corrected <= h_try:
                            h_taken = h_corrected
                            if newton_steps < IMPACT_NEWTON_ITERATIONS:
                                continue  # the next pass steps to the corrected size
                    reaching = False
                    held = REACHED
                else:
                    n_steps += 1
                    if mode < 0.0 and not unchecked:
                        signs = switch_signs(t, y[X], y[V], coefficients)
                        if switch_signs(t + h_try, y_new[X], y_new[V], coefficients) != signs:
                            # The step crosses a switching surface: taken again frozen on the side it
                            # starts on, so that its error estimate is that of one smooth field (see below)
                            mode = float(signs)
                            _hold_mode(scratch, mode)
                            rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                            n_rhs += 1
                            h = h_try
                            continue
                    err = step_error(K, h_try, y, y_new, rtol, atol)
                    if not (err <= 1.0):  # also catches NaN from an overflowing trial step
                        n_rejected += 1
                        retrying = True
                        cut_at_switch = False
                        unchecked = False
                        if mode < 0.0:
                            # Retried frozen on the side it starts on: stages beyond a surface that the
                            # step's end does not cross (a field pointing into it from both sides, at
                            # the mass's arrival at a stick) were each side's field in turn, an error no
                            # step size cured: the steps crept up to the surface, 1e-9 long, never
                            # crossing it (millions of steps). Frozen, the step crosses and is cut there.
                            # (A smooth model's switch_signs is UNFROZEN, a constant: its mode stays
                            # unfrozen, and the frozen branches fold away as before; its steps are the same.)
                            mode = float(switch_signs(t, y[X], y[V], coefficients))
                            _hold_mode(scratch, mode)
                        h = h_try * (rejected_factor(err) if err == err else 0.2)
                        if h <= _smallest_step(t, slow_period):
                            status = Status.STEP_TOO_SMALL if err == err else Status.NON_FINITE
                            break
                        continue
                    # A switching surface of the acceleration inside the step (a kink of abs, min,
                    # max; a jump of sign): the step is taken again to end on it, as an impact is
                    # reached, so that each step sees one smooth side and the method keeps its order
                    # (across a kink the error estimate only shrinks the step: R of a bilinear spring
                    # was 1.5e-6 off at rtol 1e-6). The step that ends there, and the next, which
                    # leaves it, each hold every switch on one side for all their stages, the frozen
                    # mode (codegen.frozen_acceleration): their first and last stages lie a rounding
                    # from the surface, on either side, and across a jump (friction's sign(v)) or a
                    # jump of the Jacobian (the tangent vectors at a kink) one such stage is an error
                    # of the jump times the step, at any rtol. The step that leaves the surface holds
                    # the side the trajectory crossed to; where its field at once turns back to the
                    # surface, and the acceleration jumps there, the field points into the surface
                    # from both sides: a sliding motion (Filippov), followed on v = constant (the
                    # sliding pass above), the status SLIDING elsewhere.
                    next_mode = mode
                    departing = False  # the step leaves a sliding surface, its end on it to rounding
                    if cut_at_switch:
                        next_mode = float(int(mode) ^ crossing)  # on the surface: the side it heads to
                    elif mode >= 0.0:
                        signs = int(mode)
                        if switch_signs(t + h_try, y_new[X], y_new[V], coefficients) != signs:
                            prepare(t, h_try, coefficients, scratch, True)
                            n_rhs += dense_output(stage_rhs, t, y, h_try, coefficients, K, y_new, dense, stage,
                                                  scratch, n_dynamic)
                            theta = locate_switch(switch_signs, signs, dense, y, t, h_try, coefficients)
                            crossed = signs ^ switch_signs(t + theta * h_try, dense_value(dense, y, h_try, theta, X),
                                                           dense_value(dense, y, h_try, theta, V), coefficients)
                            if SWITCH_SLIVER < theta < 1.0 and theta * h_try > _smallest_step(t, slow_period):
                                h = theta * h_try
                                cut_at_switch = True
                                crossing = crossed
                                continue
                            if theta < 1.0:
                                # crossed at the step's start: the step starts on the surface
                                if landed:
                                    # and the side it crossed to turns back at once
                                    if jumped:
                                        # the field points into the surface from both sides: slide on
                                        # it where it is v = speed (Filippov), else end `sliding`
                                        speed = sliding_surface(coefficients, crossed, 0)
                                        gain = sliding_surface(coefficients, crossed, 1)
                                        if speed == speed:
                                            v_start = y[V]
                                            below, above = _sliding_rates(rhs, switch_signs, t, y[X], speed, gain,
                                                                          crossed, coefficients, y, f, scratch)
                                            n_rhs += 2
                                            if below > 0.0 and above < 0.0:
                                                sliding = True
                                                slide_bit = crossed
                                                slide_speed = speed
                                                slide_gain = gain
                                                slide_x0 = y[X]
                                                slide_t0 = t
                                                n_sticks = log_stick_start(stick_log, n_sticks, t)
                                                if tangents:
                                                    slide_tangents(y, monodromy_log.shape[0] > 0)
                                                landed = False
                                                mode = UNFROZEN
                                                continue
                                            # The surface's own fields say the motion does not slide:
                                            # the step's end came back a rounding or a truncation
                                            # across, not the field. Leaving a slide the field on the
                                            # side left to is tangent to v = speed (it lets go where
                                            # its ds/dt reaches 0), so the step that leaves moves off
                                            # as h^2: a step of 3e-10 (the one that cut to the
                                            # surface before the slide) ended on v = speed exactly,
                                            # and the point ended `sliding` (belt, rk45 at rtol 1e-9,
                                            # t = 28.87; tests/test_written_sliding.py). The mass
                                            # goes to the side whose field leads away, as at a
                                            # slide's exit (_sliding_exit); frozen on it already,
                                            # the step is taken as it is, still frozen there.
                                            y[V] = v_start  # _sliding_rates left (x, speed) in y
                                            others = int(mode) & ~crossed
                                            heads = float(others | crossed) if (above >= 0.0 and above >= -below) \
                                                else float(others)
                                            departing = heads == mode
                                            mode = heads
                                            _hold_mode(scratch, mode)
                                            rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                                            n_rhs += 1
                                            if not departing:
                                                h = h_try
                                                continue
                                        else:
                                            status = Status.SLIDING
                                            break
                                    else:
                                        mode = UNFROZEN  # a kink touched, not crossed: taken unfrozen, as it is
                                        unchecked = True
                                else:
                                    # a start on the surface (at rest on sign(v)'s): frozen on the side it heads to
                                    mode = float(signs ^ crossed)
                                    landed = True
                                if not departing:
                                    _hold_mode(scratch, mode)
                                    before = f[V]
                                    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                                    n_rhs += 1
                                    jumped = abs(f[V] - before) > JUMP_TOLERANCE * max(abs(f[V]), abs(before))
                                    h = h_try
                                    continue
                        # off the surface, on the held side; or still leaving it (departing, above): on
                        # the surface to rounding, frozen on the side it leaves to for the next step too
                        next_mode = mode if departing else UNFROZEN
                    cut_at_switch = False
                    unchecked = False
                    landed = departing
                    # The next step is at the cap whenever h >= h_max, whatever h's value: so the factor
                    # (two pow calls) is computed only where it can matter, with bit for bit the same steps.
                    if clipped and h >= h_max:
                        h_next = h  # h = max(h_next, h) below stays >= h_max whatever the factor
                    elif h_try >= h_max and certain_growth(err, err_previous):
                        h_next = h_try  # the factor is >= 1: h_try * factor >= h_max
                    else:
                        h_next = h_try * accepted_factor(err, err_previous)
                    if retrying and hold_after_reject:
                        h_next = min(h_next, h_try)  # Hairer's DOP853: no growth right after a rejection
                    retrying = False
                    err_previous = err
                    h = max(h_next, h) if clipped else h_next
                    held = ACCEPTED
                    # Which barriers the step's ends alone cannot place far from: those get the dense
                    # output and the exact test below. A barrier below (SIDE -1) is the same problem
                    # seen in -x (a barrier above multiplies by 1, exact).
                    near = 0
                    for barrier in range(0 if transparent else n_barriers):
                        slot = BARRIER + BARRIER_VALUES * barrier
                        side = coefficients[slot + SIDE]
                        level = side * coefficients[slot + POSITION]
                        if (side * y_new[X] >= level or side * y[X] >= level
                                or hermite_reach(side * y[X], side * y[V], side * f[V], side * y_new[X],
                                                 side * y_new[V], side * K[n_stages, V], h_try, level) >= 0.0):
                            near |= 1 << barrier
                # a sample inside the step (its end if it has no impact): read by the branches below
                sampling = next_sample < sample_times.shape[0] and sample_times[next_sample] <= (
                    t_boundary if clipped else t + h_try)
                if vote != APART and (held == REACHED or near != 0 or y[V] * y_new[V] < 0.0 or sampling):
                    continue  # on a GPU: the step is kept, its branches taken with the warp's others
            # --- the step's branches (at once on the CPU; on a GPU when the warp releases them) ---
            kept = held
            held = 0
            # The step's dense output, computed once here for every branch below that reads it: an
            # impact's last Newton step; a barrier the ends alone cannot clear (near: its exact
            # test); a sample inside the step; a turn of v (the period's extremes). The same
            # condition as a GPU's held step above. One call site, not one per branch: dop853's
            # dense output inlines three more stages of the model, and each site was compiled anew.
            if kept == REACHED or near != 0 or sampling or y[V] * y_new[V] < 0.0:
                h_dense = h_taken if kept == REACHED else h_try
                prepare(t, h_dense, coefficients, scratch, True)
                n_rhs += dense_output(stage_rhs, t, y, h_dense, coefficients, K, y_new, dense, stage, scratch,
                                      n_dynamic)
            if kept != REACHED:
                # --- does the step cross a barrier? ---
                # Barrier tests run on the mirrored step (_mirror) for a barrier below, which keeps
                # every theta.
                impact = False
                theta_turn = math.nan
                hit = -1  # the barrier the step meets first, between theta hit_low and hit_high
                hit_low = hit_high = 0.0
                unresolved = False
                position = side = restitution = 1.0
                for barrier in range(0 if transparent else n_barriers):
                    if not (near >> barrier) & 1:
                        continue
                    slot = BARRIER + BARRIER_VALUES * barrier
                    side = coefficients[slot + SIDE]
                    level = side * coefficients[slot + POSITION]
                    # Every step that the ends alone cannot place far from the barrier has its dense
                    # output (above) and the exact test on it (find_crossing: Bernstein form).
                    pushed = side * y[X] >= level and barrier_force(t, coefficients, barrier) > 0.0
                    if side < 0.0:
                        _mirror(y, y_new, dense)
                    verdict = find_crossing(dense, y, y_new, h_try, level, pushed, bracket)
                    if side < 0.0:
                        _mirror(y, y_new, dense)
                    if verdict == UNRESOLVED:
                        unresolved = True
                        break
                    if verdict == IMPACT:
                        if hit < 0 or bracket[1] < hit_high:
                            hit = barrier
                            hit_low = bracket[0]
                            hit_high = bracket[1]
                    elif bracket[TURNING_POINT] == bracket[TURNING_POINT]:
                        theta_turn = bracket[TURNING_POINT]
                if unresolved:
                    # Off the barrier and back within the first scan interval: look closer.
                    h = h_try * UNRESOLVED_STEP_FACTOR
                    if h <= _smallest_step(t, slow_period):
                        status = Status.STEP_TOO_SMALL
                        break
                    continue
                impact = hit >= 0
                if impact:
                    slot = BARRIER + BARRIER_VALUES * hit
                    side = coefficients[slot + SIDE]
                    position = coefficients[slot + POSITION]
                    restitution = coefficients[slot + RESTITUTION]
                    # Located on the dense output; the exact step is taken in the next passes.
                    if hit_low < hit_high:
                        theta = locate_root(dense, y, h_try, X, position, hit_low, hit_high)
                    else:
                        theta = hit_high
                    h_taken = theta * h_try
                    reaching = True
                    newton_steps = 0
                    continue
                h_taken = h_try

            # --- observers: samples and the period's extremes, on the step's dense output ---
            t_new = t_boundary if (clipped and not impact) else t + h_taken
            if next_sample < sample_times.shape[0] and sample_times[next_sample] <= t_new:
                next_sample = emit_samples(sample_times, samples, next_sample, t, h_taken, y, dense, t_new)
            update_extremes(record, dense, y, y_new, h_taken, theta_turn)
            if transparent:
                window_x_max = window_top(window_x_max, dense, y, y_new, h_taken)
            elif track_free_maxima and y[V] > 0.0 and y_new[V] < 0.0:  # dense is ready: see above
                theta = locate_root(dense, y, h_taken, V, 0.0, 0.0, 1.0)
                x_turn = dense_value(dense, y, h_taken, theta, X)
                if x_turn > free_x_max:
                    free_x_max = x_turn
                    free_x_max_time = t + theta * h_taken

            # --- advance ---
            t = t_new
            for j in range(n_state):
                y[j] = y_new[j]
                f[j] = K[n_stages, j]
            if impact:
                next_mode = UNFROZEN  # the state jumps: every switch on the side it is on
            if next_mode != mode:
                landing = mode >= 0.0 and next_mode >= 0.0
                mode = next_mode
                _hold_mode(scratch, mode)
                if landing:
                    # On the surface, the next step frozen on the side it heads to: f is that side's
                    before = f[V]
                    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                    n_rhs += 1
                    jumped = abs(f[V] - before) > JUMP_TOLERANCE * max(abs(f[V]), abs(before))
                    landed = True
                    # Where the force jumps there (sign(v)), so do the tangent vectors: a neighbour
                    # crosses a little earlier or later and spends the difference in the other
                    # side's field (the saltation matrix; without it lambda_1 of Coulomb friction
                    # was 1.5e-2 off, tests/test_written_saltation.py)
                    if tangents and switch_saltation(t, y, coefficients, mode, crossing, before, f[V]):
                        rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)  # f of the jumped tangent vectors
                        n_rhs += 1
                    # Filippov's test at the arrival, where both fields are known: where each side's
                    # points into a sliding surface, the mass rides it from here. Up to 0.7.8 the
                    # slide began only when the next step, frozen on the side crossed to, came back
                    # across; near the sliding region's edge that side's field turns within the step
                    # (v dips under the belt's speed and rises again), its end lies on the side it
                    # started, and the stick was stepped over with status ok: belt friction at omega
                    # 1.5, mu 0.72, dop853 at rtol 1e-10 logged 38 sticks where SciPy has 52, x off
                    # by 2e-3 (tests/test_written_sliding.py).
                    speed = sliding_surface(coefficients, crossing, 0) if jumped else math.nan
                    if speed == speed:
                        gain = sliding_surface(coefficients, crossing, 1)
                        v_start = y[V]
                        below, above = _sliding_rates(rhs, switch_signs, t, y[X], speed, gain, crossing,
                                                      coefficients, y, f, scratch)
                        n_rhs += 2
                        if below > 0.0 and above < 0.0:
                            sliding = True
                            slide_bit = crossing
                            slide_speed = speed
                            slide_gain = gain
                            slide_x0 = y[X]
                            slide_t0 = t
                            n_sticks = log_stick_start(stick_log, n_sticks, t)
                            if tangents:
                                slide_tangents(y, monodromy_log.shape[0] > 0)
                            landed = False
                            mode = UNFROZEN
                        else:  # it crosses (or leaves): the step from here as before, frozen on the side it heads to
                            y[V] = v_start
                            _hold_mode(scratch, mode)
                            rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                            n_rhs += 1

            # --- the impact: restitution (eq2.2), or the start of sticking ---
            if impact:
                y[X] = position  # the exact step left it within IMPACT_POSITION_TOLERANCE
                n_impacts += 1
                record[REC_IMPACTS] += 1.0
                if side > 0.0:
                    record[REC_X_MAX] = position
                else:
                    record[REC_X_MIN] = position
                if record[REC_IMPACTS] > max_impacts_per_period:
                    status = Status.CHATTER_LIMIT
                    break
                # Speeds and accelerations into the barrier (side * ...): eq2.2 and the saltation
                # matrix are written for a barrier above; seen in -x, one below is the same.
                acceleration_before = side * f[V]
                v_before, v_after, stuck, push = _restitution(y, t, coefficients, barrier_force, hit, side,
                                                              restitution, stick_velocity)
                log_impact(impact_log, n_impacts, t, side * v_before, side * v_after)
                record_impact(record, v_before, response_frequency * t)
                if stuck:
                    stuck_at = hit
                    n_sticks = log_stick_start(stick_log, n_sticks, t)
                    if tangents:
                        collapse_tangents(y)
                else:
                    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
                    n_rhs += 1
                    if tangents:
                        apply_saltation(y, v_before, acceleration_before, side * f[V], restitution)
                        tangent(t, y, coefficients, f)  # f of the jumped tangent vectors
                    h = _rebound_step(h, v_after, push)
                err_previous = 1.0

            if tangents and monodromy_log.shape[0] == 0 and tangents_out_of_range(y):
                # A strongly damped or stretched period would underflow or overflow them before
                # its end: renormalise now, the period's record sums the logs.
                add_tangent_growth(record, y)
                tangent(t, y, coefficients, f)

            if not (math.isfinite(y[X]) and math.isfinite(y[V])):
                status = Status.NON_FINITE
                break
            if abs(y[X]) > divergence_bound or abs(y[V]) > divergence_bound:
                status = Status.DIVERGED
                break

        if t >= t_boundary:
            raw = tangents and period < monodromy_log.shape[0]
            if raw:
                record_monodromy(monodromy_log[period], y)
            close_period(record, t, y, f, tangent, coefficients, tangents, stuck)
            if raw and not stuck:
                seed_tangents(y)  # the next period's map starts from the identity, not from Q
                tangent(t, y, coefficients, f)
            if tangents and sliding:
                slide_tangents(y, monodromy_log.shape[0] > 0)  # renormalised or seeded afresh, still on the surface
            period += 1
            if period == n_periods:
                break
            t_boundary = (period + 1) * slow_period
            start_period(period_records[max(period - first_row, 0)], y[X], tangents)

    if (stuck or sliding) and n_sticks - 1 < stick_log.shape[0]:
        stick_log[n_sticks - 1, 1] = t
    status = summarize(period_records, n_transient - first_row, n_periods - first_row, slow_period,
                       coefficients[RESPONSE_SCALE], status, summary)
    summary[SUM_STEPS] = n_steps
    summary[SUM_REJECTED] = n_rejected
    summary[SUM_RHS] = n_rhs
    summary[SUM_X_FINAL] = y[X]
    summary[SUM_V_FINAL] = y[V]
    summary[SUM_T_FINAL] = t
    summary[SUM_IMPACTS] = n_impacts
    summary[SUM_STICKS] = n_sticks
    summary[SUM_WINDOW_X_MAX] = window_x_max
    summary[SUM_FREE_X_MAX] = free_x_max
    summary[SUM_FREE_X_MAX_TIME] = free_x_max_time
    return status


@kernel_jit(inline="always")
def _restitution(y, t, coefficients, barrier_force, barrier, side, restitution, stick_velocity):
    """The impact law at a barrier: v -> -e v (eq2.2), or sticking. Returns (v_before, v_after,
    stuck, force), the speeds into the barrier (side * v) and the force at rest on it, which
    _rebound_step reuses (one evaluation an impact).

    The mass sticks when chatter has died out and the force at rest on the barrier presses it
    there: the rebound is slower than stick_velocity, or its flight rises less than the rounding of
    the position (STICK_HEIGHT), where the next impact would be decided by rounding.
    """
    v_before = max(side * y[V], 0.0)
    v_after = -restitution * v_before  # eq2.2
    force = barrier_force(t, coefficients, barrier)
    height = STICK_HEIGHT * max(1.0, abs(coefficients[BARRIER + BARRIER_VALUES * barrier + POSITION]))
    stuck = force > 0.0 and (-v_after < stick_velocity or v_after * v_after < 2.0 * force * height)
    if stuck:
        v_after = 0.0
    y[V] = side * v_after
    return v_before, v_after, stuck, force


@kernel_jit
def _rebound_step(h, v_after, push):
    """The next step size after a rebound: a slow rebound against a force pushing back (push, the
    force at rest on the barrier at the impact) returns after about 2 |v| / a, so the step stays
    well inside that flight and its return is seen."""
    if push > 0.0:
        return min(h, REBOUND_STEP_FRACTION * 2.0 * -v_after / push)
    return h


@kernel_jit
def _add_stuck_quadratures(y, position, frequency, t_start, t_end):
    """eq3.1, eq3.2 integrands over [t_start, t_end] with x = position held: in closed form."""
    y[QS_INTEGRAL] += position * (math.cos(frequency * t_start) - math.cos(frequency * t_end)) / frequency
    y[QC_INTEGRAL] += position * (math.sin(frequency * t_end) - math.sin(frequency * t_start)) / frequency


@kernel_jit
def _mirror(y, y_new, dense):
    """x -> -x, v -> -v in a step's ends and dense output (a barrier below seen as one above).
    Negation is exact: calling it twice restores every bit."""
    y[X] = -y[X]
    y[V] = -y[V]
    y_new[X] = -y_new[X]
    y_new[V] = -y_new[V]
    for q in range(dense.shape[1]):
        dense[X, q] = -dense[X, q]
        dense[V, q] = -dense[V, q]


@kernel_jit(inline="always")
def _sliding_rates(rhs, switch_signs, t, x, speed, gain, bit, coefficients, y, f, scratch):
    """ds/dt on each side of a sliding surface s = gain (v - speed) at (t, x, speed): (the field where
    s < 0, the field where s > 0), every other switch on the side the state is on. With speed and
    gain constants ds/dt = gain a. The motion slides while the first is positive and the second
    negative: each side's field points into the surface. Leaves y at (x, speed), f the second field."""
    others = switch_signs(t, x, speed, coefficients) & ~bit
    y[X] = x
    y[V] = speed
    _hold_mode(scratch, float(others))
    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
    below = gain * f[V]
    _hold_mode(scratch, float(others | bit))
    rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
    return below, gain * f[V]


# The exit scan along a slide steps at most this share of the way to where the margin of the
# sliding condition, falling at the rate of the last interval, would reach zero, and no less than
# SLIDE_SCAN_SMALLEST of the scan step.
SLIDE_SCAN_SHARE = 0.5
SLIDE_SCAN_SMALLEST = 1.0 / 1024.0


@kernel_jit(inline="always")
def _sliding_exit(rhs, switch_signs, t_start, t_limit, t0, x0, speed, gain, bit, coefficients, y, f, scratch,
                  scan_step, max_scans):
    """The end of a sliding motion x = x0 + speed (t - t0), v = speed, from t_start: the first t in
    (t_start, t_limit] where the field on one side leads away from the surface (_sliding_rates),
    scanned and bisected to rounding, as a stuck mass's release (impact.release_time): the t
    returned is the first found past the root. A field that only turns tangent (its ds/dt 0) and
    back keeps the slide, as a force that only touches zero keeps a stuck mass: dry friction
    mu sign(v) against F cos t at F = mu exactly (0 in doubles at the double nearest 2 pi, where a
    period's scan ends) let the resting mass go there, up to 0.7.17, and it crept by 1e-18 a period.
    Returns (t, scans, side): side -1 or +1, the side of s it leaves to; 0 and t_limit + 1 if it
    still slides at t_limit; t NaN if max_scans intervals reached neither.
    The fields are evaluated at scans + 1 points (_sliding_rates: two each), the start's included.

    The scan step is scan_step (a share of the fastest force's period: the explicit time), cut
    where the margin min(below, -above) falls: the state moves along the slide, and on a fast belt
    the force changes with x far faster than with t (a double-well spring at speed 2.5 let go at
    t = 0.46, the exit at 0.207 stepped over, up to 0.7.8). The cut is SLIDE_SCAN_SHARE of the way
    to the margin's zero at the rate of the last interval (the first from a probe of the smallest
    scan beside the start)."""
    below, above = _sliding_rates(rhs, switch_signs, t_start, x0 + speed * (t_start - t0), speed, gain, bit,
                                  coefficients, y, f, scratch)
    margin = min(below, -above)
    smallest = SLIDE_SCAN_SMALLEST * scan_step
    rate = 0.0
    probe = True  # the first interval is a probe of the smallest scan: the margin's rate at the start
    t_a = t_start
    scans = 0
    while t_a < t_limit:
        if scans >= max_scans:
            return np.nan, scans, 0
        scans += 1
        step = scan_step
        if probe:
            step = smallest
        elif rate < 0.0:
            step = min(scan_step, max(smallest, SLIDE_SCAN_SHARE * margin / -rate))
        t_b = min(t_a + step, t_limit)
        below, above = _sliding_rates(rhs, switch_signs, t_b, x0 + speed * (t_b - t0), speed, gain, bit,
                                      coefficients, y, f, scratch)
        if below < 0.0 or above > 0.0:
            for _ in range(MAX_ROOT_ITERATIONS):
                t_mid = 0.5 * (t_a + t_b)
                if t_mid <= t_a or t_mid >= t_b:
                    break
                middle_below, middle_above = _sliding_rates(rhs, switch_signs, t_mid, x0 + speed * (t_mid - t0), speed,
                                                            gain, bit, coefficients, y, f, scratch)
                scans += 1
                if middle_below >= 0.0 and middle_above <= 0.0:
                    t_a = t_mid
                else:
                    t_b = t_mid
                    below = middle_below
                    above = middle_above
            # the side whose field leads away; where both do (a corner), the faster
            return t_b, scans, (1 if above >= 0.0 and above >= -below else -1)
        margin_b = min(below, -above)
        rate = (margin_b - margin) / (t_b - t_a)
        margin = margin_b
        probe = False
        t_a = t_b
    return t_limit + 1.0, scans, 0


@kernel_jit
def _add_sliding_quadratures(y, t0, x0, speed, frequency, t_start, t_end):
    """eq3.1, eq3.2 integrands over [t_start, t_end] along x = x0 + speed (t - t0): in closed form
    (integrated by parts; speed = 0 is _add_stuck_quadratures')."""
    x_start = x0 + speed * (t_start - t0)
    x_end = x0 + speed * (t_end - t0)
    cos_start = math.cos(frequency * t_start)
    cos_end = math.cos(frequency * t_end)
    sin_start = math.sin(frequency * t_start)
    sin_end = math.sin(frequency * t_end)
    y[QS_INTEGRAL] += ((x_start * cos_start - x_end * cos_end) / frequency
                       + speed * (sin_end - sin_start) / (frequency * frequency))
    y[QC_INTEGRAL] += ((x_end * sin_end - x_start * sin_start) / frequency
                       + speed * (cos_end - cos_start) / (frequency * frequency))
