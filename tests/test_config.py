"""The config loader: defaults, every error case with its file, line and field path, overrides,
the grid, the canonical YAML, and a property test that nothing but ConfigError ever escapes."""

import dataclasses
import json
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vrsweep.config import (
    INITIAL_DEFAULTS, INTEGRATION_DEFAULTS, Axis, Config, load_config, parse_config, with_overrides,
)
from vrsweep.errors import ConfigError
from vrsweep.numerics.model import DEFAULT_PARAMETERS, PARAMETER_NAMES

CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def problems(text, overrides=(), name="fig1.yaml"):
    """The problems parse_config reports for ``text`` (dedented), which must be invalid."""
    with pytest.raises(ConfigError) as info:
        parse_config(textwrap.dedent(text), source_name=name, overrides=overrides)
    assert info.value.problems, "a ConfigError must list its problems"
    return info.value.problems


def only_problem(text, overrides=(), name="fig1.yaml"):
    found = problems(text, overrides, name)
    assert len(found) == 1, found
    return found[0]


def assert_words(problem, *words):
    for word in words:
        assert word in problem, f"{word!r} not in {problem!r}"


# -- defaults and types ----------------------------------------------------------------------


def test_empty_config_is_the_papers_single_point():
    config = parse_config("")
    assert config.model == "original"
    assert config.parameters == DEFAULT_PARAMETERS
    assert config.parameters == {"gamma": 0.22, "alpha": 0.1, "c": 0.04, "omega0": 0.1, "omega": 0.5,
                                 "Delta": 1.0, "e": 0.95, "g": 0.0, "Omega": 4.0}
    assert config.initial == {"x": 0.99, "v": 0.5} == INITIAL_DEFAULTS
    assert config.axes == () and config.shape == () and config.n_points == 1
    assert config.integration.rtol == 1e-9 and config.integration.atol == 1e-11
    assert config.integration.transient_periods == 100 and config.integration.measure_periods == 100
    assert {key: getattr(config.integration, key) for key in INTEGRATION_DEFAULTS} == INTEGRATION_DEFAULTS
    assert config.output is None


def test_empty_sections_read_as_defaults():
    assert parse_config("parameters:\ninitial:\nsweep:\nintegration:\n") == parse_config("")


def test_yaml_1_2_exponent_floats_and_ints_for_floats():
    config = parse_config("integration: {rtol: 1e-9, atol: 1.0e-12, divergence_bound: 1e6}\n"
                          "parameters: {Omega: 5}\n")
    assert config.integration.rtol == 1e-9 and isinstance(config.integration.rtol, float)
    assert config.integration.atol == 1e-12
    assert config.parameters["Omega"] == 5.0 and isinstance(config.parameters["Omega"], float)


def test_counts_written_as_integral_floats_are_counts():
    config = parse_config("integration: {max_steps: 2e7}")
    assert config.integration.max_steps == 20_000_000 and isinstance(config.integration.max_steps, int)


def test_a_string_is_not_silently_a_number():
    assert_words(only_problem("parameters:\n  c: '0.04'\n"), "fig1.yaml:2:", "parameters.c", "must be a number")
    assert_words(only_problem("parameters: {e: yes}"), "parameters.e", "must be a number", "'yes'")
    assert_words(only_problem("parameters: {e: true}"), "parameters.e", "must be a number", "true")


# -- every error case, with file, line and field path ----------------------------------------


@pytest.mark.parametrize("text, line, words", [
    ("parameters:\n  gamma: 0.2\n  e: 1.5\n", 3, ["parameters.e", "must be in (0, 1]", "got 1.5"]),
    ("parameters:\n  e: 0\n", 2, ["parameters.e", "(0, 1]", "got 0"]),
    ("parameters:\n  omega: 0\n", 2, ["parameters.omega", "must be > 0"]),
    ("parameters:\n  Omega: -4\n", 2, ["parameters.Omega", "must be > 0"]),
    ("integration:\n  rtol: 0\n", 2, ["integration.rtol", "[1e-14, 0.01]"]),
    ("integration:\n  rtol: 1\n", 2, ["integration.rtol", "[1e-14, 0.01]"]),
    ("integration:\n  rtol: 0.1\n", 2, ["integration.rtol", "[1e-14, 0.01]", "got 0.1"]),
    ("integration:\n  atol: 0.5\n", 2, ["integration.atol", "(0, 0.01]"]),
    ("integration:\n  period_tolerance: 10\n", 2, ["integration.period_tolerance", "(0, 0.001]"]),
    ("integration:\n  atol: -1e-12\n", 2, ["integration.atol", "(0, 0.01]"]),
    ("integration:\n  divergence_bound: 0\n", 2, ["integration.divergence_bound", "> 0"]),
    ("integration:\n  stick_velocity: 0\n", 2, ["integration.stick_velocity", "> 0"]),
    ("integration:\n  period_tolerance: 0\n", 2, ["integration.period_tolerance", "(0, 0.001]"]),
    ("integration:\n  transient_periods: -1\n", 2, ["integration.transient_periods", "integer >= 0"]),
    ("integration:\n  transient_periods: 1.5\n", 2, ["integration.transient_periods", "must be an integer"]),
    ("integration:\n  measure_periods: 0\n", 2, ["integration.measure_periods", "integer >= 1"]),
    ("integration:\n  max_steps: 0\n", 2, ["integration.max_steps", ">= 1"]),
    ("integration:\n  max_impacts_per_period: 0\n", 2, ["integration.max_impacts_per_period", ">= 1"]),
    ("integration:\n  strobe_periods: 0\n", 2, ["integration.strobe_periods", ">= 1"]),
    ("integration:\n  max_period: 0\n", 2, ["integration.max_period", ">= 1"]),
    ("integration:\n  strobe_periods: 120\n", 2,
     ["integration.strobe_periods", "<= integration.measure_periods = 100", "got 120"]),
    ("integration:\n  measure_periods: 8\n", 2,
     ["integration.measure_periods", ">= integration.strobe_periods = 16"]),
    ("parameters:\n  Delta: 0.9\n", 2, ["parameters.Delta", "above initial.x = 0.99", "got 0.9"]),
    ("initial:\n  x: 1.0\n", 2, ["initial.x", "below parameters.Delta = 1.0", "got 1.0"]),
    ("model: orignal\n", 1, ["model", "one of original, effective", "did you mean 'original'"]),
    ("output: 3\n", 1, ["output", "must be a string"]),
    ("output: ''\n", 1, ["output", "empty"]),
    ("\nparameters: [1, 2]\n", 2, ["parameters", "must be a mapping", "allowed: gamma"]),
    ("parameters:\n  c: .nan\n", 2, ["parameters.c", "finite"]),
    ("initial:\n  v: .inf\n", 2, ["initial.v", "finite"]),
])
def test_value_errors(text, line, words):
    problem = only_problem(text)
    assert problem.startswith(f"fig1.yaml:{line}: "), problem
    assert_words(problem, *words)


@pytest.mark.parametrize("text, words", [
    ("integration:\n  measure_periods: 1e23\n", ["integration.measure_periods", "got 1e+23"]),
    ("integration:\n  max_steps: 1.0e30\n", ["integration.max_steps", "got 1e+30"]),
    ("integration:\n  transient_periods: 9223372036854775808\n", ["integration.transient_periods", ">= 0"]),
    ("integration:\n  measure_periods: 2.5\n", ["integration.measure_periods", "must be an integer, got 2.5"]),
])
def test_a_count_beyond_int64_is_told_its_limit(text, words):
    """`measure_periods: 1e23` said "must be an integer, got 1e+23 (allowed: an integer >= 1)": a
    whole number, within what was said allowed. The kernel reads its counts from doubles, exact to
    2^53, and the message says so."""
    problem = only_problem(text)
    assert_words(problem, *words, "<= 2^53 = 9007199254740992")
    assert problem.startswith("fig1.yaml:2: "), problem


def test_a_count_below_its_least_is_not_told_int64():
    assert only_problem("integration:\n  measure_periods: 0\n").endswith("must be an integer >= 1, got 0")


@pytest.mark.parametrize("text, line, words", [
    ("sweep:\n  g: {start: 40, stop: 0, num: 81}\n", 2,
     ["sweep.g.stop", "must be >= start", "use an explicit list or swap start and stop",
      "continuation: down sweeps downwards"]),
    ("sweep:\n  g: {start: 0, stop: 1, num: 1}\n", 2, ["sweep.g.num", "num = 1 needs start == stop"]),
    ("sweep:\n  g: {start: 0, stop: 1, num: 0}\n", 2, ["sweep.g.num", "integer in [1,"]),
    ("sweep:\n  g: {start: 0, stop: 1, num: 2.5}\n", 2, ["sweep.g.num", "must be an integer"]),
    ("sweep:\n  g: {start: 0, stop: 1}\n", 2, ["sweep.g.num", "missing"]),
    ("sweep:\n  g: {start: 0, stop: 1, num: 3, step: 1}\n", 2, ["sweep.g.step", "unknown key", "allowed: start"]),
    ("sweep:\n  g: {strat: 0, stop: 1, num: 3}\n", 2, ["sweep.g.strat", "did you mean 'start'"]),
    ("sweep:\n  g: []\n", 2, ["sweep.g", "must not be empty"]),
    ("sweep:\n  g: {values: []}\n", 2, ["sweep.g.values", "must not be empty"]),
    ("sweep:\n  g:\n    - 1\n    - abc\n", 4, ["sweep.g[1]", "must be a number", "'abc'"]),
    ("sweep:\n  g: [1, .nan]\n", 2, ["sweep.g[1]", "finite"]),
    ("sweep:\n  gg: [1, 2]\n", 2, ["sweep.gg", "not a parameter", "did you mean 'g'", "allowed: gamma"]),
    ("sweep:\n  delta: [1.5, 2]\n", 2, ["sweep.delta", "did you mean 'Delta'"]),
    ("sweep:\n  g: 5\n", 2, ["sweep.g", "set parameters.g"]),
    ("sweep: [g, Omega]\n", 1, ["sweep", "must be a mapping"]),
    ("sweep:\n  e: [0.5, 1.5]\n", 2, ["sweep.e[1]", "must be in (0, 1]", "got 1.5"]),
    ("sweep:\n  e: {start: 0, stop: 1, num: 11}\n", 2, ["sweep.e.start", "(0, 1]", "got 0"]),
    ("sweep:\n  Omega: {values: [4, -5]}\n", 2, ["sweep.Omega.values[1]", "> 0"]),
    ("sweep:\n  Delta: [2, 0.5]\n", 2, ["sweep.Delta[1]", "above initial.x = 0.99", "got 0.5"]),
    ("sweep:\n  Delta: {start: 0.9, stop: 2, num: 3}\n", 2, ["sweep.Delta.start", "above initial.x"]),
    ("sweep:\n  g: {values: [1, 2], continuation: sideways}\n", 2,
     ["sweep.g.continuation", "one of up, down, both"]),
    ("sweep:\n  g: {values: [1, 2], start: 0}\n", 2, ["sweep.g.start", "either {start, stop, num} or {values"]),
    ("sweep:\n  g: {start: 0, stop: 1, num: 100000000}\n", 2, ["sweep.g.num", "10000000"]),
    ("output: \"a\\ud800b\"\n", 1, ["output", "unpaired surrogate"]),
])
def test_sweep_errors(text, line, words):
    problem = only_problem(text)
    assert problem.startswith(f"fig1.yaml:{line}: "), problem
    assert_words(problem, *words)


def test_continuation_on_two_axes():
    problem = only_problem("""\
        sweep:
          g: {start: 0, stop: 40, num: 5, continuation: up}
          Omega: {values: [4, 5], continuation: both}
        """)
    assert_words(problem, "fig1.yaml:3:", "sweep.Omega.continuation", "only one axis", "sweep.g")


def test_unknown_keys_with_did_you_mean():
    found = problems("""\
        modle: original
        parameters:
          gama: 0.2
          rtol: 1e-9
        integration:
          transient: 10
        g: 5
        """)
    assert_words(found[0], "fig1.yaml:1:", "modle", "unknown key", "did you mean 'model'", "allowed: model")
    assert_words(found[1], "fig1.yaml:3:", "parameters.gama", "did you mean 'gamma'")
    assert_words(found[2], "fig1.yaml:4:", "parameters.rtol", "did you mean integration.rtol")
    assert_words(found[3], "fig1.yaml:6:", "integration.transient", "did you mean 'transient_periods'")
    assert_words(found[4], "fig1.yaml:7:", "g: unknown key", "did you mean parameters.g")
    assert len(found) == 5


def test_same_parameter_twice_reports_file_and_both_lines():
    found = problems("""\
        sweep:
          g: {start: 0, stop: 40, num: 81}
          Omega: [4, 5]
          g: [1, 2]
        parameters:
          e: 1.5
        """)
    assert_words(found[0], "fig1.yaml:4:", "sweep.g", "given twice", "lines 2 and 4")
    assert_words(found[1], "fig1.yaml:6:", "parameters.e", "(0, 1]")  # and the rest is still checked


def test_yaml_syntax_error_has_line_column_and_problem():
    problem = only_problem("parameters:\n  e: 0.5\n  g: [1, 2\nsweep: {}\n")
    assert problem.startswith("fig1.yaml:4:6: YAML syntax error: "), problem
    assert_words(problem, "expected ',' or ']'", "flow sequence started on line 3")
    problem = only_problem("parameters:\n  e: 0.5\n   g: 3\n")
    assert_words(problem, "fig1.yaml:3:", "YAML syntax error", "mapping values are not allowed")


def test_not_a_mapping():
    assert_words(only_problem("- 1\n- 2\n"), "fig1.yaml:1:", "must be a mapping of sections")
    assert_words(only_problem("just words"), "fig1.yaml:1:", "must be a mapping of sections")


def test_many_problems_reported_at_once_in_line_order():
    found = problems("""\
        model: effective
        parameters:
          e: 2
          omega: -1
        sweep:
          g: {start: 10, stop: 0, num: 5}
          Omegaa: [1]
        integration:
          rtol: abc
          measure_periods: 0
        """)
    lines = [int(problem.split(":")[1]) for problem in found]
    assert lines == [3, 4, 6, 7, 9, 10], found
    assert all(problem.startswith("fig1.yaml:") for problem in found)


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path / "nope.yaml")
    assert_words(info.value.problems[0], "nope.yaml", "no such config file")
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path)
    assert "directory" in info.value.problems[0]


def test_load_config_names_the_file_as_given(tmp_path, monkeypatch):
    (tmp_path / "fig1.yaml").write_text("parameters:\n  e: 1.5\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as info:
        load_config("fig1.yaml")
    assert info.value.problems == ["fig1.yaml:2: parameters.e: must be in (0, 1], got 1.5"]


# -- overrides -------------------------------------------------------------------------------


FIG1 = """\
parameters: {Omega: 4.0}
sweep:
  g: {start: 0.0, stop: 40.0, num: 81}
  Omega: [4.0, 5.0]
"""


def test_override_a_parameter_integration_key_initial_and_model():
    config = parse_config(FIG1, overrides=["e=0.8", "rtol=1e-10", "initial.v=0", "model=effective",
                                           "integration.measure_periods=50", "parameters.c=0.05"])
    assert config.parameters["e"] == 0.8 and config.parameters["c"] == 0.05
    assert config.integration.rtol == 1e-10 and config.integration.measure_periods == 50
    assert config.initial["v"] == 0.0 and config.model == "effective"
    assert config.overrides == ("e=0.8", "rtol=1e-10", "initial.v=0", "model=effective",
                                "integration.measure_periods=50", "parameters.c=0.05")


def test_override_of_the_continuation_section():
    """--set continuation.KEY: one config serves several starts (docs/continuation.md, Fig. 1)."""
    text = "continuation: {parameter: g, from: 17.86, to: [0.0, 40.0], max_step: 0.5}\n"
    config = parse_config(text, overrides=["continuation.from=30", "continuation.to=18,40",
                                           "continuation.max_step=0.05", "continuation.switch=true"])
    section = config.continuation
    assert (section.start, section.low, section.high, section.max_step, section.switch) == (30.0, 18.0, 40.0, 0.05, True)
    # the range as the config writes it, [LOW, HIGH], as well (it was split at its comma and read as
    # the scalars "[18" and " 40]": "VALUE is not a YAML scalar (expected ',' or ']', but got
    # '<stream end>')")
    for written in ("[18, 40]", " [18,40] "):
        bracketed = parse_config(text, overrides=[f"continuation.to={written}"]).continuation
        assert (bracketed.low, bracketed.high) == (18.0, 40.0)
    for wrong in ("18", "[18]", "18,30,40", "[18,]", ""):
        assert only_problem(text, overrides=[f"continuation.to={wrong}"]) == (
            f"--set continuation.to={wrong}: continuation.to: expected two numbers LOW,HIGH, e.g. --set "
            f"continuation.to=20,27 or '[20, 27]', got {wrong.strip()!r}")
    assert only_problem(text, overrides=["continuation.max_step=-1"]) == \
        "--set continuation.max_step=-1: continuation.max_step: must be > 0, got -1.0"
    # max_period is an integration key too: without the section's name it stays the integration's
    assert parse_config(text, overrides=["max_period=4"]).continuation.max_period == section.max_period


def test_override_of_a_swept_parameter_removes_its_axis():
    config = parse_config(FIG1, overrides=["g=5"])
    assert config.axis_names == ("Omega",) and config.parameters["g"] == 5.0
    config = parse_config(FIG1, overrides=["g=5", "Omega=4"])
    assert config.axes == () and config.n_points == 1 and config.parameters["Omega"] == 4.0


def test_a_boolean_says_true_or_false_in_the_configs_words():
    """Strict: 'yes', 'on', 1 or a quoted "true" is not taken for true (YAML 1.2 reads yes as a
    word), and the message is worded as every other one, not pydantic's 'Input should be...'."""
    assert only_problem("integration: {lyapunov: yes}") == \
        "fig1.yaml:1: integration.lyapunov: must be true or false, got 'yes'"
    assert only_problem("", overrides=["lyapunov=yes"]) == \
        "--set lyapunov=yes: integration.lyapunov: must be true or false, got 'yes'"
    assert only_problem("", overrides=["lyapunov=1"]) == \
        "--set lyapunov=1: integration.lyapunov: must be true or false, got 1"
    assert_words(only_problem("integration:\n  lyapunov: 'true'\n"), "fig1.yaml:2:", "got 'true'")
    assert parse_config("integration: {lyapunov: true}").integration.lyapunov is True
    assert parse_config("", overrides=["lyapunov=false"]).integration.lyapunov is False


def test_bad_overrides_are_reported_with_the_other_problems():
    found = problems("parameters:\n  e: 1.5\n  omega: 0\n",
                     overrides=["gg=5", "e=0.5", "rtol=abc", "g", "g=[1", "Omega=-1", "model=nope"])
    assert found == [
        "fig1.yaml:3: parameters.omega: must be > 0, got 0.0",
        "--set gg=5: unknown name 'gg' (did you mean 'g'?) "
        "(allowed: a parameter (gamma, alpha, c, omega0, omega, Delta, e, g, Omega), an integration key, "
        "initial.x (or x0), initial.v (or v0), model or continuation.KEY)",
        "--set rtol=abc: integration.rtol: must be a number, got 'abc' (allowed: a number in [1e-14, 0.01])",
        "--set g: expected NAME=VALUE, e.g. --set g=5",
        "--set g=[1: VALUE is not a YAML scalar (expected ',' or ']', but got '<stream end>')",
        "--set Omega=-1: parameters.Omega: must be > 0, got -1.0",
        "--set model=nope: model: must be one of original, effective, got 'nope'",
    ]  # and e=0.5 replaced the file's bad e, which is therefore no longer a problem


def test_a_setting_given_twice_with_two_values_is_refused_naming_both():
    # The later value was taken without a word (--set g=5 ... --set parameters.g=6), as plot --at
    # once took the later of two values of one axis.
    assert only_problem("", overrides=["g=5", "parameters.g=6"]) == (
        "--set parameters.g=6: parameters.g is already set by --set g=5: give one value")
    assert only_problem("", overrides=["x0=0.1", "initial.x=0.2"]) == (
        "--set initial.x=0.2: initial.x is already set by --set x0=0.1: give one value")
    assert only_problem("", overrides=["lyapunov=true", "integration.lyapunov=false"]).startswith(
        "--set integration.lyapunov=false: integration.lyapunov is already set by --set lyapunov=true")
    assert problems("", overrides=["continuation.to=1,2", "continuation.to=1,3"])[-1] == (
        "--set continuation.to=1,3: continuation.to is already set by --set continuation.to=1,2: give one value")
    assert len(problems("", overrides=["g=5", "g=6", "parameters.g=7"])) == 2
    # The same value twice says one thing: taken.
    assert parse_config("", overrides=["g=5", "parameters.g=5.0", "g=5"]).parameters["g"] == 5.0
    assert parse_config("", overrides=["lyapunov=true", "lyapunov=true"]).integration.lyapunov is True


def test_a_setting_given_twice_through_keyword_arguments_names_both():
    import vrsweep

    with pytest.raises(ConfigError) as info:
        vrsweep.theory({"model": "effective"}, g=5, **{"parameters.g": 6})
    assert info.value.problems == [
        "keyword argument parameters.g=6: parameters.g is already set by keyword argument g=5: give one value"]


def test_a_tilde_in_the_configs_output_is_the_home_folder(monkeypatch, tmp_path):
    # No shell expands a config's text: output: ~/results/x.h5 wrote ./~/results/x.h5.
    monkeypatch.setenv("HOME", str(tmp_path))
    config = parse_config("output: ~/results/x.h5\n")
    assert config.output_path() == tmp_path / "results" / "x.h5"
    assert config.output == "~/results/x.h5"  # the config as written: what --resume compares
    assert parse_config("output: results/~x.h5\n").output_path() == Path("results/~x.h5")
    assert config.output_path("~/given.h5") == Path("~/given.h5")  # -o: the shell's business


def test_override_breaking_a_cross_field_rule():
    assert_words(only_problem("", overrides=["Delta=0.5"]), "--set Delta=0.5: parameters.Delta",
                 "at or above initial.x")


def test_override_is_blamed_for_a_broken_rule_even_if_the_file_set_the_other_field():
    assert only_problem("parameters: {Delta: 1.2}\n", overrides=["initial.x=1.3"]) == (
        "--set initial.x=1.3: initial.x: must be at or below parameters.Delta = 1.2 "
        "(the mass starts below or on the barrier), got 1.3")
    assert_words(only_problem("integration: {strobe_periods: 10}\n", overrides=["measure_periods=5"]),
                 "--set measure_periods=5: integration.measure_periods: must be >= integration.strobe_periods = 10")


def test_a_measure_window_below_the_default_strobe_periods_names_that_default():
    """measure_periods: 10 alone was refused as below "integration.strobe_periods = 16", a key the
    config never wrote: the message says it is the default and what to set."""
    assert only_problem("integration: {measure_periods: 10}\n").endswith(
        "integration.measure_periods: must be >= integration.strobe_periods = 16 (its default; set "
        "integration.strobe_periods <= 10 for a shorter window), got 10")


def test_override_name_in_the_wrong_form_gets_a_hint():
    assert_words(only_problem("", overrides=["x=0.5"]), "--set x=0.5: unknown name 'x' (did you mean initial.x?)")


def test_with_overrides_applies_on_top_and_keeps_the_origin():
    config = parse_config("parameters:\n  g: 1\n", source_name="a.yaml", overrides=["e=0.5"])
    changed = with_overrides(config, ["g=2"])
    assert changed.parameters["g"] == 2.0 and changed.parameters["e"] == 0.5
    assert changed.source_text == config.source_text and changed.source_name == "a.yaml"
    assert changed.overrides == ("e=0.5", "g=2")
    with pytest.raises(ConfigError) as info:
        with_overrides(config, ["e=7"])
    assert info.value.problems == ["--set e=7: parameters.e: must be in (0, 1], got 7.0"]
    # a Config changed in code keeps its changes
    replaced = dataclasses.replace(config, model="effective")
    assert with_overrides(replaced, ["c=0.1"]).model == "effective"


# -- grid, output path, canonical YAML -------------------------------------------------------


def test_grid_parameters_broadcast_in_axis_order():
    config = parse_config("""\
        parameters: {c: 0.05}
        sweep:
          g: {start: 0, stop: 10, num: 3}
          Omega: [4, 5]
          e: {values: [0.9, 0.8, 0.7, 0.6]}
        """)
    assert config.shape == (3, 2, 4) and config.n_points == 24
    assert config.axis_names == ("g", "Omega", "e")
    grid = config.grid_parameters()
    assert set(grid) == set(PARAMETER_NAMES)
    for array in grid.values():
        assert array.shape == (3, 2, 4) and array.dtype == np.float64
    assert np.array_equal(grid["g"][:, 1, 2], [0.0, 5.0, 10.0])
    assert np.array_equal(grid["Omega"][2, :, 0], [4.0, 5.0])
    assert np.array_equal(grid["e"][0, 0, :], [0.9, 0.8, 0.7, 0.6])
    assert np.all(grid["c"] == 0.05) and np.all(grid["Delta"] == 1.0)
    assert np.all(grid["g"][1] == 5.0)  # g varies along dimension 0 only


def test_axis_values_are_float64_read_only_and_in_the_order_given():
    config = parse_config("sweep:\n  g: [3, 2, 1]\n")
    axis = config.axes[0]
    assert isinstance(axis, Axis) and axis.values.dtype == np.float64 and axis.values.ndim == 1
    assert list(axis.values) == [3.0, 2.0, 1.0] and axis.continuation is None
    with pytest.raises(ValueError):
        axis.values[0] = 7.0


def test_output_path_precedence(tmp_path):
    config = parse_config("output: results/x.h5\n", source_name="configs/fig1.yaml")
    assert config.output_path() == Path("results/x.h5")
    assert config.output_path("o.h5") == Path("o.h5")
    assert parse_config("", source_name="configs/fig1.yaml").output_path() == Path("fig1.h5")
    assert parse_config("").output_path() == Path("vrsweep.h5")


CANONICAL_CASES = [
    "",
    FIG1,
    "model: effective\nsweep:\n  Omega: {values: [5, 4], continuation: down}\n  g: [0, 1e-3]\n",
    "sweep:\n  g: [0, 20, 40]\noutput: \"r\u00e9sultats/\\\"q\\\"\\t.h5\"\n",
    "sweep:\n  g: {start: 0, stop: 40, num: 81, continuation: both}\nintegration: {rtol: 3.3e-10}\n",
]


@pytest.mark.parametrize("text", CANONICAL_CASES)
def test_to_yaml_round_trips_and_is_stable(text):
    config = parse_config(text, overrides=["c=0.03"])
    canonical = config.to_yaml()
    again = parse_config(canonical)
    assert again == config
    assert again.to_yaml() == canonical
    for axis, axis_again in zip(config.axes, again.axes):
        assert np.array_equal(axis.values, axis_again.values) and axis.continuation == axis_again.continuation


def test_to_yaml_is_the_same_however_the_config_was_written():
    short = parse_config("sweep: {g: {start: 0, stop: 40, num: 5}}")
    long = parse_config("parameters: {gamma: 0.22, g: 0}\ninitial: {x: 0.99}\nsweep:\n  g: [0, 10, 20, 30, 40]\n")
    assert short == long and short.to_yaml() == long.to_yaml()
    assert "g: {start: 0.0, stop: 40.0, num: 5}" in short.to_yaml()


def test_configs_differ_when_content_differs():
    assert parse_config("") != parse_config("parameters: {g: 1}")
    assert parse_config("sweep: {g: [1, 2]}") != parse_config("sweep: {g: [1, 3]}")
    assert parse_config("") == parse_config("", source_name="other.yaml")


# -- shipped configs -------------------------------------------------------------------------


@pytest.mark.parametrize("path", sorted(CONFIGS.glob("*.yaml")), ids=lambda path: path.name)
def test_shipped_configs_load(path):
    config = load_config(path)
    assert config.model in ("original", "effective") or config.written
    assert parse_config(config.to_yaml()) == config


def test_shipped_configs_are_what_they_say():
    fig1 = load_config(CONFIGS / "fig1.yaml")
    assert fig1.axis_names == ("g",) and fig1.parameters["Omega"] == 4.0
    assert np.array_equal(fig1.axes[0].values, np.linspace(0, 40, 81))
    assert str(fig1.output_path()) == "results/fig1.h5"
    fig2 = load_config(CONFIGS / "fig2.yaml")
    assert fig2.parameters["Omega"] == 5.0 and fig2.shape == (121,) and fig2.axes[0].values[-1] == 60.0
    grid = load_config(CONFIGS / "map_g_Omega.yaml")
    assert grid.axis_names == ("g", "Omega") and grid.n_points <= 500
    quick = load_config(CONFIGS / "quickstart.yaml")
    from vrsweep.execution.estimate import estimate

    assert estimate(quick, 1).seconds < 2.0  # "in a few seconds", compile time aside
    assert str(quick.output_path()) == "quickstart.h5"
    for config in (fig1, fig2, grid, quick):
        assert {name: config.parameters[name] for name in PARAMETER_NAMES if name not in ("g", "Omega")} == {
            name: DEFAULT_PARAMETERS[name] for name in PARAMETER_NAMES if name not in ("g", "Omega")}


# -- property tests: nothing but a Config or a ConfigError -----------------------------------


KEYS = ["model", "parameters", "initial", "sweep", "integration", "output", "start", "stop", "num",
        "values", "continuation", "x", "v", "modle", "swep", "", "<<", *PARAMETER_NAMES,
        *INTEGRATION_DEFAULTS, "Omegaa", "delta"]
SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(-10, 10), st.integers(), st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-100, 100), st.sampled_from(["original", "effective", "up", "down", "both", "abc", "1e-9",
                                           "", "results/x.h5"]),
    st.text(max_size=8),
)
VALUES = st.recursive(
    SCALARS,
    lambda children: st.one_of(st.lists(children, max_size=4),
                               st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=5), children, max_size=5)),
    max_leaves=20,
)
DOCUMENTS = st.dictionaries(st.sampled_from(KEYS), VALUES, max_size=7)
OVERRIDES = st.lists(st.one_of(
    st.builds(lambda key, value: f"{key}={value}", st.sampled_from(KEYS + ["initial.x", "integration.rtol"]),
              st.sampled_from(["5", "0", "-1", "1e-9", "abc", "", "[1", "{a: 1}", "up", "effective", "0.5"])),
    st.text(max_size=10)), max_size=3)


def parse_or_config_error(text, overrides=()):
    try:
        config = parse_config(text, source_name="random.yaml", overrides=overrides)
    except ConfigError as error:
        assert error.problems and all(isinstance(problem, str) and problem for problem in error.problems)
        return None
    assert isinstance(config, Config)
    assert len(config.parameters) == 9 and config.n_points >= 1
    assert parse_config(config.to_yaml()) == config
    return config


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(DOCUMENTS, OVERRIDES)
def test_random_documents_give_a_config_or_a_config_error(document, overrides):
    parse_or_config_error(json.dumps(document), overrides)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80))
def test_random_text_gives_a_config_or_a_config_error(text):
    parse_or_config_error(text)


YAML_ALPHABET = st.sampled_from(list(":-[]{},#&*!|>'\"%@` \n\t?.0123456789eE+gOmega<") + ["\x00", "\ufeff"])


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(CANONICAL_CASES + [FIG1]), st.lists(st.tuples(st.integers(0, 200), st.text(YAML_ALPHABET,
                                                                                                 max_size=3)),
                                                           max_size=3))
def test_mutated_configs_give_a_config_or_a_config_error(text, edits):
    for position, insert in edits:
        position = position % (len(text) + 1)
        text = text[:position] + insert + text[position:]
    parse_or_config_error(text)


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
positive = st.floats(1e-6, 1e6)


@st.composite
def valid_documents(draw):
    """A random config that must be accepted."""
    x = draw(st.floats(-2, 2))
    parameters = {
        "gamma": draw(finite), "alpha": draw(finite), "c": draw(positive), "omega0": draw(finite),
        "omega": draw(positive), "Delta": draw(st.floats(x + 1e-3, 10)), "e": draw(st.floats(1e-3, 1)),
        "g": draw(finite), "Omega": draw(positive),
    }
    sweep = {}
    for name in draw(st.lists(st.sampled_from(["g", "Omega", "c", "alpha"]), unique=True, max_size=3)):
        low = 0.1 if name in ("Omega", "c") else -5.0
        if draw(st.booleans()):
            start = draw(st.floats(low, 10))
            stop = draw(st.floats(start, 20).filter(lambda stop: stop - start > 1e-9 * max(1, abs(start))))
            sweep[name] = {"start": start, "stop": stop, "num": draw(st.integers(2, 30))}
        else:
            values = sorted(draw(st.lists(st.floats(low, 20), min_size=1, max_size=5, unique=True)))
            sweep[name] = values[::-1] if draw(st.booleans()) else values  # strictly monotonic, either way
    measure = draw(st.integers(1, 500))
    integration = {"rtol": draw(st.floats(1e-14, 1e-2)), "measure_periods": measure,
                   "transient_periods": draw(st.integers(0, 500)), "strobe_periods": draw(st.integers(1, measure))}
    document = {"model": draw(st.sampled_from(["original", "effective"])), "parameters": parameters,
                "initial": {"x": x, "v": draw(finite)}, "sweep": sweep, "integration": integration}
    if draw(st.booleans()):
        # any text but NUL and unpaired surrogates; ASCII-escaped JSON is valid YAML
        document["output"] = draw(st.text(st.characters(blacklist_categories=("Cs",)), min_size=1,
                                          max_size=12).filter(lambda s: s.strip() and "\0" not in s))
    return document


@settings(max_examples=200, deadline=None)
@given(valid_documents())
def test_random_valid_configs_are_accepted_and_round_trip(document):
    config = parse_config(json.dumps(document))
    assert config.shape == tuple(len(spec) if isinstance(spec, list) else spec["num"]
                                 for spec in document["sweep"].values())
    canonical = config.to_yaml()
    again = parse_config(canonical)
    assert again == config and again.to_yaml() == canonical
    assert again.output == document.get("output")
