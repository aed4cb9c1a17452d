"""``vrsweep plot --kind lyapunov`` and ``bifurcation+lyapunov``, and maps of the exponent (issue 13):
what is drawn is the file's numbers, -inf is shown and counted, the panels share one axis."""

import math

import numpy as np
import pytest
from matplotlib.collections import QuadMesh

from vrsweep import plot
from vrsweep.store.reading import load_results

LINE = """\
sweep:
  g: [3.0, 5.0, 10.0, 25.0, 40.0]
integration: {method: dop853, transient_periods: 20, measure_periods: 20, strobe_periods: 8, lyapunov: true}
"""
PLANE = """\
sweep:
  g: [5.0, 25.0, 40.0]
  Omega: [4.0, 5.0]
integration: {method: dop853, transient_periods: 10, measure_periods: 10, strobe_periods: 4, lyapunov: true}
"""


@pytest.fixture(scope="module")
def line(tmp_path_factory, invoke, write_config):
    folder = tmp_path_factory.mktemp("lyapunov_line")
    out = folder / "line.h5"
    result = invoke("run", write_config(folder, LINE), "-o", out, "--quiet")
    assert result.exit_code == 0, result.output
    return out


def _lines(fig, gid):
    return [line for ax in fig.axes for line in ax.get_lines() if line.get_gid() == gid]


def test_the_panel_draws_the_files_exponent_and_calls_chaos_by_its_band(line):
    ds = load_results(line)
    exponent, error, g = ds["lyapunov"].values, ds["lyapunov_err"].values, ds["g"].values
    fig = plot.plot(line, kind="lyapunov")
    (curve,) = _lines(fig, "lyapunov")
    np.testing.assert_array_equal(curve.get_xdata(), g)
    np.testing.assert_array_equal(curve.get_ydata(), exponent)
    chaotic = exponent - error > 0
    assert chaotic.any() and not chaotic.all()  # g = 3, 5 chaotic; 10, 25, 40 periodic
    (filled,) = _lines(fig, "chaotic")
    np.testing.assert_array_equal(filled.get_xdata(), g[chaotic])
    (hollow,) = _lines(fig, "not_chaotic")
    np.testing.assert_array_equal(hollow.get_xdata(), g[~chaotic])
    assert any(list(l.get_ydata()) == [0.0, 0.0] for l in fig.axes[0].get_lines())  # the zero line
    # Hollow is every point not beyond its band, a positive lambda_1 within it included (g = 20 of
    # Fig. 1: +0.04, motion chaotic): the legend called them all "not chaotic".
    assert "not chaotic" not in hollow.get_label() and "undecided" in hollow.get_label()


@pytest.mark.parametrize("bifurcation", [False, True])
def test_minus_infinity_is_drawn_apart_from_the_data_and_counted(line, bifurcation):
    """-inf (stuck) was a triangle inside the exponent's panel, at some height near its bottom, where
    it read as that value of lambda_1. It is in a strip of its own under the panel, on the same
    parameter axis, named -inf, and the exponent's panel holds no mark of it."""
    ds = load_results(line)
    ds["lyapunov"].values[1] = -math.inf  # as a point that stuck on the barrier stores it
    fig = plot.lyapunov_figure(ds, bifurcation=bifurcation)
    (stuck,) = _lines(fig, "stuck")
    np.testing.assert_array_equal(stuck.get_xdata(), [5.0])
    assert "1 point stuck on the barrier" in fig._suptitle.get_text()
    (curve,) = _lines(fig, "lyapunov")
    assert np.isnan(curve.get_ydata()[1])  # not drawn as a number
    strip, panel = stuck.axes, curve.axes
    assert strip is not panel and strip.get_shared_x_axes().joined(strip, panel)
    assert strip.get_position().y1 <= panel.get_position().y0  # below the panel, not over its data
    assert [t.get_text() for t in strip.get_yticklabels()] == ["$\\lambda_1$ = $-\\infty$"]
    assert strip.get_xlabel() and not panel.get_xlabel()  # the parameter's label under the lowest panel
    # Without -inf, no strip.
    assert len(plot.lyapunov_figure(load_results(line), bifurcation=bifurcation).axes) == (2 if bifurcation else 1)


def test_under_the_bifurcation_diagram_on_one_axis(line):
    fig = plot.plot(line, kind="bifurcation+lyapunov")
    top, bottom = fig.axes[:2]
    assert top.get_shared_x_axes().joined(top, bottom)
    dots = [l for l in top.get_lines() if l.get_marker() == "."]
    assert sum(len(l.get_xdata()) for l in dots) == 5 * 8  # every strobe sample of every point
    assert _lines(fig, "lyapunov")[0].axes is bottom


def test_the_cli_names_the_figure_and_refuses_a_file_without_exponents(line, tmp_path, invoke, write_config):
    result = invoke("plot", line, "--kind", "bifurcation+lyapunov")
    assert result.exit_code == 0, result.output
    assert line.with_name("line.bifurcation+lyapunov.png").is_file()
    plain = tmp_path / "plain.h5"
    config = write_config(tmp_path, LINE.replace(", lyapunov: true", ""))
    assert invoke("run", config, "-o", plain, "--quiet").exit_code == 0
    refused = invoke("plot", plain, "--kind", "lyapunov", "-o", tmp_path / "f.png")
    assert refused.exit_code == 2
    assert "has no lyapunov: run the sweep with integration.lyapunov: true" in refused.output
    assert not (tmp_path / "f.png").exists()


def test_a_map_of_the_exponent_is_centred_on_zero_and_shows_minus_infinity(tmp_path, invoke, write_config):
    out = tmp_path / "plane.h5"
    assert invoke("run", write_config(tmp_path, PLANE), "-o", out, "--quiet").exit_code == 0
    ds = load_results(out)
    ds["lyapunov"].values[0, 1] = -math.inf
    fig = plot.map_figure(ds, "lyapunov")
    (mesh,) = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)]
    assert mesh.norm.vmin == -mesh.norm.vmax < 0.0  # symmetric about zero: one slope for both signs
    cells = np.ma.filled(mesh.get_array(), np.nan).astype(float).reshape(2, 3)  # (Omega, g)
    assert np.isnan(cells[1, 0])  # the -inf cell has no colour ...
    (marks,) = _lines(fig, "minus_infinity")  # ... but a mark
    assert (marks.get_xdata()[0], marks.get_ydata()[0]) == (5.0, 5.0)
    finite = np.delete(ds["lyapunov"].values.T.ravel(), 3)
    np.testing.assert_array_equal(np.delete(cells.ravel(), 3), finite)
    # --kind lyapunov of such a file: the line figure needs one axis, and the refusal names the map
    # that draws both (it said only 'this plot needs 1 axis(es); fix the others with --at').
    refused = invoke("plot", out, "--kind", "lyapunov", "-o", tmp_path / "l.png")
    assert refused.exit_code == 2
    assert ("this plot is drawn against one axis; fix the others with --at, e.g. --at Omega=4; both at once: "
            "--kind map --var lyapunov") in refused.output, refused.output


def test_minus_infinity_of_a_written_model_is_stuck_on_one_of_its_barriers(line):
    """A written model may have two barriers (or none): its -inf points were 'stuck on the barrier'.
    The file's numbers with a stored written config of two barriers, drawn as its figure."""
    ds = load_results(line)
    ds["lyapunov"].values[1] = -math.inf
    ds.attrs["config"] = """\
model:
  acceleration: "-0.1*v - g*x + cos(t)"
  parameters: {g: 1.0}
  barriers: [{position: 1.0, side: above, restitution: 0.8}, {position: -1.0, side: below, restitution: 0.8}]
  period: "2*pi"
  response: {frequency: 1, scale: 1}
initial: {x: 0.0, v: 0.0}
sweep:
  g: [3.0, 5.0, 10.0, 25.0, 40.0]
"""
    fig = plot.lyapunov_figure(ds)
    assert "1 point stuck on a barrier" in fig._suptitle.get_text(), fig._suptitle.get_text()
    labels = [text.get_text() for legend in fig.legends for text in legend.get_texts()]
    assert any(label.endswith("stuck on a barrier") for label in labels), labels
    assert not any("the barrier" in label for label in labels), labels
