"""Issue 33, class 3: files and figures that claim success.

- A figure is written whole (rendered in memory, written beside its path, renamed): a failed write
  leaves nothing and exits non-zero.
- A figure replaces, unasked, only a figure vrsweep wrote (its metadata names vrsweep); any other
  file at the default or the given path needs --overwrite, and an HDF5 file (results, reached
  through a link or named directly) is never replaced by a figure.
- merge refuses shards whose versions compute different points (as --resume refuses such a file),
  and a shard whose label does not name the points it owns.
"""

import errno
import os
import shutil

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

TINY = """\
    sweep:
      g: {start: 0.0, stop: 30.0, num: 5}
      Omega: [4.0, 5.0]
    integration: {transient_periods: 3, measure_periods: 3, strobe_periods: 2}
    """
FIGURE_FORMATS = ("png", "pdf", "svg")
SETTINGS = settings(max_examples=12, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def made(tmp_path_factory, write_config, invoke):
    """A finished sweep, its two shards, and one vrsweep figure of each format."""
    folder = tmp_path_factory.mktemp("made")
    config = write_config(folder, TINY)
    for shard in ("0/2", "1/2"):
        result = invoke("run", config, "-o", folder / "sweep.h5", "--shard", shard, "-q")
        assert result.exit_code == 0, result.output
    result = invoke("run", config, "-o", folder / "sweep.h5", "-q")
    assert result.exit_code == 0, result.output
    for suffix in FIGURE_FORMATS:
        result = invoke("plot", folder / "sweep.h5", "-o", folder / f"figure.{suffix}")
        assert result.exit_code == 0, result.output
    return folder


def _copy(made, tmp_path, *names):
    for name in names:
        shutil.copy(made / name, tmp_path / name)
    return [tmp_path / name for name in names]


def _one_error_line(result, code=2):
    """The one "Error: " line of ``result`` (a file of an old version may be noted first as unprotected)."""
    lines = [line for line in result.output.strip().splitlines()
             if not (line.startswith("Note: ") and "before attributes had checksums" in line)]
    assert result.exit_code == code and len(lines) == 1 and lines[0].startswith("Error: "), result.output
    return lines[0]


# ---------------------------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", FIGURE_FORMATS)
def test_a_figure_vrsweep_wrote_is_replaced_unasked(made, tmp_path, invoke, suffix):
    from vrsweep.plot.labels import made_by_vrsweep

    (figure,) = _copy(made, tmp_path, f"figure.{suffix}")
    assert made_by_vrsweep(figure)
    result = invoke("plot", made / "sweep.h5", "-o", figure, "--kind", "status")
    assert result.exit_code == 0, result.output
    assert figure.read_bytes() != (made / f"figure.{suffix}").read_bytes() and made_by_vrsweep(figure)


@SETTINGS
@given(contents=st.binary(max_size=200).filter(lambda b: b"vrsweep" not in b), suffix=st.sampled_from(FIGURE_FORMATS),
       default=st.booleans())
def test_a_file_vrsweep_did_not_write_needs_overwrite(made, tmp_path_factory, invoke, contents, suffix, default):
    """At the default path (RESULTS.png beside RESULTS.h5) or the given one: another figure, a
    manuscript, an empty file is kept, and the message names the way to replace it."""
    from vrsweep.plot.labels import made_by_vrsweep

    tmp_path = tmp_path_factory.mktemp("foreign")
    (results,) = _copy(made, tmp_path, "sweep.h5")
    suffix = "png" if default else suffix
    foreign = tmp_path / f"sweep.{suffix}"
    foreign.write_bytes(contents)
    assert not made_by_vrsweep(foreign)
    args = ["plot", results] + ([] if default else ["-o", foreign])
    line = _one_error_line(invoke(*args))
    assert "not a figure vrsweep wrote" in line and "--overwrite" in line and str(foreign.name) in line
    assert foreign.read_bytes() == contents
    result = invoke(*args, "--overwrite")
    assert result.exit_code == 0, result.output
    assert made_by_vrsweep(foreign)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["sweep.h5", foreign.name])  # no temporary left


@pytest.mark.parametrize("how", ["link_to_results", "link_to_input", "named", "link_to_link"])
@pytest.mark.parametrize("overwrite", [False, True])
def test_results_are_never_replaced_by_a_figure(made, tmp_path, invoke, how, overwrite):
    results, other = _copy(made, tmp_path, "sweep.h5", "sweep.shard0of2.h5")
    before = {path: path.read_bytes() for path in (results, other)}
    out = tmp_path / "p.png"
    if how == "link_to_results":
        out.symlink_to(other.name)
    elif how == "link_to_input":
        out.symlink_to(results.name)
    elif how == "link_to_link":
        (tmp_path / "middle.h5").symlink_to(other.name)
        out.symlink_to("middle.h5")
    else:  # a results file that happens to be called .png
        shutil.copy(other, out)
        before[out] = out.read_bytes()
    line = _one_error_line(invoke("plot", results, "-o", out, *(["--overwrite"] if overwrite else [])))
    assert "choose another output" in line, line
    assert ("HDF5" in line) or how == "link_to_input", line
    for path, contents in before.items():
        assert path.read_bytes() == contents


@pytest.mark.parametrize("suffix", FIGURE_FORMATS)
def test_a_figure_that_cannot_be_written_leaves_nothing(made, tmp_path, invoke, monkeypatch, suffix):
    """A full disk while the figure is written: exit 1 with the system's words, no file, no
    temporary file, and an existing figure kept as it was."""
    from vrsweep.store import fileio

    (figure,) = _copy(made, tmp_path, f"figure.{suffix}")
    old = figure.read_bytes()

    def full(path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), path)

    monkeypatch.setattr(fileio, "fsync_path", full)
    for out in (figure, tmp_path / f"new.{suffix}"):
        line = _one_error_line(invoke("plot", made / "sweep.h5", "-o", out), code=1)
        assert "No space left on device" in line and out.name in line, line
    assert figure.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == [figure.name]


# ---------------------------------------------------------------------------------------------
# merge
# ---------------------------------------------------------------------------------------------


def _set_attr(path, name, value, sealed=True):
    """Set a root attribute as a file written that way would hold it: sealed again, or (``sealed``
    False: a file of a version before attributes had a checksum) without a checksum."""
    from damaged import reseal

    with h5py.File(path, "r+") as f:
        if value is None:
            del f.attrs[name]
        else:
            f.attrs[name] = value
        if not sealed:
            del f.attrs["vrsweep_attributes_sha256"]
    if sealed:
        reseal(path)


OLD_VERSIONS = st.sampled_from(["0.1.0", "0.1.9", "0.0.1", "0.2.0", "0.5.0", "0.6.0", "0.6.9", "0.7.0", "0.7.1", "0.7.2", "0.7.3", "0.7.4", "0.7.5", "0.7.6", "0.7.7", "0.7.8", "0.7.9", "0.7.10", "0.7.13", "0.7.14", "0.7.17", "dev", None])
NEW_VERSIONS = st.sampled_from(["0.7.18", "0.7.19", "0.8.0", "1.0"])


@SETTINGS
@given(old=OLD_VERSIONS, new=NEW_VERSIONS, which=st.integers(0, 1))
def test_merge_refuses_shards_of_versions_with_different_points(made, tmp_path_factory, invoke, old, new, which):
    tmp_path = tmp_path_factory.mktemp("versions")
    shards = _copy(made, tmp_path, "sweep.shard0of2.h5", "sweep.shard1of2.h5")
    _set_attr(shards[which], "vrsweep_version", old, sealed=False)  # written before attributes had a checksum
    _set_attr(shards[1 - which], "vrsweep_version", new)
    line = _one_error_line(invoke("merge", *shards, "-o", tmp_path / "merged.h5"))
    assert shards[which].name in line and "points differ" in line and "run the older shards again" in line, line
    assert not (tmp_path / "merged.h5").exists()


@SETTINGS
@given(versions=st.lists(NEW_VERSIONS, min_size=2, max_size=2))
def test_merge_joins_shards_of_versions_with_the_same_points(made, tmp_path_factory, invoke, versions):
    tmp_path = tmp_path_factory.mktemp("same")
    shards = _copy(made, tmp_path, "sweep.shard0of2.h5", "sweep.shard1of2.h5")
    for shard, version in zip(shards, versions):
        _set_attr(shard, "vrsweep_version", version)
    result = invoke("merge", *shards, "-o", tmp_path / "merged.h5")
    assert result.exit_code == 0, result.output
    assert ("different vrsweep_version" in result.output) == (versions[0] != versions[1])


def test_merge_of_two_old_shards_of_one_version_is_not_a_mix(made, tmp_path, invoke):
    shards = _copy(made, tmp_path, "sweep.shard0of2.h5", "sweep.shard1of2.h5")
    for shard in shards:
        _set_attr(shard, "vrsweep_version", "0.1.0", sealed=False)
    result = invoke("merge", *shards, "-o", tmp_path / "merged.h5", "-q")
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("which", [0, 1])
@pytest.mark.parametrize("sealed", [True, False])
def test_merge_refuses_a_shard_whose_label_was_changed(made, tmp_path, invoke, which, sealed):
    """Shard 0 of 2 relabelled 1/2 (or 1 relabelled 0/2): its owned mask is the other shard's.
    Under a fresh checksum (or in a file written before attributes had one) the label is checked
    against the run's own assignment of points."""
    shards = _copy(made, tmp_path, "sweep.shard0of2.h5", "sweep.shard1of2.h5")
    _set_attr(shards[which], "shard", f"{1 - which}/2", sealed=sealed)
    line = _one_error_line(invoke("merge", *shards, "-o", tmp_path / "merged.h5"))
    assert shards[which].name in line and f"says it is shard {1 - which}/2" in line, line
    assert f"those of shard {which}/2" in line, line
    assert not (tmp_path / "merged.h5").exists()


@pytest.mark.parametrize("name,value", [("shard", "1/2"), ("vrsweep_version", "0.1.0"), ("config", "sweep: {}\n"),
                                        ("model", "effective")])
def test_an_edited_attribute_of_a_shard_fails_its_checksum(made, tmp_path, invoke, name, value):
    shards = _copy(made, tmp_path, "sweep.shard0of2.h5", "sweep.shard1of2.h5")
    with h5py.File(shards[0], "r+") as f:
        f.attrs[name] = value
    line = _one_error_line(invoke("merge", *shards, "-o", tmp_path / "merged.h5"))
    assert shards[0].name in line and "do not match their checksum" in line, line


def test_merge_names_a_shard_whose_values_were_changed_under_a_fresh_checksum(made, tmp_path, invoke):
    """R doubled by h5py (the chunk's checksum rewritten): a point two shards hold differs, and
    merge says so in one line, exit 2."""
    shards = _copy(made, tmp_path, "sweep.shard0of2.h5", "sweep.shard1of2.h5", "sweep.h5")
    with h5py.File(shards[2], "r+") as f:
        f["R"][...] = 2 * f["R"][()]
    line = _one_error_line(invoke("merge", shards[0], shards[1], shards[2], "-o", tmp_path / "merged.h5"))
    assert "different values of R" in line and "sweep.h5" in line, line


def test_resume_refuses_a_shard_of_an_older_version(made, tmp_path, invoke, write_config):
    config = write_config(tmp_path, TINY)
    (shard,) = _copy(made, tmp_path, "sweep.shard0of2.h5")
    with h5py.File(shard, "r+") as f:
        f.attrs["vrsweep_version"] = "0.1.0"
        del f.attrs["vrsweep_attributes_sha256"]  # 0.1.0 wrote none
        f.attrs["vrsweep_complete"] = np.int32(0)
        f["done"][0, 0] = 0
    before = shard.read_bytes()
    line = _one_error_line(invoke("run", config, "-o", tmp_path / "sweep.h5", "--shard", "0/2", "--resume", "-q"))
    assert "cannot resume" in line and "0.1.0" in line and "--overwrite" in line, line
    assert shard.read_bytes() == before
