"""Numbers as text, round 4 of the hostile inputs: one rule (vrsweep.numbertext) for every number
typed as text, and one length for every value a message quotes (errors.clip).

- Unicode digits: Python's int() and float() read "١٢" and the fullwidth "１２" as 12, so
  `--threads ١٢`, `--shard ١/٢` and `plot --xlim ١,٢` ran as if ASCII were typed.
- A value of 400 digits was quoted whole in its message (`--set g=999...`, `--shard 0/999...`).
- A literal beyond the doubles: `rtol: 1e-400` was refused as "got 0.0", `gamma: 1e-400` (and
  a written model's `1e-400*x`) ran as 0.
- Counts no kernel can run: `transient_periods: 2^63 - 1` was valid (estimated at 1.4e10 days)
  and reached the kernel as the double 2^63, whose int64 conversion overflows.
- A written model's name in Unicode's compatibility forms ('ｚeta') was read as zeta.
"""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrsweep.config import parse_config
from vrsweep.config.schema import COUNT_MAX, INTEGRATION_DOMAINS
from vrsweep.errors import ConfigError, UsageError, clip
from vrsweep.numbertext import NumberTextError, read_float, read_int

FOREIGN = ["١٢", "１２", "۱۲", "१२", "𝟏𝟐"]  # Arabic-Indic, fullwidth, Persian, Devanagari, mathematical bold
BIG = "9" * 400
CONFIG = "model: effective\nintegration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}\n"


def _one_line(result):
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error"), result.output
    assert "Traceback" not in result.output
    return lines[0]


def _problem(text):
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "c.yaml")
    assert len(caught.value.problems) == 1, caught.value.problems
    return caught.value.problems[0]


# --- the rule itself -------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(st.text(min_size=1, max_size=12))
def test_only_ascii_decimal_text_is_a_number(text):
    """Any text holding a character outside ASCII is no number; an ASCII one that is, is Python's."""
    for read in (read_int, read_float):
        try:
            value = read(text)
        except NumberTextError:
            continue
        assert text.strip(" \t").isascii(), (text, value)
        assert value == (int if read is read_int else float)(text)


@pytest.mark.parametrize("text", FOREIGN)
def test_unicode_digits_are_refused_saying_so(text):
    assert int(text) == 12  # what Python does, and vrsweep did
    for read in (read_int, read_float):
        with pytest.raises(NumberTextError, match="digits other than 0-9"):
            read(text)


@pytest.mark.parametrize("text, words", [
    ("1e-400", "below the smallest double"), ("-2.5e-330", "below the smallest double"),
    ("1e400", "beyond the largest double"), (BIG + ".0", "beyond the largest double"),
    ("nan", "not a finite number"), ("inf", "not a finite number"), ("1_0", "not a finite number"),
])
def test_a_float_no_double_holds_is_refused(text, words):
    with pytest.raises(NumberTextError, match=words):
        read_float(text)


@pytest.mark.parametrize("text", ["0", "0.0", "-0e-999", "5e-324", "1e-310", "1.7976931348623157e308"])
def test_zero_and_the_doubles_edges_are_numbers(text):
    assert read_float(text) == float(text)


# --- options of the command line -------------------------------------------------------------


@pytest.mark.parametrize("digits", FOREIGN[:2])
@pytest.mark.parametrize("option", ["--threads", "--progress-interval", "--shard"])
def test_run_options_refuse_unicode_digits(tmp_path, invoke, write_config, option, digits):
    config = write_config(tmp_path, CONFIG)
    value = f"{digits[0]}/{digits[1]}" if option == "--shard" else digits
    line = _one_line(invoke("run", config, "-o", tmp_path / "o.h5", option, value))
    assert option in line, line
    assert not list(tmp_path.glob("o*.h5"))


@pytest.mark.parametrize("args", [
    ("--samples-per-period", "١٢"), ("--samples-per-period", "１２"),
])
def test_simulate_refuses_unicode_digits(tmp_path, invoke, write_config, args):
    config = write_config(tmp_path, "model: effective\nparameters: {g: 5}\n")
    line = _one_line(invoke("simulate", config, "-o", tmp_path / "t.h5", *args))
    assert args[0] in line and "ASCII" in line, line
    assert not (tmp_path / "t.h5").exists()


@pytest.mark.parametrize("args", [("--dpi", "１５０"), ("--vmin", "١"), ("--vmax", "1e-400")])
def test_plot_options_refuse_before_reading(tmp_path, invoke, args):
    line = _one_line(invoke("plot", tmp_path / "missing.h5", *args))
    assert args[0] in line, line


@pytest.mark.parametrize("args", [("--point", "١"), ("--to", "１", "2"), ("--within", "1", "1e400")])
def test_continue_options_refuse_before_reading(tmp_path, invoke, args):
    line = _one_line(invoke("continue", tmp_path / "missing.h5", "--along", "g", *args))
    assert args[0] in line, line


def test_text_options_parsed_in_the_library_refuse_unicode_digits():
    from vrsweep.execution.distributed import parse_local
    from vrsweep.execution.job import parse_shard
    from vrsweep.plot.labels import parse_size
    from vrsweep.plot.layout import parse_limits
    from vrsweep.plot.trajectories import parse_periods
    from vrsweep.store.reading import axis_index
    import numpy as np

    for call in (lambda: parse_size("４,３"), lambda: parse_limits("١,٢", "xlim"), lambda: parse_periods("١:٢"),
                 lambda: axis_index("g", np.array([12.0]), "١٢"), lambda: parse_shard("٠/٢"),
                 lambda: parse_local("local:٢"), lambda: parse_shard("auto", {"SLURM_ARRAY_TASK_ID": "٠",
                                                                            "SLURM_ARRAY_TASK_COUNT": "2"})):
        with pytest.raises(UsageError):
            call()


def test_numba_num_threads_in_unicode_digits_is_dropped(monkeypatch):
    from vrsweep.execution.threads import available_threads

    monkeypatch.setenv("NUMBA_NUM_THREADS", "١")
    monkeypatch.delattr("os.sched_getaffinity", raising=False)
    monkeypatch.setattr("os.cpu_count", lambda: 3)
    assert available_threads() == 3  # not 1: "١" is no number


# --- long values, quoted short -----------------------------------------------------------------


@pytest.mark.parametrize("args", [
    ("validate", "{config}", "--set", f"g={BIG}"),
    ("validate", "{config}", "--set", f"transient_periods={BIG}"),
    ("validate", "{config}", "--threads", BIG),
    ("run", "{config}", "-o", "{out}", "--shard", f"0/{BIG}"),
    ("run", "{config}", "-o", "{out}", "--shard", f"{BIG}/{BIG}"),
    ("run", "{config}", "-o", "{out}", "--shard", f"0/-{BIG}"),
    ("run", "{config}", "-o", "{out}", "--progress-interval", BIG),
])
def test_a_400_digit_value_is_quoted_short(tmp_path, invoke, write_config, args):
    config = write_config(tmp_path, CONFIG)
    args = [str(a).format(config=config, out=tmp_path / "o.h5") for a in args]
    line = _one_line(invoke(*args))
    assert "9" * 50 not in line and "..." in line, line
    assert len(line) < 400, line


def test_a_keyword_argument_is_quoted_short():
    import vrsweep

    with pytest.raises(ConfigError) as caught:
        vrsweep.sweep(CONFIG, g=BIG)
    assert "9" * 50 not in str(caught.value), str(caught.value)


def test_clip_keeps_short_text_whole():
    assert clip("x" * 40) == "x" * 40
    assert clip("x" * 41) == "x" * 37 + "..."


# --- literals beyond the doubles, in YAML and in a written model --------------------------------


@pytest.mark.parametrize("text, field, words", [
    ("integration: {rtol: 1e-400}\n", "integration.rtol", "1e-400 is below the smallest double"),
    ("parameters: {gamma: 1e-400}\n", "parameters.gamma", "1e-400 is below the smallest double"),
    ("parameters: {alpha: -1.0e-400}\n", "parameters.alpha", "is below the smallest double"),
    ("initial: {x: -1e400}\n", "initial.x", "-1e400 is beyond the largest double"),
    (f"parameters: {{Omega: {BIG}}}\n", "parameters.Omega", "is beyond the largest double"),
    ("integration: {max_steps: 1e-400}\n", "integration.max_steps", "below the smallest double"),
    ("sweep:\n  g: [1e-400, 1]\n", "sweep.g", "below the smallest double"),
    ("sweep:\n  g: {start: 1e-400, stop: 1, num: 3}\n", "sweep.g.start", "below the smallest double"),
])
def test_a_yaml_literal_no_double_holds_is_refused_saying_why(text, field, words):
    """gamma: 1e-400 ran as 0 and rtol: 1e-400 was refused as 'got 0.0'."""
    problem = _problem(text)
    assert field in problem and words in problem, problem
    assert "got 0.0" not in problem


@pytest.mark.parametrize("text, field, words", [
    ("parameters: {Omega: 0x10}\n", "parameters.Omega", "0x10 written in hexadecimal"),
    ("parameters: {Omega: 0o10}\n", "parameters.Omega", "0o10 written in octal"),
    ("parameters: {Omega: 0b11}\n", "parameters.Omega", "0b11 written in binary"),
    ("integration: {max_steps: 1_000_000}\n", "integration.max_steps", "write it without them (1000000)"),
    ("parameters: {gamma: 1__0.5}\n", "parameters.gamma", "written with underscores"),
    ("sweep:\n  g: [1, 0x2]\n", "sweep.g", "0x2 written in hexadecimal"),
])
def test_a_yaml_number_not_in_decimal_is_refused_as_an_option_is(text, field, words):
    """YAML read 0x10 as 16 and 1_000 (or 1__0) as 1000 where --threads 0x10 or 1_000 was refused:
    one value, two meanings by where it was typed."""
    problem = _problem(text)
    assert field in problem and words in problem, problem
    for option_text in ("0x10", "1_000"):
        with pytest.raises(NumberTextError):
            read_int(option_text)


@pytest.mark.parametrize("text, value", [("010", 10.0), ("+4", 4.0), (".5", 0.5), ("5.", 5.0), ("1.5e-3", 1.5e-3)])
def test_decimal_yaml_numbers_are_read_as_written(text, value):
    config = parse_config(f"model: effective\nparameters: {{c: {text}}}\n", "c.yaml")
    assert config.parameters["c"] == value


def test_a_quoted_yaml_number_is_a_string_as_before():
    assert "must be a number" in _problem("parameters: {Omega: '0x10'}\n")


@pytest.mark.parametrize("directive", ["%YAML 1.1", "%YAML 1.0"])
def test_a_yaml_version_other_than_1_2_is_refused(directive):
    # Under %YAML 1.1 ruamel read lyapunov: yes as true (refused without it), 010 as 8, 1:30 as 90.
    text = f"# a comment\n{directive}\n---\nmodel: effective\nintegration: {{lyapunov: yes}}\n"
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "c.yaml")
    assert str(caught.value).splitlines() == [
        f"c.yaml:2: {directive}: vrsweep reads configs as YAML 1.2 (YAML 1.1 reads yes and on as true, 010 as 8, "
        "1:30 as 90): remove the directive, or write %YAML 1.2"]
    with pytest.raises(ConfigError, match="lyapunov: must be true or false, got 'yes'"):
        parse_config(text.replace(directive, "%YAML 1.2"), "c.yaml")


def test_a_set_value_no_double_holds_is_refused_saying_why():
    with pytest.raises(ConfigError, match="1e-400 is below the smallest double"):
        parse_config("model: effective\n", "c.yaml", ["gamma=1e-400"])


@pytest.mark.parametrize("text", ["0.0", "-0.0", "0e-999", "1e-310"])
def test_zero_and_subnormals_stay_numbers(text):
    assert parse_config(f"parameters: {{gamma: {text}}}\n").parameters["gamma"] == float(text)


WRITTEN = """\
model:
  acceleration: "{acceleration}"
  parameters: {{zeta: 0.05, F: 1.0, omega: 0.8, Delta: 1.2, r: 0.8}}
  barriers: [{{position: Delta, side: above, restitution: r}}]
  period: "2*pi/omega"
  response: {{frequency: omega, scale: F}}
initial: {{x: 0.0, v: 0.0}}
"""


@pytest.mark.parametrize("acceleration, words", [
    ("-2*zeta*v - x + F*cos(omega*t) + 1e-400*x", "1e-400, which is below the smallest double"),
    ("-2*zeta*v - x + F*cos(omega*t) + 1e400", "holds a number too large for a double"),
    # (refused before parsing, as any character outside ASCII: expressions._refuse_non_ascii)
    ("-2*ｚeta*v - x + F*cos(omega*t)", "Python's parser would silently read it as 'z'"),
    ("-2*zeta*v - ｘ + F*cos(omega*t)", "Python's parser would silently read it as 'x'"),
])
def test_a_written_model_is_read_as_written(acceleration, words):
    problem = _problem(WRITTEN.format(acceleration=acceleration))
    assert "model.acceleration" in problem and words in problem, problem


def test_a_written_model_with_a_small_literal_is_kept():
    config = parse_config(WRITTEN.format(acceleration="-2*zeta*v - x + F*cos(omega*t) + 1e-300*x"))
    assert "1e-300" in config.model.acceleration


# --- counts the kernel cannot take ----------------------------------------------------------------


COUNTS = [name for name, domain in INTEGRATION_DOMAINS.items() if domain.integer]


@pytest.mark.parametrize("name", COUNTS)
@pytest.mark.parametrize("value", [2**63 - 1, 2**53 + 1, 2**63])
def test_every_count_stops_at_two_to_the_53(name, value):
    """The kernel reads its counts from doubles, exact to 2^53: 2^63 - 1 reached it as 2^63."""
    assert float(2**63 - 1) == 2.0**63 and float(2**53 + 1) == 2.0**53  # why
    problem = _problem(f"integration: {{{name}: {value}}}\n")
    assert f"integration.{name}" in problem and "2^53 = 9007199254740992" in problem, problem


def test_counts_up_to_two_to_the_53_are_counts():
    assert COUNT_MAX == 2**53
    config = parse_config(f"integration: {{max_steps: {2**53}, max_impacts_per_period: {2**53}, max_period: {2**53}}}\n")
    assert config.integration.max_steps == 2**53


@pytest.mark.parametrize("text, field", [
    (f"integration: {{transient_periods: {2**53}}}\n", "integration.transient_periods"),
    ("integration: {transient_periods: 40000001, measure_periods: 0}\n", None),  # measure_periods' own problem
    ("integration: {transient_periods: 39999901}\n", "integration.transient_periods"),
    ("integration: {measure_periods: 40000000, strobe_periods: 1}\n", "integration.measure_periods"),
    ("integration: {max_steps: 99}\n", "integration.max_steps"),
])
def test_periods_beyond_twice_max_steps_are_refused(text, field):
    """Each slow period takes at least one step or one scan of a stuck mass, and a point stops
    after max_steps of either: past 2 max_steps periods every point ends max_steps (100 + 100
    periods against the default max_steps of 2e7)."""
    problem = _problem(text)
    if field is not None:
        assert field in problem and "cannot be integrated within max_steps" in problem, problem


@pytest.mark.parametrize("text", [
    "integration: {transient_periods: 39999900}\n",
    "integration: {max_steps: 100}\n",
])
def test_periods_up_to_twice_max_steps_are_allowed(text):
    parse_config(text)


def test_a_set_that_breaks_the_periods_rule_is_named(tmp_path, invoke, write_config):
    config = write_config(tmp_path, CONFIG)
    line = _one_line(invoke("validate", config, "--set", "max_steps=1"))
    assert "--set max_steps=1: integration.max_steps" in line, line


# --- the Python API: numbers of other types ------------------------------------------------------


@pytest.mark.parametrize("value, words", [
    ("Decimal('1e-400')", "below the smallest double"), ("Fraction(1, 10**400)", "below the smallest double"),
    ("Decimal('-2.5e400')", "beyond the largest double"), ("10**400", "beyond the largest double"),
])
def test_a_keyword_number_no_double_holds_is_refused(value, words):
    """vrsweep.sweep(config, rtol=Decimal("1e-400")) read float(value), 0.0: a gamma so given ran as 0."""
    from decimal import Decimal  # noqa: F401 - for eval
    from fractions import Fraction  # noqa: F401 - for eval
    import vrsweep

    with pytest.raises(ConfigError, match=words) as caught:
        vrsweep.sweep(CONFIG, gamma=eval(value))
    assert str(caught.value).startswith("keyword argument gamma="), str(caught.value)


def test_keyword_numbers_of_other_types_are_their_values():
    from decimal import Decimal
    from fractions import Fraction
    from vrsweep.execution.api import resolve_config

    for value in (Decimal("0.25"), Fraction(1, 4), 0.25):
        assert resolve_config(CONFIG, {"gamma": value}).parameters["gamma"] == 0.25


def test_a_huge_whole_number_in_a_library_message_is_quoted_short():
    """VrsweepError.naming quotes an int at clip's length: simulate(samples_per_period=10**400)
    printed the 400-digit count and its 400-digit product."""
    import vrsweep

    with pytest.raises(UsageError) as caught:
        vrsweep.simulate("model: effective\nparameters: {g: 5}\n", samples_per_period=10 ** 400)
    message = str(caught.value)
    assert "0" * 50 not in message and "samples per period" in message, message
