"""vrsweep continue: the config section, the branch file, its summary, and the refusals."""

import numpy as np
import pytest

import vrsweep

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
    assert "g=24 " in result.output  # the continued parameter's start value, not the config's default
    assert "bifurcation: fold at g = " in result.output


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


def test_original_model_with_incommensurate_forcing_is_refused(invoke, tmp_path, write_config):
    config = write_config(tmp_path, "parameters: {g: 5.0, Omega: 4.3}\n"
                                    "continuation: {parameter: g, from: 5.0, to: [4.0, 6.0]}\n", "q.yaml")
    result = invoke("continue", config, "-o", tmp_path / "q.h5")
    assert result.exit_code == 2
    assert "not a whole number" in result.output and "parameters.Omega" in result.output


def test_original_model_refuses_omega_as_parameter(invoke, tmp_path, write_config):
    config = write_config(tmp_path, "parameters: {g: 5.0}\n"
                                    "continuation: {parameter: Omega, from: 4.0, to: [3.0, 5.0]}\n", "w.yaml")
    result = invoke("continue", config, "-o", tmp_path / "w.h5")
    assert result.exit_code == 2 and "effective model" in result.output


def test_config_without_the_section_is_refused(invoke, tmp_path, write_config):
    config = write_config(tmp_path, "model: effective\n", "none.yaml")
    result = invoke("continue", config, "-o", tmp_path / "n.h5")
    assert result.exit_code == 2 and "no continuation section" in result.output


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
    assert any(label.startswith("fold, $g$ = ") for label in labels)  # each bifurcation named in the legend
    styles = {line.get_linestyle() for line in axes[0].lines if line.get_color() == "C0"}
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
