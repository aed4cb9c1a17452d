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


def _unfinished(tmp_path, shape, strobe=16, finished=False):
    """An unfinished sweep file of the real variables: every other point done, and the points of a
    write in flight (values on disk, no flags yet) holding values that must not show."""
    from types import SimpleNamespace

    from vrsweep.store import ResultWriter, VariableSpec
    from vrsweep.store.variables import point_variables
    from vrsweep.store.writer import _write_selection

    variables = point_variables(SimpleNamespace(strobe_periods=strobe, lyapunov=False))
    specs = [VariableSpec(name, dtype, extra, attrs) for name, dtype, extra, attrs in variables]
    axes = [("g", np.linspace(0.0, 40.0, shape[0])), ("Omega", np.linspace(1.0, 8.0, shape[1]))]
    writer = ResultWriter.create(tmp_path / "unfinished.h5", axes, specs, {"config": "parameters: {}\n"})
    rng = np.random.default_rng(3)

    def values(idx):
        return {spec.name: (rng.integers(0, 3, (idx.size,) + spec.extra_shape).astype(spec.dtype)
                            if spec.dtype.kind == "i" else rng.random((idx.size,) + spec.extra_shape))
                for spec in specs}

    n = shape[0] * shape[1]
    if finished:
        writer.write_points(np.arange(n), values(np.arange(n)))
        writer.finish()
        return tmp_path / "unfinished.h5", None
    writer.write_points(np.arange(0, n, 2), values(np.arange(0, n, 2)))
    in_flight = np.arange(1, n, 6)
    for name, array in values(in_flight).items():
        _write_selection(writer._file[name], writer.grid_shape, in_flight, array)
    writer._file.flush()
    writer.close()
    return tmp_path / "unfinished.h5", in_flight


def test_an_unfinished_file_is_read_lazily_its_points_not_done_as_not_computed(tmp_path):
    """open_results read an unfinished file whole when it opened it (to mask the points not done):
    a 1000 x 1000 map mid-run took 570 MB and 2 s to open in a notebook, a finished one almost
    nothing. It is lazy again: each index reads only its part, masked with done, and gives what
    the file read whole gives, for every kind of index xarray hands on."""
    import tracemalloc

    path, in_flight = _unfinished(tmp_path, (300, 250))
    with h5py.File(path, "r") as f:
        done = f["done"][()].astype(bool)
        raw = {name: f[name][()] for name in ("R", "status", "n_steps", "strobe_x")}
        stored = sum(f[name].id.get_storage_size() for name in f if name not in ("g", "Omega"))
    expected = {name: np.where(done.reshape(done.shape + (1,) * (array.ndim - 2)), array,
                               np.nan if array.dtype.kind == "f" else -1).astype(array.dtype)
                for name, array in raw.items()}
    assert not done.reshape(-1)[in_flight].any() and not np.isnan(raw["R"].reshape(-1)[in_flight]).any()

    vrsweep.open_results(path).close()  # what the first open imports is not the file's
    tracemalloc.start()
    ds = vrsweep.open_results(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    try:
        # done, status and the checksums' scan, a few MiB at a time (13 MB for a 435 MB file), not the values
        assert peak < stored / 3, (peak, stored)
        assert not isinstance(ds.R.variable._data, np.ndarray)
        assert np.array_equal(ds.done.values, done.astype(np.int8))
        for name, array in expected.items():
            assert ds[name].dtype == array.dtype
            np.testing.assert_array_equal(ds[name].values, array)
        keys = [dict(g=7, Omega=3), dict(g=slice(3, 90, 4), Omega=slice(None, None, -3)),
                dict(g=[5, 1, 299], Omega=[0, 249, 2]), dict(g=xr.DataArray([4, 8, 9], dims="p"),
                                                             Omega=xr.DataArray([1, 2, 2], dims="p")),
                dict(Omega=-1), dict(strobe=slice(2, 5))]
        for key in keys:
            for name, array in expected.items():
                if "strobe" in key and name != "strobe_x":
                    continue
                whole = xr.DataArray(array, dims=ds[name].dims).isel(key)
                np.testing.assert_array_equal(ds[name].isel(key).values, whole.values, err_msg=f"{name} {key}")
        assert float(ds.R.sum()) == pytest.approx(np.nansum(expected["R"]), rel=1e-12)
    finally:
        ds.close()


@pytest.mark.parametrize("finished", [False, True])
def test_resuming_a_file_another_process_reads_names_the_reader(tmp_path, finished):
    """A Dataset holds its file until it is closed (an unfinished one too, now that it is lazy):
    --resume of a file that a notebook holds was told "is locked: another process (a run in
    progress?) has it open for writing; set HDF5_USE_FILE_LOCKING=FALSE to read it anyway", advice
    for a reader, given to a writer about a reader."""
    import subprocess
    import sys

    from vrsweep.store import ResultWriter

    path, _ = _unfinished(tmp_path, (4, 3), strobe=2, finished=finished)
    reader = subprocess.Popen([sys.executable, "-c", "import sys, vrsweep\nds = vrsweep.open_results(sys.argv[1])\n"
                               "print('open', flush=True)\nsys.stdin.read()\n", str(path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert reader.stdout.readline().strip() == "open"
        with pytest.raises(ResultFileError) as info:
            ResultWriter.open_for_resume(path, "parameters: {}\n")
    finally:
        reader.communicate("", timeout=60)
    assert str(info.value) == (f"{path} is open in another process (a Dataset of vrsweep.open_results or xarray, "
                               "a viewer): HDF5 cannot lock it for writing; close it there (ds.close()) and try again")
    ResultWriter.open_for_resume(path, "parameters: {}\n").close()  # the reader gone, it resumes
