"""Issue 24, class 5: every option that takes a number, given nan, inf or a huge value, answers the
question asked or refuses it in one line (exit 2); none draws, computes or writes something else.

The families: --at NAME=VALUE (plot), --set FIELD=VALUE (every numeric config field), --json of
theory at huge g, --progress-interval, --threads, --shard, --samples-per-period, --dpi.
"""

import json
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vrsweep.config.schema import INITIAL_DOMAINS, INTEGRATION_DOMAINS, PARAMETER_DOMAINS

CONFIG = """\
model: effective
sweep:
  g: {start: 0, stop: 40, num: 3}
  Omega: [3, 4]
integration: {transient_periods: 2, measure_periods: 16}
"""
NOT_FINITE = ["nan", "NaN", "inf", "-inf", "+inf", "Infinity", "1e400", "-1e400", ".nan", ".inf", "-.inf"]
HUGE = ["1e308", "-1e308", "99999999999999999999999999", "1.7976931348623157e308"]
SETTINGS = settings(max_examples=8, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, sweep_file):
    return sweep_file(tmp_path_factory.mktemp("numbers"), CONFIG)


def _one_line_refusal(result):
    lines = [line for line in result.output.strip().splitlines() if line.startswith("Error")]
    assert result.exit_code == 2, result.output
    assert len(lines) == 1, result.output
    return lines[0]


@SETTINGS
@given(axis=st.sampled_from(["g", "Omega"]),
       value=st.one_of(st.sampled_from(NOT_FINITE + HUGE), st.floats(allow_nan=True, allow_infinity=True).map(repr)))
def test_plot_at_answers_only_a_value_on_the_axis(sweep, tmp_path, invoke, axis, value):
    _, path = sweep
    on_axis = {"g": [0.0, 20.0, 40.0], "Omega": [3.0, 4.0]}[axis]
    figure = tmp_path / "figure.png"
    figure.unlink(missing_ok=True)  # tmp_path is shared by the examples
    result = invoke("plot", path, "-o", figure, "--at", f"{axis}={value}", "--kind", "status")
    try:
        number = float(value)
    except ValueError:  # .nan, .inf: YAML's spellings, not numbers to --at
        number = math.nan
    if math.isfinite(number) and any(abs(number - v) <= 1e-9 * max(1.0, abs(number)) for v in on_axis):
        assert result.exit_code == 0, result.output
    else:
        line = _one_line_refusal(result)
        assert any(words in line for words in ("not a finite number", "not a value of the axis", "not a number")), line
        assert not figure.exists()


NUMERIC_FIELDS = ([f"parameters.{name}" for name in PARAMETER_DOMAINS] + [f"initial.{name}" for name in INITIAL_DOMAINS]
                  + [f"integration.{name}" for name in INTEGRATION_DOMAINS])


@SETTINGS
@given(field=st.sampled_from(NUMERIC_FIELDS), value=st.sampled_from(NOT_FINITE))
def test_every_numeric_config_field_refuses_non_finite_values(tmp_path, invoke, write_config, field, value):
    config = write_config(tmp_path, "model: effective\n")
    line = _one_line_refusal(invoke("validate", config, "--set", f"{field}={value}"))
    assert field.split(".")[-1] in line, line


@SETTINGS
@given(g=st.floats(min_value=1e150, max_value=1.7e308))
def test_theory_json_at_huge_g_is_json(tmp_path, invoke, write_config, g):
    config = write_config(tmp_path, f"model: effective\nsweep:\n  g: [1, {g!r}]\n")
    result = invoke("theory", config, "--json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.output)  # strict JSON: no Infinity, no NaN
    assert rows and all(isinstance(row, dict) for row in rows)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400", "-1"])
def test_progress_interval_refuses_what_is_not_a_finite_number(tmp_path, invoke, write_config, value):
    config = write_config(tmp_path, CONFIG)
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--progress-interval", value)
    assert result.exit_code == 2 and "--progress-interval" in result.output, result.output
    assert not (tmp_path / "out.h5").exists()


@pytest.mark.parametrize("option,value", [("--threads", v) for v in ["nan", "inf", "1e400", "0", "-1"]]
                         + [("--shard", v) for v in ["0/nan", "nan/2", "0/1e400", "0/7", "0/99999999999999999999",
                                                     "99999999999999999999/99999999999999999999"]])
def test_run_numbers_refused(tmp_path, invoke, write_config, option, value):
    config = write_config(tmp_path, CONFIG)  # 6 points: at most 6 shards
    result = invoke("run", config, "-o", tmp_path / "out.h5", option, value)
    assert result.exit_code == 2, result.output
    assert option in result.output, result.output
    assert not list(tmp_path.glob("out*.h5"))


@pytest.mark.parametrize("value", ["nan", "inf", "1e400", "0", "99999999999999999999"])
def test_samples_per_period_refused(tmp_path, invoke, write_config, value):
    config = write_config(tmp_path, "model: effective\nparameters: {g: 5}\n")
    result = invoke("simulate", config, "-o", tmp_path / "t.h5", "--samples-per-period", value)
    assert result.exit_code == 2, result.output
    assert not (tmp_path / "t.h5").exists()


@pytest.mark.parametrize("value", ["nan", "inf", "1e400", "0", "99999999999999999999"])
def test_dpi_refused(sweep, tmp_path, invoke, value):
    _, path = sweep
    result = invoke("plot", path, "-o", tmp_path / "f.png", "--at", "Omega=4", "--dpi", value)
    assert result.exit_code == 2 and "--dpi" in result.output, result.output


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(["omega", "Omega", "g", "c", "alpha"]),
       value=st.sampled_from(["1e-320", "5e-324", "1e300", "1.7e308", "-1e300"]))
def test_extreme_finite_values_give_answers_not_warnings(tmp_path, invoke, write_config, name, value):
    """A value at the edge of the floats is answered (or refused by its domain) without numpy's
    overflow warnings and their source lines on the user's terminal."""
    config = write_config(tmp_path, "model: effective\n")
    for command in ("validate", "theory"):
        result = invoke(command, config, "--set", f"{name}={value}")
        assert result.exit_code in (0, 2), result.output
        assert "Warning" not in result.output, result.output
