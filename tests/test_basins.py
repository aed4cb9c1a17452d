"""Basins of attraction (issue 13): x0 / v0 sweep axes, attractor labels and their table.

The initial state as sweep axes must reproduce single runs started from `initial` bit for bit;
continuation along it is refused; the labelling is checked on synthetic stroboscopic tables
(cyclic shifts, the tolerance, period 0, failed points) and on the bistable hysteresis
example at g = 23 (effective model, gamma = alpha = 0.05): from rest a barrier-free orbit with
R = 10.1 and no impacts, from (0.9, 1.0), (-2, 0) or (0.5, -1.5) an impacting period-1 orbit
with R = 24.28 and one impact per period.
"""

import json
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from vrsweep.analysis import attractors
from vrsweep.analysis.attractors import (
    SAME_ORBIT_FACTOR, attractor_extras, attractor_extras_from_file, label_grid, label_slice,
)
from vrsweep.config import load_config, parse_config
from vrsweep.errors import ConfigError
from vrsweep.results import Status
from vrsweep.store.reading import derived_variables, load_results, point_variables
from vrsweep.store import merge_results

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
HYSTERESIS = CONFIGS / "hysteresis_effective.yaml"

SHORT = textwrap.dedent("""\
    model: effective
    parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
    integration: {transient_periods: 20, measure_periods: 20, strobe_periods: 8}
    """)


@pytest.fixture(scope="session")
def run_ok(invoke):
    """The helper below, with the shared helpers it calls (tests/conftest.py)."""
    def run_ok(*args):
        result = invoke(*args)
        assert result.exit_code == 0, result.output
        return result.output
    return run_ok


# --- config -------------------------------------------------------------------------------------

def test_x0_and_v0_are_axes_alone_or_with_parameters():
    config = parse_config(SHORT + "sweep: {g: [22, 23], x0: [-1, 0, 0.5], v0: {start: -1, stop: 1, num: 4}}\n")
    assert config.axis_names == ("g", "x0", "v0")
    assert config.shape == (2, 3, 4)
    assert set(config.grid_parameters()) == set(config.parameters)  # x0, v0 are no parameters
    assert parse_config(config.to_yaml()) == config
    assert "x: 0.99  # swept: see sweep.x0" in config.to_yaml()


def test_set_x0_fixes_the_initial_state_and_removes_its_axis():
    text = SHORT + "sweep: {x0: [-1, 0], v0: [0, 1]}\n"
    config = parse_config(text, overrides=("x0=0.25",))
    assert config.axis_names == ("v0",) and config.initial["x"] == 0.25
    config = parse_config(text, overrides=("initial.v=-0.5",))
    assert config.axis_names == ("x0",) and config.initial["v"] == -0.5


def test_continuation_along_x0_is_refused_with_file_and_line(tmp_path, invoke, write_config):
    path = write_config(tmp_path, SHORT + textwrap.dedent("""\
        sweep:
          g: [22, 23]
          x0: {start: -1, stop: 0, num: 3, continuation: up}
        """))
    with pytest.raises(ConfigError) as error:
        load_config(path)
    message = str(error.value)
    assert f"{path}:6: sweep.x0.continuation:" in message
    assert "initial state" in message
    result = invoke("validate", path)
    assert result.exit_code == 2 and "sweep.x0.continuation" in result.output


def test_continuation_along_a_parameter_with_x0_axes_is_allowed():
    config = parse_config(SHORT + "sweep: {g: {values: [22, 23], continuation: up}, v0: [0, 1]}\n")
    assert config.axes[0].continuation == "up"


def test_x0_above_the_barrier_is_refused():
    with pytest.raises(ConfigError, match=r"sweep.x0: every x0 must be at or below parameters.Delta = 1.0"):
        parse_config(SHORT + "sweep: {x0: [0, 1.01]}\n")
    # With x0 swept, initial.x is not used: above the barrier it does not matter.
    config = parse_config(SHORT.replace("Omega: 4.0}", "Omega: 4.0, Delta: 2}")
                          + "initial: {x: 5}\nsweep: {x0: [0, 1.5]}\n")
    assert config.axis_names == ("x0",)


def test_an_unknown_axis_name_lists_x0_and_v0():
    with pytest.raises(ConfigError, match=r"sweep.x: not a parameter .*allowed: .*x0, v0"):
        parse_config("sweep: {x: [0, 1]}")


# --- the initial state as axes reproduces single runs --------------------------------------------

@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory, run_ok, write_config):
    folder = tmp_path_factory.mktemp("basins")
    path = write_config(folder, SHORT + "sweep: {g: [22.5, 23.0], x0: [-2.0, 0.5], v0: [0.0, -1.5]}\n")
    out = folder / "sweep.h5"
    run_ok("run", path, "-o", out, "--quiet")
    return path, out


def test_initial_state_axes_reproduce_single_runs_bit_for_bit(small_sweep, tmp_path, run_ok):
    path, out = small_sweep
    data = xr.load_dataset(out, engine="h5netcdf")
    for g, x0, v0 in [(22.5, -2.0, 0.0), (23.0, 0.5, -1.5), (23.0, -2.0, -1.5)]:
        single = tmp_path / f"single_{g}_{x0}_{v0}.h5"
        # initial.x / initial.v fix the state the way `initial:` does (and drop the x0 / v0 axes).
        run_ok("run", path, "-o", single, "--quiet", "--set", f"g={g!r}", "--set", f"initial.x={x0!r}",
               "--set", f"initial.v={v0!r}")
        one = xr.load_dataset(single, engine="h5netcdf")
        assert one.R.dims == ()
        point = data.sel(g=g, x0=x0, v0=v0)
        for name in ("R", "R_err", "strobe_x", "strobe_v", "x_final", "v_final", "n_steps", "status"):
            assert np.array_equal(one[name].values, point[name].values), (name, g, x0, v0)


def test_initial_state_coordinates_have_units_and_long_names(small_sweep):
    data = xr.load_dataset(small_sweep[1], engine="h5netcdf")
    assert data.x0.attrs["units"] == "1" and data.x0.attrs["long_name"] == "initial position x(0)"
    assert data.v0.attrs["units"] == "1" and data.v0.attrs["long_name"] == "initial velocity x'(0)"
    assert data.attractor.dims == ("g", "x0", "v0")
    assert data.attractor_R.dims == ("g", "attractor_label")
    assert data.attractor.attrs["slice_axes"] == "g"


# --- labelling: synthetic stroboscopic tables ------------------------------------------------------

TOLERANCE = SAME_ORBIT_FACTOR * 1e-6


def synthetic(rows):
    """label_slice's input from rows of (status, period, strobe x list, strobe v list, R, R_err, x_min, x_max)."""
    n = len(rows)
    values = {name: [] for name in attractors.NEEDED}
    for status, period, xs, vs, R, R_err, x_min, x_max in rows:
        values["status"].append(status)
        values["period"].append(period)
        values["strobe_x"].append(xs)
        values["strobe_v"].append(vs)
        values["R"].append(R)
        values["R_err"].append(R_err)
        values["impacts_per_cycle"].append(1 if period else -1)
        values["impacts_per_period"].append(0.5)
        values["x_min"].append(x_min)
        values["x_max"].append(x_max)
    out = {name: np.array(v) for name, v in values.items()}
    assert out["strobe_x"].shape == (n, 6)
    return out


CYCLE_X, CYCLE_V = [0.3, -0.7], [1.1, 0.2]  # a period-2 cycle


def periodic(shift=0, dx=0.0, period=2, R=20.0):
    xs = [CYCLE_X[(k + shift) % 2] for k in range(6)]
    vs = [CYCLE_V[(k + shift) % 2] for k in range(6)]
    xs[-1] += dx
    return (Status.OK, period, xs, vs, R, 1e-9, -1.0, 1.0)


def chaotic(R, R_err=0.1, x_min=-1.0, x_max=1.0):
    return (Status.OK, 0, list(np.linspace(-1, 1, 6)), list(np.linspace(1, -1, 6)), R, R_err, x_min, x_max)


FAILED = (Status.MAX_STEPS, 0, [np.nan] * 6, [np.nan] * 6, np.nan, np.nan, np.nan, np.nan)


def test_cyclic_shifts_of_one_cycle_share_a_label():
    labels, groups = label_slice(synthetic([periodic(0), periodic(1), periodic(0), periodic(1)]), TOLERANCE)
    assert labels.tolist() == [0, 0, 0, 0]
    assert len(groups) == 1 and groups[0]["period"] == 2


def test_the_tolerance_is_tied_to_period_tolerance():
    # |x| <= 1 here, so the tolerance is absolute: half of it joins, twice it does not.
    inside, outside = 0.5 * TOLERANCE, 2.0 * TOLERANCE
    labels, _ = label_slice(synthetic([periodic(0), periodic(1, dx=inside), periodic(0, dx=outside)]), TOLERANCE)
    assert labels[0] == labels[1] != labels[2]
    # period_tolerance 1e-5 makes the tolerance ten times larger: the third joins too.
    labels, _ = label_slice(synthetic([periodic(0), periodic(1, dx=inside), periodic(0, dx=outside)]),
                            SAME_ORBIT_FACTOR * 1e-5)
    assert labels.tolist() == [0, 0, 0]


def test_the_same_first_sample_with_another_period_is_another_attractor():
    one = (Status.OK, 1, [0.3] * 6, [1.1] * 6, 20.0, 1e-9, -1.0, 1.0)
    labels, groups = label_slice(synthetic([periodic(0), periodic(0), one]), TOLERANCE)
    assert labels.tolist() == [0, 0, 1]
    assert [group["period"] for group in groups] == [2, 1]


def test_non_periodic_points_group_by_R_within_R_err_and_overlapping_x_range():
    rows = [chaotic(5.0), chaotic(5.1), chaotic(8.0),           # 5.1 is within hypot(0.1, 0.1) of 5.0; 8 is not
            chaotic(5.05, x_min=2.0, x_max=3.0),                 # same R, but on another part of the line
            FAILED, periodic(0, R=30.0)]
    labels, groups = label_slice(synthetic(rows), TOLERANCE)
    assert labels[0] == labels[1] == 0             # the biggest basin first
    assert labels[4] == -1                          # failed
    # Singletons are ordered by R: the period-2 orbit (R = 30) is last.
    assert labels[3] == 1 and labels[2] == 2 and labels[5] == 3
    assert [group["period"] for group in groups] == [0, 0, 0, 2]


def test_labels_are_numbered_by_basin_size_then_R():
    rows = [periodic(0, R=20.0), chaotic(3.0), chaotic(3.0), periodic(1, R=20.0), periodic(0, R=20.0)]
    labels, _ = label_slice(synthetic(rows), TOLERANCE)
    assert labels.tolist() == [0, 1, 1, 0, 0]
    rows = [chaotic(9.0), periodic(0, R=20.0), chaotic(3.0, x_min=5, x_max=6)]
    labels, _ = label_slice(synthetic(rows), TOLERANCE)
    assert labels.tolist() == [1, 2, 0]  # one point each: by R


def test_slices_are_labelled_apart_and_the_table_counts_their_points():
    # Axes (g: 2, x0: 3): slice g=0 holds a period-2 orbit twice and a failed point; slice g=1
    # two different attractors and the orbit again.
    grid = [[periodic(0), periodic(1), FAILED], [chaotic(4.0), periodic(0), chaotic(4.0)]]
    flat = synthetic([row for line in grid for row in line])
    variables = {name: array.reshape((2, 3) + array.shape[1:]) for name, array in flat.items()}
    axes = {"g": np.array([1.0, 2.0]), "x0": np.array([-1.0, 0.0, 0.5])}
    labels, table, counts = label_grid(axes, variables, 1e-6)
    assert labels.tolist() == [[0, 0, -1], [0, 1, 0]]
    assert counts.tolist() == [1, 2]
    assert table["points"].tolist() == [[2, 0], [2, 1]]
    np.testing.assert_allclose(table["fraction"][0], [2 / 3, np.nan])
    np.testing.assert_allclose(table["fraction"][1], [2 / 3, 1 / 3])
    assert table["period"].tolist() == [[2, -1], [0, 2]]
    assert table["x0"][1].tolist() == [-1.0, 0.0]  # the first start of each basin, in grid order
    # The same grid with x0 first: the same labels, transposed.
    swapped = {name: np.swapaxes(array, 0, 1) for name, array in variables.items()}
    labels_swapped, _, _ = label_grid({"x0": axes["x0"], "g": axes["g"]}, swapped, 1e-6)
    assert labels_swapped.T.tolist() == labels.tolist()


def test_a_slice_of_failed_points_has_no_attractor_and_a_filler_row():
    flat = synthetic([FAILED, FAILED])
    labels, table, counts = label_grid({"v0": np.array([0.0, 1.0])}, flat, 1e-6)
    assert labels.tolist() == [-1, -1] and int(counts) == 0
    assert table["points"].tolist() == [0] and table["period"].tolist() == [-1]
    extra, coords = attractor_extras({"v0": np.array([0.0, 1.0])}, flat, 1e-6)
    assert extra["attractor_R"][1] == ("attractor_label",) and coords["attractor_label"][0].tolist() == [0]


def test_a_grid_without_initial_state_axes_gets_no_labels():
    assert attractor_extras({"g": np.array([1.0, 2.0])}, {}, 1e-6) == ({}, {})


# --- the bistable hysteresis example at g = 23 ----------------------------------------------------

@pytest.fixture(scope="module")
def bistable(tmp_path_factory, run_ok, write_config):
    """configs/hysteresis_effective.yaml's parameters at g = 23, started from rest and from the
    three impacting starts of the issue (12 points, about a second)."""
    config = load_config(HYSTERESIS)
    parameters = ", ".join(f"{name}: {config.parameters[name]!r}" for name in ("gamma", "alpha", "Omega"))
    folder = tmp_path_factory.mktemp("bistable")
    path = write_config(folder, f"""\
        model: {config.model}
        parameters: {{{parameters}, g: 23.0}}
        sweep: {{x0: [-2.0, 0.0, 0.5, 0.9], v0: [-1.5, 0.0, 1.0]}}
        integration: {{transient_periods: 300, measure_periods: 100}}
        """)
    out = folder / "bistable.h5"
    run_ok("run", path, "-o", out, "--quiet")
    return out


def test_the_bistable_example_has_exactly_its_two_attractors(bistable):
    data = xr.load_dataset(bistable, engine="h5netcdf")
    assert int(data.attractor_count) == 2
    rest = int(data.attractor.sel(x0=0.0, v0=0.0))
    impacting = {int(data.attractor.sel(x0=x0, v0=v0)) for x0, v0 in [(0.9, 1.0), (-2.0, 0.0), (0.5, -1.5)]}
    assert impacting == {1 - rest}
    impacting = 1 - rest
    table = data.sel(attractor_label=rest)
    assert int(table.attractor_period) == 1 and int(table.attractor_impacts_per_cycle) == 0
    assert float(table.attractor_R) == pytest.approx(10.1, abs=0.05 + float(table.attractor_R_err))
    table = data.sel(attractor_label=impacting)
    assert int(table.attractor_period) == 1 and int(table.attractor_impacts_per_cycle) == 1
    assert float(table.attractor_R) == pytest.approx(24.28, abs=0.005 + float(table.attractor_R_err))
    assert float(data.attractor_fraction.sum()) == pytest.approx(1.0)
    # Every point of a basin is on its attractor: its R is the table's.
    for label in (rest, impacting):
        R = data.R.values[data.attractor.values == label]
        assert np.allclose(R, float(data.attractor_R.sel(attractor_label=label)), rtol=1e-6, atol=0)


def test_the_tolerance_picks_one_of_four_coexisting_orbits_of_the_original_model(tmp_path, run_ok):
    """gamma = 0.1, alpha = 0.2, g = 5, Omega = 4: runs from (0.99, 0.5) at three tolerances end on
    different period-1 orbits; a 6 x 6 basin sweep finds four, and each single run is one of them."""
    path = CONFIGS / "basins_g5_original.yaml"
    out = tmp_path / "basins.h5"
    small = tmp_path / "small.yaml"
    small.write_text(path.read_text().replace("num: 31", "num: 6"))
    run_ok("run", small, "-o", out, "--quiet", "--overwrite")
    data = xr.load_dataset(out, engine="h5netcdf")
    assert int(data.attractor_count) == 4
    assert data.attractor_period.values.tolist() == [1] * 4
    assert data.attractor_impacts_per_cycle.values.tolist() == [4] * 4
    R = np.sort(data.attractor_R.values)
    assert np.all(np.diff(R) > 1e-3)  # four distinct orbits, not one split by the tolerance
    reached = set()
    for rtol in ("1e-8", "1e-10", "1e-12"):
        single = tmp_path / f"single_{rtol}.h5"
        run_ok("run", path, "-o", single, "--quiet", "--set", "x0=0.99", "--set", "v0=0.5", "--set", f"rtol={rtol}")
        one = xr.load_dataset(single, engine="h5netcdf")
        assert int(one.period) == 1 and int(one.impacts_per_cycle) == 4
        nearest = int(np.argmin(np.abs(R - float(one.R))))
        assert abs(R[nearest] - float(one.R)) < 1e-6, (rtol, float(one.R), R)
        reached.add(nearest)
    assert len(reached) >= 2  # the tolerance changes which orbit a run from one start reaches


def test_info_prints_the_attractor_table(bistable, run_ok):
    text = run_ok("info", bistable)
    assert "attractors:  2 found" in text
    assert "period 1, R = 24.28" in text and "period 1, R = 10.11" in text
    summary = json.loads(run_ok("info", bistable, "--json"))
    rows = summary["attractors"][0]["attractors"]
    assert sorted(row["impacts_per_cycle"] for row in rows) == [0, 1]
    assert sum(row["points"] for row in rows) == 12


def test_basin_plot(bistable, tmp_path, run_ok):
    out = tmp_path / "basin.png"
    run_ok("plot", bistable, "--kind", "basin", "-o", out)
    assert out.stat().st_size > 10_000


def test_basin_plot_along_one_initial_state_axis_is_a_strip(tmp_path, run_ok, write_config):
    path = write_config(tmp_path, SHORT + "sweep: {v0: [-1.0, 0.0, 1.0]}\n")
    out = tmp_path / "v0.h5"
    run_ok("run", path, "-o", out, "--quiet")
    run_ok("plot", out, "-o", tmp_path / "v0.png")  # the default kind of a basin sweep
    assert (tmp_path / "v0.png").stat().st_size > 5_000


def test_basin_plot_of_a_sweep_without_initial_state_axes_is_a_usage_error(tmp_path, invoke, run_ok, write_config):
    path = write_config(tmp_path, SHORT + "sweep: {g: [22.5, 23.0]}\n")
    out = tmp_path / "g.h5"
    run_ok("run", path, "-o", out, "--quiet")
    result = invoke("plot", out, "--kind", "basin", "-o", tmp_path / "x.png")
    assert result.exit_code == 2 and "no x0 or v0 axis" in result.output


def test_basin_plot_asks_for_a_slice_and_takes_at(small_sweep, tmp_path, invoke, run_ok):
    result = invoke("plot", small_sweep[1], "--kind", "basin", "-o", tmp_path / "x.png")
    assert result.exit_code == 2 and "--at g=22.5" in result.output
    run_ok("plot", small_sweep[1], "--kind", "basin", "--at", "g=23", "-o", tmp_path / "x.png")


# --- shards: labels come from the merged point values alone -----------------------------------------

def test_labels_of_merged_shards_equal_the_single_runs(small_sweep, tmp_path, assert_same_result, run_ok):
    path, whole = small_sweep
    shards = []
    for index in range(2):
        run_ok("run", path, "--shard", f"{index}/2", "-o", tmp_path / "sweep.h5", "--quiet")
        shards.append(tmp_path / f"sweep.shard{index}of2.h5")
        assert "attractor" not in load_results(shards[-1])  # a shard sees part of a slice
    merged = tmp_path / "merged.h5"
    merge_results(shards, merged)
    assert_same_result(merged, whole)  # the labels and the table included
    results = load_results(merged)
    # The merge's labelling, from the file, is the single run's, from the point variables.
    tolerance = load_config(path).integration.period_tolerance
    with h5py.File(merged, "r") as f:
        from_file = attractor_extras_from_file(f, tolerance)
    for extra, coords in (attractor_extras({name: results[name].values for name in results.done.dims},
                                                    {name: results[name].values for name in point_variables(results)},
                                                    tolerance), from_file):
        single = load_results(whole)
        for name, (array, dims, _) in extra.items():
            assert np.array_equal(array, single[name].values, equal_nan=True), name
            assert dims == single[name].dims
        assert set(extra) == set(derived_variables(single)) - {"A_theory", "A_theory_stable",
                                                              "A_theory_max_stable", "g_res"}
        assert np.array_equal(coords["attractor_label"][0], single["attractor_label"].values)


def test_resume_adds_the_labels_to_a_finished_file_without_them(small_sweep, tmp_path, invoke, run_ok):
    path, whole = small_sweep
    for index in range(2):
        run_ok("run", path, "--shard", f"{index}/2", "-o", tmp_path / "sweep.h5", "--quiet")
    merged = tmp_path / "merged.h5"
    merge_results([tmp_path / f"sweep.shard{index}of2.h5" for index in range(2)], merged)
    with h5py.File(merged, "r+") as f:  # a file merged by a vrsweep that did not label
        for name in [n for n in f if n.startswith("attractor")]:
            # detached from their scales first, as a file that never had them holds its scales:
            # a deleted dataset left in a scale's REFERENCE_LIST is damage HDF5 trips over
            for i, dim in enumerate(f[name].dims):
                for scale in list(dim.values()):
                    f[name].dims[i].detach_scale(scale)
        for name in [n for n in f if n.startswith("attractor")]:
            del f[name]
        del f.attrs["vrsweep_attributes_sha256"]  # nor had checksums of attributes
    result = invoke("plot", merged, "--kind", "basin", "-o", tmp_path / "x.png")
    assert result.exit_code == 2 and "--resume" in result.output
    run_ok("run", path, "--resume", "-o", merged, "--quiet")
    labelled, single = load_results(merged), load_results(whole)
    for name in derived_variables(single):
        assert np.array_equal(labelled[name].values, single[name].values, equal_nan=True), name
