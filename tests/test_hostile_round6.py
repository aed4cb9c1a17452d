"""Round 6 of the hostile inputs: files that are not what their names (or a command) take them
for, the theory at parameters beyond a double's range, and a written model's caption of forty
parameters."""

import os

import pytest

from test_hostile_round5 import _written_branch_file


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
                                     "of one sweep (those of vrsweep run, each --shard of it)")
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
