"""``vrsweep run``: the result file through xarray, options, refusals, summary, threads."""

from pathlib import Path

import numpy as np
import pytest
from result_files import assert_same_result, invoke, write_config

from vrsweep.results import FLAG_MEANINGS, Status

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")

CONFIGS = Path(__file__).resolve().parent.parent / "configs"

TINY = """\
    sweep:
      g: {start: 0.0, stop: 30.0, num: 6}
    integration: {transient_periods: 5, measure_periods: 5, strobe_periods: 4}
    """


@pytest.fixture(scope="module")
def quickstart(tmp_path_factory):
    out = tmp_path_factory.mktemp("quickstart") / "quickstart.h5"
    result = invoke("run", CONFIGS / "quickstart.yaml", "-o", out)
    return out, result


def test_quickstart_through_xarray(quickstart):
    out, result = quickstart
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.sizes["g"] == 9 and "g" in ds.coords
        np.testing.assert_array_equal(ds["g"].values, np.linspace(0.0, 40.0, 9))
        for name in ("R", "Qs", "Qc", "Q_amplitude", "impacts_per_period", "status", "R_err"):
            assert ds[name].dims[0] == "g", name
            assert ds[name].attrs["long_name"], name
            if name != "status":
                assert "units" in ds[name].attrs, name
        assert ds["g"].attrs["units"] and ds["g"].attrs["long_name"]
        assert ds["status"].dtype == np.int8
        assert ds["status"].attrs["flag_meanings"] == FLAG_MEANINGS
        assert (ds["status"].values == Status.OK).all()
        assert np.isfinite(ds["R"].values).all() and (ds["R"].values > 0).all()
        assert "model: original" in ds.attrs["config"]
        for key in ("vrsweep_version", "numba_version", "numpy_version", "created"):
            assert key in ds.attrs


def test_a_one_line_summary_of_statuses(quickstart):
    out, result = quickstart
    last = result.output.strip().splitlines()[-1]
    assert last.endswith(f"9 of 9 points computed (9 ok) -> {out}"), last


def test_quiet_prints_nothing(tmp_path):
    config = write_config(tmp_path, TINY)
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--quiet")
    assert result.exit_code == 0 and result.output == ""


def test_set_overrides_the_config(tmp_path):
    config = write_config(tmp_path, TINY)
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--set", "Omega=5", "--set", "g=10", "-q")
    assert result.exit_code == 0, result.output
    with xr.open_dataset(tmp_path / "out.h5", engine="h5netcdf") as ds:
        assert "g" not in ds.dims  # fixing a swept parameter leaves a single point
        assert ds["R"].shape == ()
        assert "Omega: 5.0" in ds.attrs["config"] and "g: 10.0" in ds.attrs["config"]


def test_refuses_to_overwrite_and_names_the_ways_out(tmp_path):
    config = write_config(tmp_path, TINY)
    out = tmp_path / "out.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    before = out.read_bytes()
    result = invoke("run", config, "-o", out)
    assert result.exit_code == 2
    assert "already exists" in result.output
    assert "--overwrite" in result.output and "--resume" in result.output
    assert out.read_bytes() == before
    assert invoke("run", config, "-o", out, "--overwrite", "-q").exit_code == 0


def test_resume_and_overwrite_exclude_each_other(tmp_path):
    config = write_config(tmp_path, TINY)
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--resume", "--overwrite")
    assert result.exit_code == 2 and "exclude" in result.output


def test_threads_do_not_change_a_bit(tmp_path):
    config = write_config(tmp_path, TINY)
    for threads in (1, 2):
        result = invoke("run", config, "-o", tmp_path / f"t{threads}.h5", "--threads", threads, "-q")
        assert result.exit_code == 0, result.output
    assert_same_result(tmp_path / "t1.h5", tmp_path / "t2.h5")


def test_bad_shard_and_dask_options_are_usage_errors(tmp_path):
    config = write_config(tmp_path, TINY)
    for args, words in ((("--shard", "3/3"), "not in 0..2"), (("--shard", "x"), "expected I/N"),
                        (("--shard", "auto"), "SLURM_ARRAY_TASK_ID"),
                        (("--dask", "local:0"), "local:N")):
        result = invoke("run", config, "-o", tmp_path / "out.h5", *args,
                        env={"SLURM_ARRAY_TASK_ID": None, "SLURM_ARRAY_TASK_COUNT": None})
        assert result.exit_code == 2, (args, result.output)
        assert words in result.output, (args, result.output)
        assert not (tmp_path / "out.h5").exists()
