"""Issue 24, class 4, for trajectory files: their structure is checked once where they are opened
(store/trajectory_file.read_trajectory), so plot and info give one line and exit 2 for a damaged
file, never a traceback or a figure of wrong numbers."""

import numpy as np
import pytest

from vrsweep.store.trajectory_file import read_trajectory

from damaged import damaged_copy, flip_bit, one_line_error, refused_by_plot_and_info

CONFIG = """\
model: original
parameters: {g: 5.0, Omega: 4.0}
integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}
"""


@pytest.fixture(scope="module")
def trajectory(tmp_path_factory, invoke):
    folder = tmp_path_factory.mktemp("trajectory")
    config = folder / "one.yaml"
    config.write_text(CONFIG)
    path = folder / "good.h5"
    result = invoke("simulate", config, "-o", path, "--compare", "effective", "-q")
    assert result.exit_code == 0, result.output
    return path


def _nan_in_time(f):
    time = f["original/time"][()]
    time[3] = np.nan
    f["original/time"][...] = time


def _time_backwards(f):
    time = f["effective/time"][()]
    f["effective/time"][...] = time[::-1]


def _x_of_wrong_shape(f):
    del f["original/x"]
    f["original"].create_dataset("x", data=np.zeros((3, 2)))


def _v_of_wrong_length(f):
    del f["original/v"]
    f["original"].create_dataset("v", data=np.zeros(5))


def _strobe_as_text(f):
    del f["original/strobe_x"]
    f["original"].create_dataset("strobe_x", data=np.array([b"a", b"b"]))


def _slow_flow_series_missing(f):
    del f["slow_flow/state/theta"]


def _slow_period_as_text(f):
    f.attrs["slow_period"] = "long"


def _samples_per_period_negative(f):
    f.attrs["samples_per_period"] = -3


def _config_as_a_number(f):
    f.attrs["config"] = 7


def _status_out_of_range(f):
    f["original"].attrs["status"] = 99




DAMAGES = {
    "nan in time": (_nan_in_time, "/original/time must be finite and non-decreasing"),
    "time backwards": (_time_backwards, "/effective/time must be finite and non-decreasing"),
    "x of wrong shape": (_x_of_wrong_shape, "/original/x must be a 1-D float64 series"),
    "v of wrong length": (_v_of_wrong_length, "/original/v has 5 values"),
    "strobe as text": (_strobe_as_text, "/original/strobe_x must be a 1-D float64 series"),
    "slow-flow series missing": (_slow_flow_series_missing, "/slow_flow/state/theta is missing"),
    "slow_period as text": (_slow_period_as_text, "attribute slow_period must be a positive number"),
    "samples_per_period negative": (_samples_per_period_negative, "samples_per_period must be a whole number"),
    "config a number": (_config_as_a_number, "attribute config must be text"),
    "status out of range": (_status_out_of_range, "/original has no valid status attribute"),
}


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_a_damaged_trajectory_is_one_line_in_plot_and_info(damage, trajectory, tmp_path, invoke):
    change, words = DAMAGES[damage]
    refused_by_plot_and_info(invoke, damaged_copy(trajectory, tmp_path, change), tmp_path, words)


def test_a_flipped_bit_in_a_series_fails_its_checksum(trajectory, tmp_path, invoke):
    path = damaged_copy(trajectory, tmp_path, None, "flipped.h5")
    checksummed = flip_bit(path, "original/x")
    assert checksummed
    assert "is truncated or corrupt" in one_line_error(invoke("plot", path, "-o", tmp_path / "figure.png"))


def test_an_undamaged_trajectory_reads_whole(trajectory):
    data = read_trajectory(trajectory)
    assert set(data.runs) == {"original", "effective"} and set(data.slow_flow) == {"state", "paper", "paper_literal"}
    for run in data.runs.values():
        assert run.x.shape == run.t.shape and np.all(np.diff(run.t) >= 0)
