"""vrsweep.plot: every kind of figure from small real runs, checked through matplotlib's objects
(labels, lines, data), never through pixels."""

import textwrap

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.collections import QuadMesh
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from vrsweep import plot
from vrsweep.analysis import theory
from vrsweep.cli import main
from vrsweep.errors import UsageError
from vrsweep.numerics.model import DEFAULT_PARAMETERS
from vrsweep.commands.plot import FLAGS
from vrsweep.store.reading import load_results
from vrsweep.store.trajectory_file import read_trajectory
from greyscale import lightness as _lightness

SHORT = "integration: {transient_periods: 5, measure_periods: 16, strobe_periods: 8}\n"
G_RES_4 = float(theory.g_res(0.1, 0.1, 0.5, 4.0))   # 21.065 (ERRATA 7)
G_RES_5 = float(theory.g_res(0.1, 0.1, 0.5, 5.0))   # 32.914
# The theory's A/c far below any measured R (4e-5 at Omega = 0.51, 6e-4 at 1), with a fast force
# (Omega > omega = 0.5: below it no theory is drawn).
SMALL_THEORY = "parameters: {g: 100.0}\nsweep:\n  Omega: [0.51, 0.75, 1.0]\n" + SHORT


def _run(directory, name, text, *command):
    config = directory / f"{name}.yaml"
    config.write_text(textwrap.dedent(text))
    out = directory / f"{name}.h5"
    result = CliRunner().invoke(main, [*command, str(config), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Small real runs of every shape the plots take."""
    d = tmp_path_factory.mktemp("plots")
    return {
        "g": _run(d, "g", "parameters: {Omega: 4.0}\nsweep:\n  g: {start: 0.0, stop: 40.0, num: 9}\n" + SHORT, "run"),
        "g_Omega_short": _run(d, "g_Omega_short", "sweep:\n  g: {start: 0.0, stop: 40.0, num: 5}\n"
                                                  "  Omega: [4.0, 5.0]\n" + SHORT, "run"),
        "map": _run(d, "map", "sweep:\n  g: {start: 0.0, stop: 50.0, num: 7}\n"
                              "  Omega: {start: 3.0, stop: 6.0, num: 6}\n"
                              "integration: {transient_periods: 3, measure_periods: 4, strobe_periods: 2}\n", "run"),
        "both": _run(d, "both", "parameters: {Omega: 4.0}\nsweep:\n"
                                "  g: {start: 0.0, stop: 30.0, num: 4, continuation: both}\n" + SHORT, "run"),
        "traj": _run(d, "traj", "parameters: {g: 5.0, Omega: 5.0}\n"
                                "integration: {transient_periods: 4, measure_periods: 6, strobe_periods: 3}\n",
                     "simulate", "--compare", "effective", "--samples-per-period", "50"),
        "failed": _run(d, "failed", "parameters: {Omega: 4.0}\nsweep:\n  g: {start: 0.0, stop: 40.0, num: 5}\n"
                                    "integration: {transient_periods: 5, measure_periods: 16, strobe_periods: 8, "
                                    "max_steps: 6000}\n", "run"),
        "traj20": _run(d, "traj20", "parameters: {g: 20.0, Omega: 5.0}\n"
                                    "integration: {transient_periods: 4, measure_periods: 6, strobe_periods: 3}\n",
                       "simulate", "--samples-per-period", "20"),
    }


def lines_with_label(fig, text):
    return [line for ax in fig.axes for line in ax.get_lines() if text in line.get_label()]


def legend_texts(fig):
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    return [t.get_text() for legend in legends for t in legend.get_texts()]


def vertical_lines_at(ax):
    return [line.get_xdata()[0] for line in ax.get_lines()
            if len(line.get_xdata()) == 2 and line.get_xdata()[0] == line.get_xdata()[1]]


# --- response (Fig. 1, Fig. 2) -------------------------------------------------------------------


def test_response_is_the_default_for_one_axis(files):
    fig = plot.plot(files["g"])
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = fig.axes[0]
    assert "$g$" in ax.get_xlabel() and "[1]" not in ax.get_xlabel()
    assert "R = |Q|/c" in ax.get_ylabel() and "A/c" in ax.get_ylabel() and "[1]" not in ax.get_ylabel()
    assert "g.h5" in fig._suptitle.get_text() and "original" in fig._suptitle.get_text()
    assert "Ω" in fig._suptitle.get_text() or "Omega" in fig._suptitle.get_text()


def markers(ax):
    """The numerical points of a response plot by class: {gid: line}, gid = 'trusted periodic' etc."""
    return {line.get_gid(): line for line in ax.get_lines()
            if line.get_gid() and line.get_gid() not in ("failed", "barrier")}


def curve_labels(fig):
    return [text for text in legend_texts(fig) if text.startswith("numerical")]


def _classes(R, R_err, period):
    trusted = R_err <= plot.RELATIVE_ERROR_LIMIT * R
    return {"trusted periodic": trusted & (period > 0), "untrusted periodic": ~trusted & (period > 0),
            "trusted aperiodic": trusted & (period == 0), "untrusted aperiodic": ~trusted & (period == 0)}


def test_response_markers_follow_the_readme_rule(files):
    """Trust by R_err (filled or hollow), kind of motion by period (circle or square), colour by curve."""
    results = load_results(files["g"])
    R, period, R_err = (results[n].values for n in ("R", "period", "R_err"))
    fig = plot.plot(files["g"], log=False)
    drawn = markers(fig.axes[0])
    classes = _classes(R, R_err, period)
    assert any(mask.any() for name, mask in classes.items() if name.startswith("untrusted"))
    for name, mask in classes.items():
        if not mask.any():
            assert name not in drawn
            continue
        line = drawn[name]
        np.testing.assert_array_equal(np.sort(line.get_ydata()), np.sort(R[mask]))
        assert line.get_marker() == ("s" if "aperiodic" in name else "o")
        assert line.get_markeredgecolor() == "tab:blue"
        assert line.get_markerfacecolor() == ("none" if name.startswith("untrusted") else "tab:blue")
    assert sum(len(line.get_ydata()) for line in drawn.values()) == 9
    texts = legend_texts(fig)
    assert any("filled" in t and "R_{err}" in t for t in texts)


def test_a_converged_point_without_a_period_is_not_called_chaos(files):
    """Issue 15: period 0 with a tiny R_err (a slowly settling or long-period motion) is a
    trusted R -- drawn filled, as a square -- not 'no period found (chaos?)'."""
    results = load_results(files["g"])
    results["period"][:] = 0
    results["R_err"][:] = 1e-6 * results["R"]
    drawn = markers(plot.plot([results], log=False).axes[0])
    assert list(drawn) == ["trusted aperiodic"]
    assert drawn["trusted aperiodic"].get_markerfacecolor() == "tab:blue"
    assert len(drawn["trusted aperiodic"].get_ydata()) == 9


def test_hollow_points_keep_their_curves_colour(files):
    results = load_results(files["g_Omega_short"])
    results["R_err"][:] = results["R"]  # every point untrusted
    fig = plot.plot([results], log=False)
    hollow = [line for line in fig.axes[0].get_lines() if (line.get_gid() or "").startswith("untrusted")]
    assert {line.get_markeredgecolor() for line in hollow} == {"tab:blue", "tab:orange"}
    assert all(line.get_markerfacecolor() == "none" for line in hollow)


def test_response_marks_g_res_and_draws_the_analytic_gain(files):
    fig = plot.plot(files["g"])
    ax = fig.axes[0]
    assert vertical_lines_at(ax) == pytest.approx([G_RES_4])
    texts = legend_texts(fig)
    assert any("21.065" in t for t in texts)
    assert any("A/c, stable" in t for t in texts) and any("A/c, unstable" in t for t in texts)
    analytic = [line for line in ax.get_lines() if len(line.get_xdata()) > 20]
    solid = [line for line in analytic if line.get_linestyle() == "-"]
    dashed = [line for line in analytic if line.get_linestyle() == "--"]
    assert solid and dashed
    # The gain A/c (ERRATA 6): the largest stable root at g = 0 is ~1.93, so A/c ~ 48
    top = max(line.get_ydata().max() for line in solid)
    A_top = np.nanmax(theory.response_branches(dict(DEFAULT_PARAMETERS, Omega=4.0), [0.0]).R)
    assert top == pytest.approx(A_top / 0.04, rel=1e-6)


def test_amplitude_draws_Q_and_A_unscaled(files):
    results = load_results(files["g"])
    fig = plot.plot(files["g"], amplitude=True, log=False)
    ax = fig.axes[0]
    assert "|Q|" in ax.get_ylabel() and "A/c" not in ax.get_ylabel()
    drawn = np.concatenate([line.get_ydata() for line in markers(ax).values()])
    np.testing.assert_allclose(np.sort(drawn), np.sort(results["Q_amplitude"].values))
    texts = legend_texts(fig)
    assert any("|Q|" in t and "filled" in t for t in texts)
    assert not any(" of R" in t or "R =" in t for t in texts), texts  # the legend speaks of |Q|
    solid = [line for line in ax.get_lines() if len(line.get_xdata()) > 20 and line.get_linestyle() == "-"]
    assert max(line.get_ydata().max() for line in solid) < 2.0  # A, not A/c


def test_analytic_branches_follow_the_fold():
    """Omega = 4: three roots below g ~ 17.3, only the largest stable; one stable root above."""
    g = np.linspace(0.0, 40.0, 2001)
    branches = plot.analytic_branches(dict(DEFAULT_PARAMETERS, Omega=4.0), "g", g, gain=False)
    assert len(branches) == 3
    spans = sorted(branches, key=lambda b: b[0][-1] - b[0][0])
    top_x, top_y, top_stable = spans[-1]
    assert top_x[0] == 0.0 and top_x[-1] == 40.0 and top_stable.all()
    assert top_y[0] == pytest.approx(1.93, abs=0.01)
    for x, y, stable in spans[:2]:
        assert not stable.any() and 17.0 < x[-1] < 17.6  # the unstable pair meets at the fold


def test_resonance_positions_on_any_axis():
    params = dict(DEFAULT_PARAMETERS, Omega=4.0)
    assert plot.resonance_positions(params, "g", np.linspace(0, 40, 101)) == pytest.approx([G_RES_4])
    # Along Omega at fixed g = 21.065, the resonance sits at Omega = 4
    at_g = dict(DEFAULT_PARAMETERS, g=G_RES_4)
    assert plot.resonance_positions(at_g, "Omega", np.linspace(3, 6, 3001)) == pytest.approx([4.0], abs=1e-5)
    assert plot.resonance_positions(params, "Delta", np.linspace(0.5, 2, 50)) == []


def test_a_short_second_axis_gives_one_curve_each(files):
    fig = plot.plot(files["g_Omega_short"])
    ax = fig.axes[0]
    assert [label.split(", ")[-1] for label in curve_labels(fig)] == ["$\\Omega$ = 4", "$\\Omega$ = 5"]
    assert sorted(vertical_lines_at(ax)) == pytest.approx([G_RES_4, G_RES_5])


def test_at_picks_a_coordinate(files):
    fig = plot.plot(files["g_Omega_short"], at={"Omega": "5"})
    assert len(curve_labels(fig)) == 1
    assert vertical_lines_at(fig.axes[0]) == pytest.approx([G_RES_5])
    assert "Ω" in fig._suptitle.get_text() or "Omega" in fig._suptitle.get_text()
    with pytest.raises(UsageError, match="not a value of the axis Omega"):
        plot.plot(files["g_Omega_short"], at={"Omega": "4.5"})
    with pytest.raises(UsageError, match="not an axis"):
        plot.plot(files["g_Omega_short"], at={"alpha": "1"})


def test_continuation_both_draws_up_and_down(files):
    fig = plot.plot(files["both"])
    labels = curve_labels(fig)
    assert len(labels) == 2 and "sweep up" in labels[0] and "sweep down" in labels[1]


# --- maps -------------------------------------------------------------------------------------


def test_two_long_axes_make_a_map_with_g_res_over_it(files):
    results = load_results(files["map"])
    fig = plot.plot(files["map"])
    ax = fig.axes[0]
    meshes = [c for c in ax.collections if isinstance(c, QuadMesh)]
    assert len(meshes) == 1
    np.testing.assert_array_equal(np.ma.filled(meshes[0].get_array(), np.nan).reshape(6, 7),
                                  results["R"].values.T)
    assert "$g$" in ax.get_xlabel() and "$\\Omega$" in ax.get_ylabel() and "[1]" not in ax.get_ylabel()
    colorbar = fig.axes[1]
    assert "R = |Q|/c" in colorbar.get_ylabel()
    contours = [c for c in ax.collections if not isinstance(c, QuadMesh) and hasattr(c, "get_paths")
                and c.get_paths() and len(c.get_paths()[0].vertices) > 50]
    assert contours, "the resonance curve g_res(Omega)"
    vertices = np.concatenate([p.vertices for c in contours for p in c.get_paths()])
    expected_g = theory.g_res(0.1, 0.1, 0.5, vertices[:, 1])
    np.testing.assert_allclose(vertices[:, 0], expected_g, rtol=2e-3)


def test_map_of_impacts_and_status(files):
    results = load_results(files["map"])
    fig = plot.plot(files["map"], kind="impacts")
    mesh = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)][0]
    np.testing.assert_array_equal(mesh.get_array().reshape(6, 7), results["impacts_per_period"].values.T)
    fig = plot.plot(files["map"], kind="status")
    labels = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert "ok" in labels and "chatter_limit" in labels


# --- impacts, status, bifurcation of a 1-axis sweep -------------------------------------------


def test_impacts_against_the_axis(files):
    results = load_results(files["g"])
    fig = plot.plot(files["g"], kind="impacts")
    (line,) = fig.axes[0].get_lines()
    np.testing.assert_array_equal(line.get_ydata(), results["impacts_per_period"].values)
    assert "impacts per slow period" in fig.axes[0].get_ylabel() and "[1]" not in fig.axes[0].get_ylabel()


def test_status_strip(files):
    fig = plot.plot(files["g"], kind="status")
    ax = fig.axes[0]
    assert "ok" in [t.get_text() for t in ax.get_yticklabels()]
    (points,) = ax.collections
    assert len(points.get_offsets()) == 9
    assert "9 ok" in fig._suptitle.get_text()


def test_bifurcation_draws_every_strobe_sample(files):
    results = load_results(files["g"])
    fig = plot.plot(files["g"], kind="bifurcation")
    ax = fig.axes[0]
    (dots,) = lines_with_label(fig, "x(nT)")
    assert len(dots.get_xdata()) == 9 * 8
    np.testing.assert_array_equal(dots.get_ydata(), results["strobe_x"].values.reshape(-1))
    np.testing.assert_array_equal(dots.get_xdata(), np.repeat(results["g"].values, 8))
    assert "x(nT)" in ax.get_ylabel() and "[1]" not in ax.get_ylabel()


def test_samples_not_at_the_forcings_period_are_marked_apart_and_explained(tmp_path):
    """At Omega/omega = 1/10 the forcing repeats after 10 periods T: a motion locked to it shows 10
    dots at t = nT, drawn as the same dots as a period-1 orbit's, with no word: a cloud read as
    chaos. Omega/omega = p/q in lowest terms: q = 10 at Omega = 0.05, 5 at 4.3 (43/5), 1 at 0.5."""
    from fractions import Fraction

    path = _run(tmp_path, "omega", "parameters: {g: 5.0}\nsweep:\n  Omega: [0.05, 0.5, 4.3]\n" + SHORT, "run")
    omega = DEFAULT_PARAMETERS["omega"]
    expected = {Omega: Fraction(Omega / omega).limit_denominator(100).denominator for Omega in (0.05, 0.5, 4.3)}
    assert expected == {0.05: 10, 0.5: 1, 4.3: 5}
    fig = plot.plot(path, kind="bifurcation")
    lines = {line.get_gid(): line for line in fig.axes[0].get_lines()}
    np.testing.assert_array_equal(lines["strobe"].get_xdata(), [0.5] * 8)
    off = lines["strobe off the forcing's period"]
    np.testing.assert_array_equal(off.get_xdata(), [0.05] * 8 + [4.3] * 8)
    assert off.get_marker() != lines["strobe"].get_marker() and off.get_mfc() == "none"
    words = plot.description(fig)
    assert "at 2 of 3 points the forcing repeats only after q periods T (q = 10 at Ω = 0.05, q = 5 at Ω = 4.3)" \
        in words, words
    assert any("hollow" in text for text in legend_texts(fig))
    # Where the forcing repeats every T (g = 0: no fast force), nothing is said.
    fig = plot.plot(_run(tmp_path, "still", "parameters: {g: 0.0}\nsweep:\n  Omega: [0.05, 4.3]\n" + SHORT, "run"),
                    kind="bifurcation")
    assert "repeats only" not in plot.description(fig)
    assert not [line for line in fig.axes[0].get_lines() if line.get_gid() == "strobe off the forcing's period"]


def test_the_forcings_repeats_are_counted_curve_by_curve(tmp_path):
    """Curves of several Omega repeat after their own q: the caption counted the points of all
    curves as one and gave every one the q of the last curve drawn ("at 3 of 3 points ... q = 2"
    where Omega = 4.1 has q = 5). Omega/omega = 8, 41/5, 17/2: q = 1, 5, 2, in lowest terms."""
    from fractions import Fraction

    path = _run(tmp_path, "curves", "model: original\nsweep:\n  g: [5.0, 10.0, 15.0]\n  Omega: [4.0, 4.1, 4.25]\n"
                "integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 2}\n", "run")
    omega = DEFAULT_PARAMETERS["omega"]
    q = {Omega: Fraction(Omega / omega).limit_denominator(100).denominator for Omega in (4.0, 4.1, 4.25)}
    assert q == {4.0: 1, 4.1: 5, 4.25: 2}
    fig = plot.plot(path, kind="bifurcation", x_axis="g")
    words = plot.description(fig)
    for Omega in (4.1, 4.25):
        assert f"Ω = {Omega:g}: at 3 of 3 points the forcing repeats only after q = {q[Omega]} periods T" in words, words
    assert "Ω = 4: at" not in words and "of 9 points" not in words, words
    # A curve with no sample at the forcing's period has no legend entry for filled dots it does not draw.
    texts = [text.replace("$\\Omega$", "Ω") for text in legend_texts(fig)]
    assert "Ω = 4" in texts and "Ω = 4.1" not in texts and any(t.startswith("Ω = 4.1: hollow") for t in texts), texts


def test_bifurcation_draws_the_barrier_where_each_point_had_it(files, tmp_path):
    """A sweep in Delta moves the barrier: it is drawn at Delta at each value (the line x = Delta),
    not as one horizontal line at the config's default Delta; elsewhere, one line at Delta."""
    (fixed,) = lines_with_label(plot.plot(files["g"], kind="bifurcation"), "barrier")
    np.testing.assert_array_equal(fixed.get_ydata(), [DEFAULT_PARAMETERS["Delta"]] * 2)
    path = _run(tmp_path, "delta", "parameters: {g: 5.0, Omega: 5.0}\ninitial: {x: 0.0, v: 0.0}\nsweep:\n  Delta: [0.6, 1.0, 1.4]\n"
                "integration: {transient_periods: 2, measure_periods: 4, strobe_periods: 2}\n", "run")
    (moving,) = lines_with_label(plot.plot(path, kind="bifurcation"), "barrier")
    np.testing.assert_array_equal(moving.get_xdata(), [0.6, 1.0, 1.4])
    np.testing.assert_array_equal(moving.get_ydata(), [0.6, 1.0, 1.4])


def test_bifurcation_of_two_axes_needs_at(files):
    with pytest.raises(UsageError, match="fix the others with at, e.g. at Omega=4") as info:
        plot.plot(files["g_Omega_short"], kind="bifurcation")
    assert "fix the others with --at, e.g. --at Omega=4" in str(info.value.reworded(FLAGS))
    fig = plot.plot(files["g_Omega_short"], kind="bifurcation", at={"Omega": "4"})
    assert len(lines_with_label(fig, "x(nT)")[0].get_xdata()) == 5 * 8


# --- trajectories (Fig. 3-6, Fig. impact_no) --------------------------------------------------------


def test_trajectory_puts_original_above_effective(files):
    data = read_trajectory(files["traj"])
    fig = plot.plot(files["traj"])
    assert len(fig.axes) == 6
    titles = [ax.get_title() for ax in fig.axes]
    assert all("original" in t for t in titles[:3]) and all("effective" in t for t in titles[3:])
    x_ax, v_ax, phase_ax = fig.axes[:3]
    assert "$t$" in x_ax.get_xlabel() and "$x$" in x_ax.get_ylabel() and "[1]" not in x_ax.get_ylabel()
    assert "\\dot{x}" in v_ax.get_ylabel() and "$x$" in phase_ax.get_xlabel()
    drawn_x = np.concatenate([line.get_ydata() for line in x_ax.get_lines() if len(line.get_xdata()) > 2])
    run = data.runs["original"]
    assert drawn_x.max() == pytest.approx(1.0)  # impacts inserted at the barrier
    assert drawn_x.min() == pytest.approx(run.x.min())
    assert x_ax.get_xlim() == pytest.approx((0.0, run.t[-1]))
    assert "g = 5" in fig._suptitle.get_text()


def test_with_impacts_jumps_at_the_barrier():
    t = np.array([0.0, 1.0, 2.0])
    impacts = np.array([[1.5, 2.0, -1.9]])
    tt, xx, vv = plot.with_impacts(t, np.array([0.5, 0.9, 0.8]), np.array([1.0, 1.0, -1.0]), impacts, 1.0)
    np.testing.assert_array_equal(tt, [0.0, 1.0, 1.5, 1.5, 2.0])
    np.testing.assert_array_equal(xx, [0.5, 0.9, 1.0, 1.0, 0.8])
    np.testing.assert_array_equal(vv, [1.0, 1.0, 2.0, -1.9, -1.0])


def test_periods_window_the_trajectory(files):
    fig = plot.plot(files["traj"], periods=(2, 3))
    T = 4 * np.pi
    assert fig.axes[0].get_xlim() == pytest.approx((T, 3 * T))
    with pytest.raises(UsageError, match="slow periods"):
        plot.plot(files["traj"], periods=(20, 30))


def test_impacts_per_period_one_panel_per_file(files):
    fig = plot.plot([files["traj"], files["traj20"]], kind="impacts")
    assert len(fig.axes) == 2
    for ax, name in zip(fig.axes, ("traj", "traj20")):
        counts = read_trajectory(files[name]).runs["original"].impacts_per_period
        (line,) = [line for line in ax.get_lines() if line.get_marker() == "o"]
        np.testing.assert_array_equal(line.get_ydata(), counts)
        np.testing.assert_array_equal(line.get_xdata(), np.arange(1, 11))
        assert name + ".h5" in ax.get_title()
        mean_lines = [c for c in ax.collections if c.get_label().startswith("mean")]
        assert mean_lines and f"{counts[4:].mean():.2f}" in mean_lines[0].get_label()
        # The mean lies on the counts where they hardly vary: tab:red on tab:blue (L* 47 and 48) was
        # one grey on a greyscale page.
        assert abs(_lightness(mean_lines[0].get_colors()[0]) - _lightness(line.get_color())) >= 8.0
    assert "(a) g = 5" in fig.axes[0].get_title() and "(b) g = 20" in fig.axes[1].get_title()
    assert "slow period number" in fig.axes[1].get_xlabel()


# The acceleration and parameters of vrsweep/examples/impact_linear.yaml (its phase phi at 0):
# the same generated kernel, which other tests compile too (the suite's time is mostly compiling).
LINEAR = """\
model:
  name: linear impact oscillator
  acceleration: "-2*zeta*v - x + F*cos(omega*t + phi)"
  parameters: {zeta: 0.05, F: 1.0, omega: 0.8, phi: 0.0, Delta: 1.2, r: 0.8}
  barriers: [{position: Delta, side: above, restitution: r}]
  period: "4*pi/omega"
  response: {frequency: omega, scale: F}
integration: {transient_periods: 4, measure_periods: 6, strobe_periods: 3}
"""


def test_impacts_per_period_of_a_written_model_speak_of_its_own_period(files, tmp_path):
    # They said 'slow period 2 pi/omega' and named the model 'written'.
    linear = _run(tmp_path, "linear", LINEAR, "simulate")
    fig = plot.plot(linear, kind="impacts")
    assert fig.axes[0].get_xlabel() == "period number $n$ (period $T$ = 4 * pi / omega)"
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()][0] == "linear impact oscillator"
    assert "slow period" not in plot.description(fig) and "2\\pi/\\omega" not in plot.description(fig)
    # Files of two models share no caption, no period: refused in one line (a KeyError before).
    with pytest.raises(UsageError, match="^kind impacts draws several trajectory files of one model.*traj.h5, "
                                         "linear.h5 are of 2 models"):
        plot.plot([files["traj"], linear], kind="impacts")
    result = CliRunner().invoke(main, ["plot", str(files["traj"]), str(linear), "--kind", "impacts",
                                       "-o", str(tmp_path / "two.png")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output


def test_slowflow_draws_the_effective_system_and_three_reconstructions(files):
    data = read_trajectory(files["traj"])
    fig = plot.plot(files["traj"], kind="slowflow")
    x_ax = fig.axes[0]
    labels = [line.get_label() for line in x_ax.get_lines()]
    assert sum("slow flow" in label for label in labels) == 3
    assert any("printed in the paper" in label for label in labels)
    (numerical,) = [line for line in x_ax.get_lines() if "numerical" in line.get_label()]
    assert numerical.get_ydata().max() == pytest.approx(1.0)  # the effective system hits the barrier
    (state,) = [line for line in x_ax.get_lines() if "x(0)" in line.get_label()]
    np.testing.assert_array_equal(state.get_ydata(), data.slow_flow["state"].x)
    assert "$X$" in x_ax.get_ylabel()


def _strokes_apart(fig):
    """For each line of the slow-flow figure's time panels: (its width, the room in points between
    two of its strokes, counted as crossings of its mid-height in the view)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()
    found = []
    for ax in fig.axes[:2]:
        width = ax.get_window_extent().width * 72.0 / fig.dpi
        for line in ax.get_lines():
            y = np.asarray(line.get_ydata(), dtype=float)
            y = y[np.isfinite(y)]
            if len(y) < 10:
                continue
            crossings = np.count_nonzero(np.diff(np.sign(y - (y.max() + y.min()) / 2)) != 0)
            found.append((line.get_linewidth(), width / max(crossings, 1), line.get_label()))
    return found


def test_the_slow_flow_over_many_periods_draws_strokes_not_blocks(files, tmp_path):
    """Over 45 slow periods four lines 1.1 to 1.6 points wide, one over another, drew solid blocks:
    each line is at most 1/2.5 of the room between two of its strokes, and over 10 periods,
    where they fit, the lines keep their widths."""
    long = _run(tmp_path, "long", "parameters: {g: 5.0, Omega: 5.0}\n"
                                  "integration: {transient_periods: 5, measure_periods: 40, strobe_periods: 10}\n",
                "simulate", "--compare", "effective", "--samples-per-period", "50")
    for size in (None, (7.0, 3.0)):
        found = _strokes_apart(plot.plot(long, kind="slowflow", size=size))
        assert len(found) >= 6
        for width, room, label in found:
            assert width <= room / 2.5, (size, width, room, label)
    widths = {label: width for width, _, label in _strokes_apart(plot.plot(files["traj"], kind="slowflow"))}
    assert widths["effective system eq2.10, numerical (with impacts)"] == 1.6


def test_the_slow_flows_lines_of_one_style_differ_in_grey(files):
    """The numerical line (tab:red) and the slow flow from x(0) (tab:blue), both solid, were one
    grey on a greyscale page (L* 47 and 48): lines of one style differ by 8 in L* (as drawn on
    white, their transparency included)."""
    from matplotlib.colors import to_rgb

    fig = plot.plot(files["traj"], kind="slowflow")
    by_style = {}
    for line in fig.axes[0].get_lines():
        alpha = line.get_alpha() if line.get_alpha() is not None else 1.0
        seen = alpha * np.array(to_rgb(line.get_color())) + (1.0 - alpha)  # over white
        by_style.setdefault(str(line.get_linestyle()), []).append(_lightness(tuple(seen)))
    assert len(by_style.get("-", [])) >= 2
    for style, light in by_style.items():
        light = sorted(light)
        assert all(b - a >= 8.0 for a, b in zip(light, light[1:])), (style, light)


def test_slowflow_needs_the_effective_run(files):
    with pytest.raises(UsageError, match="compare_effective"):
        plot.plot(files["traj20"], kind="slowflow")


def test_kinds_that_do_not_fit_the_file(files):
    with pytest.raises(UsageError, match="trajectory files"):
        plot.plot(files["g"], kind="slowflow")
    with pytest.raises(UsageError, match="sweep results"):
        plot.plot(files["traj"], kind="map")
    with pytest.raises(UsageError, match="separately"):
        plot.plot([files["g"], files["traj"]], kind="impacts")


# --- nothing hidden, nothing misstated (issue 15) --------------------------------------------------


def failed_marks(ax):
    return [line for line in ax.get_lines() if line.get_gid() == "failed"]


def failure_strip(fig, ax):
    """The strip of failed points under ``ax``: its own axes, sharing ax's horizontal axis only."""
    (strip,) = [other for other in fig.axes if other.get_label() == "failed points"
                and other.get_shared_x_axes().joined(other, ax)]
    return strip


@pytest.mark.parametrize("log", [True, False])
def test_failed_points_sit_in_a_strip_of_their_own_on_any_axis(files, log):
    """Failed points have R = NaN: drawn at R = 0 they vanished on a log axis; as marks along the
    panel's bottom edge they sat where R near 0 is drawn, and read as values. They are x marks in a
    strip under the panel, which holds no data, and the title counts them."""
    results = load_results(files["failed"])
    failed = results["status"].values > 0
    assert 0 < failed.sum() < 5
    fig = plot.plot(files["failed"], log=log)
    ax = fig.axes[0]
    assert not failed_marks(ax)  # none in the data panel
    strip = failure_strip(fig, ax)
    (marks,) = failed_marks(strip)
    np.testing.assert_array_equal(marks.get_xdata(), results["g"].values[failed])
    low, high = strip.get_ylim()
    assert all(low < y < high for y in marks.get_ydata())
    assert [t.get_text() for t in strip.get_yticklabels()] == ["failed"]
    assert strip.get_xlabel() == "fast forcing amplitude $g$" and ax.get_xlabel() == ""  # under the lowest
    assert strip.get_position().y1 <= ax.get_position().y0  # below the panel, apart from it
    assert ax.get_yscale() == ("log" if log else "linear")
    title = fig._suptitle.get_text()
    assert f"{failed.sum()} of 5 points failed ({failed.sum()} max_steps)" in title
    assert any("integration failed" in t for t in legend_texts(fig))


def test_a_bifurcation_diagram_spans_the_grid_and_marks_failed_points(files):
    """It stopped at the last good point (g = 0-21 of 0-40), reading as a sweep that stopped early."""
    fig = plot.plot(files["failed"], kind="bifurcation")
    ax = fig.axes[0]
    low, high = ax.get_xlim()
    assert low < 0.0 and high > 40.0
    results = load_results(files["failed"])
    assert not failed_marks(ax)
    (marks,) = failed_marks(failure_strip(fig, ax))
    np.testing.assert_array_equal(marks.get_xdata(), results["g"].values[results["status"].values > 0])
    assert "points failed" in fig._suptitle.get_text()


def test_the_response_axis_turns_logarithmic_when_the_values_span_decades(files):
    """The measured R decide: spanning two decades or more, a log axis, said in the caption (the
    theory, A/c ~ 48 at g = 0, decided it too until it forced 7 decades at small Omega)."""
    ds = load_results(files["g"])
    ds["R"].values[:] = np.geomspace(0.01, 2.0, ds["R"].size)
    fig = plot.plot([ds])
    assert fig.axes[0].get_yscale() == "log" and "log axis: the measured values span 2.3 decades" in \
        fig._suptitle.get_text()
    assert plot.plot([ds], log=False).axes[0].get_yscale() == "linear"
    assert "log axis" not in plot.plot([ds], log=True)._suptitle.get_text()  # asked for: no note
    ds["R"].values[:] = np.linspace(0.1, 2.0, ds["R"].size)  # 1.3 decades: linear, the theory clipped and said
    fig = plot.plot([ds])
    assert fig.axes[0].get_yscale() == "linear" and fig.axes[0].get_ylim()[1] <= 2.0 * 3.0 * 1.05
    assert "the analytic curves go on beyond the view (up to 48)" in " ".join(fig._suptitle.get_text().split())


def test_the_response_axis_follows_the_data_not_a_theory_far_from_them(tmp_path):
    """At small Omega the first-order theory's A/c falls to ~1e-6 (g = 5, Omega = 0.05): it made
    the axis logarithmic over 7 decades for measured R of one decade. The axis now follows the
    measured values (and the theory within THEORY_REACH of them); the rest is clipped, and said.
    (At Omega <= omega the theory is no longer drawn at all: the theory far below the data is
    taken at a large g just above omega.)"""
    from vrsweep.plot.sweeps import THEORY_REACH

    path = _run(tmp_path, "small", SMALL_THEORY, "run")
    ds = load_results(path)
    ds["R"].values[:] = [1.0, 2.0, 3.0]
    branches = plot.analytic_branches(dict(DEFAULT_PARAMETERS, g=100.0), "Omega", np.array([0.51]), gain=True)
    lowest = min(float(np.nanmin(y)) for _, y, _ in branches)
    assert lowest < 1e-4  # the theory far below the data: what forced the log axis
    fig = plot.plot([ds])
    ax = fig.axes[0]
    assert ax.get_yscale() == "linear", plot.description(fig)
    assert ax.get_ylim()[0] == 0.0 and 3.0 <= ax.get_ylim()[1] <= 3.0 * 1.1
    assert f"the analytic curves go on beyond the view (down to {lowest:.2g})" not in plot.description(fig)
    assert "log axis" not in plot.description(fig)
    assert THEORY_REACH == 10.0
    # Measured values that span decades themselves still get a log axis, and say so.
    ds["R"].values[:] = [0.01, 1.0, 5.0]
    fig = plot.plot([ds])
    assert fig.axes[0].get_yscale() == "log" and "log axis: the measured values span 2.7 decades" in \
        plot.description(fig)
    # Whole decades around the data (0.01/1.2) and what of the theory lies within a decade of them:
    # the barrier's level Delta/c = 25 (25*1.2 -> 100), not the branches' A/c <= 6e-4.
    low, high = fig.axes[0].get_ylim()
    assert low == 1e-3 and high == 1e2 and f"down to {lowest:.2g}" in " ".join(plot.description(fig).split()), (low, high)


def test_what_the_view_leaves_out_is_said_of_the_view_asked_for(tmp_path):
    """The note 'the analytic curves go on beyond the view' was made for the automatic limits:
    with --ylim holding the whole theory it still said so, and with --ylim cutting the curves and
    the measured points it said nothing of either. It is said of the view as drawn."""
    path = _run(tmp_path, "small", SMALL_THEORY, "run")
    ds = load_results(path)
    ds["R"].values[:] = [0.01, 1.0, 5.0]
    branches = plot.analytic_branches(dict(DEFAULT_PARAMETERS, g=100.0), "Omega", np.array([0.51]), gain=True)
    lowest = min(float(np.nanmin(y)) for _, y, _ in branches)
    said = " ".join(plot.description(plot.plot([ds])).split())
    assert f"go on beyond the view (down to {lowest:.2g})" in said  # the automatic view clips it
    fig = plot.plot([ds], ylim=(1e-9, 1e3))
    theory = [line for line in fig.axes[0].get_lines() if getattr(line, "_vrsweep_context", False)]
    assert theory and all(1e-9 <= np.nanmin(line.get_ydata()) and np.nanmax(line.get_ydata()) <= 1e3 for line in theory)
    said = " ".join(plot.description(fig).split())
    assert "beyond the view" not in said and "outside the limits" not in said, said
    said = " ".join(plot.description(plot.plot([ds], ylim=(0.5, 2.0))).split())
    assert f"go on beyond the view (down to {lowest:.2g}" in said and "outside the limits asked for" in said, said
    assert "2 measured points outside the limits asked for (1 below, 1 above)" in said, said
    said = " ".join(plot.description(plot.plot([ds], ylim=(0.5, 2.0), title=False)).split())
    assert "2 measured points outside" in said  # in the file's metadata, with no title drawn
    # The response figure sets the view itself, as an argument (its caption is written once, of that
    # view), not through a callable left on the Figure for figure_options to find and call again.
    fig = plot.response_figure(ds, ylim=(0.5, 2.0))
    assert "2 measured points outside the limits asked for" in " ".join(plot.description(fig).split())
    assert not [name for name in vars(fig) if "after_limits" in name]


def test_log_on_a_map_is_a_logarithmic_colour_scale(files):
    fig = plot.plot(files["map"], log=True)
    mesh = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)][0]
    assert isinstance(mesh.norm, LogNorm)
    R = load_results(files["map"])["R"].values
    assert mesh.norm.vmin == pytest.approx(R[np.isfinite(R) & (R > 0)].min())
    assert not isinstance([c for c in plot.plot(files["map"]).axes[0].collections
                           if isinstance(c, QuadMesh)][0].norm, LogNorm)
    with pytest.raises(UsageError, match="^log is for") as info:
        plot.plot(files["g"], kind="status", log=True)
    assert str(info.value.reworded(FLAGS)) == "--log is for response, map and impacts plots, not --kind status"


def test_the_map_legend_hides_no_cell(files):
    fig = plot.plot(files["map"])
    assert fig.axes[0].get_legend() is None
    (legend,) = fig.legends
    assert any("g_{res}" in t.get_text() for t in legend.get_texts())
    fig.canvas.draw()
    box, cells = legend.get_window_extent(), fig.axes[0].get_window_extent()
    assert box.y1 <= cells.y0 or not box.overlaps(cells)


def test_a_shard_says_it_is_a_shard(files, tmp_path):
    config = tmp_path / "shard.yaml"
    config.write_text("parameters: {Omega: 4.0}\nsweep:\n  g: {start: 0.0, stop: 40.0, num: 9}\n" + SHORT)
    result = CliRunner().invoke(main, ["run", str(config), "-o", str(tmp_path / "s.h5"), "--shard", "1/3", "-q"])
    assert result.exit_code == 0, result.output
    path = tmp_path / "s.shard1of3.h5"
    done = int(load_results(path).done.sum())
    assert 0 < done < 9
    assert f"shard 1/3, {done} of 9 points" in plot.plot(path)._suptitle.get_text()


def test_the_status_strip_names_the_rows_of_up_and_down(files):
    fig = plot.plot(files["both"], kind="status")
    ax = fig.axes[0]
    up, down = ax.collections
    assert up.get_offsets()[:, 1].max() < down.get_offsets()[:, 1].min()  # down drawn above up
    texts = legend_texts(fig)
    assert texts == ["sweep up: lower row", "sweep down: upper row"]


def test_impacts_of_several_trajectories_clip_nothing(files):
    """A shared count axis took its limits from the first panel and cut the second's peaks; zero
    counts sat half hidden on the bottom edge."""
    fig = plot.plot([files["traj"], files["traj20"]], kind="impacts")
    for ax, name in zip(fig.axes, ("traj", "traj20")):
        counts = read_trajectory(files[name]).runs["original"].impacts_per_period
        low, high = ax.get_ylim()
        assert low < 0.0 < counts.max() < high
    assert fig.axes[0].get_shared_y_axes().get_siblings(fig.axes[0]) == [fig.axes[0]]


def test_the_nearest_grid_values_offered_are_ones_at_takes():
    """On linspace(0.6, 2, 12) the message offered 'the nearest are 0.981818 and 1.10909', and
    --at omega=1.10909 was refused again (1e-9 relative is the match): each is now offered with
    the digits that name it, and taken."""
    import re

    from vrsweep.store.reading import axis_index

    values = np.linspace(0.6, 2.0, 12)
    with pytest.raises(UsageError) as refused:
        axis_index("omega", values, "1.108")
    offered = re.search(r"the nearest are (\S+) and (\S+) \(", str(refused.value)).groups()
    assert offered == ("0.981818182", "1.10909091"), offered
    assert [axis_index("omega", values, text) for text in offered] == [3, 4]
    with pytest.raises(UsageError, match="the nearest are 10 and 20"):  # short values stay short
        axis_index("g", np.array([0.0, 10.0, 20.0]), "12")


def test_at_takes_a_grid_value_rounded_to_the_digits_typed():
    """--at omega=1.109 on linspace(0.6, 2, 12) was refused: only 1.10909091 (the value to 1e-9)
    was taken. A value typed to fewer digits names the grid value it rounds to, when those digits
    tell the grid's values apart; never a nearest value the digits do not name."""
    from vrsweep.store.reading import axis_index

    values = np.linspace(0.6, 2.0, 12)  # spacing 0.127
    assert axis_index("omega", values, "1.109") == 4  # 1.1090909...
    assert axis_index("omega", values, "1.11") == 4
    assert axis_index("omega", values, "0.98") == 3 == axis_index("omega", values, "9.8e-1")
    assert axis_index("omega", values, "2") == 11  # the value itself, whatever the digits
    for text in ("1.108", "1.1", "1.10", "1"):  # not the grid value's rounding, or too coarse to tell
        with pytest.raises(UsageError, match="not a value of the axis omega"):
            axis_index("omega", values, text)
    with pytest.raises(UsageError, match="the nearest are 3.9 and 4.1"):  # '4' names neither
        axis_index("Omega", np.array([3.9, 4.1]), "4")
    with pytest.raises(UsageError, match="not a value"):  # a number, not text: the value to 1e-9
        axis_index("omega", values, 1.109)


def test_at_names_the_nearest_grid_values_and_the_directions(files):
    with pytest.raises(UsageError, match=r"g=22: not a value of the axis g; the nearest are 20 and 25"):
        plot.plot(files["g"], at={"g": "22"})
    with pytest.raises(UsageError, match=r"the nearest is 40"):
        plot.plot(files["g"], at={"g": "50"})
    with pytest.raises(UsageError, match="the direction is up or down"):
        plot.plot(files["both"], at={"direction": "sideways"})
    assert plot.plot(files["both"], at={"direction": "down"}) is not None


def test_the_slow_flow_from_rest_is_drawn(tmp_path):
    """simulate from x = v = 0 gave a slow flow of NaN that the legend listed and nothing drew."""
    out = _run(tmp_path, "rest", "model: effective\nparameters: {gamma: 0.05, alpha: 0.05, g: 24.0, Omega: 4.0}\n"
                                 "initial: {x: 0.0, v: 0.0}\n"
                                 "integration: {transient_periods: 2, measure_periods: 4, strobe_periods: 2}\n",
               "simulate", "--samples-per-period", "20")
    fig = plot.plot(out, kind="slowflow")
    (state,) = [line for line in fig.axes[0].get_lines() if "x(0)" in line.get_label()]
    assert np.isfinite(state.get_ydata()).all() and np.ptp(state.get_ydata()) > 0
    assert not any("not drawn" in text for text in legend_texts(fig))


def test_axis_labels_of_the_initial_state_name_it_once():
    from vrsweep.plot import parameter_label

    assert parameter_label("x0") == "initial position $x(0)$"
    assert parameter_label("v0") == r"initial velocity $\dot{x}(0)$"
    assert parameter_label("g") == "fast forcing amplitude $g$"


def test_the_resonance_curve_is_named_g_res_of_omega_only_over_g_and_omega(tmp_path, invoke, write_config):
    """Over (g, alpha) the dashed curve omega~^2 = omega^2 is g_res(alpha): its legend said
    g_res(Omega), as over (Delta, alpha), where it is no g_res at all."""
    config = write_config(tmp_path, """\
        model: effective
        sweep:
          g: {start: 5.0, stop: 40.0, num: 7}
          alpha: {start: 0.05, stop: 0.2, num: 6}
        integration: {transient_periods: 10, measure_periods: 16}
        """)
    out = tmp_path / "g_alpha.h5"
    assert invoke("run", config, "-o", out, "--quiet").exit_code == 0
    fig = plot.plot(out)
    labels = [t.get_text() for legend in [*fig.legends, *(ax.get_legend() for ax in fig.axes)] if legend
              for t in legend.get_texts()]
    resonance = [label for label in labels if "eq3.4" in label]
    assert resonance and all("g_{res}" not in label and label.startswith("resonance") for label in resonance), labels


def test_a_trajectory_says_when_its_samples_alias_the_fast_force(files, tmp_path):
    """20 samples a slow period at Omega/omega = 10 are 2 per cycle of the fast force: the lines
    alias its oscillation, and the figure said nothing. The title says so (wrapped onto the
    canvas), with the samples that resolve it; 50 samples (5 a cycle) too; none for 2000 (200)."""
    from vrsweep.plot.layout import renderer_of

    for name, per_cycle in (("traj20", "2"), ("traj", "5")):
        fig = plot.plot(files[name])
        what = plot.description(fig)
        assert f"NOT RESOLVED: {per_cycle} samples per cycle of the fastest force (10 cycles per slow period)" in what
        assert "simulating with 200 samples per slow period resolves it" in what, what
        box = fig._suptitle.get_window_extent(renderer_of(fig))
        assert box.x0 >= 0 and box.x1 <= fig.bbox.width, (box, fig.bbox)
    fine = _run(tmp_path, "fine", "parameters: {g: 20.0, Omega: 5.0}\n"
                                  "integration: {transient_periods: 1, measure_periods: 2, strobe_periods: 1}\n",
                "simulate", "--samples-per-period", "2000")
    assert "NOT RESOLVED" not in plot.description(plot.plot(fine))


def test_the_transient_and_the_rest_meet_at_a_sample(tmp_path):
    """The split at t = transient_periods * T fell between two samples when the sample's time was
    above the product by roundoff: the grey line ended one sample before the blue one began."""
    path = _run(tmp_path, "split", "parameters: {g: 5.0, Omega: 5.0}\n"
                                   "integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 1}\n",
                "simulate", "--samples-per-period", "200")
    times = np.linspace(0.0, 5 * 4 * np.pi, 1001)
    assert times[400] != 2 * (4 * np.pi)  # the sample at the split is not the product, by roundoff
    fig = plot.plot(path)
    ax = fig.axes[0]
    grey, blue = [line for line in ax.get_lines() if len(line.get_xdata()) > 2][:2]
    assert grey.get_xdata()[-1] == blue.get_xdata()[0] and grey.get_ydata()[-1] == blue.get_ydata()[0]


def test_the_kinds_of_motion_stay_apart_in_greyscale(files):
    """The motion map's chaotic (tab:red, L* 47) and quasi-periodic (tab:blue, L* 48) cells were one
    grey on a greyscale page, and periodic green against chaotic red is the pair colour-blind
    readers lose. Every two colours of the map (the greys of 'none' included) differ by 8 in L*."""
    for fig in (plot.plot(files["map"], kind="motion"), plot.plot(files["map"], kind="map", var="motion")):
        (mesh,) = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)]
        colours = [mesh.cmap(k) for k in range(mesh.cmap.N)]
        light = sorted(_lightness(colour) for colour in colours)
        assert len(light) >= 2 and min(np.diff(light)) >= 8.0, light


def test_a_marks_size_on_a_map_grows_with_its_cells():
    """The white dot of R_err > 10 % was 2.5 points on every map: on an 8 x 6 map, in cells of about
    70 points, all but invisible. It grows with the cells, within its bounds."""
    import matplotlib.pyplot as plt

    from vrsweep.plot.sweeps import MAP_MARK_LARGEST, MAP_MARK_SHARE, _cell_marker_size

    fig, ax = plt.subplots(figsize=(8, 6))
    box = ax.get_position()
    cell = 72.0 * min(box.width * 8 / 8, box.height * 6 / 6)  # an 8 x 6 map's cell, in points
    assert _cell_marker_size(ax, (8, 6), 2.5) == pytest.approx(min(MAP_MARK_SHARE * cell, MAP_MARK_LARGEST))
    assert _cell_marker_size(ax, (8, 6), 2.5) > 2 * 2.5
    assert _cell_marker_size(ax, (400, 400), 2.5) == 2.5  # a fine map: the smallest size, no larger
    assert _cell_marker_size(ax, (1, 1), 2.5) == MAP_MARK_LARGEST
    plt.close(fig)
