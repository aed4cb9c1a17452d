"""Round 6 of the hostile inputs: files that are not what their names (or a command) take them
for, the theory at parameters beyond a double's range, and a written model's caption of forty
parameters."""

import os

import pytest

from test_hostile_round5 import _written_branch_file


# --------------------------------------------------------------------------------------------
# theory: parameters where the first-order theory has no numbers
# --------------------------------------------------------------------------------------------

FIG1 = os.path.join(os.path.dirname(__file__), "..", "vrsweep", "examples", "fig1.yaml")
FIG3 = os.path.join(os.path.dirname(__file__), "..", "vrsweep", "examples", "fig3.yaml")


@pytest.mark.parametrize("config", [FIG1, FIG3])  # g swept (0..40), g fixed (5)
@pytest.mark.parametrize("settings, says", [
    (["Omega=1e-300"], "Omega = 1e-300 is not above omega = 0.5: the effective system (eq2.10) averages over the "
                       "fast force, which must be faster than the slow one; the theory has nothing to say there"),
    (["Omega=0.4"], "Omega = 0.4 is not above omega = 0.5"),
    (["Omega=1e-300", "omega=1e-301"], "Omega^4, by which wt2 and K divide (eq2.11, eq2.12), is beyond a double's "
                                       "range at Omega = 1e-300: the theory has no numbers there"),
    (["Omega=1e100"], "Omega^4, by which wt2 and K divide (eq2.11, eq2.12), is beyond a double's range at "
                      "Omega = 1e+100"),
    (["Omega=1e300"], "Omega^4, by which wt2 and K divide"),
    (["alpha=1e-320"], "g_res = Omega^2 sqrt(2 (omega^2 + omega0^2) / (3 alpha)) (eq3.4) is beyond a double's range "
                       "at Omega = 4, alpha = 9.99989e-321"),
    (["omega=1e-200", "Omega=1"], "the slow flow's coefficients gamma/omega, alpha/omega^2, c/omega^2 (eq2.13) are "
                                  "beyond a double's range at omega = 1e-200"),
    (["Omega=1e77"], "the fixed points' cubic (eq2.27) at g_res = 1.317e+154 (eq3.4) is beyond a double's range at "
                     "Omega = 1e+77, omega = 0.5"),
])
@pytest.mark.parametrize("as_json", [False, True])
def test_theory_where_it_has_no_numbers_says_why_in_one_line(invoke, config, settings, says, as_json):
    """`vrsweep theory fig1.yaml --set Omega=1e-300` printed wt2 and K as "nan..nan", every other
    number as "-", and blamed a limit cycle: "no stable fixed point on the g grid: the slow flow
    may settle on a limit cycle"; exit 0. Omega^4 underflowed to 0: wt2 and K were 0/0 and g^2/0.
    (--json wrote them as null, with the same note.)"""
    args = [arg for setting in settings for arg in ("--set", setting)] + (["--json"] if as_json else [])
    result = invoke("theory", config, *args)
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    assert line.startswith(f"Error: {config}: {says}"), line
    assert "nan" not in line and "limit cycle" not in line


def test_theory_rows_outside_it_are_dashes_with_their_reason(tmp_path, invoke):
    """An Omega axis partly outside the theory: those rows show '-' and say why, the others their
    numbers (Omega = 1e100 printed g_res as 201 digits, and "inf" and "nan" for wt2 and K)."""
    import json

    config = tmp_path / "omega.yaml"
    config.write_text("model: original\nparameters: {g: 5.0}\nsweep:\n  Omega: [0.4, 4.0, 1.0e100]\n")
    result = invoke("theory", config)
    assert result.exit_code == 0, result.output
    table = result.output.splitlines()
    assert table[2].split() == ["0.4", "-", "5.000", "-", "-", "-", "-", "-", "-", "-"]
    assert table[3].split()[:2] == ["4", "21.065"]
    assert table[4].split() == ["1e+100", "-", "5.000", "-", "-", "-", "-", "-", "-", "-"]
    text = " ".join(result.output.split())
    assert "Omega = 0.4 is not above omega = 0.5" in text and "range at Omega = 1e+100: the theory has no" in text
    assert "nan" not in text and "inf" not in text and "limit cycle" not in text
    rows = json.loads(invoke("theory", config, "--json").stdout)
    assert [row["outside_theory"] for row in rows] == [True, False, True]
    assert rows[0]["g_res"] is None and rows[0]["wt2_range"] == [None, None] and rows[1]["g_res"] > 21


@pytest.mark.parametrize("config", [FIG1, FIG3])
def test_theory_at_a_g_beyond_range_says_so_and_blames_no_limit_cycle(tmp_path, invoke, config):
    """A g (or Omega and omega) for which the cubic of the amplitudes overflows: the other values
    are shown, and a note says where there is no amplitude and why (it said "no stable fixed
    point on the g grid: the slow flow may settle on a limit cycle", or nothing)."""
    result = invoke("theory", config, "--set", "Omega=1e-60", "--set", "omega=1e-61")
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "nan" not in text
    assert ("the fixed points' cubic (eq2.27) is beyond a double's range at Omega = 1e-60, omega = 1e-61 and "
            + ("80 of the 81 values of g the peak is searched over (from g = 0.5)" if config == FIG1 else "g = 5")
            + ": no amplitude there") in text, text
    result = invoke("theory", config, "--set", "g=1e200")
    assert result.exit_code == 0, result.output
    assert "beyond a double's range at Omega = 4, omega = 0.5 and g = 1e+200: no amplitude" in " ".join(
        result.output.split())


def test_theory_writes_a_large_finite_number_with_an_exponent(invoke):
    result = invoke("theory", FIG1, "--set", "Omega=1e50")
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[2].split()[:2] == ["1e+50", "1.317e+100"]


# --------------------------------------------------------------------------------------------
# init: what it writes is a config, named as one
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["x.h5", "config", "x.yaml.h5", "fig.png"])
def test_init_refuses_a_name_that_is_no_configs(tmp_path, invoke, name):
    """`vrsweep init x.h5` wrote the quickstart's YAML into a file named x.h5 (and `init config`
    into a file with no suffix)."""
    result = invoke("init", tmp_path / name)
    assert result.exit_code == 2, result.output
    assert result.output.strip() == (f"Error: PATH {tmp_path / name}: a config is YAML, named .yaml or .yml: give a "
                                     "name ending in one of them (or a folder that exists, to write "
                                     "quickstart.yaml into it)")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name", ["c.yaml", "c.yml", "C.YAML"])
def test_init_writes_a_name_that_is_a_configs(tmp_path, invoke, name):
    result = invoke("init", tmp_path / name)
    assert result.exit_code == 0, result.output
    assert (tmp_path / name).read_text().startswith("# Quickstart")


# --------------------------------------------------------------------------------------------
# info: a file named as a figure that is none
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name, contents, holds", [
    ("text.png", b"hello\n", "text, not a PNG image"),
    ("text.svg", b"just words, no svg\n", "text, not an SVG image"),
    ("empty.pdf", b"", "nothing (0 bytes), not a PDF"),
    ("noise.png", bytes(range(256)) * 4, "data of another kind, not a PNG image"),
    ("image.pdf", b"\x89PNG\r\n\x1a\n" + bytes(64), "a PNG image, not a PDF"),
])
def test_info_says_what_a_file_named_as_a_figure_holds(tmp_path, invoke, name, contents, holds):
    """`vrsweep info text.png` (a text file) said "text.png: a figure without a vrsweep
    description in its metadata", exit 0: it went by the name alone."""
    path = tmp_path / name
    path.write_bytes(contents)
    result = invoke("info", path)
    assert result.exit_code == 2, result.output
    assert result.output.strip() == (f"Error: {path} holds {holds} as its name says: info describes the figures "
                                     "vrsweep plot writes and vrsweep's HDF5 files")


@pytest.mark.parametrize("suffix", [".png", ".pdf", ".svg"])
def test_info_still_describes_a_figure_of_each_format(tmp_path, invoke, suffix):
    branch = _written_branch_file(tmp_path / "branch.h5", "oscillator")
    assert invoke("plot", branch, "-o", tmp_path / f"f{suffix}").exit_code == 0
    result = invoke("info", tmp_path / f"f{suffix}")
    assert result.exit_code == 0, result.output
    assert result.output.startswith(f"{tmp_path / f'f{suffix}'}: figure\nPeriodic orbits continued in Delta")
    # a figure of another program (no vrsweep metadata) is still a figure
    other = tmp_path / "other.png"
    other.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    assert "a figure without a vrsweep description" in invoke("info", other).output


def test_info_describes_an_hdf5_file_named_as_a_figure_as_what_it_is(tmp_path, invoke):
    branch = _written_branch_file(tmp_path / "branch.h5", "oscillator")
    os.rename(branch, tmp_path / "branch.png")
    result = invoke("info", tmp_path / "branch.png")
    assert result.exit_code == 0, result.output
    assert result.output.startswith(f"{tmp_path / 'branch.png'}: vrsweep branch, format"), result.output


# --------------------------------------------------------------------------------------------
# merge: a file of another kind is named as such
# --------------------------------------------------------------------------------------------


def _trajectory_file(path):
    from test_plot_trajectory_titles import PAPER, trajectory

    from vrsweep.config import parse_config
    from vrsweep.store.trajectory_file import write_trajectory

    text = PAPER.replace("E", "0.9")
    write_trajectory(path, trajectory(text, "original", str(path)), parse_config(text))
    return path


@pytest.mark.parametrize("kind, says", [("trajectory", "a trajectory (vrsweep simulate)"),
                                        ("branch", "a branch (vrsweep continue)")])
def test_merge_says_a_trajectory_or_a_branch_is_no_sweeps_results(tmp_path, invoke, kind, says):
    """`vrsweep merge TRAJ.h5 -o out.h5` said "TRAJ.h5 is a vrsweep file but not a sweep result
    (no 'done' mask)": what a sweep's file has, not what this file is, nor what merge takes."""
    path = (_trajectory_file if kind == "trajectory" else lambda p: _written_branch_file(p, "osc"))(tmp_path / "in.h5")
    result = invoke("merge", path, "-o", tmp_path / "out.h5", "-q")
    assert result.exit_code == 2, result.output
    assert result.output.strip() == (f"Error: {path} is {says}, not a sweep's results: merge takes the result files "
                                     "of one sweep (those vrsweep run writes, whole or in shards)")
    assert sorted(os.listdir(tmp_path)) == ["in.h5"]


def test_a_reader_of_sweeps_names_the_kind_of_file_it_was_given(tmp_path):
    from vrsweep.errors import ResultFileError
    from vrsweep.store.reader import open_checked

    path = _trajectory_file(tmp_path / "t.h5")
    with pytest.raises(ResultFileError, match=r"t\.h5 is a trajectory \(vrsweep simulate\) but not a sweep's results"):
        open_checked(path)


# --------------------------------------------------------------------------------------------
# A written model of forty parameters: its caption inside the canvas
# --------------------------------------------------------------------------------------------


def _many_parameters_branch_file(path, count):
    """A branch file of a written model of ``count`` parameters k0, k1, ..., each a term of the
    acceleration (in sums of twenty: a chain of more is refused as nested too deep)."""
    import numpy as np

    from test_hostile_round5 import WRITTEN

    from vrsweep.analysis.continuation import Bifurcation, Branch, Orbit
    from vrsweep.config.validate import config_from_dict
    from vrsweep.store import branch_file

    terms = [f"k{i}*x**{i % 5 + 1}" for i in range(count)]
    sums = " + ".join("(" + " + ".join(terms[i:i + 20]) + ")" for i in range(0, count, 20))
    model = WRITTEN["model"]
    config = {**WRITTEN, "model": {**model, "name": "many", "acceleration": f"{model['acceleration']} - ({sums})",
                                   "parameters": {**model["parameters"],
                                                  **{f"k{i}": 0.001 * (i + 1) for i in range(count)}}}}
    orbits = [Orbit(parameter=value, state=np.array([0.5, -0.2]), periods=1, monodromy=np.diag([0.5, 0.3]),
                    R=2.0 + value, Q_amplitude=0.4, impacts_per_period=1.0, x_max=1.0, slowest_impact=0.5,
                    residual=1e-11, newton_iterations=2)
              for value in np.linspace(2.5, 3.0, 5)]
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "Delta left [2, 3.5]"),
                                                       "up": ("left_range", "Delta left [2, 3.5]")})]
    branch_file.write_branch(path, branch_file.branch_arrays(branches, [], 1.0), config_from_dict(config), "rk45")
    return path


def _title_box(figure):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(figure)
    renderer = figure.canvas.get_renderer()
    figure.draw(renderer)
    return figure._suptitle.get_window_extent(renderer), figure.bbox


@pytest.mark.parametrize("count", [40, 59])
def test_the_caption_of_a_written_model_of_many_parameters_stays_inside_the_figure(tmp_path, invoke, count):
    """A written model of 40 parameters: its equation, one item of mathtext never broken, ran off
    both edges of the canvas (the caption's widest line about twice the figure's width)."""
    from vrsweep import plot
    from vrsweep.plot.labels import description

    path = _many_parameters_branch_file(tmp_path / "many.h5", count)
    for size in (None, (3.4, 2.6)):
        figure = plot.plot(str(path), size=size)
        box, canvas = _title_box(figure)
        assert box.x0 >= -1 and box.x1 <= canvas.width + 1, (size, box, canvas)
        # the title and caption take less than half the height (40 parameters at the default size: whole)
        assert box.height <= 0.5 * canvas.height, (size, box, canvas)
        shown = figure._suptitle.get_text()
        assert all(line.replace("\\$", "").count("$") % 2 == 0 for line in shown.split("\n")), shown
        whole = description(figure)  # the file's metadata keeps every parameter and the equation unbroken
        assert f"k{count - 1} = " in whole and f"k{count - 1} * x ** " in whole
        if size is None and count == 40:
            assert "lines more" not in shown and f"k{count - 1} = " in shown
        if size is not None:
            assert "lines more" in shown
    result = invoke("plot", path, "-o", tmp_path / "many.png")
    assert result.exit_code == 0, result.output


def test_an_equation_is_broken_between_its_terms_and_each_line_is_mathtext():
    from matplotlib.mathtext import MathTextParser

    from vrsweep.plot.labels import _wrap

    equation = ("many: $\\ddot{x} = F\\,\\cos{\\left(\\omega t + \\varphi - 1 \\right)} - "
                + " - ".join(f"k_{{{i}}} x^{{{i % 5 + 1}}}" for i in range(40)) + " + x^{2 - 1}$")
    lines = _wrap(["many.h5", equation, "$\\zeta$ = 0.05"], 60).split("\n")
    assert len(lines) > 5
    for line in lines:
        assert len(line.replace("$", "").replace("\\", "")) <= 60, line
        assert line.count("$") % 2 == 0, line
        for math in line.split("$")[1::2]:
            MathTextParser("path").parse(f"${math}$")  # no break inside \left( ... \right) or braces
    assert "\\left(\\omega t + \\varphi - 1 \\right)" in "".join(lines)
    # the break is before a + or - of the sum, the mathtext closed and opened again around it
    assert all(line.startswith(("$- ", "$+ ")) for line in lines[2:-1]), lines
