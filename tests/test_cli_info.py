"""``vrsweep info``: a readable and a --json summary of real run outputs.

The files come from real (short) runs of the shipped quickstart config, so the summary is
checked against what ``run`` actually writes, not against a hand-made layout.
"""

import json
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from vrsweep import __version__
from vrsweep.cli import main
from vrsweep.store.reading import load_results, stored_variables
from vrsweep.store import FORMAT_VERSION


QUICKSTART = Path(__file__).resolve().parent / "data" / "quickstart_original.yaml"
SHORT = ["--set", "transient_periods=2", "--set", "measure_periods=2", "--set", "strobe_periods=2"]


@pytest.fixture(scope="session")
def run_quickstart(invoke):
    """The helper below, with the shared helpers it calls (tests/conftest.py)."""
    def run_quickstart(path, *extra):
        result = invoke("run", QUICKSTART, "-o", path, "--quiet", *SHORT, *extra)
        assert result.exit_code == 0, result.output
        return path
    return run_quickstart


@pytest.fixture(scope="module")
def finished(tmp_path_factory, run_quickstart):
    return run_quickstart(tmp_path_factory.mktemp("info") / "quickstart.h5")


@pytest.fixture(scope="session")
def info_json(invoke):
    """The helper below, with the shared helpers it calls (tests/conftest.py)."""
    def info_json(path):
        result = invoke("info", path, "--json")
        assert result.exit_code == 0, result.output
        return json.loads(result.stdout)
    return info_json


def test_text_summary_of_a_finished_run(finished, invoke):
    result = invoke("info", finished)
    assert result.exit_code == 0, result.output
    text = result.stdout
    stored = load_results(finished)
    n_ok = int(np.sum(stored["status"].values == 0))
    for words in (f"format {FORMAT_VERSION}, complete", "9 of 9 points done", "model:       original",
                  "g: 9 values from 0 to 40", "fast forcing amplitude g", "Omega=4",
                  "transient_periods=2 measure_periods=2", f"by vrsweep {__version__}", "numba ", "numpy "):
        assert words in text, (words, text)
    assert re.search(rf"status:\s+{n_ok} ok\b", text), text
    # Every stored variable is listed with its units and meaning.
    for name in stored_variables(stored):
        assert re.search(rf"^  {re.escape(name)}\s", text, re.MULTILINE), (name, text)
    assert re.search(r"^  R\s+\(g: 9\)\s+\[1\]\s+gain \|Q\|/c", text, re.MULTILINE), text
    assert "config:" not in text
    assert "sweep:" in invoke("info", finished, "--config").stdout  # the config as run, on request


def test_json_matches_the_file(finished, info_json):
    summary = info_json(finished)
    stored = load_results(finished)
    assert summary["format_version"] == FORMAT_VERSION
    assert summary["complete"] is True and summary["kind"] == "sweep" and summary["shard"] is None
    assert summary["points_done"] == summary["points_total"] == summary["grid_points"] == 9
    assert summary["model"] == "original"
    [axis] = summary["axes"]
    assert (axis["name"], axis["size"], axis["min"], axis["max"], axis["units"]) == ("g", 9, 0.0, 40.0, "1")
    codes, counts = np.unique(stored["status"].values, return_counts=True)
    assert {row["code"]: row["points"] for row in summary["status_counts"]} == dict(
        zip(codes.tolist(), counts.tolist()))
    assert sum(row["points"] for row in summary["status_counts"]) == 9
    variables = {v["name"]: v for v in summary["variables"]}
    assert list(variables) == list(stored_variables(stored))
    assert variables["R"]["units"] == "1" and variables["R"]["dims"] == ["g"]
    assert variables["strobe_x"]["shape"] == [9, 2]
    assert variables["g_res"]["derived"] and not variables["R"]["derived"]
    assert summary["versions"]["vrsweep"] == __version__
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", summary["created"])
    assert summary["fixed_parameters"]["Omega"] == 4.0 and "g" not in summary["fixed_parameters"]
    assert summary["integration"]["transient_periods"] == 2
    assert summary["integration"]["rtol"] == 1e-9  # YAML 1.2: a float, not the string "1e-09"
    assert summary["config"] == stored.attrs["config"]


def test_an_unfinished_checkpoint_says_so(finished, tmp_path, info_json, invoke):
    """A checkpoint (points missing, vrsweep_complete = 0) is reported as not complete, with the
    missing points counted as not_computed."""
    partial = tmp_path / "partial.h5"
    shutil.copy(finished, partial)
    with h5py.File(partial, "r+") as f:  # what a run killed after 5 points leaves
        f["done"][5:] = 0
        f["status"][5:] = -1
        f.attrs.modify("vrsweep_complete", np.int32(0))
    result = invoke("info", partial)
    assert result.exit_code == 0, result.output
    assert "NOT complete" in result.stdout and "--resume" in result.stdout
    assert "5 of 9 points done" in result.stdout
    assert re.search(r"\b4 not_computed\b", result.stdout), result.stdout
    summary = info_json(partial)
    assert summary["complete"] is False and summary["points_done"] == 5


def test_a_shard_counts_its_own_points(tmp_path, info_json, invoke, run_quickstart):
    run_quickstart(tmp_path / "sharded.h5", "--shard", "1/2")
    [shard] = tmp_path.glob("sharded.shard*.h5")
    summary = info_json(shard)
    owned = int(load_results(shard).owned.sum())
    assert summary["kind"] == "shard" and summary["shard"] == "1/2"
    assert summary["grid_points"] == 9 and summary["points_total"] == summary["points_done"] == owned < 9
    assert sum(row["points"] for row in summary["status_counts"]) == owned
    assert f"{owned} of {owned} points done (shard 1/2 of a 9-point grid)" in invoke("info", shard).stdout


def test_a_single_point_run(tmp_path, info_json, invoke, run_quickstart):
    path = run_quickstart(tmp_path / "point.h5", "--set", "g=5")
    text = invoke("info", path).stdout
    assert "axes:        none (a single point)" in text and "1 of 1 points done" in text
    assert "g=5" in text  # g is fixed now
    assert info_json(path)["axes"] == []


def test_a_vrsweep_file_without_a_grid_is_described(tmp_path, info_json, invoke):
    """A vrsweep file of this format that is none of the kinds vrsweep writes (no vrsweep_file,
    no grid): info lists its attributes and datasets, and says it does not know its kind rather
    than guessing one (issue 35: "vrsweep 7")."""
    path = tmp_path / "trajectory.h5"
    with h5py.File(path, "w") as f:
        f.attrs["vrsweep_format_version"] = np.int32(FORMAT_VERSION)
        f.attrs["vrsweep_complete"] = np.int32(1)
        f.attrs["created"] = "2024-01-01T00:00:00Z"
        f.attrs["model"] = "effective"
        f.attrs["vrsweep_version"] = __version__
        samples = f.create_dataset("x", data=np.zeros(50))
        samples.attrs.update({"units": "1", "long_name": "position x"})
    result = invoke("info", path)
    assert result.exit_code == 0, result.output
    assert "a vrsweep file of a kind this vrsweep does not know" in result.stdout and "effective" in result.stdout
    assert re.search(r"^  x\s+50\s+\[1\]\s+position x", result.stdout, re.MULTILINE), result.stdout
    summary = info_json(path)
    assert summary["kind"] == "unknown" and summary["points_total"] is None
    with h5py.File(path, "r+") as f:
        f.attrs["vrsweep_file"] = np.int64(7)
    first = invoke("info", path).stdout.splitlines()[0]
    assert "does not know" in first and "vrsweep 7" not in first, first
    assert summary["variables"][0]["shape"] == [50]


def test_a_simulate_output_is_described(tmp_path, info_json, invoke):
    if "simulate" not in main.commands:
        pytest.skip("vrsweep simulate is not built yet")
    path = tmp_path / "traj.h5"
    result = invoke("simulate", QUICKSTART, "--set", "g=5", "--set", "transient_periods=2",
                    "--set", "measure_periods=2", "--set", "strobe_periods=2", "-o", path)
    assert result.exit_code == 0, result.output
    result = invoke("info", path)
    assert result.exit_code == 0, result.output
    assert "vrsweep trajectory" in result.stdout and "g=5" in result.stdout
    summary = info_json(path)
    assert summary["format_version"] == FORMAT_VERSION and summary["complete"] is True
    # One status per model run, named as the kernel names it.
    assert {row["status"] for row in summary["status_counts"]} <= {"ok", "max_steps", "diverged",
                                                                   "chatter_limit", "step_too_small",
                                                                   "non_finite"}
    assert summary["status_counts"], summary
    names = {variable["name"] for variable in summary["variables"]}
    assert any(name.endswith("/x") for name in names), names


@pytest.mark.parametrize("suffix", [".svg", ".png", ".pdf"])
def test_a_figure_another_program_wrote_has_no_vrsweep_description(tmp_path, invoke, suffix):
    # matplotlib's SVG names its creator in a dc:title, which info printed as the figure's
    # description ("figure / Matplotlib v3.11.2, https://matplotlib.org/"); a PNG or PDF with a
    # Title of its own was described as if vrsweep had written it.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1])
    path = tmp_path / f"other{suffix}"
    metadata = {"Title": "someone else's"} if suffix != ".png" else {"Title": "someone else's",
                                                                      "Description": "not ours"}
    fig.savefig(path, metadata=metadata)
    plt.close(fig)
    result = invoke("info", str(path))
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"{path}: a figure without a vrsweep description in its metadata"



def test_a_solver_error_not_estimated_says_the_sample_held_no_converged_point(finished, info_json):
    """The rerun takes only a sample of the grid (execution/solver_error.py): with no periodic or
    quasi-periodic point among it, info must not say the file holds none (it may hold many)."""
    from vrsweep.commands.info import format_summary

    summary = info_json(finished)
    summary["solver_error"] = {"relative": None, "points": 0, "rtol": 1e-12}  # as such a file reads
    text = format_summary(summary)
    assert ("the sample of points rerun at a tighter tolerance held no periodic or quasi-periodic point"
            in text), text


@pytest.mark.parametrize("description, shown", [
    ("x" * 1_000_000, ["x" * 1000 + "... (999000 more characters; --json prints them)"]),
    ("line\n" * 100_000, ["line"] * 40 + ["... (99961 more lines; --json prints them all)"]),
])
def test_a_figures_description_of_any_size_is_printed_in_a_screenful(tmp_path, invoke, info_json, description, shown):
    # A figure's metadata is anyone's to write: `info big.png` printed a 1 MB description whole.
    from PIL import Image, PngImagePlugin

    metadata = PngImagePlugin.PngInfo()
    metadata.add_text("Software", "vrsweep 0.7.4")
    metadata.add_text("Description", description)
    path = tmp_path / "big.png"
    Image.new("RGB", (4, 4)).save(path, pnginfo=metadata)
    result = invoke("info", str(path))
    assert result.exit_code == 0, result.output
    assert result.output.splitlines() == [f"{path}: figure"] + shown
    assert info_json(path)["Description"] == description  # the data whole, for a script
