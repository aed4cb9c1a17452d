"""A written model with friction on a belt and no barrier: what its figures say of its sticks.

Built in memory (no integration, nothing compiled): the words, not the motion, are checked."""

import numpy as np
import xarray as xr

from vrsweep import plot
from vrsweep.config import parse_config
from vrsweep.plot.labels import use_model
from vrsweep.plot.sweeps import variable_label
from vrsweep.results import Status
from vrsweep.store.trajectory_file import ModelRun, TrajectoryData
from vrsweep.store.variables import IMPACT_VARIABLES

BELT = """\
model:
  name: friction oscillator on a belt
  acceleration: "-2*zeta*v - x - mu*sign(v - vb) + F*cos(omega*t)"
  parameters: {zeta: 0.05, mu: 0.6, F: 1.0, omega: 0.5, vb: 0.2}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.3}
integration: {transient_periods: 4, measure_periods: 6, strobe_periods: 3}
"""


def _stuck(long_name):
    return xr.Dataset({"stuck_fraction": (("mu",), np.array([0.0, 0.46]), {"units": "1", "long_name": long_name})},
                      coords={"mu": [0.1, 1.0]})


def test_stuck_fraction_says_that_sliding_on_a_belt_counts():
    """stuck_fraction counts a written model's sliding on v = c (kernel: REC_STUCK_TIME), but its
    colour bar and the file's long name said 'stuck on a barrier', on a map of a belt with no
    barrier at all. The paper's models (no sliding) keep their words."""
    (long_name,) = [attrs["long_name"] for name, _, _, attrs in IMPACT_VARIABLES if name == "stuck_fraction"]
    # A figure's title quotes the long name up to its first parenthesis: both there.
    assert "barrier" in long_name.split(" (")[0] and "sliding on a surface v = c" in long_name.split(" (")[0], long_name
    use_model(parse_config(BELT, "belt.yaml").model)
    try:
        label = variable_label(_stuck(long_name), "stuck_fraction")
    finally:
        use_model(None)
    assert label == "stuck_fraction: fraction of the time stuck (on a barrier, or sliding at v = c)", label
    assert variable_label(_stuck(long_name), "stuck_fraction") == \
        "stuck_fraction: fraction of the time stuck on a barrier"


def test_a_trajectory_without_a_barrier_does_not_promise_one():
    """Its title said 'impacts exact; dashed: barrier' with no barrier drawn, none in the model."""
    config = parse_config(BELT, "belt.yaml")
    period = 2 * np.pi / config.parameters["omega"]
    t = np.linspace(0.0, 10 * period, 401)
    run = ModelRun(model="written", status=Status.OK, t=t, x=0.5 * np.sin(t), v=0.5 * np.cos(t),
                   impacts=np.zeros((0, 3)), sticks=np.zeros((0, 2)), impacts_per_period=np.zeros(10, dtype=int),
                   strobe_x=np.zeros(10), strobe_v=np.zeros(10))
    data = TrajectoryData(runs={"written": run}, attrs={"config": BELT, "model": "written", "slow_period": period,
                                                       "samples_per_period": 40}, path="belt.h5")
    title = plot.plot(data)._vrsweep_description[0]
    assert "barrier" not in title and "impacts exact" not in title, title
