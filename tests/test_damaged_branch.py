"""Issue 24, class 4, for branch files (vrsweep continue): their layout and checksums are checked
once where they are opened (store/branch_file.check_branch), so open_results, info and plot give
one line and exit 2 for a damaged file, never a traceback or a figure of wrong numbers.

The file is made from hand-built orbits: what is checked is the store, not the numerics."""

import numpy as np
import pytest

import vrsweep
from vrsweep.errors import ResultFileError

from damaged import damaged_copy, flip_bit, one_line_error, refused_by_plot_and_info
from handmade import write_branch_file


@pytest.fixture(scope="module")
def branch(tmp_path_factory):
    return write_branch_file(tmp_path_factory.mktemp("branch") / "good.h5")


def _point_variable_too_short(f):
    del f["R"]
    f.create_dataset("R", data=np.zeros(4))


def _multipliers_missing(f):
    del f["multiplier_modulus"]


def _parameter_as_text(f):
    del f["parameter"]
    f.create_dataset("parameter", data=np.array([b"a"] * 9))


def _unknown_status(f):
    f["branch_end_last_status"][0] = "exploded"


def _unknown_kind(f):
    f["bifurcation_kind"][0] = "cusp"


def _branch_out_of_range(f):
    f["branch"][3] = 7


def _incomplete(f):
    f.attrs["vrsweep_complete"] = np.int32(0)


def _future_format(f):
    f.attrs["vrsweep_format_version"] = np.int32(99)


DAMAGES = {
    "point variable too short": (_point_variable_too_short, "R has 4 values along point, which has 9"),
    "multipliers missing": (_multipliers_missing, "multiplier_modulus is missing"),
    "parameter as text": (_parameter_as_text, "parameter must be numbers over (point)"),
    "unknown status": (_unknown_status, "branch_end_last_status holds 'exploded'"),
    "unknown kind": (_unknown_kind, "bifurcation_kind holds 'cusp'"),
    "branch out of range": (_branch_out_of_range, "branch names a branch outside 0..0"),
    "incomplete": (_incomplete, "is incomplete"),
    "future format": (_future_format, "has branch format 99"),
}


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_a_damaged_branch_file_is_one_line_everywhere(damage, branch, tmp_path, invoke):
    change, words = DAMAGES[damage]
    path = damaged_copy(branch, tmp_path, change)
    refused_by_plot_and_info(invoke, path, tmp_path, words)
    with pytest.raises(ResultFileError) as error:
        vrsweep.open_results(path)
    assert words in str(error.value)


def test_a_flipped_bit_fails_its_checksum(branch, tmp_path, invoke):
    path = damaged_copy(branch, tmp_path, None, "flipped.h5")
    checksummed = flip_bit(path, "x")
    assert checksummed
    assert "is truncated or corrupt" in one_line_error(invoke("info", path))


def test_an_undamaged_branch_file_reads_back(branch):
    with vrsweep.open_results(branch) as ds:
        assert ds.sizes["point"] == 9 and ds.sizes["bifurcation"] == 1
        assert np.array_equal(ds["stable"].values, (ds["parameter"].values < 24.0).astype(int))
        assert str(ds["bifurcation_kind"].values[0]) == "fold"
