"""Issue 35: attribute checksums in every kind of file vrsweep writes. Branch and curves files had
theirs (test_damaged_continuation_files); here sweep (and shard) files and trajectory files:
every attribute, of the root, of each group and of each dataset, changed by hand is refused where
the file is opened (info, plot, open_results, run --resume), in one line; what the checksum leaves
out (when and by which command a file was written, a sweep's vrsweep_complete) still opens; a file
written before attributes had a checksum opens with one note."""

import shutil

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vrsweep
from vrsweep.errors import ResultFileError
from vrsweep.store.sealing import ATTRIBUTES_CHECKSUM, SWEEP_UNSEALED, WHEN_AND_HOW, attributes_digest

SWEEP = """\
    sweep:
      g: [0.0, 10.0, 20.0]
    integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}
    """
POINT = """\
    parameters: {g: 5.0}
    integration: {transient_periods: 1, measure_periods: 2, strobe_periods: 1}
    """
SETTINGS = settings(max_examples=30, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def files(tmp_path_factory, write_config, invoke):
    folder = tmp_path_factory.mktemp("sealed")
    sweep_config = write_config(folder, SWEEP, "sweep.yaml")
    for args in (["run", sweep_config, "-o", folder / "sweep.h5", "-q"],
                 ["run", sweep_config, "-o", folder / "sweep.h5", "--shard", "0/2", "-q"],
                 ["simulate", write_config(folder, POINT, "point.yaml"), "-o", folder / "trajectory.h5", "-q",
                  "--compare", "effective"]):
        result = invoke(*args)
        assert result.exit_code == 0, result.output
    return {"sweep": folder / "sweep.h5", "shard": folder / "sweep.shard0of2.h5",
            "trajectory": folder / "trajectory.h5", "config": sweep_config}


def _attributes(path):
    """(owner path, attribute name) of every attribute the file's checksum covers."""
    skip = WHEN_AND_HOW if "trajectory" in path.name else SWEEP_UNSEALED
    found = []
    with h5py.File(path, "r") as f:
        found += [("", name) for name in f.attrs if name not in skip and name != ATTRIBUTES_CHECKSUM]

        def visit(owner, obj):
            found.extend((owner, name) for name in obj.attrs if name not in ("DIMENSION_LIST", "REFERENCE_LIST"))

        f.visititems(visit)
    return sorted(found)


def _changed(value, how):
    """``value`` (as h5py reads it) changed as damage or an edit would change it, keeping its type
    where it can (the checksum must catch what every other check lets through)."""
    if isinstance(value, str):
        return {"append": value + " ", "replace": value.replace("0", "1", 1) if "0" in value else value + "0",
                "empty": "" if value else "x"}[how]
    if isinstance(value, bytes):
        return value + b"x"
    array = np.array(value, copy=True)
    if array.dtype.kind in "iub":
        flat = array.reshape(-1)
        if flat.size:
            flat[0] = flat[0] + 1 if array.dtype.kind != "b" else not flat[0]
        return array if array.ndim else array[()]
    if array.dtype.kind == "f":
        flat = array.reshape(-1)
        if flat.size:
            flat[0] = np.nextafter(flat[0], np.inf) if np.isfinite(flat[0]) else 0.0
        return array if array.ndim else array[()]
    return str(value) + "x"


def _refusal(line):
    """The line of a file refused for a changed attribute: the checksum's, or a check before it
    (a format version, a kind of file, a config that is not this run's)."""
    return line.startswith("Error: ") and any(words in line for words in (
        "corrupt", "format", "not a vrsweep", "different config", "no trajectory"))


def _edited_copy(path, tmp_path, owner, name, how):
    copy = tmp_path / path.name
    shutil.copy(path, copy)
    with h5py.File(copy, "r+") as f:
        obj = f[owner] if owner else f
        obj.attrs[name] = _changed(obj.attrs[name], how)
    return copy


@pytest.mark.parametrize("kind", ["sweep", "shard", "trajectory"])
def test_every_file_vrsweep_writes_is_sealed(files, kind):
    skip = WHEN_AND_HOW if kind == "trajectory" else SWEEP_UNSEALED
    with h5py.File(files[kind], "r") as f:
        assert f.attrs[ATTRIBUTES_CHECKSUM] == attributes_digest(f, skip)


@pytest.mark.parametrize("kind", ["sweep", "shard", "trajectory"])
def test_every_covered_attribute_changed_is_refused(files, tmp_path_factory, invoke, kind):
    """Each attribute in turn (a few hundred reads: info only, the commands share the check)."""
    for owner, name in _attributes(files[kind]):
        tmp_path = tmp_path_factory.mktemp("one")
        copy = _edited_copy(files[kind], tmp_path, owner, name, "append")
        result = invoke("info", copy)
        lines = result.output.strip().splitlines()
        assert result.exit_code == 2 and len(lines) == 1 and _refusal(lines[0]), (owner, name, result.output)


@SETTINGS
@given(data=st.data(), how=st.sampled_from(["append", "replace", "empty"]),
       command=st.sampled_from(["info", "plot", "open_results", "resume"]))
def test_a_changed_attribute_is_refused_by_every_reader(files, tmp_path_factory, invoke, data, how, command):
    kind = data.draw(st.sampled_from(["sweep", "trajectory"] if command != "resume" else ["sweep"]))
    owner, name = data.draw(st.sampled_from(_attributes(files[kind])))
    tmp_path = tmp_path_factory.mktemp("edit")
    copy = _edited_copy(files[kind], tmp_path, owner, name, how)
    if command == "open_results":
        with pytest.raises(ResultFileError, match="corrupt"):
            vrsweep.open_results(copy)
        return
    args = {"info": ["info", copy], "plot": ["plot", copy, "-o", tmp_path / "f.png"],
            "resume": ["run", files["config"], "-o", copy, "--resume", "-q"]}[command]
    before = copy.read_bytes()
    result = invoke(*args)
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and lines[0].startswith("Error: "), result.output
    assert _refusal(lines[0]), lines[0]
    assert not (tmp_path / "f.png").exists() and copy.read_bytes() == before


@pytest.mark.parametrize("how", ["append", "replace", "empty"])
@pytest.mark.parametrize("kind, name", [("sweep", "vrsweep_format_version"), ("shard", "vrsweep_format_version"),
                                        ("trajectory", "vrsweep_format_version"), ("trajectory", "vrsweep_file")])
def test_a_changed_kind_or_format_is_called_corrupt(files, tmp_path, invoke, kind, name, how):
    """The attributes a reader reads before the checksum (what kind of file, which format): changed,
    the refusal says the file may be corrupt, not only that it is another kind or a newer format
    (hypothesis found a trajectory read as a sweep without a 'done' mask, a format 2 "from a
    newer vrsweep")."""
    copy = _edited_copy(files[kind], tmp_path, "", name, how)
    with pytest.raises(ResultFileError, match="corrupt"):
        vrsweep.open_results(copy)
    result = invoke("plot", copy, "-o", tmp_path / "f.png")
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "corrupt" in lines[0], result.output


@pytest.mark.parametrize("how", ["append", "replace", "empty"])
def test_resume_of_a_file_whose_version_was_changed_calls_it_corrupt(files, tmp_path, invoke, how):
    """--resume reads vrsweep_version before the checksum, to refuse results of older steps:
    hypothesis (fresh draws) found an emptied version refused as "written by vrsweep , whose points
    differ", without a word of damage."""
    copy = _edited_copy(files["sweep"], tmp_path, "", "vrsweep_version", how)
    before = copy.read_bytes()
    result = invoke("run", files["config"], "-o", copy, "--resume", "-q")
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "corrupt" in lines[0], result.output
    assert "vrsweep ," not in lines[0], lines[0]
    assert copy.read_bytes() == before


def test_the_issues_example_gamma_in_the_stored_config(files, tmp_path, invoke):
    copy = tmp_path / "sweep.h5"
    shutil.copy(files["sweep"], copy)
    with h5py.File(copy, "r+") as f:
        text = f.attrs["config"]
        assert "gamma: 0.22" in text
        f.attrs["config"] = text.replace("gamma: 0.22", "gamma: 0.27")
    line = invoke("info", copy).output.strip()
    assert line == f"Error: {copy} is corrupt or was changed after vrsweep wrote it (edited, or re-saved by another " \
                   "tool such as xarray's to_netcdf: open the file vrsweep wrote): its attributes (config, model, " \
                   "parameters, labels) do not match their checksum", line


@pytest.mark.parametrize("kind,name,value", [("sweep", "history", "edited"), ("sweep", "created", "2000-01-01T00:00:00Z"),
                                             ("sweep", "vrsweep_complete", np.int32(0)),
                                             ("trajectory", "history", "edited"),
                                             ("trajectory", "date_created", "2000-01-01T00:00:00Z")])
def test_what_the_checksum_leaves_out_still_opens(files, tmp_path, invoke, kind, name, value):
    copy = tmp_path / files[kind].name
    shutil.copy(files[kind], copy)
    with h5py.File(copy, "r+") as f:
        f.attrs[name] = value
    result = invoke("info", copy)
    assert result.exit_code == 0 and "Note" not in result.output, result.output


@pytest.mark.parametrize("kind", ["sweep", "trajectory"])
def test_a_file_written_before_attributes_had_a_checksum_opens_with_one_note(files, tmp_path, invoke, kind):
    copy = tmp_path / files[kind].name
    shutil.copy(files[kind], copy)
    with h5py.File(copy, "r+") as f:
        del f.attrs[ATTRIBUTES_CHECKSUM]
        f.attrs["config"] = f.attrs["config"] + "\n"  # unprotected: read as it is
    result = invoke("info", copy)
    assert result.exit_code == 0, result.output
    notes = [line for line in result.output.splitlines() if line.startswith("Note: ")]
    assert notes == [f"Note: {copy} was written before attributes had checksums: its config and parameters are "
                     "read as they are, unprotected against damage"], result.output
    with vrsweep.open_results(copy) as ds:
        assert ds.attrs["config"].endswith("\n")


def test_a_merge_is_sealed_as_a_single_run(files, tmp_path, invoke):
    """The seal is made again where attributes change (finishing and merging add the theory's
    variables), and is the same for the same attributes: a merged file's is a single run's."""
    for index in range(2):
        result = invoke("run", files["config"], "-o", tmp_path / "s.h5", "--shard", f"{index}/2", "-q")
        assert result.exit_code == 0, result.output
    merged = tmp_path / "merged.h5"
    assert invoke("merge", tmp_path / "s.shard0of2.h5", tmp_path / "s.shard1of2.h5", "-o", merged, "-q").exit_code == 0
    with h5py.File(files["sweep"], "r") as whole, h5py.File(merged, "r") as joined:
        assert joined.attrs[ATTRIBUTES_CHECKSUM] == whole.attrs[ATTRIBUTES_CHECKSUM]
        assert joined.attrs[ATTRIBUTES_CHECKSUM] == attributes_digest(joined, SWEEP_UNSEALED)


def test_a_copy_re_saved_by_xarray_is_named_as_changed_not_only_corrupt(files, tmp_path):
    """xarray's to_netcdf adds attributes of its own (_Netcdf4Dimid, _FillValue): the copy fails
    the checksum as a damaged file does, and "is corrupt" sent its user looking for damage."""
    import xarray as xr

    copy = tmp_path / "resaved.h5"
    with xr.open_dataset(files["sweep"], engine="h5netcdf") as ds:
        ds.load().to_netcdf(copy, engine="h5netcdf")
    with pytest.raises(ResultFileError) as error:
        vrsweep.open_results(copy)
    assert "re-saved by another tool such as xarray's to_netcdf" in str(error.value), error.value
