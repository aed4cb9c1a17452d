"""A referee's reading of the figures: a geometric grid on a logarithmic axis in line plots as in
maps, the resonance (eq3.4) only where the fast force is fast (Omega > omega), every curve of a
figure named even where its legend must shrink, integer maps with many values on a scale of
categories. Checked through matplotlib's objects, not pixels."""

import numpy as np
import pytest

from vrsweep import plot
from vrsweep.analysis import theory
from vrsweep.plot.labels import FINE_POINTS
from vrsweep.store.reading import load_results

SHORT = "integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 2, max_steps: 20000}\n"
# Omega in doublings from 0.25 (below omega = 0.5) to 16: a geometric grid.
GEOMETRIC = "parameters: {g: 5.0}\nsweep:\n  Omega: [0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0]\n" + SHORT
# g_res at Omega = 0.4 is 0.21 (eq3.4), on this range; but 0.4 < omega = 0.5: no fast force.
SLOW_FAST_FORCE = "parameters: {Omega: 0.4}\nsweep:\n  g: [0.0, 0.1, 0.2, 0.3]\n" + SHORT
PLANE = "sweep:\n  g: {start: 0.0, stop: 2.0, num: 3}\n  Omega: [0.25, 0.5, 1.0, 2.0]\n" + SHORT
# max_steps too few for g >= 10: four of five points fail.
FAILING = ("parameters: {Omega: 4.0}\nsweep:\n  g: {start: 0.0, stop: 40.0, num: 5}\n"
           "integration: {transient_periods: 5, measure_periods: 16, strobe_periods: 8, max_steps: 6000, "
           "lyapunov: true}\n")
CURVES = ("sweep:\n  g: {start: 0.0, stop: 40.0, num: 5}\n  Omega: [4.0, 4.5, 5.0]\n"
          "integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 2, lyapunov: true}\n")


@pytest.fixture(scope="module")
def files(tmp_path_factory, sweep_file):
    folder = tmp_path_factory.mktemp("referee")
    return {name: sweep_file(folder, text, name)[1]
            for name, text in (("geometric", GEOMETRIC), ("slow", SLOW_FAST_FORCE), ("plane", PLANE),
                               ("curves", CURVES), ("failing", FAILING))}


def _dash_dot_positions(ax):
    return [float(line.get_xdata()[0]) for line in ax.get_lines() if line.get_linestyle() == "-."]


# --- a geometric grid: a logarithmic axis on line plots, as on maps ----------------------------


@pytest.mark.parametrize("kind", ["response", "impacts", "variable", "bifurcation"])
def test_a_line_plot_over_a_geometric_grid_has_a_logarithmic_axis(files, kind):
    ds = load_results(files["geometric"])
    fig = {"response": lambda: plot.response_figure(ds), "impacts": lambda: plot.impacts_figure(ds),
           "variable": lambda: plot.variable_figure(ds, "x_max"),
           "bifurcation": lambda: plot.bifurcation_figure(ds)}[kind]()
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    low, high = ax.get_xlim()
    assert low < 0.25 and high > 16.0 and low > 0.0
    # The margin is the same share of the axis at either end (in log).
    assert np.isclose(np.log(0.25 / low), np.log(high / 16.0))
    # Ticked at the seven grid values, written out (the log axis' own ticks read 10^0 and 10^1).
    fig.draw_without_rendering()
    ticks = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    ticks += [t.get_text() for strip in fig.axes if strip.get_label() == "failed points"
              for t in strip.get_xticklabels() if t.get_text()]
    assert set(ticks) <= {"0.25", "0.5", "1", "2", "4", "8", "16"} and len(ticks) >= 4


def test_the_theory_over_a_geometric_grid_is_drawn_as_finely_in_every_decade(files):
    fig = plot.response_figure(load_results(files["geometric"]))
    theory_lines = [line for line in fig.axes[0].get_lines() if getattr(line, "_vrsweep_context", False)]
    long_lines = [np.asarray(line.get_xdata(), dtype=float) for line in theory_lines if len(line.get_xdata()) >= 3]
    assert long_lines
    # Equal steps in log along every branch (a linear fine grid left the lowest doubling, a
    # hundredth of the range, its ~1 % of the points: steps in log 60 times those at the top).
    for x in long_lines:
        steps = np.diff(np.log(x))
        assert np.allclose(steps, steps[0], rtol=1e-6)
    assert np.isclose(np.diff(np.log(long_lines[0]))[0], np.log(16.0 / 0.25) / (FINE_POINTS - 1))


def test_the_theorys_branches_stop_where_the_fast_force_is_no_longer_fast(files):
    fig = plot.response_figure(load_results(files["geometric"]))
    theory_lines = [line for line in fig.axes[0].get_lines() if getattr(line, "_vrsweep_context", False)]
    x = np.concatenate([line.get_xdata() for line in theory_lines])
    assert x.size and x.min() > 0.5 and x.max() == pytest.approx(16.0)  # omega = 0.5
    assert "no analytic curve or resonance drawn where Ω ≤ ω" in fig._vrsweep_description[1].replace("\n", " ")


def test_the_analytic_fold_and_hopf_fields_are_none_where_omega_is_at_most_omega():
    from vrsweep.numerics.model import DEFAULT_PARAMETERS
    from vrsweep.plot.curves import analytic_fields

    Omegas = np.geomspace(0.25, 4.0, 40)
    fields = analytic_fields(dict(DEFAULT_PARAMETERS), "g", "Omega", np.linspace(0.0, 30.0, 50), Omegas)
    for field in fields.values():
        assert np.all(np.isnan(field[Omegas <= 0.5]))
    assert np.any(np.isfinite(fields["fold"][Omegas > 0.5]))


def test_a_linear_grid_keeps_a_linear_axis(files):
    fig = plot.response_figure(load_results(files["slow"]))
    assert fig.axes[0].get_xscale() == "linear"


# --- the resonance (eq3.4) only where Omega > omega ---------------------------------------------


def test_fast_force_says_where_the_averaging_has_a_fast_force():
    assert theory.fast_force({"Omega": 4.0, "omega": 0.5})
    assert not theory.fast_force({"Omega": 0.5, "omega": 0.5})
    assert not theory.fast_force({"Omega": 0.4, "omega": 0.5})


@pytest.mark.parametrize("kind", ["response", "bifurcation"])
def test_no_g_res_is_drawn_where_the_fast_force_is_slow_and_the_caption_says_so(files, kind):
    ds = load_results(files["slow"])
    g_res = float(theory.g_res(0.1, 0.1, 0.5, 0.4))
    assert 0.0 < g_res < 0.3  # the formula's root lies on the axis ...
    fig = plot.response_figure(ds) if kind == "response" else plot.bifurcation_figure(ds)
    assert not [x for x in _dash_dot_positions(fig.axes[0]) if np.isclose(x, g_res)]  # ... and is not drawn
    caption = fig._vrsweep_description[1].replace("\n", " ")
    if kind == "response":  # nor the branches of the effective system's theory
        assert not [line for line in fig.axes[0].get_lines() if getattr(line, "_vrsweep_context", False)]
        assert "no analytic curve or resonance drawn where Ω ≤ ω" in caption
    else:
        assert "no resonance (eq3.4) drawn where Ω ≤ ω" in caption


def test_g_res_is_still_drawn_where_the_fast_force_is_fast(files):
    fig = plot.response_figure(plot.select(load_results(files["curves"]), {"Omega": 4.0}), x_axis="g")
    assert np.any(np.isclose(_dash_dot_positions(fig.axes[0]), float(theory.g_res(0.1, 0.1, 0.5, 4.0))))
    assert "Ω ≤ ω" not in fig._vrsweep_description[1]


def test_along_omega_the_resonance_is_kept_above_omega_only():
    parameters = {"alpha": 0.1, "omega0": 0.1, "omega": 0.5, "g": 0.2, "gamma": 0.22, "c": 0.04,
                  "Delta": 1.0, "e": 0.95, "Omega": 4.0}
    fine = np.geomspace(0.25, 16.0, 2000)
    # wt2 = omega^2 at Omega = (g / sqrt(2 (omega^2 + omega0^2) / (3 alpha)))^(1/2): 0.39 < omega.
    root = np.sqrt(0.2 / np.sqrt(2.0 * (0.25 + 0.01) / 0.3))
    assert root < 0.5
    assert plot.resonance_positions(parameters, "Omega", fine) == []
    above = dict(parameters, g=5.0)
    (position,) = plot.resonance_positions(above, "Omega", fine)
    assert np.isclose(position, np.sqrt(5.0 / np.sqrt(2.0 * 0.26 / 0.3)), rtol=1e-4)


def test_the_maps_resonance_curve_stops_at_omega_and_its_legend_says_so(files):
    fig = plot.map_figure(load_results(files["plane"]), "R")
    ax = fig.axes[0]
    (contour,) = [c for c in ax.collections if c.get_gid() == "resonance"]
    omegas = np.concatenate([path.vertices[:, 1] for path in contour.get_paths()])
    assert omegas.size and omegas.min() > 0.5
    texts = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
    assert any("drawn where Ω > ω only" in text for text in texts)


# --- every curve named, even at one journal column ---------------------------------------------


def _legend_texts(fig):
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return [text.get_text() for legend in legends for text in legend.get_texts()]


COLUMN = (3.4, 2.6)  # inches: one journal column


@pytest.mark.parametrize("kind", ["bifurcation", "response", "lyapunov"])
def test_a_figure_of_three_curves_names_each_at_one_journal_column(files, kind):
    ds = load_results(files["curves"])
    from vrsweep.plot.lyapunov import lyapunov_figure

    make = {"bifurcation": plot.bifurcation_figure, "response": plot.response_figure, "lyapunov": lyapunov_figure}[kind]
    fig = make(ds, x_axis="g", size=COLUMN)
    texts = _legend_texts(fig)
    for Omega in ("4", "4.5", "5"):
        assert sum(f"$\\Omega$ = {Omega}" in text for text in texts) >= 1, texts
    # The full legend is wider than the column would allow: only the curves' names are kept.
    assert not any("barrier" in text for text in texts) or len(texts) <= 4


# --- integer maps of many values: binned into categories, never a continuous scale --------------


def _palette_rgba():
    from matplotlib.colors import to_rgba

    from vrsweep.plot.palettes import EXTRA, QUALITATIVE

    return {to_rgba(colour) for colour in QUALITATIVE + EXTRA}


def test_many_periods_are_binned_into_runs_each_in_a_palette_colour():
    from matplotlib.colors import to_rgba

    from vrsweep.plot.palettes import MAX_CATEGORIES
    from vrsweep.plot.sweeps import NO_VALUE_COLOUR, discrete_scale

    # Period 1 on 500 cells, 2 on 200, 3 on 100, then 4 ... 39 on one cell each; 50 cells with none.
    values = np.concatenate([np.ones(500), np.full(200, 2), np.full(100, 3), np.arange(4, 40), np.zeros(50)])
    cmap, norm, ticks, labels, note = discrete_scale("period", values)
    assert cmap.N == MAX_CATEGORIES + 1 == len(ticks) == len(labels)  # twelve bins and 'no period'
    assert labels[:4] == ["0: no period", "1", "2", "3"]  # the values of many cells keep a colour each
    ordinary = [tuple(cmap(k)) for k in range(1, cmap.N)]
    assert len(set(ordinary)) == MAX_CATEGORIES and set(ordinary) <= _palette_rgba()  # no viridis
    assert to_rgba(cmap(0)) == to_rgba(NO_VALUE_COLOUR)
    # Each value is drawn in the colour of the bin whose label names it.
    for value in range(1, 40):
        (block,) = [k for k, text in enumerate(labels[1:], 1)
                    if int(text.split("\u2013")[0]) <= value <= int(text.split("\u2013")[-1])]
        assert cmap(norm(value)) == cmap(block)
    assert any("\u2013" in text for text in labels) and "39 values of period binned into 12 colours" in note


def test_up_to_twelve_values_keep_a_colour_each():
    from vrsweep.plot.sweeps import discrete_scale

    cmap, _, _, labels, note = discrete_scale("period", np.arange(0, 13))  # 0 and 1 ... 12
    assert cmap.N == 13 and labels[1:] == [str(value) for value in range(1, 13)] and note == ""


def test_a_map_of_many_periods_draws_bins_named_on_its_colour_bar(files):
    from matplotlib.collections import QuadMesh

    ds = load_results(files["curves"])
    ds["period"].values[...] = np.arange(15).reshape(ds["period"].shape)  # 0 and 1 ... 14: fourteen values
    fig = plot.map_figure(ds, "period")
    (mesh,) = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)]
    drawn = {tuple(mesh.cmap(mesh.norm(value))) for value in range(1, 15)}
    assert len(drawn) == 12 and drawn <= _palette_rgba()
    bar_labels = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert len(bar_labels) == 13 and sum("\u2013" in text for text in bar_labels) == 2
    assert "14 values of period binned into 12 colours" in fig._vrsweep_description[1].replace("\n", " ")


# --- failed points in a strip of their own, never on the data panel ------------------------------


@pytest.mark.parametrize("kind", ["response", "impacts", "bifurcation", "lyapunov", "bifurcation+lyapunov"])
def test_failed_points_are_marked_in_a_strip_under_each_panel_never_on_it(files, kind):
    from vrsweep.plot.lyapunov import lyapunov_figure

    ds = load_results(files["failing"])
    failed_g = ds["g"].values[ds["status"].values > 0]
    assert 0 < failed_g.size < 5
    fig = {"response": plot.response_figure, "impacts": plot.impacts_figure, "bifurcation": plot.bifurcation_figure,
           "lyapunov": lyapunov_figure,
           "bifurcation+lyapunov": lambda d: lyapunov_figure(d, bifurcation=True)}[kind](ds)
    strips = [ax for ax in fig.axes if ax.get_label() == "failed points"]
    panels = [ax for ax in fig.axes if ax not in strips and ax.get_ylabel()]
    assert strips
    for panel in panels:
        assert not [line for line in panel.get_lines() if line.get_gid() == "failed"]
    for strip in strips:
        (marks,) = [line for line in strip.get_lines() if line.get_gid() == "failed"]
        np.testing.assert_array_equal(marks.get_xdata(), failed_g)
        assert not [line for line in strip.get_lines() if line.get_gid() != "failed"]  # nothing else there
        (owner,) = [panel for panel in panels if panel.get_shared_x_axes().joined(panel, strip)
                    and getattr(panel, "_vrsweep_failure_strip", None) is strip]
        assert strip.get_position().y1 <= owner.get_position().y0
    # The axis is labelled once, under the lowest panel or strip.
    lowest = min(fig.axes, key=lambda ax: ax.get_position().y0 if not hasattr(ax, "_colorbar") else 1.0)
    assert lowest.get_xlabel() == "fast forcing amplitude $g$"
    assert sum(bool(ax.get_xlabel()) for ax in fig.axes) == 1
    assert "in the strip under the panel" in fig._vrsweep_description[1].replace("\n", " ")
