"""Figures at one journal column (issue 32): at --size 3.4,2.6 --no-title every text lies inside the
canvas, no two texts overlap, and the axes keep at least half of the figure -- for sweeps, maps,
branches and curves, measured with matplotlib's renderer. Also the options that make such a figure:
--xlim/--ylim on every kind, --legend, a branch figure's zoom on its bifurcations, their tags
(F1, PD1, G1, the same in vrsweep info) and --table; --var against one axis (issue 31)."""

import itertools

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text

from vrsweep import plot
from vrsweep.errors import UsageError

COLUMN = (3.4, 2.6)

LINE = """\
parameters: {Omega: 4.0}
sweep:
  g: {start: 0.0, stop: 55.0, num: 12}
integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2}
"""
BOTH_WAYS = """\
parameters: {Omega: 4.0}
sweep:
  g: {start: 0.0, stop: 30.0, num: 4, continuation: both}
integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2}
"""
PLANE = """\
sweep:
  g: {start: 0.0, stop: 55.0, num: 8}
  Omega: {start: 3.0, stop: 6.0, num: 6}
integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2, lyapunov: true}
"""
# The plane of tests/handmade.py's curves (effective model, gamma = alpha = 0.05).
EFFECTIVE_PLANE = """\
model: effective
parameters: {gamma: 0.05, alpha: 0.05}
sweep:
  g: {start: 22.0, stop: 27.0, num: 6}
  Omega: {start: 3.8, stop: 4.2, num: 5}
integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2}
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory, invoke, write_config):
    from handmade import (write_branch_file, write_cascade_branch_file, write_curves_file, write_grazing_branch_file,
                          write_switched_branch_file)

    folder = tmp_path_factory.mktemp("layout")
    made = {}
    for name, text in (("line", LINE), ("both", BOTH_WAYS), ("plane", PLANE), ("effective", EFFECTIVE_PLANE)):
        out = folder / f"{name}.h5"
        result = invoke("run", write_config(folder, text, name=f"{name}.yaml"), "-o", out, "--quiet")
        assert result.exit_code == 0, result.output
        made[name] = out
    made["branch"] = write_branch_file(folder / "branch.h5")
    made["cascade"] = write_cascade_branch_file(folder / "cascade.h5")
    made["switched"] = write_switched_branch_file(folder / "switched.h5")
    made["graze"] = write_grazing_branch_file(folder / "graze.h5")
    made["curves"] = write_curves_file(folder / "curves.h5")
    return made


def _texts(fig, renderer):
    """(owner, text, box) of every text drawn: axis labels, the tick labels drawn, titles, texts and
    tags (their text alone, not the leader line), legends (each as one box), figure texts."""
    found = []

    def add(owner, text):
        if text.get_visible() and text.get_text().strip():
            found.append((owner, text.get_text(), Text.get_window_extent(text, renderer)))

    for number, ax in enumerate(fig.axes):
        if not ax.axison:
            continue
        for axis in (ax.xaxis, ax.yaxis):
            add((number, "label"), axis.label)
            add((number, "offset"), axis.offsetText)
            for tick in axis._update_ticks():  # the ticks drawn, not those beyond the limits
                for label in (tick.label1, tick.label2):
                    add((number, axis.axis_name, "ticks"), label)
        for title in (ax.title, ax._left_title, ax._right_title, *ax.texts):
            add((number, "text"), title)
        if ax.get_legend() is not None:
            found.append(((number, "legend"), "legend", ax.get_legend().get_window_extent(renderer)))
    for legend in fig.legends:
        found.append((("figure", "legend"), "legend", legend.get_window_extent(renderer)))
    for text in fig.texts:
        add(("figure", "text"), text)
    return found


def measure(fig):
    """(share of the figure the axes take, texts outside the canvas, pairs of texts that overlap)."""
    FigureCanvasAgg(fig)
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    width, height = fig.bbox.width, fig.bbox.height
    texts = _texts(fig, renderer)
    share = sum(ax.get_window_extent(renderer).width * ax.get_window_extent(renderer).height
                for ax in fig.axes if ax.axison) / (width * height)
    outside = [text for _, text, box in texts
               if box.x0 < -1 or box.y0 < -1 or box.x1 > width + 1 or box.y1 > height + 1]
    overlapping = []
    for (owner_a, a, box_a), (owner_b, b, box_b) in itertools.combinations(texts, 2):
        if owner_a == owner_b and owner_a[-1] == "ticks":
            continue  # the tick labels of one axis are matplotlib's to space
        if min(box_a.x1, box_b.x1) - max(box_a.x0, box_b.x0) > 1 and min(box_a.y1, box_b.y1) - max(box_a.y0, box_b.y0) > 1:
            overlapping.append((a, b))
    return share, outside, overlapping


FIGURES = {
    "response": lambda f: plot.plot(f["line"], kind="response", size=COLUMN, title=False),
    "response both ways": lambda f: plot.plot(f["both"], kind="response", size=COLUMN, title=False),
    "variable": lambda f: plot.plot(f["line"], var="impact_speed_min", size=COLUMN, title=False),
    "bifurcation": lambda f: plot.plot(f["line"], kind="bifurcation", size=COLUMN, title=False),
    "impacts": lambda f: plot.plot(f["line"], kind="impacts", size=COLUMN, title=False),
    "map": lambda f: plot.plot(f["plane"], size=COLUMN, title=False),
    "capped map": lambda f: plot.plot(f["plane"], size=COLUMN, title=False, vmax=0.5),
    "lyapunov map": lambda f: plot.plot(f["plane"], var="lyapunov", size=COLUMN, title=False),
    "branch": lambda f: plot.plot(f["branch"], size=COLUMN, title=False),
    "branch with a cascade": lambda f: plot.plot(f["cascade"], size=COLUMN, title=False),
    "branch of two periods": lambda f: plot.plot(f["switched"], size=COLUMN, title=False),
    "branch through a graze": lambda f: plot.plot(f["graze"], size=COLUMN, title=False),
    "curves": lambda f: plot.plot([f["effective"], f["curves"]], size=COLUMN, title=False),
}


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_at_one_column_nothing_overlaps_and_the_axes_keep_half(files, name):
    fig = FIGURES[name](files)
    share, outside, overlapping = measure(fig)
    assert outside == [], (name, outside)
    assert overlapping == [], (name, overlapping)
    assert share >= 0.5, (name, share)


def test_a_capped_map_s_colour_bar_label_is_whole(files):
    fig = plot.plot(files["plane"], size=COLUMN, title=False, vmax=0.5)
    label = fig.axes[1].yaxis.label
    assert "capped at 0.5" in label.get_text().replace("\n", " ")
    share, outside, _ = measure(fig)
    assert outside == []


def test_no_advice_to_leave_off_a_title_already_off(files, tmp_path, invoke):
    result = invoke("plot", files["line"], "--size", "1.2,1", "--no-title", "-o", tmp_path / "f.png")
    assert result.exit_code == 0, result.output
    assert "--no-title" not in result.output
    result = invoke("plot", files["line"], "--size", "1.2,1", "-o", tmp_path / "g.png")
    assert "--no-title" in result.output


# --- --xlim / --ylim ------------------------------------------------------------------------------


@pytest.mark.parametrize("source, kind", [("line", "response"), ("line", "impacts"), ("line", "bifurcation"),
                                          ("plane", "map"), ("branch", None)])
def test_xlim_and_ylim_set_the_main_panel(files, source, kind):
    fig = plot.plot(files[source], kind=kind, xlim=(10.0, 20.0) if source != "branch" else (23.0, 25.0),
                    ylim="3.9,4.5" if source == "plane" else None)
    main = fig.axes[0]
    assert main.get_xlim() == ((10.0, 20.0) if source != "branch" else (23.0, 25.0))
    if source == "plane":
        assert main.get_ylim() == (3.9, 4.5)


def test_xlim_refits_the_vertical_axis_to_the_data_in_view(files):
    fig = plot.plot(files["branch"], xlim=(22.0, 23.0))
    top, bottom = fig.axes[:2]
    low, high = top.get_ylim()
    # R = 10 + g on the handmade branch: 32 to 33 in view, not 32 to 36 (the whole branch); the
    # theory's branches (effective model), drawn for comparison, do not count.
    assert 31.5 < low < 32.0 and 33.0 < high < 33.6
    assert bottom.get_xlim() == (22.0, 23.0)  # the multipliers' panel shares the axis


def test_a_bad_limit_is_one_line_naming_the_option(files, tmp_path, invoke):
    from damaged import one_line_error

    for args, words in ((("--xlim", "5"), "Error: --xlim 5: expected LOW,HIGH"),
                        (("--ylim", "3,1"), "Error: --ylim 3,1: LOW must be below HIGH"),
                        (("--xlim", "nan,1"), "Error: --xlim nan,1: both ends must be finite"),
                        (("--zoom", "bifurcations"), "Error: --zoom and --table are for branch files")):
        result = invoke("plot", files["line"], *args, "-o", tmp_path / "f.png")
        assert result.exit_code == 2
        assert one_line_error(result).startswith(words), result.output
    with pytest.raises(UsageError, match="xlim"):
        plot.plot(files["line"], xlim="a,b")


# --- --legend --------------------------------------------------------------------------------------


def test_legend_best_outside_none(files):
    inside = plot.plot(files["line"], kind="response", legend="best")
    assert inside.axes[0].get_legend() is not None and not inside.legends
    below = plot.plot(files["line"], kind="bifurcation", legend="outside")
    assert below.legends and below.axes[0].get_legend() is None
    none = plot.plot(files["branch"], legend="none")
    assert not none.legends and all(ax.get_legend() is None for ax in none.axes)


def test_a_legend_left_off_at_one_column_is_said(files, tmp_path, invoke):
    result = invoke("plot", files["line"], "--size", "3.4,2.6", "--no-title", "-o", tmp_path / "f.png")
    assert result.exit_code == 0
    assert "the legend (" in result.output and "is left off" in result.output
    result = invoke("plot", files["line"], "--size", "3.4,2.6", "--no-title", "--legend", "outside",
                    "-o", tmp_path / "g.png")
    assert "the legend (" not in result.output


# --- branch figures --------------------------------------------------------------------------------


def _tags(fig):
    return sorted(text.get_text() for text in fig.axes[0].texts if (text.get_gid() or "").startswith("tag"))


def test_bifurcations_are_tagged_on_the_curve_with_one_legend_entry_per_kind(files):
    fig = plot.plot(files["cascade"], size=(8, 6))
    tags = [tag for text in _tags(fig) for tag in text.split(", ")]
    assert sorted(tags) == ["F1", "F2", "G1", "PD1", "PD2"]
    legend = [text.get_text() for text in fig.legends[0].get_texts()]
    assert [entry for entry in legend if ":" in entry and entry.split(":")[0] in ("F", "PD", "G", "NS")] == [
        "PD: period doubling", "F: fold", "G: grazing"]


def test_a_branch_zooms_on_bifurcations_within_one_percent_and_says_so(files):
    fig = plot.plot(files["cascade"])
    low, high = fig.axes[0].get_xlim()
    assert 45.69 < low < 45.7483 and 45.8011 < high < 45.86
    notes = [text.get_text() for ax in fig.axes for text in ax.texts if text.get_gid() == "zoom note"]
    assert notes and "zoomed on the bifurcations" in notes[0] and "30 to 55" in notes[0]
    whole = plot.plot(files["cascade"], zoom="none")
    assert whole.axes[0].get_xlim()[0] < 31 and not [t for ax in whole.axes for t in ax.texts
                                                      if t.get_gid() == "zoom note"]
    # One fold on a 4-wide branch: no zoom unless asked.
    assert plot.plot(files["branch"]).axes[0].get_xlim()[0] < 22.1
    low, high = plot.plot(files["branch"], zoom="bifurcations").axes[0].get_xlim()
    assert 23.9 < low < 24.0 < high < 24.1


def test_the_table_lists_each_bifurcation_and_info_names_the_same_tags(files, invoke):
    fig = plot.plot(files["cascade"], table=True, size=COLUMN, title=False)
    assert fig.get_size_inches()[1] > COLUMN[1]  # grown by the table's rows
    (table,) = [child for ax in fig.axes for child in ax.tables]
    cells = table.get_celld()
    rows = sorted({row for row, _ in cells} - {0})
    assert [cells[(row, 0)].get_text().get_text() for row in rows] == ["PD1", "F1", "F2", "G1", "PD2"]
    assert cells[(2, 2)].get_text().get_text() == "45.7738"
    result = invoke("info", files["cascade"])
    assert "bifurcation: fold at g = 45.7738" in result.output and "(F1 on the figure" in result.output


# --- --var against one axis (issue 31) -----------------------------------------------------------------


def test_var_draws_any_stored_variable_against_the_swept_parameter(files, tmp_path, invoke):
    from vrsweep.store.reading import load_results

    ds = load_results(files["line"])
    fig = plot.plot(files["line"], var="impact_speed_min")
    (line,) = [line for line in fig.axes[0].get_lines() if len(line.get_xdata()) == 12]
    np.testing.assert_array_equal(line.get_xdata(), ds["g"].values)
    np.testing.assert_array_equal(line.get_ydata(), ds["impact_speed_min"].values)
    assert fig.axes[0].get_ylabel().replace("\n", " ").startswith("impact_speed_min: slowest impact speed |v-|")
    assert "slowest impact speed" in plot.description(fig)
    result = invoke("plot", files["line"], "--var", "x_max", "-o", tmp_path / "x_max.png")
    assert result.exit_code == 0, result.output
    result = invoke("plot", files["both"], "--var", "impact_speed_min", "-o", tmp_path / "both.png")
    assert result.exit_code == 0, result.output


def test_a_caption_item_wider_than_the_line_is_broken_at_its_spaces_outside_mathtext():
    # A written model's equation (150 characters) was one item, never broken: it ran off the canvas.
    from vrsweep.plot.labels import _wrap

    equation = ("single-well Duffing impact oscillator with two forces: x'' = -2 * zeta * v - x - beta * x ** 3 "
                "+ F1 * cos(omega * t) + F2 * cos(2 * omega * t + phi)")
    text = _wrap(["duffing.h5", equation, "$\\zeta$ = 0.05", "$F_1$ = 0.6"], 100)
    lines = text.split("\n")
    assert all(len(line.replace("$", "").replace("\\", "")) <= 100 for line in lines), lines
    assert " ".join(text.split()) == " ".join(f"duffing.h5 {equation},  $\\zeta$ = 0.05,  $F_1$ = 0.6".split())
    assert all(line.count("$") % 2 == 0 for line in lines)  # no line ends inside mathtext
    assert any("$\\zeta$ = 0.05" in line for line in lines) and any("$F_1$ = 0.6" in line for line in lines)
    # Only the long item is broken, never a 'name = value' after it (ζ = on one line, 0.05 on the next).
    model = "linear impact oscillator: x'' = -2 * zeta * v - x + F * cos(omega * t + phi)"
    lines = _wrap(["impact_linear_branch.h5", model, "$\\zeta$ = 0.05", "F = 1"], 115).split("\n")
    assert any("$\\zeta$ = 0.05" in line for line in lines) and any(model in line for line in lines), lines
    math = _wrap(["x", "$a \\cdot b \\cdot c \\cdot d$ " * 8], 30)  # only spaces inside $...$: kept whole
    assert all(line.count("$") % 2 == 0 for line in math.split("\n"))


def _lightness(colour):
    """CIE L* of a colour (sRGB, D65): what a greyscale page keeps of it."""
    from matplotlib.colors import to_rgb

    rgb = np.array(to_rgb(colour))
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    y = float(linear @ [0.2126, 0.7152, 0.0722])
    return 116.0 * np.cbrt(y) - 16.0 if y > 0.008856 else 903.3 * y


def test_every_line_over_a_map_is_cased_in_a_contrasting_colour(files, tmp_path):
    """Over a map the cells run from dark to light: the orange period-doubling curve, edged white,
    vanished over yellow cells (and on a greyscale page); the white g_res curve over white ones. Every line over the map (the curves of each kind, the theory's, g_res) has a
    casing wider than itself whose lightness differs from its own by 50 in L*, so that one of
    them stands out on any cell; every mark, an edge that does."""
    from matplotlib.collections import QuadMesh
    from matplotlib.colors import to_rgba
    from matplotlib.patheffects import Stroke

    from handmade import write_curves_file

    kinds = ("fold", "period_doubling", "grazing")
    curves = write_curves_file(tmp_path / "four.h5", kinds=kinds)
    for var in ("R", "impacts_per_period"):
        fig = plot.plot([files["effective"], curves], var=var)
        ax = fig.axes[0]
        seen = set()
        for artist in ax.get_lines() + [c for c in ax.collections if not isinstance(c, QuadMesh)]:
            if isinstance(artist, Line2D) and artist.get_linestyle() in ("None", "", " "):
                edge, face = artist.get_markeredgecolor(), artist.get_markerfacecolor()
                strokes = [effect for effect in artist.get_path_effects() if isinstance(effect, Stroke)]
                if strokes:  # a mark with no face ('x'): cased as a line
                    edge, face = strokes[0]._gc["foreground"], artist.get_color()
                assert abs(_lightness(edge) - _lightness(face)) >= 50.0, (artist.get_gid(), edge, face)
                continue
            core = artist.get_color() if isinstance(artist, Line2D) else to_rgba(artist.get_edgecolor()[0])
            width = artist.get_linewidth() if isinstance(artist, Line2D) else np.max(artist.get_linewidths())
            strokes = [effect for effect in artist.get_path_effects() if isinstance(effect, Stroke)]
            assert strokes, artist.get_gid()
            assert strokes[0]._gc["linewidth"] > width, artist.get_gid()
            assert abs(_lightness(strokes[0]._gc["foreground"]) - _lightness(core)) >= 50.0, (artist.get_gid(), core)
            seen.add(artist.get_gid())
        assert {f"curve_{kind}" for kind in kinds} | {"resonance"} <= seen, seen


from matplotlib.lines import Line2D  # noqa: E402
