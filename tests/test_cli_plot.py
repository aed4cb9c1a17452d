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
        periods = () if kind == "impacts" else ("--periods", "1:4")  # impacts draws every period
        result = invoke("plot", trajectory, "--kind", kind, "-o", out, *periods)
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
    from damaged import reseal
    from vrsweep import plot

    copy = tmp_path / "units.h5"
    shutil.copy(plane, copy)
    with h5py.File(copy, "r+") as f:
        f["x_min"].attrs["units"] = "mm"
        f["Omega"].attrs["units"] = "rad/s"
    reseal(copy)  # as a writer that chose those units would have sealed them
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
    # --var is for maps and curves against one axis only, and names the variable itself.
    for args, words in ((("--kind", "status"), "--var is for --kind map and --kind response (against one axis), not --kind status"),
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
    with pytest.raises(UsageError, match="^at, x_axis, var, amplitude and log/linear are for sweep results"):
        plot.plot(trajectory, at={"g": "1"})
    result = invoke("plot", trajectory, "--at", "g=1", "-o", tmp_path / "f.png")
    assert "Error: --at, --x, --var, --amplitude and --log/--linear are for sweep results" in result.output


# --- curves over a map (issue 21): vrsweep plot MAP.h5 CURVES.h5 ... -------------------------------

EFFECTIVE_MAP = """\
model: effective
parameters: {gamma: 0.05, alpha: 0.05}
initial: {x: 0.0, v: 0.0}
sweep:
  g: {start: 20.0, stop: 28.0, num: 5}
  Omega: {start: 3.8, stop: 4.2, num: 5}
integration: {transient_periods: 2, measure_periods: 4, strobe_periods: 2}
"""


def write_curves(path, names, curves, specials=(), model="effective", config=None):
    """A curves file as `vrsweep continue BRANCH.h5 --point K --along NAME` writes it (the agreed
    layout, store/curve_file.py), by h5py: curves = [(kind, {name: values})], specials =
    [(kind, curve, {name: value})]. config: the stored config's text (default: the model's alone)."""
    from vrsweep.store.branch_file import seal_attributes

    config = f"model: {model}\n" if config is None else config

    strings = h5py.string_dtype()
    with h5py.File(path, "w") as f:
        f.attrs.update(vrsweep_file="curves", vrsweep_format_version=1, vrsweep_complete=1, model=model,
                       method="rk45", config=config)
        f.attrs["parameter_names"] = np.array(names, dtype=strings)

        def dimension(name, size):
            f.create_dataset(name, data=np.arange(size)).make_scale(name)

        def variable(name, data, dims, dtype=None):
            dataset = f.create_dataset(name, data=np.asarray(data, dtype=dtype))
            for i, dim in enumerate(dims):
                dataset.dims[i].attach_scale(f[dim])

        points = sum(len(next(iter(values.values()))) for _, values in curves)
        dimension("point", points)
        dimension("multiplier", 2)
        dimension("curve_id", len(curves))
        dimension("special", len(specials))
        variable("curve", np.concatenate([np.full(len(values[names[0]]), k) for k, (_, values) in enumerate(curves)]),
                 ("point",))
        for name in names:
            variable(name, np.concatenate([values[name] for _, values in curves]), ("point",))
        for name in ("x", "v", "R", "impacts_per_period", "barrier_distance", "residual"):
            variable(name, np.zeros(points), ("point",))
        variable("periods", np.ones(points, dtype=np.int64), ("point",))
        for name in ("multiplier_real", "multiplier_imag", "multiplier_modulus"):
            variable(name, np.zeros((points, 2)), ("point", "multiplier"))
        variable("curve_kind", [kind for kind, _ in curves], ("curve_id",), strings)
        variable("curve_periods", np.ones(len(curves), dtype=np.int64), ("curve_id",))
        for end in ("first", "last"):
            variable(f"curve_end_{end}_status", ["left_range"] * len(curves), ("curve_id",), strings)
            variable(f"curve_end_{end}_reason", ["left the range"] * len(curves), ("curve_id",), strings)
        variable("special_kind", [kind for kind, _, _ in specials], ("special",), strings)
        variable("special_curve", np.array([curve for _, curve, _ in specials], dtype=np.int64), ("special",))
        for name in names:
            variable(f"special_{name}", np.array([where[name] for _, _, where in specials], dtype=float),
                     ("special",))
        seal_attributes(f)  # as this version writes them (a file without it is read with a note)
    return path


@pytest.fixture(scope="module")
def effective_map(tmp_path_factory, invoke):
    directory = tmp_path_factory.mktemp("cli_plot_curves")
    config = directory / "map.yaml"
    config.write_text(EFFECTIVE_MAP)
    out = directory / "map.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    return out


def _stored_config(path):
    with h5py.File(path, "r") as f:
        text = f.attrs["config"]
    return text.decode() if isinstance(text, bytes) else str(text)


@pytest.fixture(scope="module")
def three_kinds(effective_map, tmp_path_factory):
    """Curves of all three kinds in (Omega, g) order -- the map's axes the other way round -- with a
    fold meeting a grazing and a cusp."""
    Omega = np.linspace(3.8, 4.2, 9)
    curves = [("fold", {"g": 25.0 + 5.0 * (Omega - 4.0), "Omega": Omega}),
              ("period_doubling", {"g": 22.0 + 3.0 * (Omega - 4.0), "Omega": Omega}),
              ("grazing", {"g": np.linspace(20.5, 27.5, 9), "Omega": np.full(9, 4.1)})]
    specials = [("fold_grazing", 2, {"g": 25.5, "Omega": 4.1}), ("cusp", 0, {"g": 24.0, "Omega": 3.8})]
    return write_curves(tmp_path_factory.mktemp("curves") / "curves.h5", ["Omega", "g"], curves, specials,
                        config=_stored_config(effective_map))


def test_curves_over_a_map_each_kind_named_in_the_legend(effective_map, three_kinds, tmp_path, invoke):
    from vrsweep import plot

    for var in ("R", "period", "impacts_per_period"):
        out = tmp_path / f"curves_{var}.png"
        result = invoke("plot", effective_map, three_kinds, "--var", var, "-o", out)
        assert result.exit_code == 0, result.output
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    figure = plot.plot([effective_map, three_kinds], var="period")
    ax = figure.axes[0]
    lines = {line.get_gid(): line for line in ax.get_lines() if line.get_gid()}
    fold = lines["curve_fold"]
    # The curves file lists (Omega, g); the map's x axis is g, so x is the file's g.
    np.testing.assert_array_equal(fold.get_xdata(), 25.0 + 5.0 * (np.linspace(3.8, 4.2, 9) - 4.0))
    np.testing.assert_array_equal(fold.get_ydata(), np.linspace(3.8, 4.2, 9))
    styles = {kind: (lines[f"curve_{kind}"].get_color(), str(lines[f"curve_{kind}"].get_linestyle()))
              for kind in ("fold", "period_doubling", "grazing")}
    assert len(set(styles.values())) == 3  # each kind its own style
    assert {"special_fold_grazing", "special_cusp"} <= set(lines)
    assert lines["special_fold_grazing"].get_xydata().tolist() == [[25.5, 4.1]]
    legend = " | ".join(text.get_text() for text in figure.legends[0].get_texts())
    for words in ("fold (saddle-node)", "period doubling", "grazing", "fold meets grazing", "cusp",
                  "theory (corrected): fold"):
        assert words in legend, legend
    assert ax.get_xlabel().startswith("fast forcing amplitude") and ax.get_ylabel().startswith("fast forcing frequency")
    assert "curves.h5" in plot.description(figure)


def test_curves_over_an_effective_map_add_the_theory_s_fold_curve(effective_map, three_kinds):
    from vrsweep import plot
    from vrsweep.analysis import theory

    figure = plot.plot([effective_map, three_kinds], var="R")
    ax = figure.axes[0]
    assert [c.get_gid() for c in ax.collections].count("analytic_hopf") == 1  # the small branch's Hopf too
    contours = [c for c in ax.collections if c.get_gid() == "analytic_fold"]
    assert len(contours) == 1
    vertices = np.concatenate([path.vertices for path in contours[0].get_paths() if len(path.vertices)])
    assert len(vertices) > 10
    from vrsweep.config import parse_config

    params = dict(parse_config(_stored_config(effective_map), "map").parameters)
    folds = theory.fold_curve(params, along="Omega", values=vertices[:, 1], within=(20.0, 28.0)).at
    # The contour interpolates on a 400 x 400 mesh over g in [20, 28]: within a mesh step of the fold.
    step = 8.0 / (400 - 1)
    assert np.all(np.nanmin(np.abs(folds - vertices[:, :1]), axis=1) < step)


def test_curves_must_be_in_the_plane_of_the_map(effective_map, tmp_path, invoke):
    other = write_curves(tmp_path / "g_e.h5", ["g", "e"], [("grazing", {"g": np.array([21.0, 22.0]),
                                                                           "e": np.array([0.6, 0.7])})])
    result = invoke("plot", effective_map, other, "-o", tmp_path / "x.png")
    assert result.exit_code == 2
    message = result.output.strip().splitlines()
    assert len(message) == 1, result.output
    assert "(g, e)" in message[0] and "(g, Omega)" in message[0] and "g_e.h5" in message[0], message[0]


def test_curves_usage_errors_exit_2(effective_map, three_kinds, tmp_path, invoke):
    original = write_curves(tmp_path / "original.h5", ["g", "Omega"],
                            [("fold", {"g": np.array([21.0, 22.0]), "Omega": np.array([3.9, 4.0])})],
                            model="original")
    for args, words in [
        ((three_kinds, effective_map), "curves files go after the map"),
        ((three_kinds,), "curves files go after the map"),
        ((effective_map, three_kinds, effective_map), "after a map come curves files only"),
        ((effective_map, three_kinds, "--kind", "response"), "--kind response does not take curves files"),
        ((effective_map, three_kinds, "--var", "R", "--amplitude"), "--amplitude"),
        ((effective_map, three_kinds, "--var", "no_such"), "--var no_such"),
        ((effective_map, original), "curves of the original model"),
    ]:
        result = invoke("plot", *args, "-o", tmp_path / "x.png")
        assert result.exit_code == 2, (args, result.output)
        assert words in result.output, (args, result.output)


def test_curves_figure_takes_the_figure_options(effective_map, three_kinds, tmp_path, invoke):
    from vrsweep import plot

    out = tmp_path / "options.png"
    result = invoke("plot", effective_map, three_kinds, "--no-title", "--size", "6,5", "--style", "ggplot",
                    "--vmin", "5", "--vmax", "30", "-o", out)
    assert result.exit_code == 0, result.output
    assert out.exists()
    figure = plot.plot([effective_map, three_kinds], title=False, size=(6, 5), vmin=5.0, vmax=30.0)
    assert tuple(figure.get_size_inches()) == (6.0, 5.0)
    assert figure._suptitle is None
    mesh = next(c for c in figure.axes[0].collections if hasattr(c, "norm") and c.get_array() is not None)
    assert (mesh.norm.vmin, mesh.norm.vmax) == (5.0, 30.0)
    integer = invoke("plot", effective_map, three_kinds, "--var", "period", "--vmax", "3", "-o", out)
    assert integer.exit_code == 2 and "--vmax" in integer.output


def test_curves_over_an_original_map_have_no_analytic_curves(tmp_path, invoke):
    from vrsweep import plot

    config = tmp_path / "original.yaml"
    config.write_text("sweep:\n  g: [10.0, 20.0, 30.0]\n  Delta: [1.0, 2.0, 3.0]\n"
                      "integration: {transient_periods: 1, measure_periods: 2, strobe_periods: 1}\n")
    sweep = tmp_path / "original.h5"
    assert invoke("run", config, "-o", sweep, "-q").exit_code == 0
    curves = write_curves(tmp_path / "fold_g_Delta.h5", ["g", "Delta"],
                          [("fold", {"g": np.array([12.0, 18.0, 25.0]), "Delta": np.array([1.2, 2.0, 2.8])})],
                          model="original", config=_stored_config(sweep))
    result = invoke("plot", sweep, curves, "--var", "impacts_per_period", "-o", tmp_path / "o.png")
    assert result.exit_code == 0, result.output
    ax = plot.plot([sweep, curves], var="impacts_per_period").axes[0]
    gids = {artist.get_gid() for artist in [*ax.get_lines(), *ax.collections]}
    assert "curve_fold" in gids and not any(str(gid).startswith("analytic") for gid in gids)
    moved = write_curves(tmp_path / "other_e.h5", ["Delta", "g"],
                         [("fold", {"g": np.array([12.0, 18.0]), "Delta": np.array([1.2, 2.0])})], model="original",
                         config=_stored_config(sweep).replace("e: 0.95", "e: 0.5"))
    refused = invoke("plot", sweep, moved, "-o", tmp_path / "o.png")
    assert refused.exit_code == 2 and "e = 0.5" in refused.output and "e = 0.95" in refused.output, refused.output


BRANCH_OPTIONS = {  # issue 35: each was ignored, the same figure drawn
    ("--kind", "map"): "--kind map: a branch file has one figure",
    ("--kind", "basin"): "--kind basin is for sweep results with x0 / v0 axes, not branch files",
    ("--at", "g=24"): "--at: a branch file has no axes to fix",
    ("--var", "x"): "--var x: a branch file's figure is R along the branch",
    ("--periods", "1:5"): "--periods is for trajectory files (vrsweep simulate), not branch files",
    ("--x", "Omega"): "--x Omega: a branch file is drawn against its continued parameter",
    ("--amplitude",): "--amplitude: a branch file's figure is the gain R",
    ("--log",): "--log/--linear: a branch file's figure chooses its scales",
    ("--linear",): "--log/--linear: a branch file's figure chooses its scales",
}


@pytest.mark.parametrize("option", sorted(BRANCH_OPTIONS), ids=" ".join)
def test_a_branch_file_refuses_the_options_it_cannot_honour(tmp_path, invoke, option):
    from damaged import one_line_error
    from handmade import write_branch_file

    path = write_branch_file(tmp_path / "branch.h5")
    assert invoke("plot", path, "-o", tmp_path / "plain.png").exit_code == 0
    line = one_line_error(invoke("plot", path, "-o", tmp_path / "figure.png", *option))
    assert line.startswith(f"Error: {BRANCH_OPTIONS[option]}"), line
    assert not (tmp_path / "figure.png").exists()


STYLE_SHEETS = {  # issue 35: each printed 16-300 lines of matplotlib warnings, and drew anyway
    "axes.facecolr: red\n": "line 1: 'axes.facecolr' is not a matplotlib setting",
    "# a comment\naxes.facecolor: notacolour\n": "line 2: axes.facecolor: 'notacolour' does not look like a color",
    "font.family: NoSuchFont\n": "line 1: font.family: no font 'NoSuchFont' is installed",
}


@pytest.mark.parametrize("sheet", sorted(STYLE_SHEETS))
def test_a_bad_style_sheet_is_one_line(tmp_path, invoke, sheet):
    from damaged import one_line_error
    from handmade import write_branch_file

    path = write_branch_file(tmp_path / "branch.h5")
    style = tmp_path / "bad.mplstyle"
    style.write_text(sheet)
    line = one_line_error(invoke("plot", path, "-o", tmp_path / "figure.png", "--style", style))
    assert line.startswith(f"Error: --style {style}: {STYLE_SHEETS[sheet]}"), line
    assert not (tmp_path / "figure.png").exists()


def test_a_good_style_sheet_draws_without_a_warning(tmp_path, invoke):
    from handmade import write_branch_file

    path = write_branch_file(tmp_path / "branch.h5")
    style = tmp_path / "good.mplstyle"
    style.write_text('font.family: serif  # a generic family\naxes.facecolor: "#eeeeee"\nlines.linewidth: 2\n')
    result = invoke("plot", path, "-o", tmp_path / "figure.png", "--style", style)
    assert result.exit_code == 0 and result.output.strip().splitlines() == [f"-> {tmp_path / 'figure.png'}"], \
        result.output


@pytest.mark.parametrize("limits", [dict(vmax=1e308), dict(vmin=-1e308), dict(vmin=-1e301, vmax=1e301),
                                    dict(vmax=float("nan")), dict(vmin=float("-inf"))])
def test_a_colour_scale_end_beyond_what_a_colour_bar_draws_is_one_line(limits):
    """Issue 35: --vmax 1e308 printed a page of overflow RuntimeWarnings and drew a wrong colour bar.
    Refused before the figure is made (the data is never looked at)."""
    from vrsweep.errors import UsageError
    from vrsweep.plot import curves_figure, map_figure

    for figure in (map_figure, curves_figure):
        args = (None,) if figure is map_figure else (None, [])
        with pytest.raises(UsageError, match=r"the end of a colour scale must be a finite number of magnitude at "
                                             r"most 1e\+300"):
            figure(*args, **limits)
