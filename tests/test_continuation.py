"""Hysteresis sweeps (issue 5): `continuation: up | down | both` on a sweep axis.

Run order of the lines, the `direction` dimension in the file, that each point really starts
from its predecessor's final state, that a line is the unit of resume and sharding, and the
shipped configs/hysteresis_effective.yaml: up and down differ in the bistable window and agree
where the analytic response has a single root.
"""

import shutil
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from vrsweep.analysis import theory
from vrsweep.cli import main
from vrsweep.config import load_config, parse_config
from vrsweep.errors import ConfigError
from vrsweep.execution.sweep import Grid, shuffled_lines

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
HYSTERESIS = CONFIGS / "hysteresis_effective.yaml"


def run(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


def grid_of(text):
    return Grid.from_config(parse_config(textwrap.dedent(text)))


def open_result(path):
    return xr.load_dataset(path, engine="h5netcdf")  # read whole and closed: no file left open


# --- config and run order -------------------------------------------------------------------------

def test_up_and_down_lines_run_in_increasing_and_decreasing_parameter_value():
    # The axis is listed decreasing on purpose: up means increasing g, not config order.
    grid = grid_of("""\
        sweep:
          g: {values: [3.0, 2.0, 1.0], continuation: up}
          Omega: [4.0, 5.0]
        """)
    g = grid.axis_values[0]
    assert grid.axis_names == ("g", "Omega")  # no direction axis for one-way continuation
    lines = grid.lines()
    assert lines.shape == (2, 3)  # one line per Omega, along g
    for line in lines:
        g_index, omega_index = np.unravel_index(line, grid.shape)
        assert g[g_index].tolist() == [1.0, 2.0, 3.0]
        assert len(set(omega_index.tolist())) == 1
    down = grid_of("""\
        sweep:
          g: {values: [3.0, 2.0, 1.0], continuation: down}
          Omega: [4.0, 5.0]
        """).lines()
    assert np.array_equal(down, lines[:, ::-1])


def test_both_adds_a_direction_axis_up_first():
    grid = grid_of("""\
        sweep:
          Omega: [4.0, 5.0]
          g: {start: 0.0, stop: 3.0, num: 4, continuation: both}
        """)
    assert grid.axis_names == ("Omega", "g", "direction")
    assert grid.axis_values[2].tolist() == [1.0, -1.0]
    lines = grid.lines()
    assert lines.shape == (4, 4)  # (2 Omega) x (2 directions) lines of 4 g values
    for line in lines:
        omega_index, g_index, direction_index = np.unravel_index(line, grid.shape)
        expected = [0, 1, 2, 3] if direction_index[0] == 0 else [3, 2, 1, 0]
        assert g_index.tolist() == expected
        assert len(set(direction_index.tolist())) == 1 and len(set(omega_index.tolist())) == 1
    # Every point of the grid is in exactly one line.
    assert sorted(lines.reshape(-1).tolist()) == list(range(grid.n_points))


def test_lines_are_never_split_between_shards():
    grid = grid_of("""\
        sweep:
          g: {start: 0.0, stop: 3.0, num: 4, continuation: both}
          Omega: [3.0, 4.0, 5.0]
        """)
    shards = [shuffled_lines(grid, k, 4) for k in range(4)]
    assert sorted(np.concatenate(shards).reshape(-1).tolist()) == list(range(grid.n_points))
    as_sets = {frozenset(line.tolist()) for line in grid.lines()}
    assert all(frozenset(line.tolist()) in as_sets for shard in shards for line in shard)


@pytest.mark.parametrize("text, field", [
    ("sweep: {g: {start: 0, stop: 1, num: 2, continuation: sideways}}", "sweep.g.continuation"),
    ("sweep: {g: {start: 0, stop: 1, num: 2, continuation: up}, Omega: {values: [4, 5], continuation: up}}",
     "sweep.Omega.continuation"),
])
def test_bad_continuation_is_a_config_error(text, field):
    with pytest.raises(ConfigError) as error:
        parse_config(text)
    assert field in str(error.value)


# --- the shipped hysteresis config ---------------------------------------------------------------

@pytest.fixture(scope="module")
def hysteresis(tmp_path_factory):
    """configs/hysteresis_effective.yaml run as shipped, through `vrsweep run` (a few seconds)."""
    out = tmp_path_factory.mktemp("hysteresis") / "hysteresis.h5"
    run("run", HYSTERESIS, "-o", out, "--quiet")
    return out


def analytic_roots(config, g):
    params = {name: config.parameters[name] for name in ("gamma", "alpha", "c", "omega0", "omega", "Omega")}
    return theory.fixed_points({**params, "g": g})


def test_the_file_has_a_direction_dimension(hysteresis):
    with h5py.File(hysteresis, "r") as f:
        assert f["direction"][()].tolist() == [1.0, -1.0]
        assert [dim[0].name for dim in f["R"].dims] == ["/g", "/direction"]
        assert [dim[0].name for dim in f["strobe_x"].dims] == ["/g", "/direction", "/strobe"]
        assert "up" in f["direction"].attrs["long_name"]
    data = open_result(hysteresis)
    assert data.R.dims == ("g", "direction")
    assert (data.status == 0).all()


def test_up_and_down_differ_in_the_bistable_window_and_agree_where_one_root(hysteresis):
    config = load_config(HYSTERESIS)
    data = open_result(hysteresis)
    up, down = data.sel(direction=1), data.sel(direction=-1)
    n_bistable = n_single = 0
    for g in data.g.values:
        roots = analytic_roots(config, g)
        r_up, r_down = float(up.R.sel(g=g)), float(down.R.sel(g=g))
        if len(roots) == 3 and roots.stable[0] and roots.stable[2]:
            # Up rides the small, barrier-free branch; down the impacting orbit.
            n_bistable += 1
            assert r_down > 1.1 * r_up, (g, r_up, r_down)  # 24 vs 9-16; 23.8 vs 19.4 next to the fold
            assert float(up.impacts_per_period.sel(g=g)) == 0.0
            assert float(down.impacts_per_period.sel(g=g)) == 1.0
            assert r_up == pytest.approx(roots.R[0] / config.parameters["c"], rel=0.02)  # gain of the small root
        elif len(roots) == 1:
            n_single += 1
            assert r_up == pytest.approx(r_down, rel=1e-9, abs=0), g
            assert int(up.period.sel(g=g)) == int(down.period.sel(g=g)) == 1
    assert n_bistable >= 10 and n_single >= 5


def test_each_point_starts_from_its_predecessors_final_state(hysteresis, tmp_path):
    """A point of an up line is the single-point run started from the previous point's final
    state, bit for bit (what `continuation` promises)."""
    data = open_result(hysteresis).sel(direction=1)
    g_previous, g_next = data.g.values[10], data.g.values[11]
    start = data.sel(g=g_previous)
    out = tmp_path / "single.h5"
    run("run", HYSTERESIS, "-o", out, "--quiet", "--set", f"g={float(g_next)!r}",
        "--set", f"initial.x={float(start.x_final)!r}", "--set", f"initial.v={float(start.v_final)!r}")
    single = open_result(out)
    for name in ("R", "R_err", "x_final", "v_final", "strobe_x"):
        assert np.array_equal(single[name].values, data[name].sel(g=g_next).values), name


def test_one_way_sweeps_are_the_halves_of_both(hysteresis, tmp_path):
    data = open_result(hysteresis)
    text = HYSTERESIS.read_text().replace("continuation: both", "continuation: down")
    config = tmp_path / "down.yaml"
    config.write_text(text)
    run("run", config, "-o", tmp_path / "down.h5", "--quiet")
    down = open_result(tmp_path / "down.h5")
    assert "direction" not in down.dims
    assert np.array_equal(down.R.values, data.R.sel(direction=-1).values)


def test_resume_reruns_a_whole_line(hysteresis, tmp_path):
    """A point of a line marked not done makes the whole line run again from its start; the
    result is the uninterrupted file."""
    out = tmp_path / "partial.h5"
    shutil.copy(hysteresis, out)
    with h5py.File(out, "r+") as f:
        done = f["done"][()]
        done[12, 0] = 0  # the middle of the up line
        f["done"][()] = done
        f["R"][12, 0] = np.nan
        f.attrs["vrsweep_complete"] = 0
    output = run("run", HYSTERESIS, "-o", out, "--resume")
    assert "25 of 50 points computed" in output  # the up line, all 25 points
    expected, resumed = open_result(hysteresis), open_result(out)
    for name in expected.data_vars:
        assert np.array_equal(expected[name].values, resumed[name].values, equal_nan=True), name


def test_shards_merge_to_the_whole_run(hysteresis, tmp_path):
    for k in range(2):
        run("run", HYSTERESIS, "-o", tmp_path / "part.h5", "--shard", f"{k}/2", "--quiet")
    run("merge", tmp_path / "part.shard0of2.h5", tmp_path / "part.shard1of2.h5", "-o", tmp_path / "merged.h5")
    expected, merged = open_result(hysteresis), open_result(tmp_path / "merged.h5")
    for name in expected.data_vars:
        assert np.array_equal(expected[name].values, merged[name].values, equal_nan=True), name
