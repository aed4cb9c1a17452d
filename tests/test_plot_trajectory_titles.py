"""A trajectory's figures name every parameter of the point, whatever the model's size.

Built from trajectory data in memory (no integration, nothing compiled): what is checked is where
the figure puts each parameter's value, not the motion."""

import numpy as np

from vrsweep import plot
from vrsweep.config import parse_config
from vrsweep.store.trajectory_file import ModelRun, TrajectoryData
from vrsweep.results import Status

# The shipped impact_duffing_two_forces.yaml's model: eight parameters, symbols given.
DUFFING = """\
model:
  name: single-well Duffing impact oscillator with two forces
  acceleration: "-2*zeta*v - x - beta*x**3 + F1*cos(omega*t) + F2*cos(2*omega*t + phi)"
  parameters: {zeta: 0.05, beta: 0.5, F1: 0.6, F2: 0.3, omega: 1.1, phi: PHI, Delta: 0.8, r: 0.85}
  symbols: {zeta: '\\zeta', beta: '\\beta', F1: 'F_1', F2: 'F_2', omega: '\\omega', phi: '\\varphi', Delta: '\\Delta'}
  barriers:
    - {position: Delta, side: above, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F1}
initial: {x: 0.0, v: 0.0}
integration: {transient_periods: 4, measure_periods: 6, strobe_periods: 3}
"""

PAPER = """\
model: original
parameters: {g: 5.0, Omega: 4.0, e: E}
initial: {x: 0.0, v: 0.0}
integration: {transient_periods: 4, measure_periods: 6, strobe_periods: 3}
"""


def trajectory(text, model, name):
    """Ten periods of a made-up motion below the barrier, with the file's attributes a figure reads."""
    config = parse_config(text, name)
    period = 2 * np.pi / config.parameters["omega"]
    t = np.linspace(0.0, 10 * period, 401)
    run = ModelRun(model=model, status=Status.OK, t=t, x=0.5 * np.sin(t), v=0.5 * np.cos(t),
                   impacts=np.zeros((0, 3)), sticks=np.zeros((0, 2)),
                   impacts_per_period=np.arange(10) % 3, strobe_x=np.zeros(10), strobe_v=np.zeros(10))
    attrs = {"config": text, "model": model, "slow_period": period, "samples_per_period": 40}
    return TrajectoryData(runs={model: run}, attrs=attrs, path=name)


def duffing(phi, name="duffing.h5"):
    return trajectory(DUFFING.replace("PHI", str(phi)), "written", name)


def test_a_written_trajectory_names_all_eight_parameters_and_its_panels_fit():
    """The title named the first four parameters by their config names (zeta = 0.05, ...), and
    each panel's title began with the model's name, which ran off the figure ('... phase portr')."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plot.plot(duffing(1.0))
    title = fig._vrsweep_description[0]
    for symbol, value in (("\\zeta", "0.05"), ("\\beta", "0.5"), ("F_1", "0.6"), ("F_2", "0.3"),
                          ("\\omega", "1.1"), ("\\varphi", "1"), ("\\Delta", "0.8"), ("r", "0.85")):
        assert f"{symbol}$ = {value}," in title or f"{symbol} = {value}," in title, (symbol, title)
    # Named once: the caption leaves out what the title holds.
    assert "0.85" not in fig._vrsweep_description[1], fig._vrsweep_description[1]
    FigureCanvasAgg(fig).draw()
    canvas = fig.get_window_extent()
    for ax in fig.axes:
        box = ax.title.get_window_extent()
        assert box.x0 >= canvas.x0 and box.x1 <= canvas.x1, (ax.get_title(), box, canvas)


def test_impact_panels_name_the_parameter_they_differ_in_whatever_its_place():
    """Two files differing in the sixth parameter: each panel said 'zeta = 0.05, beta = 0.5, F1 =
    0.6, F2 = 0.3', the same, and the caption left phi out as varying: phi's values were on no part
    of the figure. The paper's panels named g and Ω only, also when the files differed in e."""
    fig = plot.plot([duffing(1.0, "a.h5"), duffing(2.5, "b.h5")], kind="impacts")
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[0].startswith("(a) $\\varphi$ = 1  ·  a.h5"), titles
    assert titles[1].startswith("(b) $\\varphi$ = 2.5  ·  b.h5"), titles
    paper = [trajectory(PAPER.replace("E", e), "original", f"e{e}.h5") for e in ("0.9", "0.7")]
    titles = [ax.get_title() for ax in plot.plot(paper, kind="impacts").axes]
    assert titles[0].startswith("(a) $e$ = 0.9, g = 5, Ω = 4  ·  e0.9.h5"), titles
    assert titles[1].startswith("(b) $e$ = 0.7, g = 5, Ω = 4  ·  e0.7.h5"), titles


def test_one_written_file_of_impacts_leaves_its_parameters_to_the_caption():
    fig = plot.plot(duffing(1.0), kind="impacts")
    assert fig.axes[0].get_title().startswith("duffing.h5  ·  "), fig.axes[0].get_title()
    assert "$\\varphi$ = 1" in fig._vrsweep_description[1]
