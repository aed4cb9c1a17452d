"""``vrsweep theory``: the table, its JSON twin, and errors as messages (exit 2)."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from vrsweep.analysis import theory
from vrsweep.cli import main


def run(*args):
    return CliRunner().invoke(main, ["theory", *map(str, args)])


@pytest.fixture
def write_config(tmp_path):
    def write(text, name="config.yaml"):
        path = tmp_path / name
        path.write_text(text)
        return path
    return write


def test_table_shows_g_res_and_the_notes(write_config):
    result = run(write_config("parameters: {Omega: 4.0, g: 5.0}\n"))
    assert result.exit_code == 0, result.output
    header, rule, row = result.stdout.splitlines()[:3]
    for column in ("Omega", "g_res (eq3.4)", "wt2 (eq2.11)", "K (eq2.12)", "peak g", "peak A", "peak gain A/c"):
        assert column in header
    assert "21.065" in row
    assert "ERRATA 1-3" in result.stdout and "ERRATA 6" in result.stdout


def test_one_row_per_omega_of_the_sweep(write_config):
    path = write_config("sweep:\n  g: {start: 0.0, stop: 40.0, num: 81}\n  Omega: [4.0, 5.0]\n")
    result = run(path)
    assert result.exit_code == 0, result.output
    rows = result.stdout.splitlines()[2:4]
    assert "21.065" in rows[0] and "32.914" in rows[1]
    assert "0.000..40.000" in rows[0]  # g range of the sweep


def test_set_overrides_the_config(write_config):
    result = run(write_config("parameters: {Omega: 4.0}\n"), "--set", "Omega=5")
    assert result.exit_code == 0, result.output
    assert "32.914" in result.stdout


def test_json_parses_and_matches_the_library(write_config):
    path = write_config("parameters: {g: 23.6, gamma: 0.05, alpha: 0.05}\nsweep:\n  Omega: [4.0, 5.0]\n")
    result = run(path, "--json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [row["Omega"] for row in rows] == [4.0, 5.0]
    for row in rows:
        params = row["parameters"]
        assert row["g_res"] == theory.g_res(params["alpha"], params["omega0"], params["omega"], row["Omega"])
        search = row["peak_search"]
        assert search["source"].startswith("default grid") and search["g_max"] == 2 * row["g_res"]
        peak = theory.analytic_peak(params, np.linspace(search["g_min"], search["g_max"], search["num"]))
        assert row["peak_g"] == float(peak.g)
        assert row["peak_amplitude"] == float(peak.amplitude)
        assert row["peak_gain"] == float(peak.gain)
        assert row["wt2_at_g"] == float(theory.effective_frequency_squared(params))
        assert row["K_at_g"] == float(theory.damping_level(params))
        points = theory.fixed_points(params)
        assert row["stable_amplitudes_at_g"] == list(points.R[points.stable])
        assert isinstance(row["notes"], list) and any("ERRATA 1-3" in note for note in row["notes"])
    # The bistable point: two stable amplitudes at Omega = 4.
    assert len(rows[0]["stable_amplitudes_at_g"]) == 2


def test_json_over_a_swept_g_axis(write_config):
    path = write_config("sweep:\n  Omega: [4.0, 5.0]\n  g: {start: 0.0, stop: 60.0, num: 121}\n")
    result = run(path, "--json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    g = np.linspace(0.0, 60.0, 121)
    for row in rows:
        assert row["g_swept"] and row["g"] is None and row["wt2_at_g"] is None
        assert row["peak_search"] == {"source": "sweep axis g", "g_min": 0.0, "g_max": 60.0, "num": 121}
        peak = theory.analytic_peak(dict(row["parameters"], g=0.0), g)
        assert row["peak_amplitude"] == float(peak.amplitude) and row["peak_g"] == float(peak.g)
        wt2 = theory.effective_frequency_squared(dict(row["parameters"], g=g))
        assert row["wt2_range"] == [wt2.min(), wt2.max()]
    assert rows[0]["g_res"] == pytest.approx(21.065, abs=1e-3)


@pytest.mark.parametrize("text", [
    "parameters: {e: 1.5}\n",
    "parameters: {gama: 0.2}\n",
    "sweep:\n  g: {start: 0.0, stop: 40.0}\n",
    "parameters: [unclosed\n",
])
def test_bad_config_exits_2_with_a_message(write_config, text):
    result = run(write_config(text), "--json")
    assert result.exit_code == 2
    assert "Error" in result.output and "Traceback" not in result.output
    assert result.stdout == ""  # nothing a script could mistake for JSON


def test_missing_config_exits_2(tmp_path):
    result = run(tmp_path / "nowhere.yaml")
    assert result.exit_code == 2 and "Traceback" not in result.output
