"""Figures for papers (issue 22): --title/--no-title, --size, --style, --vmin/--vmax, integer maps on
a discrete scale, lambda_1 on a scale symmetric about zero, stated caps, a colour scale for many
curves, the attractors on basin plots. Checked through matplotlib's objects and the written files.

The maps' values are set in a loaded Dataset (as a file could hold them), so that what must be
drawn is known exactly; the numbers themselves are tested elsewhere."""

import numpy as np
import pytest
from matplotlib.collections import PatchCollection, QuadMesh
from matplotlib.colors import BoundaryNorm, to_rgba

from vrsweep import plot
from vrsweep.errors import UsageError
from vrsweep.plot.basins import BASIN_COLOURS
from vrsweep.plot.sweeps import NO_VALUE_COLOUR
from vrsweep.store.reading import load_results
from greyscale import lightness as _lightness

PLANE = """\
sweep:
  g: {start: 0.0, stop: 55.0, num: 12}
  Omega: {start: 3.0, stop: 6.0, num: 10}
integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2, lyapunov: true}
"""
LINE = """\
parameters: {Omega: 4.0}
sweep:
  g: {start: 0.0, stop: 30.0, num: 4, continuation: both}
integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2}
"""
CUBE = """\
model: effective
sweep:
  g: {start: 0.0, stop: 30.0, num: 3}
  Omega: [4.0, 5.0]
  Delta: [1.0, 1.5, 2.0, 2.5]
integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 2}
"""
BASINS = """\
parameters: {g: 5.0, Omega: 5.0}
sweep:
  x0: {start: -1.0, stop: 0.5, num: 3}
  v0: {start: -1.0, stop: 1.0, num: 2}
integration: {transient_periods: 10, measure_periods: 6, strobe_periods: 3}
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory, invoke, write_config):
    folder = tmp_path_factory.mktemp("figures")
    made = {}
    for name, text in (("plane", PLANE), ("line", LINE), ("basins", BASINS), ("cube", CUBE)):
        out = folder / f"{name}.h5"
        result = invoke("run", write_config(folder, text, name=f"{name}.yaml"), "-o", out, "--quiet")
        assert result.exit_code == 0, result.output
        made[name] = out
    return made


def _mesh(ax):
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    return mesh


def _all_text(fig):
    """Every piece of text drawn on the figure: titles, labels, tick labels, legends, colour bars."""
    from matplotlib.text import Text

    return [t.get_text() for t in fig.findobj(Text)]


# --- integer maps: one colour per value present -------------------------------------------------


def test_an_integer_map_has_exactly_one_colour_per_value_present(files):
    ds = load_results(files["plane"])
    pattern = np.resize([0, 1, 2, 5, 1], 12)  # along g; 0 = no period
    ds["period"].values[...] = pattern[:, None]
    fig = plot.map_figure(ds, "period")
    mesh = _mesh(fig.axes[0])
    assert isinstance(mesh.norm, BoundaryNorm)
    assert mesh.cmap.N == 4 and len(mesh.norm.boundaries) == 5  # values 0, 1, 2, 5: four colours
    drawn = np.asarray(mesh.get_array(), dtype=float).ravel()
    colours = {tuple(mesh.cmap(mesh.norm(value))) for value in drawn}
    assert len(colours) == 4
    assert to_rgba(mesh.cmap(mesh.norm(0))) == to_rgba(NO_VALUE_COLOUR)  # 'no period' set apart in grey
    # Equal values share a colour, different ones do not.
    by_value = {value: tuple(mesh.cmap(mesh.norm(value))) for value in (0, 1, 2, 5)}
    assert len(set(by_value.values())) == 4
    bar_labels = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert bar_labels == ["0: no period", "1", "2", "5"]


def test_the_other_integer_variables_name_their_special_values(files):
    ds = load_results(files["plane"])
    ds["impacts_per_cycle"].values[...] = np.resize([-1, 3, 3, 4, -1], 12)[:, None]
    fig = plot.map_figure(ds, "impacts_per_cycle")
    assert _mesh(fig.axes[0]).cmap.N == 3
    assert [t.get_text() for t in fig.axes[1].get_yticklabels()] == ["-1: no period", "3", "4"]
    ds["status"].values[...] = 0
    ds["status"].values[0, 0] = 2
    fig = plot.map_figure(ds, "status")
    assert _mesh(fig.axes[0]).cmap.N == 2
    assert [t.get_text() for t in fig.axes[1].get_yticklabels()] == ["ok", "diverged"]


def test_a_map_of_motion_gives_each_kind_its_own_colour(files):
    # Every flag but status's drew in one grey: --var motion was one grey block, its bar all grey.
    ds = load_results(files["plane"])
    ds["motion"].values[...] = np.resize([1, 2, 3, 1, 4], 12)[:, None]
    fig = plot.map_figure(ds, "motion")
    mesh = _mesh(fig.axes[0])
    colours = {value: to_rgba(mesh.cmap(mesh.norm(value))) for value in (1, 2, 3, 4)}
    assert len(set(colours.values())) == 4
    from vrsweep.plot.sweeps import MOTION_COLOURS

    assert all(colours[k] == to_rgba(MOTION_COLOURS[k]) for k in (1, 2, 3, 4))  # as --kind motion
    assert [t.get_text() for t in fig.axes[1].get_yticklabels()] == [
        "periodic", "quasi-periodic", "chaotic", "not-settled"]  # named as --kind motion names them
    ds["motion"].values[0] = 0  # a failed point: 'none' in the file, named as --kind motion names it
    labels = [t.get_text() for t in plot.map_figure(ds, "motion").axes[1].get_yticklabels()]
    assert labels[0] == "failed (none)", labels


def test_a_motion_figure_sets_failed_points_apart_from_points_not_computed(files):
    """--kind motion drew a failed point (motion 'none') in the light grey of a point not computed,
    and a strip of a file not finished ended in a ValueError on the stored fill (-1). Failed,
    not computed and every kind differ by 8 in L*, each named on the colour bar (the strip's
    ticks), and the title counts both."""
    ds = load_results(files["plane"])
    ds["motion"].values[0, :], ds["status"].values[0, :] = 0, 1  # failed: no motion
    ds["done"].values[1, :], ds["motion"].values[1, :] = False, -1  # not computed: the fill
    fig = plot.motion_figure(ds)
    mesh = _mesh(fig.axes[0])
    failed, missing = (to_rgba(mesh.cmap(mesh.norm(value))) for value in mesh.get_array().reshape(
        len(ds["Omega"]), len(ds["g"]))[0, :2])
    assert abs(_lightness(failed) - _lightness(missing)) >= 8.0, (failed, missing)
    assert _apart_in_grey([mesh.cmap(k) for k in range(mesh.cmap.N)]) >= 8.0
    names = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert "not computed" in names and "failed (none)" in names
    assert to_rgba(mesh.cmap(mesh.norm(names.index("failed (none)") - 1))) == failed  # named where drawn
    title = fig._vrsweep_description[0]
    assert f"{len(ds['Omega'])} not computed" in title and f"{len(ds['Omega'])} failed" in title
    strip = plot.motion_figure(ds.isel(Omega=0))  # a ValueError before
    ticks = [t.get_text() for t in strip.axes[0].get_yticklabels()]
    (dots,) = strip.axes[0].collections
    drawn = [to_rgba(colour) for colour in dots.get_facecolors()[:2]]
    assert drawn == [failed, missing] and "not computed" in ticks


def test_an_integer_map_refuses_a_continuous_scale(files):
    with pytest.raises(UsageError, match="^vmin and vmax set a continuous colour scale; var period holds integers"):
        plot.plot(files["plane"], var="period", vmax=3)
    with pytest.raises(UsageError, match="^log: var period holds integers"):
        plot.plot(files["plane"], var="period", log=True)


# --- lambda_1: a diverging scale symmetric about zero, values within their band marked ---------


def test_the_lyapunov_scale_is_symmetric_about_zero_and_marks_values_within_their_band(files):
    ds = load_results(files["plane"])
    values = np.linspace(-0.5, 0.05, 120).reshape(12, 10)  # far from symmetric: 10 times more negative
    errors = np.full((12, 10), 0.01)
    values[2, 1], values[3, 3] = 0.004, -0.008  # within their band of zero
    ds["lyapunov"].values[...] = values
    ds["lyapunov_err"].values[...] = errors
    fig = plot.map_figure(ds, "lyapunov")
    norm = _mesh(fig.axes[0]).norm
    assert norm.vmin == -norm.vmax == -0.5  # one slope for both signs
    assert norm(0.0) == 0.5
    assert fig.axes[1].get_ylabel().startswith("$\\lambda_1$")  # as on the 1-D figure
    (hatched,) = [c for c in fig.axes[0].collections if isinstance(c, PatchCollection)]
    assert hatched.get_gid() == "within_error_of_zero" and hatched.get_hatch()
    expected = int(np.sum(np.abs(values) <= errors))
    assert expected >= 2 and len(hatched.get_paths()) == expected
    # vmax alone sets both ends; what lies beyond is said on the colour bar.
    fig = plot.map_figure(ds, "lyapunov", vmax=0.2)
    norm = _mesh(fig.axes[0]).norm
    assert (norm.vmin, norm.vmax) == (-0.2, 0.2)
    assert "floored at -0.2" in fig.axes[1].get_ylabel()


@pytest.mark.parametrize("size", [None, (3.4, 2.6)])
def test_the_lyapunov_colour_bar_labels_each_tick_with_its_own_value(files, size):
    # Eighths of the largest |lambda_1| = 1.9467, printed to two digits, put '1.5' at 1.46.
    ds = load_results(files["plane"])
    ds["lyapunov"].values[...] = np.linspace(-1.9467, 0.3, 120).reshape(12, 10)
    ds["lyapunov_err"].values[...] = 0.001
    fig = plot.map_figure(ds, "lyapunov", size=size)
    fig.canvas.draw()
    bar = fig.axes[1]
    ticks, labels = bar.get_yticks(), [t.get_text().replace("\u2212", "-") for t in bar.get_yticklabels()]
    assert len(ticks) >= 3 and 0.0 in ticks
    for tick, label in zip(ticks, labels):
        assert float(label) == pytest.approx(tick, abs=1e-12), (tick, label)
    assert np.allclose(np.sort(ticks), -np.sort(ticks)[::-1])  # symmetric about zero


def test_the_resonance_curve_keeps_a_dark_edge_over_the_white_middle_of_the_lyapunov_scale(files):
    # The white dashed g_res(Omega) vanished over the cells with lambda_1 near 0 (white).
    from matplotlib.colors import to_rgb
    from matplotlib.patheffects import Stroke

    ds = load_results(files["plane"])
    fig = plot.map_figure(ds, "lyapunov")
    (curve,) = fig.axes[0].findobj(lambda artist: artist.get_gid() == "resonance")
    strokes = [effect for effect in curve.get_path_effects() if isinstance(effect, Stroke)]
    assert strokes and max(to_rgb(strokes[0]._gc["foreground"])) < 0.3
    assert strokes[0]._gc["linewidth"] > max(np.ravel(curve.get_linewidths()))
    handle = next(h for h in fig.legends[0].legend_handles if "g_{res}" in h.get_label())
    assert handle.get_path_effects()  # the legend's sample looks like the line


# --- caps on a colour scale are stated -----------------------------------------------------------


def test_a_capped_colour_scale_says_so_on_the_figure(files):
    ds = load_results(files["plane"])
    R = np.linspace(1.0, 9.7, 120).reshape(12, 10)
    R[4, 3] = 16.5  # one wild point (of 120: above the 99th percentile)
    ds["R"].values[...] = R
    ds["R_err"].values[...] = 0.0
    fig = plot.map_figure(ds, "R")
    norm = _mesh(fig.axes[0]).norm
    assert norm.vmax == pytest.approx(np.percentile(R, 99))
    bar = fig.axes[1].get_ylabel()
    assert "capped at" in bar and "99th pct." in bar and "max 16.5" in bar, bar
    n_above = int(np.sum(R > np.percentile(R, 99)))  # 9.7 and 16.5: the percentile lies between them
    assert f"the 99th percentile: {n_above} cells above, up to 16.5" in fig._suptitle.get_text()
    # Chosen ends: the scale is the user's, and a cap is still stated.
    fig = plot.map_figure(ds, "R", vmin=2.0, vmax=5.0, title=False)
    norm = _mesh(fig.axes[0]).norm
    assert (norm.vmin, norm.vmax) == (2.0, 5.0)
    bar = fig.axes[1].get_ylabel()
    assert "capped at 5" in bar and "floored at 2" in bar
    assert any("capped at 5" in text for text in _all_text(fig))  # stated even without a title
    # No outlier, no cap: the scale reaches the largest value and says nothing.
    ds["R"].values[...] = np.linspace(1.0, 9.7, 120).reshape(12, 10)
    fig = plot.map_figure(ds, "R")
    assert _mesh(fig.axes[0]).norm.vmax == pytest.approx(9.7)
    assert "capped" not in fig.axes[1].get_ylabel()


def test_vmin_and_vmax_are_for_maps(files, tmp_path, invoke):
    with pytest.raises(UsageError, match="^vmin and vmax set the colour scale of a map; this figure has none"):
        plot.plot(files["line"], kind="bifurcation", vmax=1.0)
    result = invoke("plot", files["line"], "--vmax", "1", "-o", tmp_path / "f.png")
    assert result.exit_code == 2
    assert result.output.strip().splitlines() == [
        "Error: --vmin and --vmax set the colour scale of a map; this figure has none"]


# --- titles, sizes, styles -----------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["response", "map", "status", "bifurcation", "lyapunov", "impacts"])
def test_no_title_leaves_no_title_anywhere(files, kind):
    source = files["line"] if kind in ("response", "bifurcation", "status") else files["plane"]
    at = {"Omega": "3"} if kind == "lyapunov" else None
    fig = plot.plot(source, kind=kind, at=at, title=False)
    assert fig._suptitle is None
    assert all(ax.get_title(loc=loc) == "" for ax in fig.axes for loc in ("left", "center", "right"))
    assert plot.description(fig).count("\n") >= 1  # the description is kept for the metadata
    with_title = plot.plot(source, kind=kind, at=at)
    assert with_title._suptitle is not None and with_title._suptitle.get_text()


def test_no_title_on_basins_and_the_description_goes_into_the_png(files, tmp_path, invoke):
    from PIL import Image

    fig = plot.basin_plot(files["basins"], title=False)
    assert fig._suptitle is None
    out = tmp_path / "basins.png"
    result = invoke("plot", files["basins"], "--no-title", "-o", out)
    assert result.exit_code == 0, result.output
    with Image.open(out) as image:
        text = image.text
    assert text["Title"].startswith("Basins of attraction")
    assert "basins.h5" in text["Description"] and "g = 5" in text["Description"]


def test_the_pdf_keeps_the_description_in_its_subject(files, tmp_path, invoke):
    out = tmp_path / "f.pdf"
    assert invoke("plot", files["line"], "--no-title", "-o", out).exit_code == 0
    assert b"/Subject" in out.read_bytes()
    found = plot.read_description(out)
    assert found["Title"].startswith("Response gain R against g")
    assert "line.h5" in found["Description"] and "γ = 0.22" in found["Description"]
    result = invoke("info", out)  # and vrsweep info shows it
    assert result.exit_code == 0 and "line.h5" in result.output and "Response gain R" in result.output


@pytest.mark.parametrize("size, dpi, pixels", [("4,3", 100, (400, 300)), ("3.4,2.6", 300, (1020, 780))])
def test_size_gives_the_requested_pixels_at_the_dpi(files, tmp_path, invoke, size, dpi, pixels):
    import matplotlib.image

    out = tmp_path / "f.png"
    result = invoke("plot", files["line"], "--size", size, "--dpi", str(dpi), "-o", out)
    assert result.exit_code == 0, result.output
    height, width = matplotlib.image.imread(out).shape[:2]
    assert (width, height) == pixels


def test_a_bad_size_or_style_exits_2_with_one_line(files, tmp_path, invoke):
    for args, start in ((("--style", "no-such-style"), "Error: --style no-such-style: no such matplotlib style"),
                        (("--size", "4"), "Error: --size 4: expected WIDTH,HEIGHT in inches"),
                        (("--size", "0,3"), "Error: --size 0,3: width and height must be between")):
        result = invoke("plot", files["line"], *args, "-o", tmp_path / "f.png")
        assert result.exit_code == 2, result.output
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(start), result.output
        assert "Traceback" not in result.output
    assert not (tmp_path / "f.png").exists()


def test_fonts_follow_the_style(files, tmp_path, invoke):
    """No font size in points in the plotting code: a style's sizes reach every text."""
    sheet = tmp_path / "big.mplstyle"
    sheet.write_text("font.size: 20\naxes.labelsize: 20\nlegend.fontsize: 20\n")
    small = plot.plot(files["line"])
    big = plot.plot(files["line"], style=str(sheet))
    assert big.axes[0].xaxis.label.get_size() == 20
    assert big.legends[0].get_texts()[0].get_size() > 1.5 * small.legends[0].get_texts()[0].get_size()
    assert big._suptitle.get_size() > 1.5 * small._suptitle.get_size()
    named = plot.plot(files["line"], style="seaborn-v0_8-paper")
    assert named.axes[0].xaxis.label.get_size() != small.axes[0].xaxis.label.get_size()
    result = invoke("plot", files["line"], "--style", "seaborn-v0_8-paper", "-o", tmp_path / "f.png")
    assert result.exit_code == 0, result.output


def test_dimensionless_axes_show_no_unit(files):
    for kind in ("response", "bifurcation"):
        fig = plot.plot(files["line"], kind=kind)
        labels = [ax.get_xlabel() + ax.get_ylabel() for ax in fig.axes]
        assert not any("[1]" in label for label in labels), labels
    fig = plot.plot(files["plane"], kind="map")
    assert not any("[1]" in ax.get_xlabel() + ax.get_ylabel() for ax in fig.axes)


# --- many curves, the barrier line, legends, basins -----------------------------------------------


def test_many_curves_get_a_colour_scale_not_a_legend_entry_each(files):
    ds = load_results(files["plane"]).isel(Omega=slice(0, 9))
    fig = plot.response_figure(ds, x_axis="g", log=False)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert not any("Ω =" in text or "\\Omega$ =" in text for text in legend), legend
    assert len(legend) <= 8
    (bar,) = [ax for ax in fig.axes if ax is not fig.axes[0]]
    assert "$\\Omega$" in bar.get_ylabel()
    # Each curve's colour is the scale's colour of its Omega: nine values, nine colours.
    joins = [line for line in fig.axes[0].get_lines() if line.get_linestyle() == ":"]
    assert len({to_rgba(line.get_color()) for line in joins}) == 9


def test_curves_on_a_colour_scale_keep_their_neighbours_apart_in_greyscale(files):
    """Sixteen curves on viridis were 4 to 5 apart in L* from their neighbours (in value): one grey
    on a greyscale page. Curves are coloured by rank, every two neighbours at least 8 apart, the
    colour bar names each value in its own block; a tenth curve is refused (--at, or a map), and
    two close values (Omega = 3 and 3.01 beside 6) get colours as far apart as any neighbours."""
    from vrsweep.plot.palettes import MAX_SCALE_CURVES, most_scale_curves

    assert MAX_SCALE_CURVES == most_scale_curves() == 9
    plane = load_results(files["plane"])
    for ds in (plane.isel(Omega=slice(0, 9)), plane.isel(Omega=slice(0, 4)).assign_coords(Omega=[3.0, 3.01, 5.9, 6.0])):
        fig = plot.response_figure(ds, x_axis="g", log=False)
        joins = {float(Omega): line for Omega, line in
                 zip(ds["Omega"].values, [line for line in fig.axes[0].get_lines() if line.get_linestyle() == ":"])}
        grey = [_lightness(joins[Omega].get_color()) for Omega in sorted(joins)]
        assert np.all(np.diff(grey) >= 8.0), grey  # dark to light with the value, neighbours apart
        bar = fig.axes[-1]
        texts = [t.get_text() for t in bar.get_yticklabels()]
        np.testing.assert_allclose([float(t) for t in texts], sorted(joins),  # each in its block, to 2 % of a step
                                   atol=0.02 * min(np.diff(sorted(joins))))
    with pytest.raises(UsageError, match="^10 curves of R against g"):
        plot.response_figure(plane, x_axis="g", log=False)


def test_the_barrier_line_is_not_drawn_like_the_joins_of_a_sweep(files):
    fig = plot.plot(files["line"], log=False)  # continuation up and down: the hysteresis figure
    ax = fig.axes[0]
    (barrier,) = [line for line in ax.get_lines() if line.get_gid() == "barrier"]
    joins = [line for line in ax.get_lines() if line.get_linestyle() == ":"]
    assert len(joins) == 2
    for join in joins:  # neither the dash pattern nor the colour of a sweep's joins
        assert barrier._dash_pattern != join._dash_pattern
        assert to_rgba(barrier.get_color()) != to_rgba(join.get_color())


def test_legends_inside_axes_find_their_own_place(files):
    """No legend covers data: a legend inside the axes is placed by matplotlib ('best')."""
    for source, kind in ((files["line"], "bifurcation"), (files["line"], "impacts")):
        fig = plot.plot(source, kind=kind)
        for ax in fig.axes:
            legend = ax.get_legend()
            if legend is not None:
                assert legend._loc == 0, kind  # 0 is 'best'


def test_basins_mark_each_attractors_stroboscopic_points(files):
    ds = load_results(files["basins"])
    fig = plot.basin_plot(files["basins"])
    ax = fig.axes[0]
    count = int(ds["attractor_count"].values)
    labels = ds["attractor"].transpose("x0", "v0").values
    assert count >= 1
    x_limits, v_limits = ax.get_xlim(), ax.get_ylim()
    for label in range(count):
        i, j = np.argwhere(labels == label)[0]  # the first start of the basin, in grid order
        xs = ds["strobe_x"].transpose("x0", "v0", ...).values[i, j]
        vs = ds["strobe_v"].transpose("x0", "v0", ...).values[i, j]
        (mark,) = [line for line in ax.get_lines() if line.get_gid() == f"attractor {label}"]
        np.testing.assert_array_equal(mark.get_xdata(), xs)
        np.testing.assert_array_equal(mark.get_ydata(), vs)
        assert to_rgba(mark.get_markerfacecolor()) == to_rgba(BASIN_COLOURS[label])  # the basin's colour
        # Every point is in view, even one outside the swept plane.
        assert x_limits[0] <= xs.min() and xs.max() <= x_limits[1]
        assert v_limits[0] <= vs.min() and vs.max() <= v_limits[1]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("x(nT), v(nT)" in text for text in legend)


def test_a_legend_below_the_axes_fits_a_journal_column(files):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    for source, kind in ((files["line"], "response"), (files["plane"], "map")):
        fig = plot.plot(source, kind=kind, size=(3.4, 3.4), title=False, log=False if kind == "response" else None,
                        legend="outside")  # by default a legend this large is left off at this size
        FigureCanvasAgg(fig).draw()
        box = fig.legends[0].get_window_extent()
        assert 0 <= box.x0 and box.x1 <= fig.bbox.width, (kind, box, fig.bbox.width)


def test_the_svg_keeps_the_description(files, tmp_path, invoke):
    out = tmp_path / "f.svg"
    assert invoke("plot", files["plane"], "--var", "period", "--no-title", "-o", out).exit_code == 0
    found = plot.read_description(out)
    assert found["Title"].startswith("period over g and Ω") and "plane.h5" in found["Description"]


def test_a_figure_too_small_for_its_texts_says_what_to_do(files, tmp_path, invoke):
    result = invoke("plot", files["line"], "--size", "2,1.5", "-o", tmp_path / "f.png")
    assert result.exit_code == 0, result.output
    assert "Note: " in result.output and "too small for its title" in result.output
    assert "--no-title, a larger --size" in result.output and "constrained_layout" not in result.output


def test_a_written_models_greek_symbols_are_letters_in_the_description():
    """A written model's symbols are any LaTeX Greek letter: \\zeta and \\varphi were written
    "zeta" and "varphi" in the PNG's Description (vrsweep info FIGURE.png), Delta as Δ."""
    from types import SimpleNamespace

    from vrsweep.plot.labels import description

    figure = SimpleNamespace(_vrsweep_description=(
        r"Response gain R against $\omega$",
        r"$\zeta$ = 0.05,  $\varphi$ = 0,  $\Delta$ = 1.2,  $\varepsilon$ = 1,  $\tilde\omega$,  $\omega_0$"))
    assert description(figure) == "Response gain R against ω\nζ = 0.05,  φ = 0,  Δ = 1.2,  ε = 1,  ω̃,  ω0"


# --- categorical colours: apart on a greyscale page ---------------------------------------------


def _apart_in_grey(colours):
    """The smallest difference in CIE L* between two of ``colours``."""
    light = sorted(_lightness(colour) for colour in colours)
    return min(np.diff(light))


def _six_attractors(ds):
    """The basin file's slice with six attractors over its six starts, the table to match."""
    import xarray as xr

    count = 6
    ds = ds.drop_dims("attractor_label")
    ds["attractor"].values[...] = np.arange(count).reshape(ds["attractor"].shape)
    ds["attractor_count"] = xr.DataArray(count)
    table = {"attractor_period": np.ones(count, dtype=int), "attractor_R": np.linspace(1.0, 2.0, count),
             "attractor_fraction": np.full(count, 1.0 / count),
             "attractor_impacts_per_cycle": np.ones(count, dtype=int)}
    for name, values in table.items():
        ds[name] = xr.DataArray(values, dims=("attractor_label",))
    return ds


def test_every_categorical_palette_stays_apart_in_greyscale():
    """tab10's orange and green (L* 67, 58) and blue and red (48, 47) printed as one grey: every
    palette of categories, with the greys and black and white drawn beside it, differs by 8 in L*
    between any two colours; beyond six, the rarer categories are told apart in colour."""
    from vrsweep.plot.palettes import LIGHTNESS_STEP, NO_VALUE_GREY, NOT_COMPUTED_GREY, STATUS_COLOURS, categorical
    from vrsweep.plot.labels import RELIABLE_COLOURS
    assert LIGHTNESS_STEP == 8.0
    for count in range(1, 7):
        assert _apart_in_grey(categorical(count) + [NO_VALUE_GREY, NOT_COMPUTED_GREY, "black", "white"]) >= 8.0, count
    for count in (7, 12):  # the first six as before, the rest apart in colour
        many = categorical(count)
        assert many[:6] == categorical(6) and len({to_rgba(colour) for colour in many}) == count
    many = [_lightness(colour) for colour in categorical(16)]  # beyond: dark to light
    assert np.all(np.diff(many) > 0), many
    assert _apart_in_grey(list(STATUS_COLOURS.values())) >= 8.0
    assert _apart_in_grey(list(RELIABLE_COLOURS)) >= 8.0  # every curve a figure draws with a legend


def test_six_attractors_six_periods_and_every_status_are_apart_in_greyscale(files):
    """The colours a basin plot, an integer map and a status map draw with, read off their meshes."""
    fig = plot.basin_figure(_six_attractors(load_results(files["basins"])))
    mesh = _mesh(fig.axes[0])
    assert _apart_in_grey([mesh.cmap(k) for k in range(mesh.cmap.N)]) >= 8.0  # failed, missing, 6 basins
    ds = load_results(files["plane"])
    ds["period"].values[...] = np.resize([0, 1, 2, 3, 4, 5, 6], 12)[:, None]
    mesh = _mesh(plot.map_figure(ds, "period").axes[0])
    assert mesh.cmap.N == 7 and _apart_in_grey([mesh.cmap(k) for k in range(7)] + ["0.85"]) >= 8.0
    # Eight periods: the six of most cells (here 1 to 6, periods 7 and 8 one cell each) apart in grey.
    ds["period"].values[...] = np.resize([1, 2, 3, 4, 5, 6], 12)[:, None]
    ds["period"].values[0, 0], ds["period"].values[0, 1] = 7, 8
    mesh = _mesh(plot.map_figure(ds, "period").axes[0])
    assert mesh.cmap.N == 8 and _apart_in_grey([mesh.cmap(k) for k in range(6)] + ["0.85"]) >= 8.0
    ds["status"].values[...] = np.resize([0, 1, 2, 3, 4, 5], 12)[:, None]
    for fig in (plot.status_figure(ds), plot.map_figure(ds, "status")):
        mesh = _mesh(fig.axes[0])
        colours = {tuple(mesh.cmap(k)) for k in range(mesh.cmap.N)} | {to_rgba("0.85")}  # the background
        assert len(colours) >= 6 and _apart_in_grey(colours) >= 8.0


def test_an_attractors_dots_stand_out_on_its_own_basin(files):
    """The dots of attractor 0 lie in its basin: filled with its colour and edged black, they were
    one blue on blue. A black rim outside a white ring: one of them stands out on any cell."""
    from matplotlib.colors import to_rgb
    from matplotlib.patheffects import Stroke

    fig = plot.basin_plot(files["basins"])
    ax = fig.axes[0]
    marks = [line for line in ax.get_lines() if (line.get_gid() or "").startswith("attractor ")]
    assert marks
    for mark in marks:
        (rim,) = [effect for effect in mark.get_path_effects() if isinstance(effect, Stroke)]
        ring, outer = mark.get_markeredgecolor(), rim._gc["foreground"]
        assert abs(_lightness(ring) - _lightness(outer)) >= 90.0, (ring, outer)
        assert rim._gc["linewidth"] > mark.get_markeredgewidth()  # the rim shows outside the ring
        assert to_rgb(mark.get_markerfacecolor()) != to_rgb(ring)
    handle = next(h for h in fig.legends[0].legend_handles if "x(nT), v(nT)" in h.get_label())
    assert handle.get_path_effects()  # the legend's sample looks like the dots


# --- a map of few cells is ticked at its cells ---------------------------------------------------


@pytest.mark.parametrize("size", [None, (3.4, 2.6)])
def test_a_map_of_few_cells_is_ticked_at_its_cells(files, size):
    """Omega from 3 to 6 in 10 rows was ticked at 3.5, 4.5..., between rows, where a reader looks
    for a row computed at 3.5. Every tick of both axes sits on a grid value, its label reads that
    value (to 2 % of a cell), labels do not overlap, and the first row and column are ticked."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    ds = load_results(files["plane"])
    for fig in (plot.map_figure(ds, "R", size=size), plot.status_figure(ds, size=size)):
        FigureCanvasAgg(fig).draw()
        ax = fig.axes[0]
        for axis, name in ((ax.xaxis, "g"), (ax.yaxis, "Omega")):
            grid = ds[name].values
            step = np.min(np.diff(grid))
            ticks = [tick for tick in axis.get_major_ticks() if tick.label1.get_visible() and tick.label1.get_text()]
            located = np.array([tick.get_loc() for tick in ticks])
            assert len(located) >= 2 and located[0] == grid[0], (name, located)
            assert np.all(np.min(np.abs(located[:, None] - grid[None, :]), axis=1) == 0.0), (name, located)
            for tick in ticks:
                assert abs(float(tick.label1.get_text().replace("\u2212", "-")) - tick.get_loc()) <= 0.02 * step
            boxes = [tick.label1.get_window_extent() for tick in ticks]
            for first, second in zip(boxes, boxes[1:]):
                assert not first.overlaps(second), (name, size)


# --- a written model's equation in its caption ------------------------------------------------------


@pytest.mark.parametrize("example", ["impact_linear", "impact_two_sided", "impact_duffing_two_forces",
                                     "paper_written"])
def test_a_written_models_caption_prints_its_equation_in_its_symbols(example):
    """The caption printed the acceleration as the config wrote it, "x'' = -2 * zeta * v - x +
    F * cos(omega * t + phi)", beside parameters named by their symbols (ζ = 0.05): it is
    mathtext in the model's symbols, which matplotlib draws; the description (the figure file's
    metadata) keeps the config's text."""
    from pathlib import Path
    from types import SimpleNamespace

    from matplotlib.mathtext import MathTextParser

    from vrsweep.config.validate import load_config
    from vrsweep.plot.labels import _caption, description

    config = load_config(Path(plot.__file__).parents[1] / "examples" / f"{example}.yaml")
    caption = _caption("f.h5", config, "written", width=400)
    (equation,) = [part for part in caption.split("$") if part.startswith("\\ddot{x} = ")]
    MathTextParser("path").parse(f"${equation}$")  # matplotlib draws it
    assert "*" not in equation and "\\dot{x}" in equation, equation
    used = [name for name in config.model.parameter_names if name in config.model.acceleration.replace("*", " ")
            .replace("(", " ").replace(")", " ").split()]
    for name in used:  # every parameter the acceleration uses, by its symbol where it has one
        symbol = config.model.symbol(name)
        if symbol:
            assert symbol in equation, (name, symbol, equation)
        assert f" {name} " not in f" {equation} " or not symbol, (name, equation)
    said = description(SimpleNamespace(_vrsweep_description=("R", caption)))
    assert f"x'' = {config.model.acceleration}" in " ".join(said.split())


def test_a_function_after_a_factor_is_not_read_as_arccos():
    """'a*cos(w*t)' was drawn 'acos(tw)' (mathtext sets no space between a factor and a function's
    name, where TeX does): read as arccos(tw). A thin space separates them; 2 zeta x' stays as is."""
    from matplotlib.mathtext import MathTextParser

    from vrsweep.config.validate import config_from_dict
    from vrsweep.plot.labels import written_equation

    config = config_from_dict({
        "model": {"name": "pendulum", "acceleration": "-2*zeta*v - sin(x) + a*cos(w*t) - mu*sign(v) + b*exp(-x)",
                  "parameters": {"zeta": 0.05, "a": 0.5, "w": 0.8, "mu": 0.1, "b": 0.0},
                  "period": "2*pi/w", "response": {"frequency": "w", "scale": "a"}},
        "initial": {"x": 0.0, "v": 0.0}})
    equation = written_equation(config.model).split("$")[1]
    MathTextParser("path").parse(f"${equation}$")
    assert "a\\,\\cos" in equation and "\\mu\\,\\operatorname{sign}" in equation, equation
    assert "- \\sin" in equation and "2 \\zeta" in equation and "\\,\\zeta" not in equation, equation


def test_the_curves_of_a_variable_stay_apart_in_greyscale(files):
    """Five curves of --var x_max took tab10's blue, orange, green, red and purple, all drawn 'o':
    red, blue and purple (L* 47, 48, 52) were one grey. Any two curves differ in their marker or
    by 8 in L*; so do those of the impacts figure."""
    ds = load_results(files["plane"]).isel(Omega=slice(0, 5))
    for fig in (plot.variable_figure(ds, "x_max", x_axis="g"), plot.impacts_figure(ds, x_axis="g")):
        curves = [line for line in fig.axes[0].get_lines() if len(line.get_xdata()) == len(ds["g"])]
        assert len(curves) == 5
        for k, first in enumerate(curves):
            for second in curves[k + 1:]:
                assert first.get_marker() != second.get_marker() or \
                    abs(_lightness(first.get_color()) - _lightness(second.get_color())) >= 8.0


def test_as_many_curves_as_a_figure_allows_keep_apart_in_greyscale(files):
    """From the fourth curve on, response, lambda_1 and bifurcation figures took tab10's red, purple,
    brown... in turn: red, blue and purple are L* 47, 48 and 52, one grey on a greyscale page. With
    as many curves as a figure draws with a legend (MAX_CURVES), every two differ by 8 in L*, and
    a ninth is refused rather than drawn in a repeated colour."""
    from matplotlib.colors import to_rgb

    from vrsweep.plot.labels import MAX_CURVES

    assert MAX_CURVES == 8
    plane = load_results(files["plane"]).isel(Omega=slice(0, MAX_CURVES))
    cube = load_results(files["cube"])  # Omega x Delta: 8 curves over g, each in the legend
    figures = {"response": (plot.response_figure(cube, x_axis="g"), "periodic"),  # the marks, whatever their kind
               "variable": (plot.variable_figure(plane, "x_max", x_axis="g"), None),
               "impacts": (plot.impacts_figure(plane, x_axis="g"), None),
               "lyapunov": (plot.lyapunov_figure(plane, x_axis="g"), "lyapunov"),
               "bifurcation": (plot.bifurcation_figure(plane, x_axis="g"), "strobe")}
    for kind, (fig, gid) in figures.items():
        ax = fig.axes[0]
        curves = [line for line in ax.get_lines() if (gid is None and len(line.get_xdata()) == len(plane["g"]))
                  or (gid is not None and gid in (line.get_gid() or ""))]
        colours = {to_rgb(line.get_color()) for line in curves}
        assert len(colours) == MAX_CURVES, (kind, colours)
        assert _apart_in_grey(colours) >= 8.0, (kind, sorted(_lightness(colour) for colour in colours))
    nine = load_results(files["plane"]).isel(Omega=slice(0, MAX_CURVES + 1))
    for draw in (plot.lyapunov_figure, plot.bifurcation_figure, plot.impacts_figure):
        with pytest.raises(UsageError, match="^9 curves") as refused:
            draw(nine, x_axis="g")
        # A map of the samples x(nT) is no figure vrsweep draws: not suggested for them.
        assert ("map" in str(refused.value)) == (draw is not plot.bifurcation_figure), str(refused.value)


def test_the_resonance_lines_of_several_curves_are_each_curves_own(files):
    """Bifurcation and lambda_1 figures of curves over Omega drew one line g_res = 21.065, the
    resonance at the config's Omega = 4, which none of the curves had. Each curve gets its own,
    Omega^2 sqrt(2 (omega^2 + omega0^2) / (3 alpha)) (eq3.4, written out here), in its colour."""
    from matplotlib.colors import to_rgb

    ds = load_results(files["plane"]).isel(Omega=slice(0, 4))
    alpha, omega0, omega = 0.1, 0.1, 0.5  # the paper's, the plane's config
    expected = [Omega ** 2 * np.sqrt(2 * (omega ** 2 + omega0 ** 2) / (3 * alpha)) for Omega in ds["Omega"].values]
    for fig in (plot.bifurcation_figure(ds, x_axis="g"), plot.lyapunov_figure(ds, x_axis="g")):
        ax = fig.axes[0]
        lines = [line for line in ax.get_lines() if "g_{res}" in line.get_label()]
        positions = sorted(float(line.get_xdata()[0]) for line in lines)
        in_view = [g for g in expected if g <= float(ds["g"].max())]
        assert len(in_view) >= 2 and np.allclose(positions, in_view, rtol=1e-12), (positions, expected)
        curves = {line.get_label(): to_rgb(line.get_color()) for line in ax.get_lines()
                  if line.get_gid() in ("strobe", "lyapunov")}
        for line in lines:
            owner = line.get_label().split(":")[0]
            assert curves[owner] == to_rgb(line.get_color()), (owner, line.get_label())


def test_a_log_map_draws_zero_counts_in_its_bottom_colour_not_as_no_value(files):
    """A logarithmic norm masks values <= 0 as it masks NaN: cells with no impacts were drawn in
    the background's light grey, which the title reads as 'no value: not computed or failed',
    while the caption said they were below the scale, in its bottom colour. They are drawn there."""
    ds = load_results(files["plane"])
    ds["impacts_per_period"].values[:2, :] = 0.0
    fig = plot.map_figure(ds, "impacts_per_period", log=True)
    mesh = _mesh(fig.axes[0])
    drawn = mesh.to_rgba(mesh.get_array()).reshape(len(ds["Omega"]), len(ds["g"]), 4)
    zero = drawn[:, :2].reshape(-1, 4)
    assert np.all(zero[:, 3] == 1.0)  # opaque: not the background showing through
    assert np.allclose(zero, to_rgba(mesh.cmap.get_under()))
    assert f"{2 * len(ds['Omega'])} cells below, down to 0" in fig._vrsweep_description[1]


def test_measured_values_at_zero_on_a_log_axis_are_said_not_dropped(files):
    """On a logarithmic axis matplotlib leaves out values <= 0 without a mark: R = 0 (a written
    model's response frequency no harmonic of the orbit) vanished from the response and --var
    figures, and no caption said so. The caption counts them."""
    ds = load_results(files["plane"]).isel(Omega=0)
    ds["R"].values[:3] = 0.0
    ds["Q_amplitude"].values[:3] = 0.0
    for fig, symbol in ((plot.response_figure(ds, log=True), "R"), (plot.response_figure(ds, log=True, amplitude=True), "|Q|"),
                        (plot.variable_figure(ds, "R", log=True), "R")):
        caption = " ".join(fig._vrsweep_description[1].split())
        assert f"3 measured points with {symbol} = 0 not drawn: below the logarithmic axis" in caption, caption
    linear = plot.response_figure(ds, log=False)
    assert "not drawn" not in linear._vrsweep_description[1]  # drawn at zero there


def test_every_sweep_figure_labels_its_axes_with_the_units_the_file_gives(files):
    """Only maps and --var curves took a coordinate's units from the file: the response, impacts,
    status, motion, bifurcation and lambda_1 figures labelled the same axis without them."""
    ds = load_results(files["plane"]).isel(Omega=slice(0, 2))
    ds["g"].attrs["units"] = "m s-2"
    ds["Omega"].attrs["units"] = "rad s-1"
    figures = [plot.response_figure(ds, x_axis="g"), plot.impacts_figure(ds, x_axis="g"),
               plot.status_figure(ds, x_axis="g"), plot.motion_figure(ds, x_axis="g"),
               plot.bifurcation_figure(ds, x_axis="g"), plot.lyapunov_figure(ds, x_axis="g"),
               plot.variable_figure(ds, "x_max", x_axis="g")]
    for fig in figures:
        assert fig.axes[0].get_xlabel().endswith("[m s-2]") or fig.axes[-1].get_xlabel().endswith("[m s-2]"), \
            [ax.get_xlabel() for ax in fig.axes]
    plane = load_results(files["plane"])
    plane["g"].attrs["units"], plane["Omega"].attrs["units"] = "m s-2", "rad s-1"
    for fig in (plot.map_figure(plane, "R"), plot.status_figure(plane), plot.motion_figure(plane)):
        ax = fig.axes[0]
        assert ax.get_xlabel().endswith("[m s-2]") and ax.get_ylabel().endswith("[rad s-1]"), fig


def test_a_remade_legend_keeps_its_marks_size_and_a_long_one_goes_below(files, tmp_path):
    """A legend made again (--legend outside, or in more columns) took its own markerscale on
    handles that carried it already: a bifurcation diagram's dots 9 times their size below, and
    each column count tried 3 times larger again, until drawing ran out of memory (five curves
    over Omega). Its marks keep the size they have inside; a long legend goes below the panel,
    where 'best' laid it over the samples."""
    ds = load_results(files["plane"])
    one = ds.isel(Omega=0)
    inside = plot.bifurcation_figure(one, legend="best").axes[0].get_legend()
    below = plot.bifurcation_figure(one, legend="outside").legends[0]

    def sizes(legend):
        return {text.get_text(): handle.get_markersize() for text, handle in zip(legend.get_texts(),
                                                                                  legend.legend_handles)
                if handle.get_marker() in (".", "o")}  # the samples' marks (lines have none to draw)

    assert sizes(below) == sizes(inside) and max(sizes(inside).values()) == 3 * 2.5
    five = plot.bifurcation_figure(ds.isel(Omega=slice(0, 5)), x_axis="g")
    assert five.legends and five.axes[0].get_legend() is None
    five.savefig(tmp_path / "five.png", dpi=60)  # drawn, in bounded memory
    assert max(sizes(five.legends[0]).values()) == 3 * 2.5


def test_a_map_of_the_period_says_its_unit(files):
    """The colour bar of --var period read 'period' (its long name too long to show): a period of
    what? Slow periods 2 pi/omega, on the map and on curves of it."""
    ds = load_results(files["plane"])
    bar = plot.map_figure(ds, "period").axes[1]
    assert bar.get_ylabel() == "period, in units of the slow period $2\\pi/\\omega$"
    curve = plot.variable_figure(ds.isel(Omega=0), "period")
    assert curve.axes[0].get_ylabel() == "period, in units of the slow period $2\\pi/\\omega$"


def test_every_variable_is_named_in_words_on_its_colour_bar_and_axis(files):
    """--var R_err's colour bar read "R_err" alone (its long name did not fit), as did motion,
    stuck_fraction, lyapunov_err, the impact speeds... Every variable a map can show says what it is
    in words, with its units, on the colour bar, and the same on a curve figure of it."""
    from vrsweep.plot.sweeps import mappable_variables
    from vrsweep.store.variables import IMPACT_VARIABLES, LYAPUNOV_VARIABLES

    ds = load_results(files["plane"])
    names = mappable_variables(ds)
    assert {name for name, *_ in IMPACT_VARIABLES + LYAPUNOV_VARIABLES} | {"R_err", "motion"} <= set(names)
    for name in names:
        bar = plot.map_figure(ds, name).axes[-1].get_ylabel().replace("\n", " ")
        curve = plot.variable_figure(ds.isel(Omega=0), name).axes[0].get_ylabel().replace("\n", " ")
        assert bar.startswith(curve), (bar, curve)  # a cap's note may follow on the colour bar
        words = curve.split(" [")[0].removeprefix(f"{name}: ")
        assert words != name and len(words.split()) >= 2, (name, curve)
        if ds[name].attrs.get("units") == "rad":
            assert curve.endswith(" [rad]"), curve


# --- maps over Omega at any scale -----------------------------------------------------------------


def _tick_texts(fig, axis):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()
    ticks = [tick for tick in axis.get_major_ticks() if tick.label1.get_visible() and tick.label1.get_text()]
    return ticks, [tick.label1.get_text() for tick in ticks]


def test_a_maps_cell_ticks_write_round_values_out(files):
    """g = 0, 10, 20, 30 was labelled 0, 1e+01, 2e+01, 3e+01 (one significant digit in '{:.1g}')."""
    ds = load_results(files["plane"]).isel(g=slice(0, 4))
    ds = ds.assign_coords(g=[0.0, 10.0, 20.0, 30.0])
    fig = plot.map_figure(ds, "R")
    _, texts = _tick_texts(fig, fig.axes[0].xaxis)
    assert texts == ["0", "10", "20", "30"], texts


@pytest.mark.parametrize("size", [None, (3.4, 2.6)])
def test_a_map_over_a_geometric_grid_has_a_logarithmic_axis(files, size):
    """Omega = 0.25, 0.5, ... 128 on a linear axis: the rows below 8 were slivers a few pixels high,
    their cells' edges at linear midpoints, and their tick labels printed on top of each other. The
    axis is logarithmic, every cell as tall as the others, its edges at geometric midpoints, each
    tick on a grid value with its value, no two labels overlapping."""
    Omega = 0.25 * 2.0 ** np.arange(10)
    ds = load_results(files["plane"]).assign_coords(Omega=Omega)
    for fig in (plot.map_figure(ds, "R", size=size), plot.status_figure(ds, size=size)):
        ax = fig.axes[0]
        assert ax.get_yscale() == "log" and ax.get_xscale() == "linear"  # g = 0 ... 55: linear
        rows = np.unique(_mesh(ax).get_coordinates()[:, 0, 1])
        np.testing.assert_allclose(np.diff(np.log(rows)), np.log(2.0))
        np.testing.assert_allclose(np.sqrt(rows[:-1] * rows[1:]), Omega)  # each value in the middle of its cell
        ticks, texts = _tick_texts(fig, ax.yaxis)
        assert len(ticks) >= 3 and ticks[0].get_loc() == Omega[0]
        for tick, text in zip(ticks, texts):
            assert tick.get_loc() in Omega and float(text) == pytest.approx(tick.get_loc(), rel=0.02)
        boxes = [tick.label1.get_window_extent() for tick in ticks]
        assert not any(a.overlaps(b) for a, b in zip(boxes, boxes[1:])), texts
    linear = plot.map_figure(load_results(files["plane"]), "R")  # Omega = 3 ... 6: stays linear
    assert linear.axes[0].get_yscale() == "linear"


def test_a_map_of_the_period_says_where_the_forcing_repeats_only_after_q_periods(files):
    """Omega/omega = 20/3 repeats after q = 3 slow periods: a locked motion has period 3 there, a map
    of the period showed its rows as period 3 with no word that it is the forcing's own period, and no
    period tripling. The caption counts those cells (g = 0 has no fast force: it repeats every T)."""
    from fractions import Fraction

    ds = load_results(files["plane"])
    omega = 0.5
    q = np.array([Fraction(float(Omega) / omega).limit_denominator(1000).denominator for Omega in ds["Omega"].values])
    assert set(q) == {1, 3}
    expected = int(np.sum(ds["g"].values > 0)) * int(np.sum(q > 1))
    for name in ("period", "impacts_per_cycle"):
        said = " ".join(plot.description(plot.map_figure(ds, name)).split())
        assert f"in {expected} of {ds['g'].size * ds['Omega'].size} cells the forcing repeats only after q = 3 " \
               "slow periods" in said, said
        assert "no period doubling" in said
    assert "repeats only" not in plot.description(plot.map_figure(ds, "R"))


def test_a_map_of_a_phase_has_a_cyclic_scale_over_the_whole_circle(files):
    """impact_phase lies in [0, 2 pi): on viridis, capped at its 99th percentile, 0.1 and 6.2 rad
    (neighbours on the circle) were its darkest and lightest colours."""
    ds = load_results(files["plane"])
    mesh = _mesh(plot.map_figure(ds, "impact_phase").axes[0])
    assert (mesh.norm.vmin, mesh.norm.vmax) == (0.0, 2.0 * np.pi)
    np.testing.assert_allclose(mesh.cmap(0.0), mesh.cmap(1.0), atol=0.02)  # one colour at 0 and 2 pi
    assert abs(_lightness(mesh.cmap(0.0)) - _lightness(mesh.cmap(0.5))) >= 40.0  # half a turn away: far apart
