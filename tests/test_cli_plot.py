"""``vrsweep plot`` on the command line: outputs, formats, and every bad input as exit 2 with a message."""

import shutil
import textwrap

import h5py
import numpy as np
import pytest




@pytest.fixture(scope="module")
def sweep(tmp_path_factory, invoke):
    directory = tmp_path_factory.mktemp("cli_plot")
    config = directory / "sweep.yaml"
    config.write_text(textwrap.dedent("""\
        sweep:
          g: {start: 0.0, stop: 30.0, num: 4}
        integration: {transient_periods: 3, measure_periods: 6, strobe_periods: 3}
        """))
    out = directory / "sweep.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    return out


@pytest.fixture(scope="module")
def trajectory(tmp_path_factory, invoke):
    directory = tmp_path_factory.mktemp("cli_plot_traj")
    config = directory / "point.yaml"
    config.write_text("parameters: {g: 5.0}\nintegration: {transient_periods: 2, measure_periods: 3, strobe_periods: 1}\n")
    out = directory / "traj.h5"
    assert invoke("simulate", config, "-o", out, "-q", "--compare", "effective", "--samples-per-period", 20).exit_code == 0
    return out


def test_default_output_is_next_to_the_file(sweep, invoke):
    result = invoke("plot", sweep)
    assert result.exit_code == 0, result.output
    png = sweep.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(png) in result.output


@pytest.mark.parametrize("suffix, magic", [(".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_pdf_and_svg(sweep, tmp_path, suffix, magic, invoke):
    out = tmp_path / f"figure{suffix}"
    assert invoke("plot", sweep, "-o", out, "--kind", "bifurcation").exit_code == 0
    assert out.read_bytes().startswith(magic)


def test_an_explicit_kind_names_the_default_output(sweep, invoke):
    assert invoke("plot", sweep, "--kind", "status").exit_code == 0
    assert sweep.with_name("sweep.status.png").exists()


def test_trajectory_kinds(trajectory, tmp_path, invoke):
    for kind in ("trajectory", "impacts", "slowflow"):
        out = tmp_path / f"{kind}.png"
        result = invoke("plot", trajectory, "--kind", kind, "-o", out, "--periods", "1:4")
        assert result.exit_code == 0, result.output
        assert out.stat().st_size > 10_000


def test_an_unknown_format_is_refused(sweep, tmp_path, invoke):
    result = invoke("plot", sweep, "-o", tmp_path / "figure.jpg2")
    assert result.exit_code == 2 and ".png" in result.output


def test_a_text_file_is_not_a_vrsweep_file(tmp_path, invoke):
    path = tmp_path / "notes.h5"
    path.write_text("not HDF5 at all\n")
    result = invoke("plot", path, "-o", tmp_path / "f.png")
    assert result.exit_code == 2 and "not an HDF5 file" in result.output
    assert not (tmp_path / "f.png").exists()


def test_a_foreign_hdf5_file(tmp_path, invoke):
    path = tmp_path / "foreign.h5"
    with h5py.File(path, "w") as f:
        f["data"] = np.arange(3)
    result = invoke("plot", path, "-o", tmp_path / "f.png")
    assert result.exit_code == 2 and "not a vrsweep" in result.output


def test_a_missing_file(tmp_path, invoke):
    result = invoke("plot", tmp_path / "absent.h5", "-o", tmp_path / "f.png")
    assert result.exit_code == 2 and "not found" in result.output


@pytest.mark.parametrize("which", ["sweep", "trajectory"])
def test_a_truncated_file(which, sweep, trajectory, tmp_path, invoke):
    source = {"sweep": sweep, "trajectory": trajectory}[which]
    path = tmp_path / "truncated.h5"
    path.write_bytes(source.read_bytes()[: source.stat().st_size // 2])
    result = invoke("plot", path, "-o", tmp_path / "f.png")
    assert result.exit_code == 2 and ("truncated" in result.output or "corrupt" in result.output), result.output


def test_an_unfinished_sweep_is_plotted_with_a_warning(sweep, tmp_path, invoke):
    path = tmp_path / "unfinished.h5"
    shutil.copyfile(sweep, path)
    with h5py.File(path, "r+") as f:  # as if the run had been killed after two of four points
        f.attrs.modify("vrsweep_complete", np.int32(0))
        f["done"][2:] = 0
        f["R"][2:] = np.nan
        f["status"][2:] = -1
    result = invoke("plot", path, "-o", tmp_path / "f.png")
    assert result.exit_code == 0, result.output
    assert "unfinished" in result.output and (tmp_path / "f.png").exists()


def test_usage_errors_exit_2(sweep, trajectory, tmp_path, invoke):
    out = ["-o", tmp_path / "f.png"]
    for args, message in [
        ((sweep, "--kind", "slowflow"), "trajectory files"),
        ((trajectory, "--kind", "map"), "sweep results"),
        ((sweep, "--at", "g=3.3"), "not a value of the axis g"),
        ((sweep, "--at", "g"), "NAME=VALUE"),
        ((sweep, "--x", "Omega"), "not a swept axis"),
        ((sweep, "--periods", "1:2"), "trajectory files"),
        ((trajectory, "--periods", "5:2"), "FIRST:LAST"),
        ((sweep, sweep), "several files"),
    ]:
        result = invoke("plot", *args, *out)
        assert result.exit_code == 2, (args, result.output)
        assert message in result.output, (args, result.output)


def test_a_missing_output_directory_is_created(sweep, tmp_path, invoke):
    result = invoke("plot", sweep, "-o", tmp_path / "nowhere" / "f.png")
    assert result.exit_code == 0 and f"Created the output folder {tmp_path / 'nowhere'}" in result.output
    assert (tmp_path / "nowhere" / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_single_point_has_nothing_to_plot_against(tmp_path, invoke):
    config = tmp_path / "point.yaml"
    config.write_text("integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 1}\n")
    assert invoke("run", config, "-o", tmp_path / "point.h5", "-q").exit_code == 0
    result = invoke("plot", tmp_path / "point.h5", "-o", tmp_path / "f.png")
    assert result.exit_code == 2 and "single point" in result.output and "simulate" in result.output


def test_log_and_linear(sweep, tmp_path, invoke):
    """--log was ignored on --kind map (a byte-identical PNG); now it changes the map or is refused."""
    for args in (("--log",), ("--linear",), ()):
        assert invoke("plot", sweep, *args, "-o", tmp_path / f"r{len(args)}{args[:1]}.png").exit_code == 0
    result = invoke("plot", sweep, "--kind", "bifurcation", "--log", "-o", tmp_path / "b.png")
    assert result.exit_code == 2 and "--log is for response, map and impacts plots" in result.output


def test_periods_beyond_the_run_are_clipped_with_a_word(trajectory, tmp_path, invoke):
    result = invoke("plot", trajectory, "--periods", "2:90", "-o", tmp_path / "t.png")
    assert result.exit_code == 0, result.output
    assert "--periods 2:90: " in result.output and "has 5 slow periods; showing 2-5" in result.output
    quiet = invoke("plot", trajectory, "--periods", "2:4", "-o", tmp_path / "t2.png")
    assert "--periods" not in quiet.output


def test_at_messages(sweep, tmp_path, invoke):
    result = invoke("plot", sweep, "--at", "g=12", "-o", tmp_path / "f.png")
    assert result.exit_code == 2 and "the nearest are 10 and 20" in result.output, result.output


@pytest.fixture(scope="module")
def plane(tmp_path_factory, invoke):
    """A sweep over two axes, for maps."""
    directory = tmp_path_factory.mktemp("cli_plot_map")
    config = directory / "plane.yaml"
    config.write_text(textwrap.dedent("""\
        sweep:
          g: {start: 0.0, stop: 30.0, num: 4}
          Omega: [4.0, 5.0, 6.0]
        integration: {transient_periods: 3, measure_periods: 6, strobe_periods: 3}
        """))
    out = directory / "plane.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    return out


@pytest.mark.parametrize("name", ["R_err", "period", "impacts_per_period", "x_min", "status"])
def test_a_map_of_any_stored_variable(plane, tmp_path, name, invoke):
    from matplotlib.collections import QuadMesh

    from vrsweep import plot
    from vrsweep.store.reading import load_results

    out = tmp_path / f"{name}.png"
    result = invoke("plot", plane, "--kind", "map", "--var", name, "-o", out)
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # What the map draws is the stored variable, cell by cell ([x, y] = [g, Omega]).
    fig = plot.plot(plane, kind="map", var=name)
    (mesh,) = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)]
    stored = load_results(plane)[name].values
    np.testing.assert_array_equal(np.asarray(mesh.get_array()).reshape(3, 4), stored.T.astype(float))
    assert fig.axes[1].get_ylabel().startswith(name) or name == "impacts_per_period"


def test_a_map_is_labelled_with_the_units_the_file_gives(plane, tmp_path):
    """Units come from the file's attributes, not from what vrsweep writes today."""
    from vrsweep import plot

    copy = tmp_path / "units.h5"
    shutil.copy(plane, copy)
    with h5py.File(copy, "r+") as f:
        f["x_min"].attrs["units"] = "mm"
        f["Omega"].attrs["units"] = "rad/s"
    fig = plot.plot(copy, var="x_min")  # a variable to map asks for a map
    x_label, y_label, bar_label = fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel(), fig.axes[1].get_ylabel()
    assert x_label.endswith("$g$") and y_label.endswith("$\\Omega$ [rad/s]"), (x_label, y_label)
    assert bar_label == "x_min: smallest x over the measurement window [mm]"


def test_an_unknown_map_variable_lists_the_ones_the_file_has(plane, tmp_path, invoke):
    result = invoke("plot", plane, "--kind", "map", "--var", "nope", "-o", tmp_path / "f.png")
    assert result.exit_code == 2, result.output
    line = result.output.strip().splitlines()[-1]
    assert line.startswith(f"Error: --var nope: {plane} has no such variable with one value per grid point; "
                           "it has R, Qs, Qc, Q_amplitude, R_err, impacts_per_period, status, period, "), line
    assert "x_min" in line and "strobe_x" not in line  # strobe_x has a value per sample, not per point
    # --var is for maps only, and names the variable itself.
    for args, words in ((("--kind", "status"), "--var is for --kind map, not --kind status"),
                        (("--amplitude",), "--amplitude maps Q_amplitude and --var names the variable itself")):
        result = invoke("plot", plane, "--var", "R_err", *args, "-o", tmp_path / "f.png")
        assert result.exit_code == 2 and words in result.output, result.output


def test_cli_messages_name_the_flags_the_library_names_arguments(sweep, trajectory, tmp_path, invoke):
    """The library's message names its arguments; the command's names its flags, word for word."""
    from vrsweep import plot
    from vrsweep.errors import UsageError

    result = invoke("plot", sweep, "--x", "Omega", "-o", tmp_path / "f.png")
    assert result.output.strip().splitlines()[-1] == (
        f"Error: --x Omega: not a swept axis of {sweep} (axes: g)")
    with pytest.raises(UsageError) as info:
        plot.plot(sweep, x_axis="Omega")
    assert str(info.value) == f"x_axis Omega: not a swept axis of {sweep} (axes: g)"
    with pytest.raises(UsageError, match="^at, x_axis, amplitude and log/linear are for sweep results"):
        plot.plot(trajectory, at={"g": "1"})
    result = invoke("plot", trajectory, "--at", "g=1", "-o", tmp_path / "f.png")
    assert "Error: --at, --x, --amplitude and --log/--linear are for sweep results" in result.output
