"""vrsweep continue: the config section, the branch file, its summary, and the refusals."""

import re

import numpy as np
import pytest
from click.testing import CliRunner

import vrsweep
from vrsweep.cli import main

HYSTERESIS = """\
model: effective
parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
initial: {x: 0.0, v: 0.0}
integration: {rtol: 1.0e-10, atol: 1.0e-12, transient_periods: 200}
continuation:
  parameter: g
  from: 24.0
  to: [23.5, 25.4]
  max_step: 0.3
"""


@pytest.fixture(scope="module")
def branch_file(tmp_path_factory, write_config, invoke):
    folder = tmp_path_factory.mktemp("continue")
    config = write_config(folder, HYSTERESIS, "hysteresis.yaml")
    output = folder / "branch.h5"
    result = invoke("continue", config, "-o", output)
    assert result.exit_code == 0, result.output
    return output, result.output


def test_branch_file_opens_as_a_dataset_along_points(branch_file):
    path, output = branch_file
    with vrsweep.open_results(path) as ds:
        assert ds.attrs["vrsweep_file"] == "branch" and ds.attrs["parameter"] == "g"
        assert ds["R"].dims == ("point",) and ds["multiplier_modulus"].dims == ("point", "multiplier")
        assert ds["R"].attrs["units"] == "1" and "eq3.3" in ds["R"].attrs["long_name"]
        stable = ds["stable"].values.astype(bool)
        modulus = ds["multiplier_modulus"].values
        # stable exactly when both multipliers lie inside the unit circle
        assert np.array_equal(stable, np.all(modulus < 1.0, axis=1))
        assert stable.any() and not stable.all()
        kinds = list(ds["bifurcation_kind"].values)
        assert "fold" in kinds
        assert np.all(ds["residual"].values < 1e-7)
    assert "fold at g = " in output


def test_info_summarises_the_branch(branch_file, invoke):
    path, _ = branch_file
    result = invoke("info", path)
    assert result.exit_code == 0
    assert "vrsweep branch" in result.output and "branch 0:" in result.output
    # The continued parameter moves: neither its config default (0) nor its start (24) is fixed, as
    # validate says of the section (the branch line gives its range).
    fixed = next(line for line in result.output.splitlines() if line.startswith("fixed:"))
    assert "g=" not in fixed and "Omega=4" in fixed, fixed
    assert re.search(r"branch 0: +period 1, \d+ points \(\d+ stable\), g from ", result.output), result.output
    assert "bifurcation: fold at g = " in result.output


def test_info_of_a_bifurcation_without_a_parameter_says_nan(branch_file, invoke, tmp_path):
    # A file written elsewhere (or edited) may hold NaN where a located parameter belongs: info
    # prints it as nan, as it prints every other missing number, not a traceback.
    from damaged import damaged_copy

    def forget_the_parameter(f):
        f["bifurcation_parameter"][0] = np.nan

    path = damaged_copy(branch_file[0], tmp_path, forget_the_parameter)
    result = invoke("info", path)
    assert result.exit_code == 0, result.output
    assert re.search(r" at g = nan \([A-Z]+1 on the figure, branch 0", result.output), result.output


def test_existing_output_is_refused(branch_file, invoke, tmp_path, write_config):
    path, _ = branch_file
    config = write_config(tmp_path, HYSTERESIS, "again.yaml")
    result = invoke("continue", config, "-o", path)
    assert result.exit_code == 2 and "--overwrite" in result.output


def test_bad_section_names_file_line_and_field(invoke, tmp_path, write_config):
    config = write_config(tmp_path, HYSTERESIS.replace("to: [23.5, 25.4]", "to: [25.4, 23.5]")
                          .replace("parameter: g", "parameter: gg"), "bad.yaml")
    result = invoke("continue", config, "-o", tmp_path / "x.h5")
    assert result.exit_code == 2
    assert "bad.yaml:6: continuation.parameter" in result.output and "did you mean 'g'" in result.output
    assert "bad.yaml:8: continuation.to: must be [low, high] with low < high" in result.output


def test_sweep_axis_continuation_key_still_means_hysteresis(write_config, tmp_path):
    from vrsweep.config import load_config

    config = load_config(write_config(tmp_path, "sweep:\n  g: {start: 1, stop: 2, num: 3, continuation: both}\n"))
    assert config.axes[0].continuation == "both" and config.continuation is None


@pytest.mark.parametrize("fixed_g", ["g: 5.0, ", ""])
def test_original_model_with_incommensurate_forcing_is_refused(invoke, tmp_path, write_config, fixed_g):
    # refused alike whether parameters.g is set or g is continued from its default 0 (issue 35)
    config = write_config(tmp_path, "parameters: {" + fixed_g + "Omega: 4.3001}\n"
                                    "continuation: {parameter: g, from: 5.0, to: [4.0, 6.0]}\n", "q.yaml")
    result = invoke("continue", config, "-o", tmp_path / "q.h5")
    assert result.exit_code == 2
    assert "is not a ratio p/q of whole numbers" in result.output and "parameters.Omega" in result.output


def test_original_model_refuses_omega_as_parameter(invoke, tmp_path, write_config):
    config = write_config(tmp_path, "parameters: {g: 5.0}\n"
                                    "continuation: {parameter: Omega, from: 4.0, to: [3.0, 5.0]}\n", "w.yaml")
    result = invoke("continue", config, "-o", tmp_path / "w.h5")
    assert result.exit_code == 2 and "effective model" in result.output


def test_config_without_the_section_is_refused(invoke, tmp_path, write_config):
    config = write_config(tmp_path, "model: effective\n", "none.yaml")
    result = invoke("continue", config, "-o", tmp_path / "n.h5")
    assert result.exit_code == 2 and "no continuation section" in result.output


SECTIONS_CONTINUE_REFUSES = {
    # issue 35: validate said "valid" to each; continue named --start for the first, and ran the
    # second into a one-point branch that claimed left_range
    "from outside to": (("from: 24.0", "from: 30.0"), "continuation.from = 30.0 lies outside continuation.to"),
    "initial_step above max_step": (("max_step: 0.3", "max_step: 0.3\n  initial_step: 0.8"),
                                    "continuation.initial_step = 0.8 must lie between continuation.min_step = "
                                    "1e-05 and continuation.max_step = 0.3"),
    "initial_step below min_step": (("max_step: 0.3", "max_step: 0.3\n  min_step: 0.01\n  initial_step: 0.001"),
                                    "continuation.initial_step = 0.001 must lie between"),
    "incommensurate forcing": (("model: effective", "model: original\nparameters: {g: 5.0, Omega: 4.3001}"),
                               "is not a ratio p/q of whole numbers"),
}


@pytest.mark.parametrize("damage", sorted(SECTIONS_CONTINUE_REFUSES))
def test_validate_refuses_what_continue_refuses(invoke, tmp_path, write_config, damage):
    (old, new), words = SECTIONS_CONTINUE_REFUSES[damage]
    text = HYSTERESIS.replace(old, new)
    if damage == "incommensurate forcing":
        text = text.replace("parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}\n", "")
    config = write_config(tmp_path, text, "section.yaml")
    for command in (("validate", config), ("continue", config, "-o", tmp_path / "x.h5")):
        result = invoke(*command)
        lines = result.output.strip().splitlines()
        assert result.exit_code == 2 and len(lines) == 1, (command, result.output)
        assert words in lines[0] and "--start" not in lines[0], (command, lines[0])
    assert not (tmp_path / "x.h5").exists()


def test_validate_describes_the_continuation(invoke, tmp_path, write_config):
    result = invoke("validate", write_config(tmp_path, HYSTERESIS.replace("max_step: 0.3", "max_step: 0.3\n  switch: true"),
                                             "ok.yaml"))
    assert result.exit_code == 0, result.output
    assert ("continuation: g from 24 within [23.5, 25.4]; steps 0.05 (1e-05 to 0.3), at most 400 points, periods "
            "up to 16; the branches of 2p periods too (switch)") in result.output.splitlines()
    fixed = next(line for line in result.output.splitlines() if line.startswith("fixed:"))
    assert "Omega=4" in fixed and "g=" not in fixed  # g moves: its config value (0) is not used


def test_a_max_step_alone_below_the_default_first_step_is_the_first_step(invoke, tmp_path, write_config):
    """`max_step: 0.02` alone was refused: 'continuation.initial_step = 0.05 must lie between ...
    and continuation.max_step = 0.02', an initial_step the config never wrote (its default). An
    unwritten first step is the default brought within [min_step, max_step], as a curve's
    --set continuation.max_step alone already did; a written one outside is refused as before."""
    from vrsweep.config import load_config

    small = write_config(tmp_path, HYSTERESIS.replace("max_step: 0.3", "max_step: 0.02"), "small.yaml")
    result = invoke("validate", small)
    assert result.exit_code == 0, result.output
    assert "steps 0.02 (1e-05 to 0.02)" in result.output
    assert load_config(small).continuation.initial_step == 0.02
    coarse = write_config(tmp_path, HYSTERESIS.replace("max_step: 0.3", "max_step: 0.3\n  min_step: 0.1"),
                          "coarse.yaml")
    assert load_config(coarse).continuation.initial_step == 0.1
    assert load_config(write_config(tmp_path, HYSTERESIS, "plain.yaml")).continuation.initial_step == 0.05


class Started(Exception):
    """continue got past its announcements to the work itself."""


@pytest.mark.parametrize("with_branch_file", [False, True])
def test_an_empty_cache_says_that_continue_compiles(tmp_path, monkeypatch, invoke, write_config, with_branch_file):
    """Issue 35: the first continue was silent for up to 3 minutes while numba compiled (sweeps say so)."""
    def started(*args, **kwargs):
        raise Started

    monkeypatch.setattr("vrsweep.execution.continuation.run_continuation", started)
    monkeypatch.setattr("vrsweep.execution.curves.run_curve", started)
    args = ("continue", write_config(tmp_path, HYSTERESIS), "-o", tmp_path / "out.h5")
    if with_branch_file:
        from handmade import write_branch_file

        args = ("continue", write_branch_file(tmp_path / "branch.h5"), "--point", "0", "--along", "Omega",
                "--to", "3", "5", "-o", tmp_path / "out.h5")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "empty-cache"))
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert isinstance(result.exception, Started)
    assert result.stderr.startswith("Compiling the numba kernels of continuation (up to 3 minutes, once: later "
                                    "runs load them from "), result.stderr
    assert str(tmp_path / "empty-cache") in result.stderr
    quiet = CliRunner().invoke(main, [str(a) for a in args] + ["-q"])
    assert isinstance(quiet.exception, Started) and quiet.stderr == ""


def test_plot_draws_the_branch_with_a_sweep(branch_file, invoke, tmp_path, write_config):
    path, _ = branch_file
    sweep_config = write_config(tmp_path, "model: effective\nparameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}\n"
                                          "initial: {x: 0.0, v: 0.0}\nsweep:\n  g: {start: 23.5, stop: 25.0, num: 3}\n"
                                          "integration: {transient_periods: 20, measure_periods: 20}\n", "s.yaml")
    sweep = tmp_path / "s.h5"
    assert invoke("run", sweep_config, "-o", sweep, "-q").exit_code == 0
    figure = tmp_path / "branch.png"
    result = invoke("plot", path, sweep, "-o", figure)
    assert result.exit_code == 0, result.output
    assert figure.stat().st_size > 10_000

    from vrsweep.plot import plot

    figure = plot([path, sweep])
    axes = figure.axes
    assert len(axes) == 2
    labels = [text.get_text() for legend in figure.legends for text in legend.get_texts()]
    # one legend entry per kind of bifurcation, each bifurcation tagged on the curve (F1, ...)
    assert "F: fold" in labels, labels
    assert any(text.get_text().startswith("F1") for text in axes[0].texts)
    from vrsweep.plot.branches import BRANCH_COLOUR

    styles = {line.get_linestyle() for line in axes[0].lines if line.get_color() == BRANCH_COLOUR}
    assert {"-", "--"} <= styles  # stable solid, unstable dashed
    assert figure._suptitle is not None and "continued in" in figure._suptitle.get_text()
    paper = plot([path, sweep], title=False, size=(3.4, 3.6))  # the options of every figure
    assert paper._suptitle is None and not any(ax.get_title() for ax in paper.axes)
    assert tuple(paper.get_size_inches()) == (3.4, 3.6)


def test_start_from_a_sweep_point(invoke, tmp_path, write_config):
    """--start SWEEP.h5 --at g=...: the transient starts from that point's final state. The
    down-sweep of the hysteresis loop is on the impacting orbit, which the start from rest at
    the same g does not find."""
    sweep_config = write_config(tmp_path, "model: effective\nparameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}\n"
                                          "initial: {x: 0.0, v: 0.0}\n"
                                          "sweep:\n  g: {start: 24.0, stop: 27.0, num: 4, continuation: down}\n"
                                          "integration: {transient_periods: 50, measure_periods: 20}\n", "d.yaml")
    sweep = tmp_path / "d.h5"
    assert invoke("run", sweep_config, "-o", sweep, "-q").exit_code == 0
    config = write_config(tmp_path, HYSTERESIS.replace("to: [23.5, 25.4]", "to: [23.8, 24.2]"), "c.yaml")
    output = tmp_path / "impacting.h5"
    result = invoke("continue", config, "-o", output, "--start", sweep, "--at", "g=24")
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(output) as ds:
        assert np.all(ds["impacts_per_period"].values == 1) and np.all(ds["stable"].values == 1)
    result = invoke("continue", config, "-o", tmp_path / "y.h5", "--start", sweep)
    assert result.exit_code == 2 and "--at" in result.output
    for off_grid in ("24.3", "nan", "1e400"):  # no nearest point chosen for the user
        result = invoke("continue", config, "-o", tmp_path / "z.h5", "--start", sweep, "--at", f"g={off_grid}")
        assert result.exit_code == 2 and "--at g=" in result.output, result.output
        assert not (tmp_path / "z.h5").exists()


# --- continue BRANCH.h5 --point K --along NAME: bifurcation curves (analysis/curves.py) ---------
def _bifurcation_index(path, kind):
    with vrsweep.open_results(path) as ds:
        return list(ds["bifurcation_kind"].values).index(kind)


@pytest.fixture(scope="module")
def curves_file(branch_file, invoke):
    path, _ = branch_file
    output = path.with_name("fold_curve.h5")
    point = _bifurcation_index(path, "fold")
    result = invoke("continue", path, "--point", point, "--along", "Omega", "--to", "3.9", "4.1",
                    "--within", "20", "30", "-o", output)
    assert result.exit_code == 0, result.output
    return output, result.output


CASCADE = """\
model: original
parameters: {g: 17.86}
initial: {x: 0.99, v: 0.5}
integration: {rtol: 1.0e-12, atol: 1.0e-14, transient_periods: 300}
continuation:
  parameter: g
  from: 17.86
  to: [17.8255, 17.87]
  max_points: 50
  max_step: 0.3
  max_period: 4
"""


@pytest.fixture(scope="module")
def switched_file(tmp_path_factory, write_config, invoke):
    """The original model's orbit of 2 slow periods near g = 17.86 (Fig. 1's parameters) and, with
    --switch, the period-4 branch born at its period doubling (max_period 4: no further switch)."""
    folder = tmp_path_factory.mktemp("switch")
    config = write_config(folder, CASCADE, "cascade.yaml")
    output = folder / "switched.h5"
    result = invoke("continue", config, "-o", output, "--switch")
    assert result.exit_code == 0, result.output
    return output, result.output


def test_curves_file_opens_with_the_agreed_layout(curves_file):
    path, output = curves_file
    with vrsweep.open_results(path) as ds:
        assert ds.attrs["vrsweep_file"] == "curves" and list(ds.attrs["parameter_names"]) == ["g", "Omega"]
        assert ds.attrs["model"] == "effective" and ds.attrs["vrsweep_complete"] == 1
        for name in ("curve", "g", "Omega", "x", "v", "periods", "R", "impacts_per_period", "barrier_distance",
                     "residual"):
            assert ds[name].dims == ("point",) and ds[name].attrs["units"] == "1" and ds[name].attrs["long_name"]
        assert ds["Omega"].attrs["long_name"] == "fast forcing frequency Omega"
        for name in ("multiplier_real", "multiplier_imag", "multiplier_modulus"):
            assert ds[name].dims == ("point", "multiplier")
        assert list(ds["curve_kind"].values) == ["fold"]
        for name in ("curve_periods", "curve_end_first_status", "curve_end_first_reason", "curve_end_last_status",
                     "curve_end_last_reason"):
            assert ds[name].dims == ("curve_id",)
        for name in ("special_kind", "special_curve", "special_g", "special_Omega"):
            assert ds[name].dims == ("special",)
        g, omega = ds["g"].values, ds["Omega"].values
        assert omega.min() < 3.95 and omega.max() > 4.05
        # the effective model's fold curve is g = k Omega^2 (eq2.11, eq2.12: g/Omega^2 only)
        assert np.ptp(g / omega**2) < 3e-5 * np.mean(g / omega**2)
        # a multiplier at +1 at every point (the fold's test function det(M - I) = 0)
        assert np.all(np.min(np.abs(ds["multiplier_real"].values - 1.0), axis=1) < 1e-5)
        assert np.all(ds["residual"].values < 1e-7)
        assert set(ds["curve_end_first_status"].values) | set(ds["curve_end_last_status"].values) == {"left_range"}
    assert "curve 0: fold, period 1" in output and "Omega left [3.9, 4.1]" in output


def test_info_summarises_the_curves(curves_file, invoke):
    path, _ = curves_file
    result = invoke("info", path)
    assert result.exit_code == 0, result.output
    assert "vrsweep curves" in result.output and "curve 0:     fold, period 1" in result.output
    assert "first end:   left_range: Omega left [3.9, 4.1]" in result.output


def test_grazing_and_fold_curves_in_one_file(branch_file, invoke, tmp_path):
    # Both bifurcations of the branch followed in Delta: the fold curve (g constant: the fold
    # orbit is clear of the barrier) ends where its orbit starts to hit the barrier, the very
    # point where the grazing curve passes the free orbit's fold.
    path, _ = branch_file
    output = tmp_path / "both.h5"
    result = invoke("continue", path, "--point", _bifurcation_index(path, "grazing"), "--point",
                    _bifurcation_index(path, "fold"), "--along", "Delta", "--to", "0.8", "1.2", "-o", output)
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(output) as ds:
        assert list(ds["curve_kind"].values) == ["grazing", "fold"]
        on_graze = ds["curve"].values == 0
        assert np.all(np.abs(ds["barrier_distance"].values[on_graze]) < 1e-6)
        assert ds["curve_end_first_status"].values[1] == "fold_grazing" or \
            ds["curve_end_last_status"].values[1] == "fold_grazing"
        kinds, curve = list(ds["special_kind"].values), list(ds["special_curve"].values)
        assert sorted(zip(kinds, curve)) == [("fold_grazing", 0), ("fold_grazing", 1)]
        # two computations of one point: a regula falsi on the grazing curve, an extrapolation
        # to the barrier on the fold curve (tests/test_curves.py says why 1e-4)
        assert np.ptp(ds["special_g"].values) < 1e-4 and np.ptp(ds["special_Delta"].values) < 1e-4
    assert "fold_grazing at g = " in result.output and "(curve 1)" in result.output


def test_curve_requests_that_cannot_be_met_are_refused(branch_file, invoke, tmp_path, write_config):
    path, _ = branch_file
    out = tmp_path / "c.h5"
    result = invoke("continue", path, "--point", 9, "--along", "Omega", "--to", "3", "5", "-o", out)
    assert result.exit_code == 2 and "--point = 9 is not a bifurcation" in result.output
    result = invoke("continue", path, "--point", 0, "--along", "g", "--to", "3", "5", "-o", out)
    assert result.exit_code == 2 and "--along = g is the branch's own parameter" in result.output
    result = invoke("continue", path, "--point", 0, "--along", "Omega", "-o", out)
    assert result.exit_code == 2 and "--to" in result.output
    result = invoke("continue", path, "--point", 0, "--along", "Omega", "--to", "4.5", "5", "-o", out)
    assert result.exit_code == 2 and "outside its range [4.5, 5] (--to)" in result.output
    result = invoke("continue", path, "--point", 0, "--along", "Omega", "--to", "5", "4", "-o", out)
    assert result.exit_code == 2 and "--to 5 4: the range of Omega is empty" in result.output
    result = invoke("continue", path, "-o", out)
    assert result.exit_code == 2 and "--point 0 --along Omega" in result.output
    config = write_config(tmp_path, HYSTERESIS, "h.yaml")
    result = invoke("continue", config, "--point", 0, "--along", "Omega", "-o", out)
    assert result.exit_code == 2 and "branch file" in result.output
    assert not out.exists()


@pytest.mark.parametrize("damage", ["missing", "short", "kind"])
def test_damaged_curves_file_is_one_line(curves_file, invoke, tmp_path, damage):
    import shutil

    import h5py

    path = tmp_path / "damaged.h5"
    shutil.copy(curves_file[0], path)
    with h5py.File(path, "r+") as f:
        if damage == "missing":
            del f["Omega"]
        elif damage == "short":
            del f["R"]
            f.create_dataset("R", data=np.zeros(2))
        else:
            f["curve_kind"][0] = "exploded"
    with pytest.raises(vrsweep.errors.ResultFileError, match="is corrupt"):
        vrsweep.open_results(path)
    result = invoke("info", path)
    assert result.exit_code == 2 and "is corrupt" in result.output and "Traceback" not in result.output


def test_switch_writes_the_doubled_branch(switched_file, invoke):
    path, output = switched_file
    with vrsweep.open_results(path) as ds:
        assert ds["branch_periods"].values.tolist() == [2, 4]
        assert str(ds["branch_end_first_status"].values[1]) == "period_doubling"
        on_second = ds["branch"].values == 1
        assert np.all(ds["periods"].values[on_second] == 4) and np.all(ds["periods"].values[~on_second] == 2)
        kinds = list(ds["bifurcation_kind"].values)
        branches = ds["bifurcation_branch"].values
        # the doubling of branch 0 where branch 1 starts, and branch 1's own
        assert {int(b) for k, b in zip(kinds, branches) if k == "period_doubling"} == {0, 1}
        assert "switch: true" in ds.attrs["config"]  # the stored config says what was run
    assert "branch 1: period 4" in output and "period_doubling at g = " in output
    info = invoke("info", path)
    assert info.exit_code == 0 and "branch 1:" in info.output and "period 4" in info.output
    assert "first end:   period_doubling: meets the period-2 branch" in info.output


def test_plot_draws_every_branch_in_its_period_colour(switched_file):
    from vrsweep.plot import plot

    path, _ = switched_file
    figure = plot([path])
    colours = {line.get_color() for line in figure.axes[0].lines if line.get_xdata().size > 1}
    assert len(colours) == 2  # period 2 and period 4
    labels = [text.get_text() for legend in figure.legends for text in legend.get_texts()]
    assert "period 2 T" in labels and "period 4 T" in labels
    assert "PD: period doubling" in labels, labels
    assert any("PD1" in text.get_text() for text in figure.axes[0].texts)


def test_switch_key_is_validated(invoke, tmp_path, write_config):
    config = write_config(tmp_path, CASCADE + "  switch: sometimes\n", "s.yaml")
    result = invoke("continue", config, "-o", tmp_path / "s.h5")
    assert result.exit_code == 2
    assert "s.yaml:12: continuation.switch: must be true or false" in result.output
