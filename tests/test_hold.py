"""A held step's branches (kernel._integrate's vote; cuda.HOLD_LANES): the same numbers, bit for bit.

On a GPU that holds branches back, a lane whose accepted step (or an impact's last Newton step)
needs the loop's rare branches keeps the step and waits until its warp's vote releases it. The
lane must then compute exactly what it would have computed at once, whatever the other lanes do,
that is whatever the vote answers and when. The warp's vote needs a card, so here the loop is
compiled for the CPU with a vote that answers HOLD or RELEASE at random: every output of a point
(records, summary, status, samples, impacts) equals the CPU's own run (lanes_apart; with rk45 the
CPU's compiled entry point itself) bit for bit, for the paper's model and a written model with two
barriers, both methods as the GPU composes them (kernel.METHOD_PARTS), with and without the
tangent vectors. A pure-Python run counts the holds, so that the comparison is known to have held
steps of every kind.
"""

from pathlib import Path

import numba
import numpy as np
import pytest

from vrsweep.config import load_config
from vrsweep.config.grid import Grid
from vrsweep.execution.sweep import integration_settings
from vrsweep.numerics import codegen, kernel, rhs
from vrsweep.numerics.impact import N_BRACKET
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.state import N_STATE, N_STATE_WITH_TANGENTS
from vrsweep.numerics.written import WrittenModel
from vrsweep.results import Status

EXAMPLES = Path(__file__).resolve().parent.parent / "vrsweep" / "examples"
RELEASE_SHARE = 0.3  # the random vote's share of RELEASE answers


@numba.njit
def votes_at_random(waiting):
    """A warp's vote as another lane might make it: a waiting lane waits a random number of passes."""
    return kernel.RELEASE if np.random.random() < RELEASE_SHARE else kernel.HOLD


@numba.njit
def seed_votes(seed):
    np.random.seed(seed)


def _functions(model, tangents):
    """(rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface) as the GPU's kernel takes them."""
    if isinstance(model, WrittenModel):
        return codegen.written_functions(codegen.compiled(model), tangents)
    return rhs.paper_functions(tangents)


def _outputs(coefficients, settings):
    """A point's output arrays, NaN-filled: records, summary, sample times, samples, impacts, sticks."""
    n_periods = int(settings[kernel.TRANSIENT_PERIODS] + settings[kernel.MEASURE_PERIODS])
    period = coefficients[kernel.PERIOD]
    sample_times = np.linspace(0.5 * period, (n_periods - 0.5) * period, 7 * n_periods)
    return (np.full((n_periods, kernel.N_RECORD), np.nan), np.full(kernel.N_SUMMARY, np.nan), sample_times,
            np.full((len(sample_times), 2), np.nan), np.full((4096, 3), np.nan), np.full((1024, 2), np.nan))


def _outcome(status, records, summary, sample_times, samples, impacts, sticks):
    n_impacts = min(int(summary[kernel.SUM_IMPACTS]), len(impacts))
    return {"status": np.array([int(status)]), "records": records, "summary": summary, "samples": samples,
            "impacts": impacts[:n_impacts]}


def _integrate(integrate, functions, method, tangents, coefficients, initial_state, settings, gather):
    model_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface = functions
    rules, step, error, dense_output, accepted, growth, rejected, k_rows, dense_order = kernel.METHOD_PARTS[method]
    n_state = N_STATE_WITH_TANGENTS if tangents else N_STATE
    outputs = _outputs(coefficients, settings)
    status = integrate(
        model_rhs, model_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface,
        rhs.no_preparations, rules,
        step, error,
        dense_output, accepted, growth, rejected, tangents, (np.empty((k_rows, n_state)),
        np.empty((n_state, dense_order)), np.empty((kernel.N_VECTORS, n_state)), np.empty(N_BRACKET)), np.empty(1),
        coefficients, initial_state, settings, *outputs, np.empty((0, 4)), gather)
    return _outcome(status, *outputs)


def _cpu_entry(model, method, tangents, coefficients, initial_state, settings):
    """The CPU's own compiled (and cached) entry point, as a sweep or simulate runs it."""
    outputs = _outputs(coefficients, settings)
    status = kernels_for(model).integrator(method, tangents)(coefficients, initial_state, settings, *outputs)
    return _outcome(status, *outputs)


def _points(tmp_path, text, overrides):
    path = tmp_path / "hold.yaml"
    path.write_text(text)
    config = load_config(path, overrides)
    grid = Grid.from_config(config)
    flat = np.arange(grid.n_points, dtype=np.int64)
    kernels = kernels_for(config.model)
    coefficients = np.ascontiguousarray(kernels.coefficients(grid.parameters_at(config, flat)))
    initial_states = np.ascontiguousarray(grid.initial_states_at(config, flat), dtype=np.float64)
    return config.model, coefficients, initial_states, integration_settings(config.integration)


TWO_SIDED = (EXAMPLES / "impact_two_sided.yaml").read_text()
CASES = {
    # the paper's original model where it impacts (g 20 and 30) and where it does not (g 5)
    "original": ("sweep:\n  g: {values: [5.0, 20.0, 30.0]}\n  Omega: {values: [4.0]}\n",
                 ["transient_periods=3", "measure_periods=16"]),
    # a mass between two stops: both barriers' tests, and impacts on each side
    "written, two barriers": (TWO_SIDED.replace("F: {start: 0.1, stop: 3.0, num: 59}", "F: {values: [0.5, 2.0, 3.0]}"),
                              ["transient_periods=20", "measure_periods=16"]),
}
assert "F: {values: [0.5, 2.0, 3.0]}" in CASES["written, two barriers"][0]
# kernel._integrate as an entry point of its own, for the vote handed to it (uncached: see
# cuda.simulated_integrate)
INTEGRATE = kernel.kernel_jit(kernel._integrate.py_func, cache=False)


# Each case compiles _integrate uncached with the random vote (a minute on a loaded 2-core
# machine), and dop853's also with lanes_apart, so the three factors are covered in pairs rather
# than all eight combinations: every model with every method, every method with and without the
# tangent vectors, every model with and without them.
PAIRWISE = [("original", "rk45", True), ("original", "dop853", False),
            ("written, two barriers", "rk45", False), ("written, two barriers", "dop853", True)]


@pytest.mark.parametrize(("case", "method", "tangents"), PAIRWISE,
                         ids=[f"{case}-{method}-{'tangent vectors' if tangents else 'state'}"
                              for case, method, tangents in PAIRWISE])
def test_a_step_held_for_the_warp_gives_the_same_numbers_bit_for_bit(tmp_path, case, method, tangents):
    model, coefficients, initial_states, settings = _points(tmp_path, *CASES[case])
    functions = _functions(model, tangents)
    integrate = INTEGRATE
    for point in range(len(coefficients)):
        if method == "rk45":  # the GPU composes rk45 as the CPU's entry point does: the CPU's own kernel
            alone = _cpu_entry(model, method, tangents, coefficients[point], initial_states[point], settings)
        else:  # dop853's stages rotate the forcing on the CPU, and call cos on a GPU
            alone = _integrate(integrate, functions, method, tangents, coefficients[point], initial_states[point],
                               settings, kernel.lanes_apart)
        seed_votes(point)
        held = _integrate(integrate, functions, method, tangents, coefficients[point], initial_states[point],
                          settings, votes_at_random)
        assert alone["status"][0] == Status.OK
        for name, values in alone.items():
            np.testing.assert_array_equal(held[name], values, err_msg=f"{case}, {method}, point {point}: {name}")


def test_the_random_vote_holds_steps_of_every_kind(tmp_path):
    """The loop in pure Python (the njit functions it calls stay compiled), with a vote that counts:
    steps are held, accepted steps near a barrier and impacts' last Newton steps among them, and
    the held run's outputs equal the lone one's."""
    model, coefficients, initial_states, settings = _points(tmp_path, *CASES["written, two barriers"])
    functions = _functions(model, False)
    point = 2  # F = 3: an impact on each stop every cycle
    rng = np.random.default_rng(7)
    waits = {"passes": 0, "held": 0}

    def counting(waiting):
        waits["passes"] += 1
        waits["held"] += bool(waiting)
        return kernel.RELEASE if rng.random() < RELEASE_SHARE else kernel.HOLD

    short = settings.copy()
    short[kernel.TRANSIENT_PERIODS], short[kernel.MEASURE_PERIODS] = 2, 2
    alone = _integrate(kernel._integrate.py_func, functions, "rk45", False, coefficients[point],
                       initial_states[point], short, lambda waiting: kernel.APART)
    held = _integrate(kernel._integrate.py_func, functions, "rk45", False, coefficients[point],
                      initial_states[point], short, counting)
    assert len(alone["impacts"]) >= 4  # both stops, twice
    assert waits["held"] > 2 * len(alone["impacts"])  # at least the impacts' steps and their last Newton steps
    assert waits["passes"] > waits["held"]
    for name, values in alone.items():
        np.testing.assert_array_equal(held[name], values, err_msg=name)
