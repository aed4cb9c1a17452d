"""The kind of motion and R at quasi-periodic points (vrsweep.analysis.motion): weighted Birkhoff
averages against closed forms, quasi-periodic points against 10x longer runs, the classes on
points of known kind."""

import math

import numpy as np
import pytest
import xarray as xr

import vrsweep
from vrsweep.analysis import motion
from vrsweep.numerics import kernel
from vrsweep.results import Motion

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _plain(values):
    return float(np.mean(values))


@pytest.mark.parametrize("periods, weighted_below", [(100, 1e-9), (150, 1e-11), (200, 1e-13)])
def test_weighted_average_of_a_quasi_periodic_signal_converges_faster_than_any_power(periods, weighted_below):
    # f_n = 0.7 + cos(2 pi rho n + 0.3): mean 0.7 exactly, rho the golden mean. The error is the
    # bump's discrete Fourier transform at rho: 5e-10 after 100 periods, 5e-14 after 200, where
    # the plain mean is still off by 4e-3 to 5e-3 (it falls like 1/N)
    n = np.arange(periods)
    f = 0.7 + np.cos(2 * np.pi * GOLDEN * n + 0.3)
    assert abs(motion.weighted_mean(f) - 0.7) < weighted_below
    assert abs(_plain(f) - 0.7) > 1e-3


def test_a_second_harmonic_slows_it_but_not_to_a_power():
    # 2 rho mod 1 = 0.236 lies nearer a whole number: 5e-8 after 100 periods, 2e-12 after 200
    for periods, below in ((100, 1e-7), (200, 1e-11)):
        n = np.arange(periods)
        f = 0.7 + np.cos(2 * np.pi * GOLDEN * n + 0.3) + 0.5 * np.sin(4 * np.pi * GOLDEN * n)
        assert abs(motion.weighted_mean(f) - 0.7) < below


def test_weighted_average_keeps_a_constant_exact_and_a_cycle_to_1e8():
    assert motion.weighted_mean(np.full(100, 2.5)) == pytest.approx(2.5, rel=1e-15)
    # period 3, mean 1; 100 periods are no whole number of cycles: the plain mean is 1.02, the
    # weighted one 1 - 1.1e-9 (which is why a periodic point keeps its whole-cycle average)
    cycle = np.tile([3.0, -2.0, 2.0], 34)[:100]
    assert abs(motion.weighted_mean(cycle) - 1.0) < 1e-8
    assert abs(_plain(cycle) - 1.0) > 1e-2


def test_weights_sum_to_one_and_kappa_is_the_variance_ratio():
    w = motion.bump_weights(100)
    assert w.sum() == pytest.approx(1.0, rel=1e-14) and (w > 0).all()
    rng = np.random.default_rng(1)
    samples = rng.standard_normal((20000, 100))
    ratio = np.var(samples @ w) / np.var(samples.mean(axis=1))
    assert ratio == pytest.approx(motion._kappa(100), rel=0.05)


def _records(columns, m):
    """Synthetic window records (n_points, m, N_RECORD) with the observables given per point."""
    records = np.zeros((len(columns), m, kernel.N_RECORD))
    for i, values in enumerate(columns):
        for k, column in zip(motion.OBSERVABLES, values):
            records[i, :, k] = column
    return records


def test_classes_of_synthetic_sequences():
    m = 100
    n = np.arange(m)
    rng = np.random.default_rng(7)
    torus = [np.cos(2 * np.pi * GOLDEN * n + k) for k in range(3)]
    noise = [rng.standard_normal(m) for _ in range(3)]
    dying = [np.exp(-n / 8.0) * np.cos(2.0 * n + k) for k in range(3)]
    records = _records([torus, noise, dying, torus], m)
    ok = np.array([True, True, True, False])
    period = np.zeros(4, dtype=np.int64)
    found = motion.classify(records, ok, period)
    assert list(found) == [Motion.QUASI_PERIODIC, Motion.CHAOTIC, Motion.NOT_SETTLED, Motion.NONE]
    # a positive exponent beyond its error bar makes chaos of anything; a negative one makes a
    # response locked to the forcing of unconverged averages; dying away stays not settled
    lyapunov = np.array([0.1, -0.2, 0.0, np.nan])
    error = np.array([0.01, 0.01, 0.5, np.nan])
    found = motion.classify(records, ok, period, lyapunov, error)
    assert list(found) == [Motion.CHAOTIC, Motion.QUASI_PERIODIC, Motion.NOT_SETTLED, Motion.NONE]
    assert motion.classify(records, ok, np.array([2, 0, 0, 0]))[0] == Motion.PERIODIC


def test_independent_values_give_the_same_convergence_for_any_window_far_above_the_limit():
    # the larger of two comparisons, each about 1 in units of its expected spread: about 1.4
    rng = np.random.default_rng(3)
    for m in (50, 100, 400, 1000):
        records = _records([[rng.standard_normal(m) for _ in range(3)] for _ in range(400)], m)
        found = motion.convergence(records)
        assert 1.1 < np.median(found) < 1.7
        assert np.mean(found < motion.QUASI_PERIODIC_LIMIT) == 0.0


# Omega/omega irrational; at these g the response is quasi-periodic (convergence 0.002, 0.003)
QUASI_PERIODIC_POINTS = ((25.0, 3.0 + 0.5 * math.sqrt(2.0)), (40.0, 4.0 + 0.5 * (math.sqrt(5.0) - 1.0)))


def _sweep(tmp_path, name, config):
    out = tmp_path / f"{name}.h5"
    vrsweep.sweep(config, output=out, progress=False, overwrite=True)
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        return {k: ds[k].values.ravel() for k in ds.data_vars if ds[k].ndim == 1}


def _quasi_periodic_runs(tmp_path, measure_periods):
    runs = []
    for k, (g, omega) in enumerate(QUASI_PERIODIC_POINTS):
        config = {"model": "original", "parameters": {"Omega": omega}, "sweep": {"g": [g]},
                  "integration": {"transient_periods": 100, "measure_periods": measure_periods, "strobe_periods": 16}}
        runs.append(_sweep(tmp_path, f"m{measure_periods}_{k}", config))
    return {name: np.concatenate([run[name] for run in runs]) for name in runs[0]}


@pytest.fixture(scope="module")
def quasi_periodic(tmp_path_factory):
    """The original model at QUASI_PERIODIC_POINTS over 100 and 1000 periods."""
    tmp_path = tmp_path_factory.mktemp("qp")
    return {m: _quasi_periodic_runs(tmp_path, m) for m in (100, 1000)}


def test_quasi_periodic_points_of_the_original_model_against_a_10x_longer_run(quasi_periodic):
    short, long = quasi_periodic[100], quasi_periodic[1000]
    assert (short["motion"] == Motion.QUASI_PERIODIC).all() and (long["motion"] == Motion.QUASI_PERIODIC).all()
    error = np.abs(short["R"] - long["R"])
    # R to 1e-4 relative in 100 periods, where the plain average is off by 2e-3 or more
    assert (error < 1e-4 * long["R"]).all(), error / long["R"]
    # R_err is honest (covers the error) and says the point is trusted (under 10% of R)
    assert (short["R_err"] >= error).all(), (short["R_err"], error)
    assert (short["R_err"] < 1e-2 * short["R"]).all()


def test_the_plain_average_is_what_the_weighted_one_improves_on(quasi_periodic, tmp_path, monkeypatch):
    """The same 100 periods averaged plainly (no point called quasi-periodic) are off by more than
    1e-3 relative: the estimator, not the window, made the difference."""
    monkeypatch.setattr(motion, "QUASI_PERIODIC_LIMIT", -1.0)
    plain = _quasi_periodic_runs(tmp_path, 100)
    assert (plain["motion"] == Motion.CHAOTIC).all()
    reference = quasi_periodic[1000]["R"]
    assert (np.abs(plain["R"] - reference) > 1e-3 * reference).all()


def test_near_a_neimark_sacker_point_an_unresolved_torus_is_not_called_quasi_periodic(tmp_path):
    # docs/continuation.md: the effective model's small orbit loses stability at g = 21.927. Just
    # below, the torus's slow modulation spans most of a 100-period window and its averages only
    # look converged (R differs from a 1000-period run's by up to 3e-3): such points must keep the
    # wide error bar of chaos, which then covers R's distance from the long run
    config = {"model": "effective", "parameters": {"gamma": 0.05, "alpha": 0.05, "Omega": 4.0},
              "initial": {"x": 0.0, "v": 0.0}, "sweep": {"g": [21.0, 21.2]},
              "integration": {"transient_periods": 1000, "measure_periods": 100}}
    short = _sweep(tmp_path, "short", config)
    config["integration"]["measure_periods"] = 1000
    long = _sweep(tmp_path, "long", config)
    assert (short["motion"] == Motion.CHAOTIC).all()
    assert (np.abs(short["R"] - long["R"]) <= short["R_err"]).all()


def test_a_chaotic_point_is_chaotic_with_and_without_exponents(tmp_path):
    # the paper's parameters at g = 5, Omega = 4: lambda1 about 0.25 (docs/lyapunov.md)
    config = {"model": "original", "sweep": {"g": [5.0]}, "parameters": {"Omega": 4.0},
              "integration": {"lyapunov": True}}
    with_exponents = _sweep(tmp_path, "lyap", config)
    assert with_exponents["lyapunov"][0] - with_exponents["lyapunov_err"][0] > 0
    assert with_exponents["motion"][0] == Motion.CHAOTIC
    config["integration"]["lyapunov"] = False
    assert _sweep(tmp_path, "plain", config)["motion"][0] == Motion.CHAOTIC


def test_periodic_and_chaotic_points_keep_the_plain_average(tmp_path, monkeypatch):
    # the effective model's large orbit at g = 25 (period 1) and the original model's chaos at
    # g = 5, Omega = 4: R and R_err are those of the plain averages, bit for bit
    configs = {"p1": {"model": "effective", "sweep": {"g": [25.0]}},
               "chaos": {"model": "original", "sweep": {"g": [5.0]}, "parameters": {"Omega": 4.0}}}
    found = {name: _sweep(tmp_path, name, config) for name, config in configs.items()}
    assert found["p1"]["motion"][0] == Motion.PERIODIC and found["chaos"]["motion"][0] == Motion.CHAOTIC
    monkeypatch.setattr(motion, "QUASI_PERIODIC_LIMIT", -1.0)
    for name, config in configs.items():
        plain = _sweep(tmp_path, name + "_plain", config)
        for variable in ("R", "R_err", "Qs", "Qc"):
            np.testing.assert_array_equal(found[name][variable], plain[variable])


@pytest.fixture(scope="module")
def kinds_file(tmp_path_factory, invoke, write_config):
    """A sweep of the original model at Omega = 4: g = 5 chaotic (lambda1 > 0, docs/lyapunov.md),
    g = 10 period 3, g = 30 period 1."""
    tmp_path = tmp_path_factory.mktemp("kinds")
    config = write_config(tmp_path, """\
        model: original
        parameters: {Omega: 4.0}
        sweep:
          g: [5.0, 10.0, 30.0]
        integration: {transient_periods: 100, measure_periods: 100}
        """)
    out = tmp_path / "kinds.h5"
    assert invoke("run", config, "-o", out, "-q").exit_code == 0
    return out


def test_info_counts_the_kinds_of_motion(kinds_file, invoke):
    lines = [line for line in invoke("info", kinds_file).output.splitlines() if line.startswith("motion:")]
    assert lines == ["motion:      2 periodic, 1 chaotic (docs/trust.md)"]
    import json

    summary = json.loads(invoke("info", kinds_file, "--json").output)
    assert summary["motion_counts"] == {"periodic": 2, "chaotic": 1}


def test_forcing_periods_from_the_coefficient_header():
    from vrsweep.analysis.diagnostics import forcing_periods
    from vrsweep.numerics.coefficients import PERIOD
    from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
    from vrsweep.numerics.models import kernels_for

    omegas = [4.0, 4.3, float(np.linspace(3.0, 6.0, 12)[2]), QUASI_PERIODIC_POINTS[0][1]]
    coefficients = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=np.full(4, 10.0), Omega=np.array(omegas)), "original")
    # Omega/omega = 8, 43/5, 78/11, irrational; no fast force (g = 0): the slow one alone, q = 1
    frequencies = kernels_for("original").forcing_frequencies(coefficients)
    assert list(forcing_periods(coefficients[:, PERIOD], frequencies, 50)) == [1, 5, 11, 0]
    assert list(forcing_periods(coefficients[:, PERIOD], frequencies, 10)) == [1, 5, 0, 0]
    no_fast = kernel_coefficients(dict(DEFAULT_PARAMETERS, g=0.0, Omega=omegas[3]), "original")[np.newaxis]
    assert list(forcing_periods(no_fast[:, PERIOD], kernels_for("original").forcing_frequencies(no_fast), 50)) == [1]


def test_a_motion_locked_to_a_forcing_of_11_periods_is_periodic_beyond_max_period(tmp_path):
    # Omega/omega = 78/11 (Omega = 39/11, a value of linspace(3, 6, 12)): the fast force repeats
    # after 11 slow periods, and at g = 40 the motion is locked to it (7 1/11 impacts a period).
    # max_period is 8, the forcing's period is found all the same, and R is over whole cycles
    omega = float(np.linspace(3.0, 6.0, 12)[2])
    config = {"model": "original", "parameters": {"Omega": omega}, "sweep": {"g": [40.0]},
              "integration": {"transient_periods": 100, "measure_periods": 100}}
    values = _sweep(tmp_path, "locked", config)
    assert values["period"][0] == 11 and values["motion"][0] == Motion.PERIODIC
    assert values["impacts_per_cycle"][0] == 78
    assert values["R_err"][0] < 1e-9 * values["R"][0]
    config["integration"]["measure_periods"] = 99  # 9 whole cycles: the kernel's own window mean
    whole = _sweep(tmp_path, "whole", config)
    assert whole["R"][0] == pytest.approx(values["R"][0], rel=1e-8)


def test_plot_kind_motion_draws_the_classes_and_refuses_a_file_without_them(kinds_file, tmp_path, invoke):
    import shutil

    import h5py
    from damaged import reseal

    result = invoke("plot", kinds_file, "--kind", "motion", "-o", tmp_path / "motion.png")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "motion.png").stat().st_size > 0
    out = tmp_path / "old.h5"
    shutil.copy(kinds_file, out)
    with h5py.File(out, "r+") as f:  # as vrsweep 0.5.0 wrote it
        del f["motion"]
        names = f["done"].attrs["point_variables"]
        names = names.decode() if isinstance(names, bytes) else names
        f["done"].attrs["point_variables"] = " ".join(n for n in names.split() if n != "motion")
        f.attrs["vrsweep_version"] = "0.5.0"
    reseal(out)
    assert invoke("plot", out, "-o", tmp_path / "old_r.png").exit_code == 0  # readable as before
    assert "motion:" not in invoke("info", out).output
    result = invoke("plot", out, "--kind", "motion", "-o", tmp_path / "old.png")
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert "has no motion (written by vrsweep before 0.6.0)" in result.output


def test_with_exponents_a_response_locked_to_a_quasi_periodic_forcing_is_recognised(tmp_path):
    """Omega/omega = p/59 (Omega from linspace(3, 6, 60)): no period within 50. Where lambda1 < 0
    the motion is quasi-periodic even when 100 periods leave its averages unconverged, and the
    partial windows' R_err covers R's distance from a 1000-period run (measured: at most 0.79 of it
    over 122 such points, analysis/motion.py); where lambda1 > 0, chaotic."""
    omega = float(np.linspace(3.0, 6.0, 60)[13])
    config = {"model": "original", "parameters": {"Omega": omega}, "sweep": {"g": [2.0, 6.0, 14.0, 30.0]},
              "integration": {"transient_periods": 100, "measure_periods": 100, "lyapunov": True}}
    short = _sweep(tmp_path, "short", config)
    config["integration"]["measure_periods"] = 1000
    long = _sweep(tmp_path, "long", config)
    negative = short["lyapunov"] + short["lyapunov_err"] < 0
    positive = short["lyapunov"] - short["lyapunov_err"] > 0
    assert negative.sum() == 3 and positive.sum() == 1 and (short["period"] == 0).all()
    assert (short["motion"][negative] == Motion.QUASI_PERIODIC).all()
    assert (short["motion"][positive] == Motion.CHAOTIC).all()
    locked = negative & (long["motion"] == Motion.QUASI_PERIODIC)
    assert locked.any()
    assert (np.abs(short["R"] - long["R"])[locked] <= short["R_err"][locked]).all()


def test_run_notes_many_chaotic_points_without_exponents(tmp_path, invoke, write_config):
    omega = float(np.linspace(3.0, 6.0, 60)[13])
    text = f"""\
        model: original
        parameters: {{Omega: {omega!r}}}
        sweep:
          g: [2.0, 6.0, 14.0, 30.0]
        integration: {{transient_periods: 100, measure_periods: 100{{lyapunov}}}}
        """
    plain = write_config(tmp_path, text.replace("{lyapunov}", ""), "plain.yaml")
    result = invoke("run", plain, "-o", tmp_path / "plain.h5")
    with xr.open_dataset(tmp_path / "plain.h5", engine="h5netcdf") as ds:
        chaotic = int((ds["motion"].values == Motion.CHAOTIC).sum())
    assert chaotic > 0.3 * 4  # the premise: three of the four look chaotic without exponents
    assert f"Note: {chaotic} of the 4 points" in result.output and "integration.lyapunov: true" in result.output
    exponents = write_config(tmp_path, text.replace("{lyapunov}", ", lyapunov: true"), "lyap.yaml")
    result = invoke("run", exponents, "-o", tmp_path / "lyap.h5")
    assert result.exit_code == 0 and "Note:" not in result.output
