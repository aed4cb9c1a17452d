"""The HDF5 store: layout, xarray compatibility, checkpoint/resume, errors, merge, atomic writes.

No numerics here: the store writes what it is given, so the tests feed it synthetic values that are
a known function of the flat point index.
"""

import inspect
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from damaged import reseal
from vrsweep.commands.options import OUTPUT_FLAGS
from vrsweep.errors import ResultFileError, UsageError
from vrsweep.store.reading import load_results, open_results
from vrsweep.results import FLAG_MEANINGS, FLAG_VALUES, Status
from vrsweep.store import (
    FORMAT_VERSION,
    ResultWriter,
    VariableSpec,
    StoredLayout,
    atomic_write,
    merge_results,
)


xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")

CONFIG = "parameters:\n  e: 0.95\nsweep:\n  g: {start: 0.0, stop: 4.0, num: 5}\n"
ATTRS = {"config": CONFIG, "vrsweep_version": "0.1.0", "numba_version": "0.60.0",
         "numpy_version": np.__version__}


def specs(n_roots=2):
    """The shape of a real run's variables: floats, an int counter, int8 status, an extra dim."""
    return [
        VariableSpec("R", np.float64, attrs={"units": "1", "long_name": "response R (eq3.3)"}),
        VariableSpec("Qs", np.float64, attrs={"units": "1", "long_name": "sine component Qs"}),
        VariableSpec("n_steps", np.int64, attrs={"units": "1", "long_name": "accepted steps"}),
        VariableSpec("roots", np.float64, (("root", n_roots),),
                     {"units": "1", "long_name": "amplitude roots"}),
        VariableSpec("status", np.int8, attrs={"long_name": "point status",
                                               "flag_values": FLAG_VALUES,
                                               "flag_meanings": FLAG_MEANINGS},
                     fill=Status.NOT_COMPUTED),
    ]


def values_for(idx, n_roots=2):
    """Deterministic values of the points with flat indices ``idx``."""
    idx = np.asarray(idx, dtype=np.int64)
    x = idx.astype(np.float64)
    return {
        "R": np.sin(x) + 2.0,
        "Qs": np.cos(x) * 1e-3,
        "n_steps": idx * 7 + 1,
        "roots": np.stack([x + k / 10 for k in range(n_roots)], axis=1),
        "status": (idx % 3).astype(np.int8),  # ok, max_steps, diverged
    }


AXES_2D = [("g", np.linspace(0.0, 4.0, 5)), ("Omega", np.array([4.0, 4.5, 5.0]))]
AXES_1D = [("g", np.linspace(0.0, 4.0, 5))]


def write_file(path, axes, *, points=None, finish=True, **kwargs):
    """Create a file over ``axes`` and write ``points`` (default: all) in two chunks."""
    writer = ResultWriter.create(path, axes, specs(), ATTRS, **kwargs)
    n = int(np.prod([len(v) for _, v in axes]))
    points = np.arange(n) if points is None else np.asarray(points)
    for chunk in np.array_split(points, 2):
        writer.write_points(chunk, values_for(chunk))
    if finish:
        writer.finish({"g_res": (np.array([1.0, 2.0, 3.0]), ("Omega",),
                                 {"units": "1", "long_name": "theory column"})}
                      if any(a[0] == "Omega" for a in axes) else {})
    else:
        writer.close()
    return path


# ---------------------------------------------------------------------------------------------
# Layout
# ---------------------------------------------------------------------------------------------


def test_layout_seen_through_h5py(tmp_path):
    path = write_file(tmp_path / "r.h5", AXES_2D, points=[0, 4, 7], finish=False)
    with h5py.File(path, "r") as f:
        # One 1-D dimension-scale coordinate per axis, with units and long_name.
        for name, values in AXES_2D:
            ds = f[name]
            assert ds.is_scale and ds.ndim == 1
            np.testing.assert_array_equal(ds[()], values)
            assert ds.attrs["units"] == "1" and ds.attrs["long_name"]
        assert f["root"].is_scale and list(f["root"][()]) == [0, 1]
        # Data variables over the axes in axis order, extra dims last, with units/long_name.
        for name in ("R", "Qs", "n_steps", "status", "done"):
            assert [d[0].name for d in f[name].dims] == ["/g", "/Omega"]
        assert [d[0].name for d in f["roots"].dims] == ["/g", "/Omega", "/root"]
        assert f["R"].attrs["units"] == "1" and f["R"].attrs["long_name"]
        # status: int8 with CF flags whose type is the variable's.
        status = f["status"]
        assert status.dtype == np.int8
        assert status.attrs["flag_values"].dtype == np.int8
        assert list(status.attrs["flag_values"]) == FLAG_VALUES
        assert status.attrs["flag_meanings"] == FLAG_MEANINGS
        assert status.fillvalue == -1 and "_FillValue" not in status.attrs
        # Floats: NaN fill value, declared; ints: fill value, not declared (xarray would mask).
        assert np.isnan(f["R"].fillvalue) and np.isnan(f["R"].attrs["_FillValue"])
        assert f["n_steps"].fillvalue == -1 and "_FillValue" not in f["n_steps"].attrs
        # Chunked, uncompressed, allocated up front (crash safety).
        assert f["R"].chunks is not None and f["R"].compression is None
        assert f["R"].id.get_create_plist().get_alloc_time() == h5py.h5d.ALLOC_TIME_EARLY
        # Root attributes.
        assert f.attrs["config"] == CONFIG
        assert f.attrs["vrsweep_version"] == "0.1.0"
        assert f.attrs["numba_version"] and f.attrs["numpy_version"]
        assert f.attrs["vrsweep_format_version"] == FORMAT_VERSION
        assert f.attrs["vrsweep_complete"] == 0
        assert f.attrs["created"].endswith("Z") and "T" in f.attrs["created"]
        assert list(f["done"][()].reshape(-1).nonzero()[0]) == [0, 4, 7]


def test_chunks_are_sized_for_large_grids(tmp_path):
    axes = [("g", np.linspace(0, 40, 400)), ("Omega", np.linspace(3, 6, 250))]  # 10^5 points
    writer = ResultWriter.create(tmp_path / "big.h5", axes, specs(), ATTRS)
    writer.close()
    with h5py.File(tmp_path / "big.h5", "r") as f:
        for name in ("R", "roots", "status"):
            ds = f[name]
            nbytes = np.prod(ds.chunks) * ds.dtype.itemsize
            # Small chunks: a sweep chunk writes shuffled points, each touching its own HDF5 chunk,
            # and rewriting (and checksumming) a big one per point made checkpoints slow.
            assert 1024 <= nbytes <= 16 * 1024, (name, ds.chunks)
            assert ds.chunks[1] == 250  # trailing axis whole: a C-order run hits few chunks
            assert 1 < np.prod(ds.shape) / np.prod(ds.chunks) < 1000


def test_xarray_opens_a_2_axis_file(tmp_path):
    path = write_file(tmp_path / "r.h5", AXES_2D, points=[0, 4, 7], finish=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no h5netcdf/xarray complaints about the layout
        ds = xr.open_dataset(path, engine="h5netcdf")
    with ds:
        assert dict(ds.sizes) == {"g": 5, "Omega": 3, "root": 2}
        assert list(ds.coords) == ["g", "Omega", "root"]
        assert list(ds["g"].dims) == ["g"] and ds["g"].attrs["units"] == "1"
        np.testing.assert_array_equal(ds["Omega"].values, AXES_2D[1][1])
        assert ds["R"].dims == ("g", "Omega")
        assert ds["roots"].dims == ("g", "Omega", "root")
        assert ds["R"].attrs["long_name"] == "response R (eq3.3)"
        # Not computed points: NaN for floats, -1 (int8, not float) for status.
        assert ds["status"].dtype == np.int8 and ds["done"].dtype == np.int8
        assert ds["n_steps"].dtype == np.int64
        R = ds["R"].values.reshape(-1)
        status = ds["status"].values.reshape(-1)
        expected = values_for([0, 4, 7])
        np.testing.assert_array_equal(R[[0, 4, 7]], expected["R"])
        assert np.isnan(np.delete(R, [0, 4, 7])).all()
        assert (np.delete(status, [0, 4, 7]) == Status.NOT_COMPUTED).all()
        np.testing.assert_array_equal(status[[0, 4, 7]], expected["status"])
        assert np.isnan(np.delete(ds["roots"].values.reshape(-1, 2), [0, 4, 7], axis=0)).all()
        assert list(ds["status"].attrs["flag_values"]) == FLAG_VALUES
        assert ds.attrs["config"] == CONFIG and ds.attrs["vrsweep_complete"] == 0
        assert ds.attrs["vrsweep_format_version"] == FORMAT_VERSION


def test_xarray_opens_a_1_axis_finished_file(tmp_path):
    path = write_file(tmp_path / "r.h5", AXES_1D)
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert dict(ds.sizes) == {"g": 5, "root": 2}
        assert ds["R"].dims == ("g",) and ds["roots"].dims == ("g", "root")
        np.testing.assert_array_equal(ds["R"].values, values_for(range(5))["R"])
        assert ds.attrs["vrsweep_complete"] == 1


def test_single_point_file_has_0d_variables(tmp_path):
    """A config without a sweep is one point: grid shape (), 0-d variables, flat index 0."""
    writer = ResultWriter.create(tmp_path / "one.h5", [], specs(), ATTRS)
    assert writer.grid_shape == () and writer.done_mask().shape == () and not writer.done_mask()
    writer.close()
    with xr.open_dataset(tmp_path / "one.h5", engine="h5netcdf") as ds:
        assert ds["R"].dims == () and np.isnan(ds["R"].values)
        assert ds["status"].values == Status.NOT_COMPUTED and ds["status"].dtype == np.int8
    writer = ResultWriter.open_for_resume(tmp_path / "one.h5", CONFIG)
    writer.write_points([0], values_for([0]))
    assert writer.done_mask()
    writer.finish()
    with xr.open_dataset(tmp_path / "one.h5", engine="h5netcdf") as ds:
        assert dict(ds.sizes) == {"root": 2}
        assert ds["R"].dims == () and ds["roots"].dims == ("root",)
        assert ds["R"].values == values_for([0])["R"][0]
        np.testing.assert_array_equal(ds["roots"].values, values_for([0])["roots"][0])
        assert ds["status"].values == 0 and ds["done"].values == 1
    result = StoredLayout.read(tmp_path / "one.h5")
    assert result.axes == {} and result.shape == () and result.complete


def test_finish_adds_derived_variables_over_new_dims(tmp_path):
    writer = ResultWriter.create(tmp_path / "r.h5", AXES_2D, specs(), ATTRS)
    writer.write_points(np.arange(15), values_for(np.arange(15)))
    writer.finish(
        {"g_res": (np.arange(3.0), ("Omega",), {"units": "1", "long_name": "eq3.4"}),
         "branch_R": (np.ones((5, 2)), ("g", "branch"), {"units": "1", "long_name": "eq2.28"})},
        coords={"branch": (np.array([1, 2], dtype=np.int32), {"long_name": "branch"})})
    with xr.open_dataset(tmp_path / "r.h5", engine="h5netcdf") as ds:
        assert ds["g_res"].dims == ("Omega",) and ds["branch_R"].dims == ("g", "branch")
        assert list(ds["branch"].values) == [1, 2]
    result = StoredLayout.read(tmp_path / "r.h5")
    assert result.derived_variables == ("g_res", "branch_R") and result.complete


def test_a_long_config_text_fits_in_an_attribute(tmp_path):
    config = "sweep:\n  g: [" + ", ".join(f"{x:.6f}" for x in np.linspace(0, 1, 20000)) + "]\n"
    assert len(config) > 64 * 1024  # past HDF5's compact attribute limit
    ResultWriter.create(tmp_path / "r.h5", AXES_1D, specs(), {**ATTRS, "config": config}).close()
    assert StoredLayout.read(tmp_path / "r.h5").attrs["config"] == config


def test_write_points_validates_its_input(tmp_path):
    writer = ResultWriter.create(tmp_path / "r.h5", AXES_1D, specs(), ATTRS)
    good = values_for([0, 1])
    with pytest.raises(ValueError, match="exactly"):
        writer.write_points([0, 1], {k: v for k, v in good.items() if k != "R"})
    with pytest.raises(ValueError, match="shape"):
        writer.write_points([0, 1, 2], good)
    with pytest.raises(ValueError, match="in \\[0, 5\\)"):
        writer.write_points([0, 5], good)
    with pytest.raises(ValueError, match="twice"):
        writer.write_points([1, 1], good)
    assert not writer.done_mask().any()
    writer.close()


# ---------------------------------------------------------------------------------------------
# Refusing, resuming, and reading bad files
# ---------------------------------------------------------------------------------------------


def test_create_refuses_an_existing_path(tmp_path, describe):
    path = write_file(tmp_path / "r.h5", AXES_1D)
    before = describe(path)
    with pytest.raises(UsageError) as info:
        ResultWriter.create(path, AXES_1D, specs(), ATTRS)
    message = str(info.value)
    assert str(path) in message and "overwrite=True" in message and "ResultWriter.open_for_resume" in message
    cli = str(info.value.reworded(OUTPUT_FLAGS))  # what vrsweep run says
    assert cli == f"output {path} already exists: pass --overwrite to replace it, or --resume to continue the run that wrote it"
    assert describe(path) == before
    ResultWriter.create(path, AXES_1D, specs(), ATTRS, overwrite=True).close()
    assert not load_results(path).done.any()


def test_create_in_a_missing_directory_creates_it(tmp_path, capsys):
    ResultWriter.create(tmp_path / "no" / "r.h5", AXES_1D, specs(), ATTRS).close()
    assert capsys.readouterr().err == f"Created the output folder {tmp_path / 'no'}\n"
    assert not load_results(tmp_path / "no" / "r.h5").done.any()


def test_resume_continues_to_a_file_identical_to_an_uninterrupted_run(tmp_path, assert_same_result):
    full = write_file(tmp_path / "full.h5", AXES_2D)
    partial = write_file(tmp_path / "part.h5", AXES_2D, points=[1, 2, 3, 9], finish=False)
    writer = ResultWriter.open_for_resume(partial, CONFIG)
    done = writer.done_mask()
    assert done.shape == (5, 3) and list(np.flatnonzero(done)) == [1, 2, 3, 9]
    todo = np.flatnonzero(~done)
    writer.write_points(todo, values_for(todo))
    writer.finish({"g_res": (np.array([1.0, 2.0, 3.0]), ("Omega",),
                             {"units": "1", "long_name": "theory column"})})
    assert_same_result(full, partial)


@settings(max_examples=40, deadline=None)
@given(shape=st.lists(st.integers(1, 7), min_size=1, max_size=3), data=st.data())
def test_points_written_as_slabs_or_as_points_give_the_same_file(tmp_path_factory, shape, data):
    """writer._write_selection writes a chunk's points as a slab of rows (read, updated, written
    back) or as an HDF5 point selection, by their share of the slab: both give every dataset the
    same values, whatever the points (some of the grid's or all), their chunks and what the file
    held before (the earlier chunks, as on a resume)."""
    from vrsweep.store import writer as writer_module

    n = int(np.prod(shape))
    points = data.draw(st.permutations(range(n)))[:data.draw(st.integers(1, n))]
    cuts = sorted(data.draw(st.lists(st.integers(0, n), max_size=4)))
    chunks = [chunk for chunk in np.split(np.array(points, dtype=np.int64), cuts) if chunk.size]
    axes = [(f"a{k}", np.arange(float(size))) for k, size in enumerate(shape)]
    folder = tmp_path_factory.mktemp("slabs")
    contents = []
    for share in (0.0, np.inf):  # every write a slab; every write points
        writer_module.SLAB_WRITE_SHARE = share
        try:
            path = folder / f"share_{share}.h5"
            writer = ResultWriter.create(path, axes, specs(), ATTRS)
            for chunk in chunks:
                writer.write_points(chunk, values_for(chunk))
            writer.close()
        finally:
            writer_module.SLAB_WRITE_SHARE = 1 / 16
        with h5py.File(path, "r") as f:
            contents.append({name: f[name][()] for name in ("R", "Qs", "n_steps", "roots", "status", "done")})
    for name in contents[0]:
        np.testing.assert_array_equal(contents[0][name], contents[1][name], err_msg=name)
    done = contents[0]["done"].reshape(-1)
    assert set(np.flatnonzero(done)) == {point for chunk in chunks for point in chunk}
    written = np.flatnonzero(done)
    np.testing.assert_array_equal(contents[0]["roots"].reshape(n, -1)[written], values_for(written)["roots"])


def test_resume_refuses_a_foreign_config(tmp_path):
    path = write_file(tmp_path / "r.h5", AXES_1D, finish=False)
    other = CONFIG.replace("0.95", "0.9")
    with pytest.raises(ResultFileError) as info:
        ResultWriter.open_for_resume(path, other)
    message = str(info.value)
    assert "different config" in message and "pass overwrite=True" in message and str(path) in message
    assert "; pass --overwrite to replace it" in str(info.value.reworded(OUTPUT_FLAGS))
    assert "line 2" in message and "0.95" in message and "\n" not in message


def test_resume_refuses_another_shard(tmp_path):
    owned = np.zeros(5, bool)
    owned[::2] = True
    writer = ResultWriter.create(tmp_path / "s.h5", AXES_1D, specs(), {**ATTRS, "shard": "1/2"},
                                 owned_mask=owned)
    with pytest.raises(ValueError, match="does not own"):
        writer.write_points([1], values_for([1]))
    writer.close()
    ResultWriter.open_for_resume(tmp_path / "s.h5", CONFIG, expected_shard="1/2").close()
    with pytest.raises(ResultFileError, match="shard 1/2, not 2/2"):
        ResultWriter.open_for_resume(tmp_path / "s.h5", CONFIG, expected_shard="2/2")
    with pytest.raises(ResultFileError, match="shard 1/2"):
        ResultWriter.open_for_resume(tmp_path / "s.h5", CONFIG)


def one_line_error(path, *, resume=False):
    with pytest.raises(ResultFileError) as info:
        if resume:
            ResultWriter.open_for_resume(path, CONFIG)
        else:
            open_results(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    return message


def test_missing_file(tmp_path):
    assert "not found" in one_line_error(tmp_path / "nope.h5")
    assert "does not exist" in one_line_error(tmp_path / "nope.h5", resume=True)


def test_not_an_hdf5_file(tmp_path):
    (tmp_path / "notes.h5").write_text("hello\n")
    assert "not an HDF5 file" in one_line_error(tmp_path / "notes.h5")
    (tmp_path / "empty.h5").write_bytes(b"")
    assert "empty" in one_line_error(tmp_path / "empty.h5")
    assert "directory" in one_line_error(tmp_path)


def test_hdf5_but_not_a_vrsweep_file(tmp_path):
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = np.arange(3)
    for resume in (False, True):
        message = one_line_error(tmp_path / "other.h5", resume=resume)
        assert "not a vrsweep results file" in message


def test_newer_format_version(tmp_path):
    path = write_file(tmp_path / "r.h5", AXES_1D)
    with h5py.File(path, "r+") as f:
        f.attrs["vrsweep_format_version"] = np.int32(FORMAT_VERSION + 1)
    for resume in (False, True):
        message = one_line_error(path, resume=resume)
        assert f"newer vrsweep (format {FORMAT_VERSION + 1}" in message and "upgrade" in message


@pytest.mark.parametrize("fraction", [0.3, 0.9])
def test_truncated_file(tmp_path, fraction):
    path = write_file(tmp_path / "r.h5", AXES_2D)
    size = os.path.getsize(path)
    with open(path, "r+b") as handle:
        handle.truncate(int(size * fraction))
    for resume in (False, True):
        assert "truncated or corrupt" in one_line_error(path, resume=resume)


def test_a_file_being_written_is_reported_as_locked(tmp_path):
    if os.environ.get("HDF5_USE_FILE_LOCKING", "").upper() in ("FALSE", "0"):
        pytest.skip("file locking disabled in this environment")
    path = write_file(tmp_path / "r.h5", AXES_1D, finish=False)
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys
            from vrsweep.store import ResultWriter
            w = ResultWriter.open_for_resume({str(path)!r}, {CONFIG!r})
            print("open", flush=True)
            sys.stdin.readline()
        """)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "open"
        try:
            open_results(path)
        except ResultFileError as error:
            assert "locked" in str(error) and "HDF5_USE_FILE_LOCKING" in str(error)
        else:
            pytest.skip("this file system does not support locks")
    finally:
        holder.kill()
        holder.wait()


# ---------------------------------------------------------------------------------------------
# Crash safety: kill -9 while writing
# ---------------------------------------------------------------------------------------------

GRID = [("g", np.linspace(0.0, 1.0, 60)), ("Omega", np.linspace(3.0, 6.0, 50))]  # 3000 points
CHUNK = 25

# The child imports only numpy and the store (not this module: xarray and pytest are slow to
# import); it gets values_for's source so parent and child agree on every value.
CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    from vrsweep.store import ResultWriter
    CONFIG, CHUNK = {config!r}, {chunk}
""").format(config=CONFIG, chunk=CHUNK) + inspect.getsource(values_for) + textwrap.dedent("""
    path, pause = sys.argv[1], sys.argv[2] == "pause"
    writer = ResultWriter.open_for_resume(path, CONFIG)
    order = np.random.default_rng(1).permutation(writer.n_points)  # scattered, like a shard
    for k in range(0, writer.n_points, CHUNK):
        idx = order[k:k + CHUNK]
        writer.write_points(idx, values_for(idx))
        print(k // CHUNK, flush=True)
        if pause:
            sys.stdin.readline()
""")


def chunks_of_child(n_chunks):
    order = np.random.default_rng(1).permutation(3000)
    return [order[k * CHUNK:(k + 1) * CHUNK] for k in range(n_chunks)]


def check_resumed(path, reported):
    """After a kill: the file opens for resume, every reported chunk is done, every done point
    holds its values, and the rest is still fill, except perhaps the chunk in flight (its values
    may be on disk without its done flags: it will be recomputed)."""
    writer = ResultWriter.open_for_resume(path, CONFIG)
    done = writer.done_mask().reshape(-1)
    writer.close()
    for chunk in chunks_of_child(reported):
        assert done[chunk].all()
    assert done.sum() <= (reported + 1) * CHUNK  # at most the chunk in flight beyond them
    result = load_results(path)
    points = np.flatnonzero(done)
    expected = values_for(points)
    for name, values in expected.items():
        stored = result[name].values.reshape((3000,) + values.shape[1:])
        np.testing.assert_array_equal(stored[points], values)
    untouched = ~done
    untouched[chunks_of_child(reported + 1)[-1]] = False
    assert np.isnan(result["R"].values.reshape(-1)[untouched]).all()
    assert (result["status"].values.reshape(-1)[untouched] == Status.NOT_COMPUTED).all()
    return done


def test_kill_9_between_chunks_then_resume(tmp_path, assert_same_result):
    path = tmp_path / "ckpt.h5"
    ResultWriter.create(path, GRID, specs(), ATTRS).close()
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(path), "pause"],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        for expected in range(3):
            assert child.stdout.readline().strip() == str(expected)
            if expected < 2:
                child.stdin.write("\n")
                child.stdin.flush()
        os.kill(child.pid, signal.SIGKILL)  # blocked after chunk 2: nothing in flight
        child.wait()
    finally:
        if child.poll() is None:
            child.kill()
    done = check_resumed(path, reported=3)
    assert done.sum() == 3 * CHUNK

    # Resume to the end: identical to a file written in one go.
    writer = ResultWriter.open_for_resume(path, CONFIG)
    todo = np.flatnonzero(~writer.done_mask())
    writer.write_points(todo, values_for(todo))
    writer.finish()
    reference = ResultWriter.create(tmp_path / "ref.h5", GRID, specs(), ATTRS)
    reference.write_points(np.arange(3000), values_for(np.arange(3000)))
    reference.finish()
    assert_same_result(path, tmp_path / "ref.h5")


@pytest.mark.parametrize("delay", [0.0, 0.01, 0.03, 0.07])
def test_kill_9_at_any_moment_loses_at_most_the_chunk_in_flight(tmp_path, delay):
    path = tmp_path / "ckpt.h5"
    ResultWriter.create(path, GRID, specs(), ATTRS).close()
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(path), "run"],
                             stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "0"  # writing is under way
        time.sleep(delay)
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
        reported = 1 + len(child.stdout.read().split())
    finally:
        if child.poll() is None:
            child.kill()
    check_resumed(path, reported)


# ---------------------------------------------------------------------------------------------
# Merge
# ---------------------------------------------------------------------------------------------


def owned_masks(n_shards, shape):
    """Interleaved ownership, as a cost-balanced sharding would give."""
    flat = np.arange(int(np.prod(shape)))
    return [(flat % n_shards == i).reshape(shape) for i in range(n_shards)]


def write_shards(tmp_path, n_shards=3, axes=AXES_2D, skip=()):
    shape = tuple(len(v) for _, v in axes)
    paths = []
    for i, owned in enumerate(owned_masks(n_shards, shape)):
        path = tmp_path / f"shard{i}.h5"
        points = np.flatnonzero(owned)
        points = np.array([p for p in points if p not in skip], dtype=np.int64)
        write_file(path, axes, points=points, owned_mask=owned,
                   finish=len(points) == owned.sum())
        with h5py.File(path, "r+") as f:  # label as the sweep would (before any resume)
            f.attrs["shard"] = f"{i + 1}/{n_shards}"
        reseal(path)  # as the sweep's writer seals its labels (store/sealing.py)
        paths.append(path)
    return paths


def test_merge_of_three_shards_equals_a_single_run(tmp_path, assert_same_result):
    import vrsweep.store.merge

    assert vrsweep.store.merge.merge_results is merge_results  # the package re-exports it
    single = write_file(tmp_path / "single.h5", AXES_2D)
    shards = write_shards(tmp_path)
    report = merge_results(shards, tmp_path / "merged.h5")
    assert report.complete and report.n_done == 15 and report.n_duplicated == 0
    assert "15 of 15" in str(report)
    assert_same_result(single, tmp_path / "merged.h5")
    with xr.open_dataset(tmp_path / "merged.h5", engine="h5netcdf") as ds:
        assert "shard" not in ds.attrs and "owned" not in ds and ds.attrs["vrsweep_complete"] == 1


def test_merge_of_single_point_shards(tmp_path, assert_same_result):
    single = tmp_path / "single.h5"
    w = ResultWriter.create(single, [], specs(), ATTRS)
    w.write_points([0], values_for([0]))
    w.finish()
    merge_results([single], tmp_path / "merged.h5")
    assert_same_result(single, tmp_path / "merged.h5")


def test_merge_refuses_missing_points(tmp_path):
    shards = write_shards(tmp_path)
    with pytest.raises(ResultFileError) as info:
        merge_results(shards[:2], tmp_path / "merged.h5")
    message = str(info.value)
    assert "5 of 15 points are missing" in message
    assert "g=0, Omega=5" in message  # flat index 2: the first point of shard 3/3
    assert "belong to no shard given" in message and "1/3, 2/3" in message
    assert not (tmp_path / "merged.h5").exists()


def test_merge_names_an_unfinished_shard_and_can_write_a_resumable_partial_file(tmp_path, assert_same_result):
    shards = write_shards(tmp_path, skip=(4, 7))  # shard 2/3 was killed before two of its points
    with pytest.raises(ResultFileError) as info:
        merge_results(shards, tmp_path / "merged.h5")
    message = str(info.value)
    assert "2 of 15 points are missing" in message
    assert f"2 (g=1, Omega=4.5; g=2, Omega=4.5) owned by shard 2/3 ({shards[1]}, which finished 3 of its 5 points" in message
    assert "resume it with ResultWriter.open_for_resume" in message and "pass allow_missing=True" in message
    worded = str(info.value.reworded(OUTPUT_FLAGS))  # what vrsweep merge says
    assert "resume it with --resume" in worded and "pass --allow-missing to write" in worded

    report = merge_results(shards, tmp_path / "merged.h5", allow_missing=True)
    assert not report.complete and report.n_missing == 2 and "2 point(s) missing" in str(report)
    result = load_results(tmp_path / "merged.h5")
    assert result.attrs["vrsweep_complete"] == 0 and result.done.sum() == 13
    writer = ResultWriter.open_for_resume(tmp_path / "merged.h5", CONFIG)
    writer.write_points([4, 7], values_for([4, 7]))
    writer.finish({"g_res": (np.array([1.0, 2.0, 3.0]), ("Omega",),
                             {"units": "1", "long_name": "theory column"})})
    assert_same_result(write_file(tmp_path / "single.h5", AXES_2D), tmp_path / "merged.h5")


def test_merge_of_unfinished_whole_runs_says_no_file_has_the_missing_points(tmp_path):
    partial = write_file(tmp_path / "partial.h5", AXES_2D, points=range(12), finish=False)
    with pytest.raises(ResultFileError) as info:
        merge_results([partial], tmp_path / "merged.h5")
    message = str(info.value)
    assert "3 of 15 points are missing" in message
    assert "3 (g=4, Omega=4; g=4, Omega=4.5; g=4, Omega=5) were computed by none of the files given" in message
    assert not (tmp_path / "merged.h5").exists()


def test_merge_names_a_foreign_shard(tmp_path):
    shards = write_shards(tmp_path)
    with h5py.File(shards[1], "r+") as f:
        f.attrs["config"] = CONFIG.replace("num: 5", "num: 6")
    reseal(shards[1])  # a shard of another run, not a damaged one
    with pytest.raises(ResultFileError) as info:
        merge_results(shards, tmp_path / "merged.h5")
    message = str(info.value)
    assert str(shards[1]) in message and "different config" in message
    assert str(shards[0]) in message.split("than", 1)[1]  # the reference is a good shard


def test_one_file_given_twice_is_one_shard_read_once(tmp_path, assert_same_result):
    # As `merge a.h5 ./a.h5 b.h5 c.h5`, a glob and a name, or a link: it was counted as two shards
    # ("merged 4 shard(s)") and its points as "computed by more than one shard".
    single = write_file(tmp_path / "single.h5", AXES_2D)
    shards = write_shards(tmp_path)
    link = tmp_path / "link.h5"
    link.symlink_to(shards[0])
    again = [shards[0], tmp_path / "." / shards[0].name, link, shards[1], shards[2], shards[1]]
    report = merge_results(again, tmp_path / "merged.h5")
    assert report.complete and report.n_done == 15 and report.n_duplicated == 0
    assert [path for path, _, _ in report.shards] == [os.fspath(p) for p in shards]
    assert report.warnings[:2] == [f"{shards[0]} given 3 times (read once)", f"{shards[1]} given 2 times (read once)"]
    assert "merged 3 shard(s)" in str(report)
    assert_same_result(single, tmp_path / "merged.h5")


def test_merge_accepts_identical_duplicates_and_rejects_conflicts(tmp_path, assert_same_result):
    shards = write_shards(tmp_path)
    single = write_file(tmp_path / "single.h5", AXES_2D)  # every point, identical values
    report = merge_results(shards + [single], tmp_path / "merged.h5")
    assert report.n_duplicated == 15 and report.complete
    assert_same_result(single, tmp_path / "merged.h5")

    with h5py.File(shards[2], "r+") as f:
        f["R"][0, 2] = 99.0  # flat index 2 belongs to shard 3/3
    with pytest.raises(ResultFileError) as info:
        merge_results(shards + [single], tmp_path / "merged2.h5")
    message = str(info.value)
    assert "g=0, Omega=5" in message and "different values of R" in message
    assert str(shards[2]) in message and str(single) in message
    assert not (tmp_path / "merged2.h5").exists()


def test_merge_keeps_the_first_derived_variables_and_says_if_others_differ(tmp_path):
    shards = write_shards(tmp_path)
    assert merge_results(shards, tmp_path / "merged.h5").warnings == []
    # Shard 2 holds g_res stored another way (contiguous, no checksum) but with the same values:
    # its stored bytes differ, its values do not.
    with h5py.File(shards[1], "r+") as f:
        attrs = dict(f["g_res"].attrs)
        f["g_res"].dims[0].detach_scale(f["Omega"])
        del f["g_res"]
        ds = f.create_dataset("g_res", data=np.array([1.0, 2.0, 3.0]))
        ds.dims[0].attach_scale(f["Omega"])
        for key in ("units", "long_name"):
            ds.attrs[key] = attrs[key]
    reseal(shards[1])
    assert merge_results(shards, tmp_path / "merged2.h5").warnings == []
    # Shard 3's differ: kept from the first shard, with a warning naming both.
    with h5py.File(shards[2], "r+") as f:
        f["g_res"][1] = 2.5
    report = merge_results(shards, tmp_path / "merged3.h5")
    assert report.warnings == [f"derived variables of {shards[2]} differ from {shards[0]}; "
                               f"kept those of {shards[0]}"]
    assert list(load_results(tmp_path / "merged3.h5")["g_res"].values) == [1.0, 2.0, 3.0]


def test_merge_stops_when_asked_and_leaves_nothing(tmp_path):
    """``stop`` is called before every read of a shard; what it raises ends the merge, and the
    temporary file of the output is removed (the CLI's SIGINT/SIGTERM)."""
    shards = write_shards(tmp_path)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    reads = []

    def stop():
        reads.append(1)
        if len(reads) > 10:  # 3 shards opened, 3 done masks read: now it is writing
            assert len(list(out_dir.glob(".merged.h5.*.tmp"))) == 1
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        merge_results(shards, out_dir / "merged.h5", stop=stop)
    assert list(out_dir.iterdir()) == []


def test_merge_refuses_a_shard_replaced_while_it_is_merged(tmp_path):
    """Shards are reopened for every block: one replaced in between (a resumed or re-run shard) is
    an error naming it, not a mix of two files."""
    shards = write_shards(tmp_path)
    reads = []

    def replace_shard_1_when_writing_starts():
        reads.append(1)
        if len(reads) == 7:  # after the 3 opens and 3 done masks
            copy = tmp_path / "copy.h5"
            copy.write_bytes(shards[1].read_bytes())
            os.replace(copy, shards[1])  # the same bytes, another file

    with pytest.raises(ResultFileError, match=re.escape(f"{shards[1]} was changed or replaced while")):
        merge_results(shards, tmp_path / "merged.h5", stop=replace_shard_1_when_writing_starts)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in shards)


def test_merge_refuses_to_overwrite_and_reports_bad_shards(tmp_path):
    shards = write_shards(tmp_path)
    (tmp_path / "merged.h5").write_text("precious")
    with pytest.raises(UsageError, match="pass overwrite=True to replace it"):
        merge_results(shards, tmp_path / "merged.h5")
    assert (tmp_path / "merged.h5").read_text() == "precious"
    merge_results(shards, tmp_path / "merged.h5", overwrite=True)
    with pytest.raises(UsageError, match="one of the shards"):
        merge_results(shards, shards[0], overwrite=True)
    (tmp_path / "junk.h5").write_text("junk")
    with pytest.raises(ResultFileError, match="junk.h5 is not an HDF5 file"):
        merge_results(shards + [tmp_path / "junk.h5"], tmp_path / "m3.h5")


AXES_3D = [("g", np.linspace(0.0, 6.0, 7)), ("Omega", np.array([4.0, 4.5, 5.0])),
           ("c", np.array([0.1, 0.2, 0.3, 0.4]))]


@pytest.fixture
def small_blocks(monkeypatch):
    """HDF5 chunks of 64 bytes and merge blocks of 160: an 84-point grid then takes many blocks,
    chunks cut axes, and blocks fix leading axes, as a large grid would."""
    import vrsweep.store.layout
    import vrsweep.store.merge

    monkeypatch.setattr(vrsweep.store.layout._chunk_shape, "__defaults__", (64,))
    monkeypatch.setattr(vrsweep.store.merge, "BLOCK_BYTES", 160)


def test_merge_in_many_blocks_equals_a_single_run(tmp_path, small_blocks, assert_same_result):
    single = write_file(tmp_path / "single.h5", AXES_3D)
    with h5py.File(single, "r") as f:
        assert f["R"].chunks == (1, 2, 4) and f["roots"].chunks == (1, 1, 4, 2)
    shards = write_shards(tmp_path, n_shards=4, axes=AXES_3D)
    merge_results(shards, tmp_path / "merged.h5")
    assert_same_result(single, tmp_path / "merged.h5")
    # The single run given again after them: every point twice, compared block by block.
    report = merge_results(shards + [single], tmp_path / "twice.h5")
    assert report.n_duplicated == 84
    assert_same_result(single, tmp_path / "twice.h5")
    # A value changed in the last block: found, and counted over all blocks.
    with h5py.File(single, "r+") as f:
        f["roots"][6, 2, 3, 1] = 0.0
        f["roots"][0, 0, 1, 0] = -1.0
    with pytest.raises(ResultFileError) as info:
        merge_results(shards + [single], tmp_path / "conflict.h5")
    message = str(info.value)
    assert "g=0, Omega=4, c=0.2 was computed by both" in message and "different values of roots" in message
    assert "2 point(s) conflict" in message
    assert not (tmp_path / "conflict.h5").exists()


def test_merge_in_many_blocks_with_points_missing(tmp_path, small_blocks, assert_same_result):
    lost = (5, 40, 41, 83)
    partial = write_file(tmp_path / "partial.h5", AXES_3D,
                         points=[p for p in range(84) if p not in lost], finish=False)
    shards = write_shards(tmp_path, n_shards=4, axes=AXES_3D, skip=lost)
    report = merge_results(shards, tmp_path / "merged.h5", allow_missing=True)
    assert report.n_missing == 4 and not report.complete
    assert_same_result(partial, tmp_path / "merged.h5")  # unwritten points hold the fill values


@settings(max_examples=200, deadline=None)
@given(shape=st.lists(st.integers(1, 6), max_size=4), extra=st.integers(1, 40),
       chunk_bytes=st.sampled_from([8, 64, 512, 4096]), max_points=st.integers(1, 400))
def test_merge_blocks_cover_the_grid_once_in_order_without_cutting_chunks(shape, extra, chunk_bytes,
                                                                          max_points):
    from vrsweep.store.layout import _chunk_shape
    from vrsweep.store.merge import _blocks

    shape = tuple(shape)
    chunks = _chunk_shape(shape, (extra,), 8, chunk_bytes)[:len(shape)]
    flat = np.arange(int(np.prod(shape))).reshape(shape)
    next_point = 0
    for block in _blocks(shape, chunks, max_points):
        points = flat[block].reshape(-1)
        # A run of consecutive points, where the previous block stopped: C order, each point once.
        assert np.array_equal(points, np.arange(next_point, next_point + points.size))
        next_point += points.size
        for k, part in enumerate(block):  # starts and ends on chunk boundaries (or the grid's end)
            assert part.start % chunks[k] == 0
            assert part.stop % chunks[k] == 0 or part.stop == shape[k]
    assert next_point == flat.size


# ---------------------------------------------------------------------------------------------
# atomic_write
# ---------------------------------------------------------------------------------------------


def test_atomic_write_leaves_no_partial_file(tmp_path):
    target = tmp_path / "traj.h5"

    def failing(tmp):
        with h5py.File(tmp, "w") as f:
            f["x"] = np.arange(10)
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        atomic_write(target, failing)
    assert list(tmp_path.iterdir()) == []

    target.write_text("old")
    with pytest.raises(RuntimeError):
        atomic_write(target, failing)
    assert target.read_text() == "old" and list(tmp_path.iterdir()) == [target]

    def good(tmp):
        with h5py.File(tmp, "w") as f:
            f["x"] = np.arange(10)
        return "written"

    assert atomic_write(target, good) == "written"
    assert list(tmp_path.iterdir()) == [target]
    with h5py.File(target, "r") as f:
        assert list(f["x"][()]) == list(range(10))
    mode = os.stat(target).st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    assert mode == 0o666 & ~umask  # like any new file, not mkstemp's 0600


def test_finishing_a_resumed_finished_file_replaces_derived_variables(tmp_path):
    path = write_file(tmp_path / "r.h5", AXES_2D)
    writer = ResultWriter.open_for_resume(path, CONFIG)
    assert writer.complete and writer.done_mask().all()
    writer.finish({"g_res": (np.array([7.0, 8.0, 9.0]), ("Omega",),
                             {"units": "1", "long_name": "theory column"})})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            assert list(ds["g_res"].values) == [7.0, 8.0, 9.0] and ds.attrs["vrsweep_complete"] == 1
    with h5py.File(path, "r") as f:  # R Qs n_steps roots status done g_res: no dangling entry
        assert len(f["Omega"].attrs["REFERENCE_LIST"]) == 7
