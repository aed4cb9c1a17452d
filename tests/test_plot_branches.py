"""The figure of a branch file (vrsweep/plot/branches.py), checked through matplotlib's objects:
where the multipliers' lines are broken, what the legend explains at one journal column, where
the bifurcations' tags go, and what colour and style mean in each panel."""

import numpy as np
import pytest

from vrsweep import plot

COLUMN = (3.4, 2.6)
GRAZE = 24.25


def _spans(ax):
    """(low, high) of the horizontal extent of each line of ``ax`` with data (not legend proxies,
    not the unit circle's level, drawn in axes coordinates across)."""
    xs = [np.asarray(line.get_xdata(), dtype=float) for line in ax.get_lines() if line.get_transform() is ax.transData]
    return [(float(x.min()), float(x.max())) for x in xs if x.size > 1 and np.ptp(x) > 0]


@pytest.mark.parametrize("impacts_change", [True, False], ids=["impacts change", "graze record alone"])
def test_the_multipliers_are_not_joined_across_a_graze(tmp_path, impacts_change):
    from handmade import write_grazing_branch_file

    path = write_grazing_branch_file(tmp_path / "graze.h5", impacts_change=impacts_change)
    fig = plot.plot(path)
    top, bottom = fig.axes[:2]
    multipliers = _spans(bottom)
    assert multipliers, "the multipliers are drawn"
    assert not [span for span in multipliers if span[0] < GRAZE < span[1]], multipliers
    # Both sides are drawn: 22 to 24 free, 24.5 to 26 impacting, each multiplier.
    assert sorted(multipliers) == [(22.0, 24.0)] * 2 + [(24.5, 26.0)] * 2
    # R is continuous through the graze: the gain's line goes on across it.
    assert [span for span in _spans(top) if span[0] < GRAZE < span[1]]


def _below_the_panels(fig, legend):
    from vrsweep.plot.layout import renderer_of

    renderer = renderer_of(fig)
    return legend.get_window_extent(renderer).y1 <= min(ax.get_window_extent(renderer).y0 for ax in fig.axes) + 1


def test_at_one_column_a_multi_branch_legend_is_kept_abbreviated_below_the_panels(tmp_path):
    from handmade import write_switched_branch_file

    fig = plot.plot(write_switched_branch_file(tmp_path / "switched.h5"), size=COLUMN, title=False)
    (legend,) = fig.legends  # not left off, not inside a panel over the data
    assert all(ax.get_legend() is None for ax in fig.axes)
    labels = [text.get_text() for text in legend.get_texts()]
    assert {"2T", "4T", "PD: doubling", "stable (- - unstable)"} <= set(labels), labels
    assert _below_the_panels(fig, legend)
    assert "abbreviated" in plot.legend_note(fig)
    # A screen-sized figure keeps the words in full.
    full = [text.get_text() for text in plot.plot(tmp_path / "switched.h5").legends[0].get_texts()]
    assert {"period 2 T", "period 4 T", "PD: period doubling"} <= set(full), full


def test_where_below_leaves_the_panels_too_little_the_legend_is_a_strip_above_the_data(tmp_path):
    from handmade import write_switched_branch_file

    fig = plot.plot(write_switched_branch_file(tmp_path / "switched.h5"), size=(2.6, 2.0), title=False)
    top = fig.axes[0]
    legend = top.get_legend()
    assert legend is not None and not fig.legends
    from vrsweep.plot.layout import renderer_of

    renderer = renderer_of(fig)
    box = legend.get_window_extent(renderer)
    # Every point of the data (branches, theory, markers) lies below the strip.
    for line in top.get_lines():
        if line.get_transform() is not top.transData or np.size(line.get_xdata()) == 0:
            continue
        y = top.transData.transform(np.column_stack([line.get_xdata(), line.get_ydata()]))[:, 1]
        assert np.all(y[np.isfinite(y)] < box.y0), line
    # An explicit vertical range is not raised: the legend goes where it did before.
    fixed = plot.plot(tmp_path / "switched.h5", size=(2.6, 2.0), title=False, ylim=(20.0, 40.0))
    assert fixed.axes[0].get_ylim() == (20.0, 40.0)


def _tag_boxes(fig):
    """{tag text: (its box, its point in pixels)} of the gain panel's visible tags."""
    from matplotlib.text import Text

    from vrsweep.plot.layout import renderer_of

    renderer = renderer_of(fig)
    top = fig.axes[0]
    return {text.get_text(): (Text.get_window_extent(text, renderer), top.transData.transform(text.xy))
            for text in top.texts if (text.get_gid() or "").startswith("tag") and text.get_visible()}


# Like fig1c's cascade: a doubling on the branch and two of the period-4 branch just below and left
# of it (their markers overlap), a graze beside them, two folds further on. Before, PD3 was written
# over the other markers and G1 and PD1 were stacked four tag heights away.
CROWDED = (("period_doubling", 45.7483), ("period_doubling", 45.7478, 8.25), ("period_doubling", 45.7476, 8.24),
           ("grazing", 45.7500), ("fold", 45.7738), ("fold", 45.7904))


@pytest.mark.parametrize("size", [COLUMN, (8.0, 6.0)], ids=["one column", "screen"])
@pytest.mark.parametrize("crowded", [False, True], ids=["cascade", "crowded"])
def test_tags_sit_next_to_their_points_clear_of_each_other_and_of_the_markers(tmp_path, size, crowded):
    from handmade import CASCADE, write_cascade_branch_file

    from vrsweep.plot.layout import renderer_of

    bifurcations = CROWDED if crowded else CASCADE
    fig = plot.plot(write_cascade_branch_file(tmp_path / "cascade.h5", bifurcations), size=size, title=False)
    tags = _tag_boxes(fig)
    assert len([tag for text in tags for tag in text.split(", ")]) == len(bifurcations)
    renderer = renderer_of(fig)
    markers = [line.get_window_extent(renderer) for line in fig.axes[0].get_lines()
               if (line.get_gid() or "").startswith("bifurcation")]
    legends = [legend.get_window_extent(renderer) for legend in fig.legends]
    boxes = [box for box, _ in tags.values()]
    for number, (text, (box, point)) in enumerate(tags.items()):
        for other in boxes[number + 1:] + markers + legends:
            overlap = min(box.x1, other.x1) - max(box.x0, other.x0), min(box.y1, other.y1) - max(box.y0, other.y0)
            assert min(overlap) <= 0.5, (text, box, other)
        # Near its point: within about two tag heights of the marker's centre.
        gap = np.hypot(max(box.x0 - point[0], 0, point[0] - box.x1), max(box.y0 - point[1], 0, point[1] - box.y1))
        assert gap <= 3.0 * box.height, (text, gap, box.height)


def test_a_crowd_of_bifurcations_gets_one_tag_saying_how_many_and_where(tmp_path):
    """Fig. 1's continuation figure drew some thirty tags at g = 17.6-17.9 of a 40-wide axis,
    joined ('PD?6, PD10') and led out by lines over each other: unreadable. More than eight within
    1 % of the axis in view of each other get one tag, their count and range; the others keep
    theirs. Zoomed in (--xlim), each has its own again."""
    from handmade import write_cascade_branch_file

    crowd = tuple(("period_doubling", 45.70 + 0.005 * k, 4.0 + 0.3 * k) for k in range(30))
    path = write_cascade_branch_file(tmp_path / "crowd.h5", crowd + (("fold", 32.0), ("fold", 53.0)))
    fig = plot.plot(path, zoom="none", title=False)
    tags = _tag_boxes(fig)
    assert set(tags) == {"F1", "F2", "30 bifurcations,\n$g$ 45.7\u201345.845"}, list(tags)
    boxes = [box for box, _ in tags.values()]
    for number, box in enumerate(boxes):
        for other in boxes[number + 1:]:
            assert min(min(box.x1, other.x1) - max(box.x0, other.x0), min(box.y1, other.y1) - max(box.y0, other.y0)) <= 0.5
    near = plot.plot(path, xlim=(45.69, 45.86), title=False)
    assert len([tag for text in _tag_boxes(near) for tag in text.split(", ")]) == 30


def _data_lines(ax):
    return [line for line in ax.get_lines() if line.get_transform() is ax.transData and np.size(line.get_xdata()) > 1
            and not getattr(line, "_vrsweep_context", False)]


def test_colour_means_the_period_in_both_panels_and_markers_tell_periods_apart_in_grey(tmp_path):
    from matplotlib.colors import to_hex

    from handmade import write_switched_branch_file

    fig = plot.plot(write_switched_branch_file(tmp_path / "switched.h5"), size=COLUMN, title=False)
    top, bottom = fig.axes[:2]
    looks = {to_hex(line.get_color()): line.get_marker() for line in _data_lines(top)}
    assert len(looks) == 2  # period 2 and period 4
    # The multipliers of a branch in its colour, not C0/C1 for |mu_1|/|mu_2| whatever the branch.
    multipliers = [line for line in _data_lines(bottom) if (line.get_gid() or "").startswith("multiplier")]
    assert {to_hex(line.get_color()) for line in multipliers} == set(looks)
    for line in multipliers:
        assert line.get_marker() == looks[to_hex(line.get_color())]
    # |mu_1| and |mu_2| apart by width (stable/unstable keeps solid/dashed, as in the gain panel).
    widths = {line.get_gid(): line.get_linewidth() for line in multipliers}
    assert widths["multiplier 1"] > widths["multiplier 2"]
    assert {line.get_linestyle() for line in multipliers} == {line.get_linestyle() for line in _data_lines(top)}
    # In greyscale the two periods differ by their markers too, in the panels and in the legend.
    assert len(set(looks.values())) == 2 and "None" in looks.values()
    entries = dict(zip([text.get_text() for text in fig.legends[0].get_texts()], fig.legends[0].legend_handles))
    assert entries["4T"].get_marker() == looks[to_hex(entries["4T"].get_color())] != "None"


def test_the_grey_bifurcation_lines_of_the_multipliers_panel_are_named_in_the_legend(tmp_path):
    from matplotlib.colors import to_hex

    from handmade import write_switched_branch_file

    path = write_switched_branch_file(tmp_path / "switched.h5")
    for fig, label in ((plot.plot(path), "bifurcation, in $|\\mu|$"),
                       (plot.plot(path, size=COLUMN, title=False), "bif. in $|\\mu|$")):
        verticals = [line for line in fig.axes[1].get_lines() if (line.get_gid() or "").startswith("bifurcation line")]
        assert len(verticals) == 2
        entries = dict(zip([text.get_text() for text in fig.legends[0].get_texts()], fig.legends[0].legend_handles))
        assert label in entries, list(entries)
        assert to_hex(entries[label].get_color()) == to_hex(verticals[0].get_color())


def test_a_sweep_over_a_second_axis_is_drawn_where_the_branch_is(tmp_path, invoke, write_config):
    # Its first value of the other axis (Omega = 3) was drawn beside a branch at Omega = 4.
    from handmade import write_grazing_branch_file

    from vrsweep.errors import UsageError
    from vrsweep.store.reading import load_results

    branch = write_grazing_branch_file(tmp_path / "graze.h5", impacts_change=True)
    import yaml

    omega = float(yaml.safe_load(str(plot.load(branch).attrs["config"]))["parameters"]["Omega"])
    assert omega == 4.0
    for name, values in (("with", f"[3.0, {omega}]"), ("without", "[3.0, 5.0]")):
        config = write_config(tmp_path, f"""\
            model: effective
            parameters: {{gamma: 0.05, alpha: 0.05}}
            sweep:
              g: [22.0, 24.0, 26.0]
              Omega: {values}
            integration: {{transient_periods: 3, measure_periods: 4, strobe_periods: 2}}
            """, name=f"{name}.yaml")
        assert invoke("run", config, "-o", tmp_path / f"{name}.h5", "--quiet").exit_code == 0
    sweep = load_results(tmp_path / "with.h5")
    sweep["R"].values[...] = [[1.0, 2.0], [1.0, 2.0], [1.0, 2.0]]  # the row at the branch's Omega: 2
    fig = plot.plot([plot.load(branch), sweep])
    (points,) = [line for line in fig.axes[0].get_lines() if line.get_label() == "sweep"]
    np.testing.assert_array_equal(points.get_ydata(), [2.0, 2.0, 2.0])
    with pytest.raises(UsageError, match="^without.h5 is swept over Omega too, and none of its values is the "
                                         "branch's Omega = 4"):
        plot.plot([branch, tmp_path / "without.h5"])
    # The sweep given first: it said several files go together only for trajectories' impacts.
    with pytest.raises(UsageError, match=r"^branch files \(vrsweep continue\) go first, the sweep files drawn "
                                         r"with them after"):
        plot.plot([sweep, branch])


def test_a_parameter_the_config_sweeps_is_stated_at_the_value_the_branch_held(tmp_path):
    # Continuation ignores sweep axes; the caption left a swept Omega out as if it varied.
    from handmade import CONFIG, orbit

    from vrsweep.analysis.continuation import Branch
    from vrsweep.config.validate import config_from_dict
    from vrsweep.store import branch_file

    config = config_from_dict({**CONFIG, "parameters": {**CONFIG["parameters"], "Omega": 4.5},
                               "sweep": {"Omega": {"start": 3.0, "stop": 6.0, "num": 4}}})
    orbits = [orbit(value, True) for value in np.linspace(22.0, 24.0, 5)]
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "g left"),
                                                       "up": ("left_range", "g left")})]
    path = tmp_path / "branch.h5"
    branch_file.write_branch(path, branch_file.branch_arrays(branches, [], 23.0), config, "rk45")
    description = plot.description(plot.plot(path))
    assert "Ω = 4.5" in description, description


def test_one_symbol_one_meaning_bifurcations_periods_and_sweeps(tmp_path, invoke, write_config):
    """A sweep's points were "^", the grazing tag's marker, and the second and third periods' line
    markers "o" and "s" were the fold's and the period doubling's: two meanings, one symbol."""
    from handmade import write_grazing_branch_file, write_switched_branch_file

    from vrsweep.plot.branches import BIFURCATION_MARKERS, PERIOD_MARKERS, SWEEP_MARKERS, UNKNOWN_BIFURCATION_MARKER

    vocabularies = [{marker for marker, _ in BIFURCATION_MARKERS.values()} | {UNKNOWN_BIFURCATION_MARKER},
                    set(PERIOD_MARKERS), set(SWEEP_MARKERS.values())]
    for k, one in enumerate(vocabularies):
        for other in vocabularies[k + 1:]:
            assert not one & other, (one, other)
    sweeps = []
    for name, axis in (("both", "{values: [22.0, 24.0, 26.0], continuation: both}"), ("plain", "[23.0, 25.0]")):
        config = write_config(tmp_path, f"""\
            model: effective
            parameters: {{gamma: 0.05, alpha: 0.05, Omega: 4.0}}
            sweep:
              g: {axis}
            integration: {{transient_periods: 3, measure_periods: 4, strobe_periods: 2}}
            """, name=f"{name}.yaml")
        assert invoke("run", config, "-o", tmp_path / f"{name}.h5", "--quiet").exit_code == 0
        sweeps.append(tmp_path / f"{name}.h5")
    fig = plot.plot([write_grazing_branch_file(tmp_path / "graze.h5"), write_switched_branch_file(tmp_path / "pd.h5"),
                     *sweeps])
    top = fig.axes[0]
    drawn = [line for line in top.get_lines() if np.size(line.get_xdata()) > 0]
    swept = {line.get_marker() for line in drawn if line.get_gid() == "sweep"}
    tagged = {line.get_marker() for line in drawn if (line.get_gid() or "").startswith("bifurcation ")}
    along = {line.get_marker() for line in drawn if line.get_gid() is None and line.get_marker() != "None"}
    assert swept == {">", "<", "x"} and tagged == {"^", "s"} and along, (swept, tagged, along)
    assert not swept & tagged and not swept & along and not tagged & along, (swept, tagged, along)


def test_the_periods_colours_are_the_projects_and_apart_in_grey(tmp_path):
    """The periods took tab10's C0, C4, C5...: the first two (L* 48 and 52) were one grey. The
    periods drawn, and up to six periods of any branch figure, differ by 8 in L* (computed in
    tests/greyscale.py); the theory's grey, unmarked, differs so from the one unmarked period."""
    from matplotlib.colors import to_hex

    from greyscale import lightness
    from handmade import write_switched_branch_file
    from vrsweep.plot.branches import THEORY_COLOUR, _period_colours
    from vrsweep.plot.palettes import QUALITATIVE

    fig = plot.plot(write_switched_branch_file(tmp_path / "switched.h5"))
    drawn = {to_hex(line.get_color()) for line in _data_lines(fig.axes[0])}
    assert drawn == {to_hex(colour) for colour in QUALITATIVE[:2]}, drawn
    for count in range(1, 7):
        colours = list(_period_colours([2 ** k for k in range(count)]).values())
        light = sorted(lightness(colour) for colour in colours)
        assert count == 1 or min(np.diff(light)) >= 8.0, (count, light)
        assert abs(lightness(colours[0]) - lightness(THEORY_COLOUR)) >= 8.0


@pytest.mark.parametrize("kind", ["fold", "branch_point", "period_doubling"])
def test_a_branch_changes_style_at_its_located_bifurcation_not_at_the_next_orbit(tmp_path, kind):
    """Five orbits in g, 1 apart, stable up to 23, the bifurcation located at 23.4: the solid line
    ends and the dashed one begins there, in both panels, and the multipliers meet it at its
    own moduli. Up to 0.7.12 the solid line went on to the next orbit, 24 (the symmetric Duffing
    oscillator's branch point, on steps of 0.025 in omega, was drawn stable 0.0045 past it)."""
    from handmade import CONFIG, orbit

    from vrsweep.analysis.continuation import Bifurcation, Branch
    from vrsweep.config.validate import config_from_dict
    from vrsweep.store import branch_file

    orbits = [orbit(g, g <= 23.0) for g in (22.0, 23.0, 24.0, 25.0, 26.0)]
    located = orbit(23.4, True)
    located.monodromy = np.diag([1.0, 0.3])
    ends = {"down": ("left_range", "g left [21, 27]"), "up": ("left_range", "g left [21, 27]")}
    path = tmp_path / "branch.h5"
    branch_file.write_branch(path, branch_file.branch_arrays([Branch(periods=1, orbits=orbits, ends=ends)],
                                                             [Bifurcation(kind, located)], 1.0),
                             config_from_dict(CONFIG), "rk45")
    fig = plot.plot(path)
    top, bottom = fig.axes[:2]
    for ax in (top, bottom):
        lines = _data_lines(ax)
        solid = [line for line in lines if line.get_linestyle() == "-"]
        dashed = [line for line in lines if line.get_linestyle() == "--"]
        assert {(float(min(line.get_xdata())), float(max(line.get_xdata()))) for line in solid} == {(22.0, 23.4)}
        assert {(float(min(line.get_xdata())), float(max(line.get_xdata()))) for line in dashed} == {(23.4, 26.0)}
    # The gain's line passes through the located point's R; the larger multiplier's through 1.
    top_line = next(line for line in _data_lines(top) if line.get_linestyle() == "-")
    assert float(np.asarray(top_line.get_ydata())[-1]) == pytest.approx(located.R)
    larger = next(line for line in _data_lines(bottom) if line.get_gid() == "multiplier 1" and line.get_linestyle() == "-")
    assert float(np.asarray(larger.get_ydata())[-1]) == pytest.approx(1.0)


def test_a_fold_beyond_a_steep_segment_is_drawn_into_it():
    """The bouncing ball's branch (configs/bouncing_ball.yaml at the default max_step) turned at
    its fold within one arclength step: the segment where the stability changes spans 0.003 in
    Gamma and 0.31 in R, and the located fold lies 0.016 beyond it. The line ran past F1 without
    touching it (the fold was left out: within one segment's width only); it now runs through it."""
    from vrsweep.plot.branches import _with_bifurcations

    values = np.array([1.2, 1.11, 1.063, 1.066, 1.10, 1.2])
    gain = np.array([2.32, 2.33, 2.27, 1.96, 1.75, 1.5])
    stable = np.array([True, True, True, False, False, False])
    modulus = np.tile([0.5, 0.5], (6, 1))
    impacts = np.ones(6)
    drawn = _with_bifurcations(values, gain, stable, modulus, impacts, [(1.0472, 2.156, np.array([1.0, 0.25]))])
    assert list(drawn[0]) == [1.2, 1.11, 1.063, 1.0472, 1.066, 1.10, 1.2]
    assert drawn[1][3] == 2.156 and not drawn[2][3] and list(drawn[3][3]) == [1.0, 0.25]
    # a fold far from every segment where the stability changes is still left out
    far = _with_bifurcations(values, gain, stable, modulus, impacts, [(0.5, 2.156, np.array([1.0, 0.25]))])
    assert len(far[0]) == 6
