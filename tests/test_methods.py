"""The integration methods (integration.method): their orders, and that they agree.

- Convergence order: fixed steps of each method on a smooth closed-form problem (the linear
  oscillator of tests/closed_form.py with both forcings, no barrier); the global error's slope
  against the step size is the method's order, 5 for rk45 and 8 for dop853.
- Dense output order: one step from the exact state, the interpolant at mid-step; its error
  falls as h^(q+1), q = 4 for DP5(4)'s continuous extension and 7 for DOP853's.
- Agreement: at tight tolerance the methods give the same impacts, sticking and grazing, and
  the same R, to within their tolerances (neither is the reference of the other: both are
  also checked against closed forms and SciPy in test_kernel.py).
"""

import math

import numpy as np
import pytest
from numba import njit

from vrsweep.numerics import dop853
from vrsweep.numerics import rk45 as integrator
from vrsweep.numerics import kernel
from vrsweep.numerics.dop853 import dop853_dense, dop853_step
from vrsweep.numerics.rk45 import DP54_C, dense_value, dp54_dense, dp54_step
from vrsweep.numerics.kernel import (
    N_STATE, dop853_rotation_scratch, no_preparation, no_scratch, oscillator_rhs, oscillator_rhs_rotated, prepare_rotations,
    rotation_scratch,
)
from vrsweep.numerics.impact import locate_root
from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
from vrsweep.numerics.records import N_RECORD, REC_X_MAX, REC_X_MIN, _inside_extremes
from vrsweep.numerics.rhs import ROTATION, ROTATION_VALUES, prepare_step_rotations
from vrsweep.results import Status
from vrsweep.numerics.trajectory import settings_vector, simulate

from closed_form import LinearOscillator
from reference import coefficient_vector

# method -> (step, dense output, rows of K, FSAL row, order, dense-output order) and the kernel's
# stage right-hand side for it: (rhs, its per-step preparation, its scratch, the nodes)
STEPPERS = {
    "rk45": (dp54_step, dp54_dense, integrator.N_STAGES + 1, integrator.N_STAGES, 5, 4),
    "dop853": (dop853_step, dop853_dense, dop853.N_STAGES_EXTENDED, dop853.N_STAGES, 8, 7),
}
STAGE_RHS = {
    "rk45": (oscillator_rhs, no_preparation, no_scratch, DP54_C),
    "dop853": (oscillator_rhs_rotated, prepare_rotations, dop853_rotation_scratch, dop853.C_STAGES),
}
assert set(STEPPERS) == set(kernel.INTEGRATORS)

# x'' + x = 0.3 cos(0.5 t) + 2 cos(4 t): smooth, two time scales, known exactly.
LINEAR = dict(k=1.0, c=0.3, omega=0.5, g=2.0, Omega=4.0)
X0, V0 = 0.2, -0.7


def _linear_coefficients():
    return coefficient_vector(stiffness=LINEAR["k"], c=LINEAR["c"], omega=LINEAR["omega"],
                              g=LINEAR["g"], Omega=LINEAR["Omega"], Delta=1e9)


@njit
def _fixed_steps(step, stage_rhs, prepare, make_scratch, nodes, k_rows, fsal_row, coefficients, x0, v0, t_end,
                 n_steps):
    """(x, v) at t_end after n_steps equal steps of ``step``, as the kernel runs it."""
    y = np.zeros(N_STATE)
    y[0], y[1] = x0, v0
    f = np.empty(N_STATE)
    K = np.empty((k_rows, N_STATE))
    y_new = np.empty(N_STATE)
    stage = np.empty(N_STATE)
    h = t_end / n_steps
    scratch = make_scratch(h)  # the method's own scratch (nodes: the method's, for the record)
    t = 0.0
    oscillator_rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
    for i in range(n_steps):
        prepare(t, h, coefficients, scratch)
        step(stage_rhs, t, y, f, h, coefficients, K, y_new, stage, scratch)
        y[:] = y_new
        f[:] = K[fsal_row]
        t = (i + 1) * h
    return y[0], y[1]


@njit
def _one_step_midpoint(step, dense_output, stage_rhs, prepare, make_scratch, nodes, k_rows, n_dense, coefficients,
                       x0, v0, h):
    """(x, v) of the dense output at the middle of one step of size h from (0, x0, v0)."""
    y = np.zeros(N_STATE)
    y[0], y[1] = x0, v0
    f = np.empty(N_STATE)
    K = np.empty((k_rows, N_STATE))
    y_new = np.empty(N_STATE)
    stage = np.empty(N_STATE)
    dense = np.empty((N_STATE, n_dense))
    scratch = make_scratch(h)  # the method's own scratch (nodes: the method's, for the record)
    oscillator_rhs(0.0, 0.0, -1, 0.0, y, coefficients, f, scratch)
    prepare(0.0, h, coefficients, scratch)
    step(stage_rhs, 0.0, y, f, h, coefficients, K, y_new, stage, scratch)
    dense_output(stage_rhs, 0.0, y, h, coefficients, K, y_new, dense, stage, scratch)
    return dense_value(dense, y, h, 0.5, 0), dense_value(dense, y, h, 0.5, 1)


def _slope(step_sizes, errors):
    return np.polyfit(np.log(step_sizes), np.log(errors), 1)[0]


@pytest.mark.parametrize("method", STEPPERS)
def test_convergence_order(method):
    step, _, k_rows, fsal_row, order, _ = STEPPERS[method]
    coefficients = _linear_coefficients()
    exact = LinearOscillator(**LINEAR).state(0.0, X0, V0, 10.0)
    # Step sizes from 0.4 down to 0.1 (Omega h from 1.6 to 0.4): asymptotic, above rounding.
    counts = np.array([25, 35, 50, 70, 100])
    errors = []
    for n in counts:
        x, v = _fixed_steps(step, *STAGE_RHS[method], k_rows, fsal_row, coefficients, X0, V0, 10.0, n)
        errors.append(math.hypot(x - exact[0], v - exact[1]))
    assert min(errors) > 1e-13  # still far above rounding, so the slope is the method's
    assert _slope(10.0 / counts, errors) == pytest.approx(order, abs=0.4)


@pytest.mark.parametrize("method", STEPPERS)
def test_dense_output_order(method):
    step, dense_output, k_rows, _, _, dense_order = STEPPERS[method]
    coefficients = _linear_coefficients()
    oscillator = LinearOscillator(**LINEAR)
    step_sizes = np.array([0.4, 0.28, 0.2, 0.14, 0.1])
    errors = []
    for h in step_sizes:
        x, v = _one_step_midpoint(step, dense_output, *STAGE_RHS[method], k_rows, dense_order, coefficients,
                                  X0, V0, h)
        exact = oscillator.state(0.0, X0, V0, 0.5 * h)
        errors.append(math.hypot(x - exact[0], v - exact[1]))
    assert min(errors) > 1e-14
    # The interpolant's local error is O(h^(q+1)).
    assert _slope(step_sizes, errors) == pytest.approx(dense_order + 1, abs=0.5)


# --- the methods agree with each other -------------------------------------------------------

def _run(method, vector, initial, periods, **settings):
    settings = dict(dict(rtol=1e-11, atol=1e-13, transient_periods=0, measure_periods=periods), **settings)
    return simulate(vector, initial, settings_vector(**settings), method=method)


def test_methods_agree_on_impacts_and_response():
    """Paper parameters, g = 10, Omega = 4: period-3 orbit with ~2.7 impacts per slow period."""
    vector = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0, Omega=4.0), "original")
    runs = [_run(method, vector, [0.99, 0.5], 10, transient_periods=10) for method in STEPPERS]
    for run in runs:
        assert run.status == Status.OK
    first, second = runs
    assert len(first.impacts) == len(second.impacts) > 40
    np.testing.assert_allclose(first.impacts, second.impacts, rtol=0, atol=1e-7)
    assert first.summary[kernel.SUM_R] == pytest.approx(second.summary[kernel.SUM_R], rel=1e-8)
    np.testing.assert_array_equal(first.impacts_per_period, second.impacts_per_period)


def test_methods_agree_on_sticking():
    """Stiffness pulls the mass off the barrier, the slow force presses it on for part of each
    period: chatter, sticking and release in every period (test_kernel's sticking case)."""
    vector = coefficient_vector(gamma=0.1, stiffness=1.0, c=5.0, omega=0.5, Delta=1.0, e=0.5)
    runs = [_run(method, vector, [0.0, 0.0], 4) for method in STEPPERS]
    first, second = runs
    assert first.status == second.status == Status.OK
    assert len(first.sticks) == len(second.sticks) >= 3
    # Sticking starts where chatter accumulates (its time is set by the last impacts), and ends
    # at the located root of the force, which both share.
    np.testing.assert_allclose(first.sticks, second.sticks, rtol=0, atol=1e-7)
    assert first.summary[kernel.SUM_QS] == pytest.approx(second.summary[kernel.SUM_QS], abs=1e-8)
    assert first.summary[kernel.SUM_QC] == pytest.approx(second.summary[kernel.SUM_QC], abs=1e-8)


@pytest.mark.parametrize("overshoot", [1e-6, -1e-6])
def test_methods_agree_on_grazing(overshoot):
    """x = v0 sin t peaks 1e-6 past (or short of) the barrier, inside one step."""
    vector = coefficient_vector(stiffness=1.0, Delta=1.0, e=0.5, omega=0.25)
    runs = [_run(method, vector, [0.0, 1.0 + overshoot], 1, rtol=1e-8, atol=1e-10) for method in STEPPERS]
    first, second = runs
    assert first.status == second.status == Status.OK
    if overshoot < 0:
        assert len(first.impacts) == len(second.impacts) == 0
        return
    # Every peak grazes (slower after each rebound, e = 0.5): the same impacts, each to the
    # accuracy a position error of ~rtol allows at its speed (dt ~ dx / v, test_kernel.py).
    assert len(first.impacts) == len(second.impacts) >= 1
    tolerance = 10 * 1e-8 / first.impacts[:, 1].min()
    np.testing.assert_allclose(first.impacts, second.impacts, rtol=0, atol=tolerance)


# --- integration.method in configs, runs and stored files --------------------------------------

def test_method_key_in_config():
    from vrsweep.config import ConfigError, parse_config

    assert parse_config("").integration.method == "rk45"
    config = parse_config("integration: {method: dop853}\n")
    assert config.integration.method == "dop853"
    assert "  method: dop853\n" in config.to_yaml() and parse_config(config.to_yaml()) == config
    # The default is not written: a run's stored config is the text it was before the key existed,
    # so files written then still resume (the resume check compares the text).
    assert "method" not in parse_config("").to_yaml()
    assert parse_config("", overrides=["method=dop853"]).integration.method == "dop853"
    with pytest.raises(ConfigError) as error:
        parse_config("integration:\n  method: dop85\n", "m.yaml")
    assert str(error.value).startswith("m.yaml:2: integration.method: must be one of rk45, dop853, got 'dop85'")
    assert "did you mean 'dop853'" in str(error.value)


def test_a_dop853_run_stores_its_method_and_resumes(tmp_path, invoke):

    from vrsweep.store.reading import load_results

    config = tmp_path / "m.yaml"
    config.write_text("sweep:\n  g: [5.0, 10.0, 30.0]\n"
                      "integration: {method: dop853, transient_periods: 3, measure_periods: 3, strobe_periods: 2}\n")
    out = tmp_path / "m.h5"
    result = invoke("run", config, "-o", out, "--quiet")
    assert result.exit_code == 0, result.output
    stored = load_results(out)
    assert "method: dop853" in stored.attrs["config"]
    assert invoke("run", config, "-o", out, "--resume", "--quiet").exit_code == 0
    # Same points as simulate with the same method: the sweep ran dop853.
    vector = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0), "original")
    run = simulate(vector, [0.99, 0.5], settings_vector(transient_periods=3, measure_periods=3), method="dop853")
    assert stored["R"].values[1] == run.summary[kernel.SUM_R]


# --- the dop853 kernel's rotated phases -------------------------------------------------------

@njit
def _stage_derivatives(coefficients, t, h, h_max):
    """dydt at every DOP853 node of a step (t, h): rotated (as the kernel) and from the library."""
    nodes = dop853.C_STAGES
    scratch = rotation_scratch(h_max, nodes)
    prepare_rotations(t, h, coefficients, scratch)
    y = np.array([0.3, -0.8, 0.0, 0.0])
    rotated = np.empty((nodes.shape[0], N_STATE))
    library = np.empty((nodes.shape[0], N_STATE))
    for node in range(nodes.shape[0]):
        oscillator_rhs_rotated(t, h, node, nodes[node], y, coefficients, rotated[node], scratch)
        oscillator_rhs(t, h, -1, nodes[node], y, coefficients, library[node], scratch)
    return rotated, library


@pytest.mark.parametrize("on_grid", [True, False])
def test_rotated_phases_equal_the_library(on_grid):
    from vrsweep.numerics.kernel import grid_step

    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0, Omega=4.0), "original")
    h_max = 2 * math.pi / 4.0 / 8
    scratch = rotation_scratch(h_max, dop853.C_STAGES)
    h = grid_step(0.1, scratch) if on_grid else 0.1
    assert (h != 0.1) == on_grid and 0.1 * 2 ** (-1 / 16) < h <= 0.1
    for t in (0.0, 3.7, 2513.0):  # up to the end of 200 slow periods
        rotated, library = _stage_derivatives(coefficients, t, h, h_max)
        # Both carry the rounding of the time t + c h (a phase error of Omega * ulp(t)): they may
        # differ by a few of those times the forcing amplitudes, and by no more.
        phase_rounding = (0.04 * 0.5 + 10.0 * 4.0) * np.spacing(max(t, 1.0))
        np.testing.assert_allclose(rotated, library, rtol=0, atol=1e-15 + 8 * phase_rounding)


def test_grid_step_is_the_largest_grid_size_below():
    from vrsweep.numerics.kernel import N_STEP_LEVELS, STEP_GRID, grid_step

    scratch = rotation_scratch(0.2, dop853.C_STAGES)
    grid = scratch[STEP_GRID:STEP_GRID + N_STEP_LEVELS]
    for h in np.concatenate([grid, np.geomspace(grid[-1], 0.2, 1001), [0.2 * (1 - 1e-16)]]):
        step = grid_step(h, scratch)
        assert step <= h and step in grid and not np.any((grid > step) & (grid <= h))
    assert grid_step(1e-9, scratch) == 1e-9  # below the grid: the step itself


@njit
def _phases_along_steps(coefficients, h, n_steps):
    """The phases prepare_rotations holds at each of n_steps consecutive steps of size h."""
    scratch = rotation_scratch(2 * h, dop853.C_STAGES)
    phases = np.empty((n_steps, 4))
    times = np.empty(n_steps)
    t = 1000.0
    for k in range(n_steps):
        prepare_rotations(t, h, coefficients, scratch)
        phases[k] = scratch[2:6]  # COS_SLOW, SIN_SLOW, COS_FAST, SIN_FAST
        times[k] = t
        t = t + h
    return times, phases


def test_phases_rotated_from_step_to_step_stay_exact():
    """A step's start phases are the last step's rotated by its size, resynchronised with the
    library every RESYNC_STEPS steps: the drift stays at rounding level."""
    from vrsweep.numerics.kernel import COS_SLOW, RESYNC_STEPS, SIN_FAST

    assert (COS_SLOW, SIN_FAST) == (2, 5)
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0, Omega=4.0), "original")
    times, phases = _phases_along_steps(coefficients, 0.1, 5 * RESYNC_STEPS)
    omega, big_omega = 0.5, 4.0
    exact = np.column_stack([np.cos(omega * times), np.sin(omega * times),
                             np.cos(big_omega * times), np.sin(big_omega * times)])
    # The library's own argument rounding at t ~ 1000 is Omega * ulp(t) ~ 5e-13.
    np.testing.assert_allclose(phases, exact, rtol=0, atol=4 * big_omega * np.spacing(1000.0) * RESYNC_STEPS)


# --- issue 23, attempt 2: the same arithmetic, cheaper (each claim of bit-for-bit equality) -------

@njit
def _loop_dop853_step(t, y, f, h, coefficients, K, y_new, stage, scratch):
    """DOP853's step as the tableau loop of version 0.2.0's first kernel (zeros skipped at run time)."""
    n = y.shape[0]
    for j in range(n):
        K[0, j] = f[j]
    for s in range(1, dop853.N_STAGES):
        for j in range(2):
            acc = 0.0
            for r in range(s):
                a = dop853.A_STAGES[s, r]
                if a != 0.0:
                    acc += a * K[r, j]
            stage[j] = y[j] + h * acc
        oscillator_rhs_rotated(t, h, s, dop853.C_STAGES[s], stage, coefficients, K[s], scratch)
    for j in range(n):
        acc = 0.0
        for r in range(dop853.N_STAGES):
            b = dop853.B_STAGES[r]
            if b != 0.0:
                acc += b * K[r, j]
        y_new[j] = y[j] + h * acc
    oscillator_rhs_rotated(t, h, dop853.N_STAGES, 1.0, y_new, coefficients, K[dop853.N_STAGES], scratch)


@njit
def _both_steps(coefficients, y, t, h, h_max):
    scratch = rotation_scratch(h_max, dop853.C_STAGES)
    prepare_rotations(t, h, coefficients, scratch)
    f = np.empty(N_STATE)
    oscillator_rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
    K1 = np.empty((dop853.N_STAGES_EXTENDED, N_STATE))
    K2 = np.empty((dop853.N_STAGES_EXTENDED, N_STATE))
    y1 = np.empty(N_STATE)
    y2 = np.empty(N_STATE)
    stage = np.empty(N_STATE)
    dop853_step(oscillator_rhs_rotated, t, y, f, h, coefficients, K1, y1, stage, scratch, 2)
    _loop_dop853_step(t, y, f, h, coefficients, K2, y2, stage, scratch)
    return K1[:dop853.N_STAGES + 1], y1, K2[:dop853.N_STAGES + 1], y2


def test_the_written_out_dop853_step_is_the_tableau_loop_bit_for_bit():
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0, Omega=4.0), "original")
    rng = np.random.default_rng(23)
    for _ in range(200):
        y = np.zeros(N_STATE)
        y[:] = rng.uniform(-2.0, 2.0, N_STATE)
        t, h = rng.uniform(0.0, 2500.0), rng.uniform(1e-4, 0.2)
        K1, y1, K2, y2 = _both_steps(coefficients, y, t, h, 0.2)
        assert y1.tobytes() == y2.tobytes() and K1.tobytes() == K2.tobytes()


@pytest.mark.parametrize("method", ["rk45", "dop853"])
def test_certain_growth_only_where_the_pi_factor_is_at_least_one(method):
    """The kernel skips the PI factor (two pow) where certain_growth says it is >= 1: never wrongly."""
    if method == "rk45":
        certain, factor = integrator.certain_growth, integrator.accepted_step_factor
    else:
        certain, factor = dop853.dop853_certain_growth, dop853.dop853_accepted_step_factor
    errs = np.concatenate([[0.0], np.geomspace(1e-12, 1.0, 400)])
    previous = np.concatenate([[0.0, 1e-6], np.geomspace(1e-4, 1.0, 60)])
    said = 0
    for err in errs:
        for err_previous in previous:
            if certain(err, err_previous):
                said += 1
                assert factor(err, err_previous) >= 1.0, (err, err_previous)
    # and it says so for most of the small errors of capped steps (the point of it)
    assert said > 0.5 * errs.size * previous.size * (np.mean(errs < 1e-3))


@njit
def _turning_points(coefficients, h, n_steps):
    """For n_steps DOP853 steps from varied states: (a turning point inside?, the skip test's answer,
    the located turning point's x, the record's min and max)."""
    scratch = rotation_scratch(h, dop853.C_STAGES)
    K = np.empty((dop853.N_STAGES_EXTENDED, N_STATE))
    dense = np.empty((N_STATE, dop853.DENSE_ORDER))
    y = np.zeros(N_STATE)
    y_new = np.empty(N_STATE)
    stage = np.empty(N_STATE)
    f = np.empty(N_STATE)
    record = np.empty(N_RECORD)
    out = np.empty((n_steps, 5))
    for k in range(n_steps):
        y[0] = -1.5 + 3.0 * ((k * 0.618034) % 1.0)
        y[1] = -0.4 + 0.8 * ((k * 0.414214) % 1.0)
        t = 0.37 * k
        prepare_rotations(t, h, coefficients, scratch)
        oscillator_rhs(t, 0.0, -1, 0.0, y, coefficients, f, scratch)
        dop853_step(oscillator_rhs_rotated, t, y, f, h, coefficients, K, y_new, stage, scratch, 2)
        dop853_dense(oscillator_rhs_rotated, t, y, h, coefficients, K, y_new, dense, stage, scratch, 2)
        # a period's extremes so far: around the step, some tight, some wide
        record[REC_X_MIN] = min(y[0], y_new[0]) - 0.3 * ((k * 0.7548) % 1.0) ** 3
        record[REC_X_MAX] = max(y[0], y_new[0]) + 0.3 * ((k * 0.5698) % 1.0) ** 3
        turning = y[1] * y_new[1] < 0.0
        x_turn = np.nan
        if turning:
            x_turn = dense_value(dense, y, h, locate_root(dense, y, h, 1, 0.0, 0.0, 1.0), 0)
        out[k, 0] = 1.0 if turning else 0.0
        out[k, 1] = 1.0 if _inside_extremes(record, dense, y, h) else 0.0
        out[k, 2] = x_turn
        out[k, 3] = record[REC_X_MIN]
        out[k, 4] = record[REC_X_MAX]
    return out


def test_a_turning_point_is_skipped_only_where_it_cannot_change_the_extremes():
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0, Omega=4.0), "original")
    out = _turning_points(coefficients, 2 * math.pi / 4.0 / 8, 4000)
    turning, skipped = out[:, 0] == 1.0, out[:, 1] == 1.0
    x_turn, low, high = out[:, 2], out[:, 3], out[:, 4]
    assert turning.sum() > 200 and (turning & skipped).sum() > 50 and (turning & ~skipped).sum() > 50
    # where skipped, the turning point as update_extremes would locate it lies strictly inside the
    # record: locating it would have changed nothing
    inside = turning & skipped
    assert np.all((low[inside] < x_turn[inside]) & (x_turn[inside] < high[inside]))


@njit
def _rotations_lazily(coefficients, t, h, h_max):
    """The rotations prepare_step_rotations then prepare_rotations leave, and those of prepare_rotations."""
    lazy = rotation_scratch(h_max, dop853.C_STAGES)
    prepare_step_rotations(t, h, coefficients, lazy)
    partial = lazy[ROTATION:ROTATION + 4 * (dop853.N_STAGES + 1)].copy()
    prepare_rotations(t, h, coefficients, lazy)
    full = rotation_scratch(h_max, dop853.C_STAGES)
    prepare_rotations(t, h, coefficients, full)
    return partial, lazy[ROTATION:ROTATION + ROTATION_VALUES], full[ROTATION:ROTATION + ROTATION_VALUES]


@pytest.mark.parametrize("h", [0.0913, 2 * math.pi / 4.0 / 8])  # off the grid, and on it (the cap)
def test_rotations_prepared_for_the_step_then_the_dense_output_are_those_prepared_at_once(h):
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=10.0, Omega=4.0), "original")
    partial, lazy, full = _rotations_lazily(coefficients, 12.3, h, 2 * math.pi / 4.0 / 8)
    assert lazy.tobytes() == full.tobytes()
    assert partial.tobytes() == full[:partial.size].tobytes()
