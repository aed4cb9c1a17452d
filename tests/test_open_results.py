"""``vrsweep.open_results``: every kind of file as a lazy xarray Dataset, and the CF attributes."""

import re

import h5py
import numpy as np
import pytest

import vrsweep
from vrsweep.errors import ResultFileError
from vrsweep.store.reading import file_kind, status_names
from vrsweep.results import FLAG_MEANINGS, Status

xr = pytest.importorskip("xarray")

GRID = """\
    sweep:
      g: {start: 0.0, stop: 30.0, num: 4}
      Omega: [4.0, 5.0]
    integration: {transient_periods: 3, measure_periods: 3, strobe_periods: 2}
    """

CF_KEYS = ("Conventions", "title", "history", "source", "references", "date_created")


@pytest.fixture(scope="module")
def files(tmp_path_factory, invoke, write_config):
    tmp = tmp_path_factory.mktemp("open_results")
    config = write_config(tmp, GRID)
    sweep = tmp / "sweep.h5"
    assert invoke("run", config, "-o", sweep, "--quiet").exit_code == 0
    shard = tmp / "sweep.shard0of2.h5"
    assert invoke("run", config, "-o", sweep, "--shard", "0/2", "--quiet").exit_code == 0
    other = tmp / "sweep.shard1of2.h5"
    assert invoke("run", config, "-o", sweep, "--shard", "1/2", "--quiet").exit_code == 0
    merged = tmp / "merged.h5"
    assert invoke("merge", shard, other, "-o", merged).exit_code == 0
    trajectory = tmp / "traj.h5"
    result = invoke("simulate", config, "--set", "g=5", "--set", "Omega=4", "--set", "transient_periods=2",
                    "--set", "measure_periods=2", "--compare", "effective", "-o", trajectory)
    assert result.exit_code == 0, result.output
    return dict(config=config, sweep=sweep, shard=shard, merged=merged, trajectory=trajectory)


def test_a_sweep_file_opens_with_its_coordinates_as_stored(files):
    with vrsweep.open_results(files["sweep"]) as ds:
        assert ds.R.dims == ("g", "Omega")
        np.testing.assert_array_equal(ds.g.values, np.linspace(0.0, 30.0, 4))
        np.testing.assert_array_equal(ds.Omega.values, [4.0, 5.0])
        assert ds.g.attrs["units"] and ds.Omega.attrs["long_name"]
        with h5py.File(files["sweep"], "r") as f:  # the same numbers h5py reads
            np.testing.assert_array_equal(ds.R.sel(Omega=5).values, f["R"][:, 1])
        assert ds.attrs["vrsweep_file"] == "sweep"


def test_variables_are_read_lazily(files):
    with vrsweep.open_results(files["sweep"]) as ds:
        # Not yet in memory: xarray holds a lazily indexed wrapper of the file's dataset.
        assert not isinstance(ds.R.variable._data, np.ndarray)
        assert ds.R.sel(g=10.0, Omega=4.0).values.shape == ()


def test_status_stays_int8_with_cf_flags_and_decodes_to_names(files):
    with vrsweep.open_results(files["shard"]) as ds:
        assert ds.attrs["vrsweep_file"] == "shard"
        assert ds.status.dtype == np.int8  # no fill-value masking: -1 = not computed stays -1
        assert ds.status.attrs["flag_meanings"] == FLAG_MEANINGS
        codes = ds.status.values
        assert set(np.unique(codes)) <= {int(Status.NOT_COMPUTED), int(Status.OK)}
        assert (codes == Status.NOT_COMPUTED).any() and (codes == Status.OK).any()
        names = status_names(ds.status)
        assert names.dims == ds.status.dims
        np.testing.assert_array_equal(names.values == "not_computed", codes == -1)
        np.testing.assert_array_equal(names.values == "ok", codes == 0)


def test_status_names_of_plain_codes():
    np.testing.assert_array_equal(status_names(np.array([0, 5, -1], dtype=np.int8)),
                                  ["ok", "non_finite", "not_computed"])
    assert status_names(np.array([42]))[0] == "unknown(42)"


def test_a_trajectory_opens_its_model_group_with_the_root_attributes(files):
    with vrsweep.open_results(files["trajectory"]) as traj:
        assert traj.attrs["vrsweep_group"] == "original" and traj.attrs["model"] == "original"
        assert traj.x.dims == ("time",) and traj.sizes["time"] > 0
        assert "config" in traj.attrs and traj.attrs["vrsweep_file"] == "trajectory"
        assert traj.attrs["status_name"] == "ok"
    with vrsweep.open_results(files["trajectory"], group="effective") as effective:
        assert effective.attrs["model"] == "effective"
    with vrsweep.open_results(files["trajectory"], group="slow_flow/state") as slow:
        assert "R" in slow and "theta" in slow


def test_wrong_group_and_wrong_files_are_clear_errors(files, tmp_path):
    with pytest.raises(ResultFileError, match=r"no group 'nope'; it has: original, effective"):
        vrsweep.open_results(files["trajectory"], group="nope")
    with pytest.raises(ResultFileError, match="sweep file, which has no groups"):
        vrsweep.open_results(files["sweep"], group="original")
    with pytest.raises(ResultFileError, match="not found"):
        vrsweep.open_results(tmp_path / "missing.h5")
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    with pytest.raises(ResultFileError, match="not an HDF5 file"):
        vrsweep.open_results(text)
    assert file_kind(files["merged"]) == "sweep"


@pytest.mark.parametrize("kind", ["sweep", "shard", "merged", "trajectory"])
def test_every_file_carries_the_cf_global_attributes(files, kind):
    with h5py.File(files[kind], "r") as f:
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    for key in CF_KEYS:
        assert key in attrs, key
    assert attrs["Conventions"] == "CF-1.10"
    assert "Roy" in attrs["references"] and "Gupta" in attrs["references"]
    assert attrs["source"].startswith(f"vrsweep {vrsweep.__version__} (numba ")
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", attrs["date_created"])
    for key in ("config", "vrsweep_version", "numba_version", "numpy_version", "created"):
        assert key in attrs, key  # the existing attributes stay
    lines = attrs["history"].splitlines()
    assert all(re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ vrsweep ", line) for line in lines), lines
    command = {"sweep": "vrsweep run ", "shard": "vrsweep run ", "trajectory": "vrsweep simulate "}
    if kind == "merged":  # the shard's own line, then the merge
        assert len(lines) == 2 and " vrsweep run " in lines[0] and " vrsweep merge " in lines[1]
    else:
        assert len(lines) == 1 and command[kind] in lines[0]
    if kind == "shard":
        assert "--shard 0/2" in lines[0]


def test_a_file_this_process_holds_open_is_not_called_corrupt(tmp_path):
    # open_results is lazy and keeps its file open; resuming into that file then failed in HDF5
    # ("already open for read-only") and was reported as "truncated or corrupt": a sound file a
    # user might delete. It says what holds it, and closing the Dataset is enough.
    config = {"model": "effective", "sweep": {"g": [1.0, 2.0]},
              "integration": {"transient_periods": 1, "measure_periods": 2, "strobe_periods": 1}}
    path = tmp_path / "sweep.h5"
    vrsweep.sweep(config, output=path, progress=False)
    opened = vrsweep.open_results(path)
    with pytest.raises(ResultFileError) as info:
        vrsweep.sweep(config, output=path, resume=True, progress=False)
    assert "is open in this process" in str(info.value) and "corrupt" not in str(info.value)
    opened.close()
    assert int(vrsweep.sweep(config, output=path, resume=True, progress=False).done.sum()) == 2
