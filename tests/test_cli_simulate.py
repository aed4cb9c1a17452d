"""``vrsweep simulate``: the trajectory file, its agreement with the kernel and with a sweep, refusals."""

import textwrap

import h5py
import numpy as np
import pytest

from vrsweep.numerics import kernel
from vrsweep.config import load_config
from vrsweep.numerics.model import kernel_coefficients
from vrsweep.store.reading import load_results
from vrsweep.numerics.trajectory import settings_vector, simulate
from vrsweep.store.trajectory_file import read_trajectory


# The paper's parameters at Omega = 5 (Fig. impact_no), short runs: 5 transient + 10 measured periods.
POINT = """\
    parameters: {Omega: 5.0, g: 20.0}
    integration: {transient_periods: 5, measure_periods: 10, strobe_periods: 5}
    """
SWEPT = """\
    parameters: {Omega: 5.0}
    sweep:
      g: [5.0, 20.0]
    integration: {transient_periods: 5, measure_periods: 10, strobe_periods: 5}
    """
SAMPLES_PER_PERIOD = 40


def write(tmp_path, text, name="point.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope="module")
def compared(tmp_path_factory, invoke):
    """One point with --compare effective: (config path, trajectory path)."""
    directory = tmp_path_factory.mktemp("simulate")
    config = write(directory, POINT)
    out = directory / "traj.h5"
    result = invoke("simulate", config, "-o", out, "--compare", "effective",
                    "--samples-per-period", SAMPLES_PER_PERIOD)
    assert result.exit_code == 0, result.output
    return config, out


def test_the_file_holds_both_models_and_the_slow_flow(compared):
    _, out = compared
    data = read_trajectory(out)
    assert list(data.runs) == ["original", "effective"]
    assert set(data.slow_flow) == {"state", "paper", "paper_literal"}
    assert "model: original" in data.config_text and "g: 20.0" in data.config_text
    for key in ("vrsweep_version", "numba_version", "numpy_version", "created"):
        assert key in data.attrs
    n_periods = 15
    slow_period = 2 * np.pi / 0.5
    for run in data.runs.values():
        assert len(run.t) == n_periods * SAMPLES_PER_PERIOD + 1
        np.testing.assert_allclose(run.t[[0, -1]], [0.0, n_periods * slow_period])
        assert np.isfinite(run.x).all() and np.isfinite(run.v).all()
        assert run.x.max() <= 1.0 + 1e-9  # never through the barrier Delta = 1
        assert len(run.impacts_per_period) == n_periods
        assert run.impacts_per_period.sum() == len(run.impacts)  # every impact counted once
        # eq2.2 at every impact not turned into sticking
        rebound = run.impacts[:, 2] != 0.0
        np.testing.assert_allclose(run.impacts[rebound, 2], -0.95 * run.impacts[rebound, 1], rtol=1e-14)


def test_samples_agree_with_the_kernel_state_at_period_ends(compared):
    """A sample at t = nT comes from the dense output; the kernel's record there is the step's end state."""
    _, out = compared
    for run in read_trajectory(out).runs.values():
        at_period_ends = slice(SAMPLES_PER_PERIOD, None, SAMPLES_PER_PERIOD)
        np.testing.assert_allclose(run.x[at_period_ends], run.strobe_x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(run.v[at_period_ends], run.strobe_v, rtol=0, atol=1e-10)


def test_samples_do_not_change_the_trajectory(compared):
    """Sampling on the dense output never touches the steps: a run asked for a few of the same
    times returns the same numbers, bit for bit, and the same impacts."""
    config_path, out = compared
    run = read_trajectory(out).runs["original"]
    config = load_config(config_path)
    some = np.arange(7, len(run.t), 97)
    again = simulate(kernel_coefficients(config.parameters, "original"), [0.99, 0.5],
                     settings_vector(**vars(config.integration)), run.t[some])
    np.testing.assert_array_equal(again.samples[:, 0], run.x[some])
    np.testing.assert_array_equal(again.samples[:, 1], run.v[some])
    np.testing.assert_array_equal(again.impacts, run.impacts)
    np.testing.assert_array_equal(again.period_records[:, kernel.REC_X], run.strobe_x)


def test_impacts_match_the_sweep_of_the_same_point(tmp_path, invoke):
    """simulate --set g=20 and the sweep over g = 5, 20 integrate the same trajectory."""
    config = write(tmp_path, SWEPT)
    assert invoke("run", config, "-o", tmp_path / "sweep.h5", "--quiet").exit_code == 0
    sweep = load_results(tmp_path / "sweep.h5")
    for index, g in enumerate((5, 20)):
        out = tmp_path / f"g{g}.h5"
        assert invoke("simulate", config, "--set", f"g={g}", "-o", out, "-q").exit_code == 0
        counts = read_trajectory(out).runs["original"].impacts_per_period
        assert counts[5:].mean() == sweep["impacts_per_period"].values[index]
        np.testing.assert_array_equal(read_trajectory(out).runs["original"].strobe_x[-5:],
                                      sweep["strobe_x"].values[index])


def test_the_slow_flow_starts_from_the_initial_state(compared):
    _, out = compared
    flow = read_trajectory(out).slow_flow
    np.testing.assert_allclose([flow["state"].x[0], flow["state"].v[0]], [0.99, 0.5], rtol=1e-12)
    # the paper's start (eq2.20-eq2.22, omega = 0.5, l = 1): R0 = Delta, theta0 = 0, X(0) = Delta
    assert flow["paper"].R0 == pytest.approx(1.0) and flow["paper"].theta0 == pytest.approx(0.0, abs=1e-12)
    assert flow["paper_literal"].literal and not flow["paper"].literal


def test_each_group_opens_in_xarray(compared):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    _, out = compared
    with xr.open_dataset(out, group="original", engine="h5netcdf") as ds:
        assert ds["x"].dims == ("time",) and ds["impacts_per_period"].dims == ("period",)
        assert ds["impact_t"].attrs["units"] == "1"
    with xr.open_dataset(out, group="slow_flow/state", engine="h5netcdf") as ds:
        assert {"x", "v", "R", "theta"} <= set(ds.data_vars)
        assert ds["theta"].attrs["units"] == "rad" and ds["R"].attrs["units"] == "1"  # a phase, an amplitude


def test_a_swept_config_needs_set(tmp_path, invoke):
    result = invoke("simulate", write(tmp_path, SWEPT), "-o", tmp_path / "t.h5")
    assert result.exit_code == 2
    assert "sweeps g (2 values)" in result.output and "--set g=" in result.output
    assert not (tmp_path / "t.h5").exists()


def test_refuses_to_overwrite_without_the_option(tmp_path, invoke):
    config = write(tmp_path, POINT.replace("measure_periods: 10", "measure_periods: 5"))
    out = tmp_path / "t.h5"
    out.write_text("precious")
    result = invoke("simulate", config, "-o", out)
    assert result.exit_code == 2 and "--overwrite" in result.output
    assert out.read_text() == "precious"
    assert invoke("simulate", config, "-o", out, "--overwrite", "-q").exit_code == 0
    assert h5py.is_hdf5(out)


def test_compare_effective_needs_the_original_model(tmp_path, invoke):
    config = write(tmp_path, "model: effective\n" + textwrap.dedent(POINT))
    result = invoke("simulate", config, "-o", tmp_path / "t.h5", "--compare", "effective")
    assert result.exit_code == 2 and "already effective" in result.output


def test_an_effective_config_stores_its_slow_flow(tmp_path, invoke):
    config = write(tmp_path, "model: effective\n" + textwrap.dedent(POINT))
    assert invoke("simulate", config, "-o", tmp_path / "t.h5", "-q", "--samples-per-period", 20).exit_code == 0
    data = read_trajectory(tmp_path / "t.h5")
    assert list(data.runs) == ["effective"] and "state" in data.slow_flow


def test_bad_config_and_bad_set_exit_2(tmp_path, invoke):
    result = invoke("simulate", write(tmp_path, "parameters: {e: 1.5}\n"), "-o", tmp_path / "t.h5")
    assert result.exit_code == 2 and "parameters.e" in result.output
    result = invoke("simulate", write(tmp_path, POINT), "--set", "gg=3", "-o", tmp_path / "t.h5")
    assert result.exit_code == 2


@pytest.mark.parametrize("model, Omega, g, expected", [
    # 20 samples per cycle of the fastest force, Omega T / 2 pi = Omega/omega cycles a slow period
    ("original", 50.0, 5.0, 20 * 100), ("original", 17.25, 5.0, 690),
    ("original", 4.0, 5.0, 200),        # 8 cycles: 160 < the 200 a slow period
    ("original", 50.0, 0.0, 200),       # no fast force: only omega, 1 cycle
    ("effective", 50.0, 5.0, 200),      # averaged out (eq2.10)
])
def test_the_default_samples_resolve_the_fastest_force(tmp_path, invoke, model, Omega, g, expected):
    """At Omega = 50 the default 200 samples a slow period were 2 per cycle of the fast force, each
    at a zero of sin(Omega t): the velocity's fast wiggle, g/Omega = 0.1, vanished from the figure."""
    config = write(tmp_path, f"""\
        model: {model}
        parameters: {{Omega: {Omega}, g: {g}}}
        integration: {{transient_periods: 1, measure_periods: 2, strobe_periods: 1}}
        """)
    assert invoke("simulate", config, "-o", tmp_path / "t.h5", "-q").exit_code == 0
    data = read_trajectory(tmp_path / "t.h5")
    assert int(data.attrs["samples_per_period"]) == expected
    run = data.runs[model]
    assert len(run.t) == 3 * expected + 1
    if expected > 200:  # the fast force's wiggle in the velocity is drawn: v changes sign of slope
        # on every half cycle of Omega, i.e. 2 * Omega/omega * 3 times over 3 slow periods
        slopes = np.sign(np.diff(run.v))
        turns = int(np.sum(slopes[1:] != slopes[:-1]))
        assert turns >= 2 * (Omega / 0.5) * 3 * 0.9, turns
