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
