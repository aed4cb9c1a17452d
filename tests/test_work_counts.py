"""n_rhs, the right-hand-side evaluations a point took (file-format.md), counted by the
right-hand side itself.

The loop runs in pure Python (NUMBA_DISABLE_JIT, in a process of its own) with a right-hand side
that counts its calls, for every kind of motion that calls it outside a step: impacts (their
location and restart), sticking on a barrier and its release, sliding on a belt and its exit scan,
with both methods and with the tangent vectors. Up to 0.7.9 a slide's exit scan did not count the
two fields evaluated at the slide's start: n_rhs was 2 short per slide.
"""

import json
import os
import subprocess
import sys
import textwrap

import pytest
from test_written_sticking import LINEAR, TWO_SIDED

COUNT = textwrap.dedent("""\
    import json, sys
    import numpy as np
    from vrsweep.config import parse_config
    from vrsweep.config.grid import Grid
    from vrsweep.execution.sweep import integration_settings
    from vrsweep.numerics import codegen, kernel, rhs
    from vrsweep.numerics.impact import N_BRACKET
    from vrsweep.numerics.models import kernels_for
    from vrsweep.numerics.state import N_STATE, N_STATE_WITH_TANGENTS
    from vrsweep.numerics.written import WrittenModel

    text, method, tangents = sys.argv[1], sys.argv[2], sys.argv[3] == "true"
    config = parse_config(text)
    grid = Grid.from_config(config)
    flat = np.arange(grid.n_points, dtype=np.int64)
    coefficients = np.ascontiguousarray(kernels_for(config.model).coefficients(grid.parameters_at(config, flat)))[0]
    initial_state = np.ascontiguousarray(grid.initial_states_at(config, flat), dtype=np.float64)[0]
    settings = integration_settings(config.integration)
    if isinstance(config.model, WrittenModel):
        functions = codegen.written_functions(codegen.compiled(config.model), tangents)
    else:
        functions = rhs.paper_functions(tangents)
    model_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface = functions
    calls = [0]

    def counting(*arguments):
        calls[0] += 1
        return model_rhs(*arguments)

    rules, step, error, dense_output, accepted, growth, rejected, k_rows, dense_order = kernel.METHOD_PARTS[method]
    n_state = N_STATE_WITH_TANGENTS if tangents else N_STATE
    n_periods = int(settings[kernel.TRANSIENT_PERIODS] + settings[kernel.MEASURE_PERIODS])
    summary = np.full(kernel.N_SUMMARY, np.nan)
    status = kernel._integrate(
        counting, counting, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface,
        rhs.no_preparations, rules, step, error, dense_output, accepted, growth, rejected, tangents,
        (np.empty((k_rows, n_state)), np.empty((n_state, dense_order)), np.empty((kernel.N_VECTORS, n_state)),
         np.empty(N_BRACKET)), rhs.no_scratch(0.0), coefficients, initial_state, settings,
        np.full((n_periods, kernel.N_RECORD), np.nan), summary, np.zeros(0), np.zeros((0, 2)),
        np.full((4096, 3), np.nan), np.full((1024, 2), np.nan), np.empty((0, 4)), kernel.lanes_apart)
    print(json.dumps({"status": int(status), "calls": calls[0], "n_rhs": int(summary[kernel.SUM_RHS]),
                      "impacts": int(summary[kernel.SUM_IMPACTS]), "sticks": int(summary[kernel.SUM_STICKS])}))
    """)

SHORT = "integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}\n"
BELT = """\
model:
  acceleration: "-2*zeta*v - x - mu*sign(v - belt) + F*cos(omega*t)"
  parameters: {zeta: 0.05, mu: 0.6, F: 1.0, omega: 0.5, belt: 0.2}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.3}
""" + SHORT
# plastic impacts (r = 0): the mass sticks on the stop while the force presses it there, then leaves;
# and a mass between two stops
STOP = LINEAR + SHORT
TWO_STOPS = TWO_SIDED + SHORT
ORIGINAL = "model: original\nparameters: {g: 30.0, Omega: 4.0}\n" + SHORT

CASES = [("belt", BELT, "rk45", False, "sticks"), ("belt", BELT, "dop853", True, "sticks"),
         ("plastic stop", STOP, "rk45", True, "impacts"), ("two stops", TWO_STOPS, "dop853", False, "impacts"),
         ("original", ORIGINAL, "rk45", False, "impacts")]


@pytest.mark.parametrize("case, text, method, tangents, events", CASES, ids=[f"{c[0]}-{c[2]}" for c in CASES])
def test_n_rhs_is_the_number_of_right_hand_sides_evaluated(case, text, method, tangents, events):
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    done = subprocess.run([sys.executable, "-c", COUNT, text, method, str(tangents).lower()], capture_output=True,
                          text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    counted = json.loads(done.stdout.strip().splitlines()[-1])
    assert counted["status"] == 0, counted  # Status.OK
    assert counted[events] > 0, counted  # the run has the case's kind of event
    assert counted["n_rhs"] == counted["calls"], counted
