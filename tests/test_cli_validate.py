"""``vrsweep validate``: exit codes, what it prints, and that it compiles nothing."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from vrsweep.cli import main
from vrsweep.config import parse_config
from vrsweep.errors import ConfigError
from vrsweep.execution.estimate import LYAPUNOV_COST, SECONDS_PER_POINT_PERIOD, check_size, estimate

CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def invoke(*args):
    result = CliRunner().invoke(main, list(args))
    output = result.output  # stdout and stderr together (click's default)
    assert "Traceback" not in output, output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result, output


def write(tmp_path, text, name="fig1.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_valid_config_prints_the_plan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result, output = invoke("validate", str(CONFIGS / "map_g_Omega.yaml"), "--threads", "4")
    assert result.exit_code == 0, output
    for words in ("valid", "model:       original", "g: 31 values from 0 to 60", "Omega: 12 values from 3 to 6",
                  "372 points (31 x 12)", "results/map_g_Omega.h5", "on 4 threads", "estimate:"):
        assert words in output, (words, output)


def test_set_is_applied(tmp_path):
    result, output = invoke("validate", str(CONFIGS / "fig1.yaml"), "--set", "g=5", "--set", "rtol=1e-10")
    assert result.exit_code == 0, output
    assert "none (a single point)" in output and "1 point" in output and "rtol=1e-10" in output


def integration_line(output):
    return next(line for line in output.splitlines() if line.startswith("integration:"))


def test_integration_line_names_every_setting_off_its_default():
    from vrsweep.config import INTEGRATION_DEFAULTS

    result, output = invoke("validate", str(CONFIGS / "fig1.yaml"))
    assert result.exit_code == 0, output
    line = integration_line(output)
    assert line == "integration: rk45, rtol=1e-09 atol=1e-11, 100 transient + 100 measured slow periods", line

    # fig1_lyapunov.yaml sets strobe_periods and lyapunov; every other setting changed by --set
    changed = {"max_steps": "1000", "max_impacts_per_period": "7", "divergence_bound": "500",
               "stick_velocity": "0.001", "max_period": "4", "period_tolerance": "1e-05", "device": "cuda"}
    args = [item for name, value in changed.items() for item in ("--set", f"{name}={value}")]
    result, output = invoke("validate", str(CONFIGS / "fig1_lyapunov.yaml"), *args)
    assert result.exit_code == 0, output
    line = integration_line(output)
    for name, value in {**changed, "strobe_periods": "32", "lyapunov": "true"}.items():
        assert f"{name}={value}" in line, (name, line)
    shown = {"method", "rtol", "atol", "transient_periods", "measure_periods"}
    assert set(INTEGRATION_DEFAULTS) == shown | set(changed) | {"strobe_periods", "lyapunov"}  # none left untested


@pytest.mark.parametrize("path", sorted(CONFIGS.glob("*.yaml")), ids=lambda path: path.name)
def test_every_shipped_config_validates(path):
    result, output = invoke("validate", str(path))
    assert result.exit_code == 0, output
    assert "warning" not in output  # none of them is too large to run without --allow-large


def test_bad_config_exit_2_with_every_problem_and_its_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, """\
        model: original
        parameters:
          e: 1.5
          Delta: 0.5
        sweep:
          gg: [1, 2]
          g: {start: 40, stop: 0, num: 81}
        integration:
          rtoll: 1e-9
        """)
    result, output = invoke("validate", "fig1.yaml")
    assert result.exit_code == 2, output
    assert "fig1.yaml:3: parameters.e: must be in (0, 1], got 1.5" in output
    assert "fig1.yaml:4: parameters.Delta: must be at or above initial.x = 0.99" in output
    assert "fig1.yaml:6: sweep.gg: not a parameter (did you mean 'g'?)" in output
    assert "fig1.yaml:7: sweep.g.stop: must be >= start" in output
    assert "fig1.yaml:9: integration.rtoll: unknown key (did you mean 'rtol'?)" in output


def test_yaml_syntax_error_exit_2(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "parameters:\n  e: 0.5\n   g: 3\n")
    result, output = invoke("validate", "fig1.yaml")
    assert result.exit_code == 2, output
    assert "fig1.yaml:3:" in output and "YAML syntax error" in output


def test_duplicate_axis_exit_2(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "sweep:\n  g: [1, 2]\n  g: [3]\n")
    result, output = invoke("validate", "fig1.yaml")
    assert result.exit_code == 2 and "fig1.yaml:3: sweep.g: parameter given twice" in output, output


def test_bad_override_exit_2(tmp_path):
    result, output = invoke("validate", str(CONFIGS / "quickstart.yaml"), "--set", "e=2", "--set", "gama=1")
    assert result.exit_code == 2, output
    assert "--set e=2: parameters.e: must be in (0, 1], got 2.0" in output
    assert "--set gama=1: unknown name 'gama' (did you mean 'gamma'?)" in output


def test_missing_config_exit_2(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result, output = invoke("validate", "nope.yaml")
    assert result.exit_code == 2 and "nope.yaml: no such config file" in output, output


def test_too_large_grid_is_reported_not_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, """\
        sweep:
          g: {start: 0, stop: 60, num: 10000}
          Omega: {start: 3, stop: 6, num: 1000}
        """, name="huge.yaml")
    result, output = invoke("validate", "huge.yaml", "--threads", "8")
    assert result.exit_code == 0, output
    assert "10000000 points" in output and "pass --allow-large" in output and "on 8 threads" in output


def test_validate_imports_no_numba(tmp_path):
    """validate must not compile anything: numba is not even imported (through the whole CLI)."""
    script = textwrap.dedent(f"""\
        import sys
        from vrsweep.cli import main
        try:
            main(["validate", {str(CONFIGS / "fig1.yaml")!r}], standalone_mode=False)
        finally:
            print("numba imported:", "numba" in sys.modules)
        """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "numba imported: False" in done.stdout, done.stdout + done.stderr
    assert "valid" in done.stdout


def test_estimate_scales_with_points_periods_threads_and_rtol():
    config = parse_config("sweep: {g: {start: 0, stop: 1, num: 10}}\n"
                          "integration: {transient_periods: 30, measure_periods: 20, strobe_periods: 4}")
    guess = estimate(config, 2)
    assert guess.n_points == 10
    more_strobe = parse_config(config.to_yaml(), overrides=["strobe_periods=8"])
    assert estimate(more_strobe, 2).output_bytes - guess.output_bytes == 10 * 2 * 4 * 8  # strobe_x, strobe_v
    assert guess.seconds == pytest.approx(10 * 50 * SECONDS_PER_POINT_PERIOD["original"] / 2)
    tighter = parse_config(config.to_yaml(), overrides=["rtol=1e-14"])
    assert estimate(tighter, 2).seconds == pytest.approx(guess.seconds * 10)  # (1e5)^(1/5)
    effective = parse_config(config.to_yaml(), overrides=["model=effective"])
    assert estimate(effective, 2).seconds < guess.seconds
    with_tangents = parse_config(config.to_yaml(), overrides=["lyapunov=true"])
    assert estimate(with_tangents, 2).seconds == pytest.approx(guess.seconds * LYAPUNOV_COST["rk45"])
    assert estimate(with_tangents, 2).output_bytes > guess.output_bytes + 10 * 2 * 8  # lyapunov, lyapunov_err


def test_check_size_refuses_a_huge_grid_unless_allowed():
    config = parse_config("sweep: {g: {start: 0, stop: 1, num: 100000}, Omega: {start: 1, stop: 2, num: 1000}}",
                          source_name="huge.yaml")
    with pytest.raises(ConfigError) as info:
        check_size(config, 4, allow_large=False)
    problem = info.value.problems[0]
    for words in ("huge.yaml", "grid of 100000000 points", "GB", "on 4 threads", "pass allow_large=True"):
        assert words in problem
    assert check_size(config, 4, allow_large=True).n_points == 100_000_000
    assert check_size(parse_config(""), 1, allow_large=False).n_points == 1


# An explicit axis list must be strictly increasing or strictly decreasing (issue 10).
@pytest.mark.parametrize("text, line, words", [
    ("sweep:\n  g: [5, 1, 5]\n", 2, ["sweep.g[2]", "5 is listed twice", "also item 0", "strictly increasing"]),
    ("sweep:\n  g:\n    - 5\n    - 1\n    - 5\n", 5, ["sweep.g[2]", "5 is listed twice", "also item 0, line 3"]),
    ("sweep:\n  Omega: {values: [4, 4.0]}\n", 2, ["sweep.Omega.values[1]", "4 is listed twice"]),
    ("sweep:\n  g: [1, 5, 3]\n", 2, ["sweep.g[2]", "3 after 5 breaks the order", "increasing up to item 1"]),
    ("sweep:\n  g: [40, 30, 35]\n", 2, ["sweep.g[2]", "35 after 30", "decreasing up to item 1"]),
    ("sweep:\n  g:\n    start: 5\n    stop: 5\n    num: 3\n", 4,
     ["sweep.g.stop", "must be > start = 5", "the same point 3 times", "set parameters.g"]),
    ("sweep:\n  g: {start: 1, stop: 1.0000000000000002, num: 5}\n", 2, ["sweep.g", "5 distinct float64 values"]),
])
def test_an_axis_list_that_is_not_strictly_monotonic_is_refused(tmp_path, text, line, words):
    path = tmp_path / "axis.yaml"
    path.write_text(text)
    result, output = invoke("validate", str(path))
    assert result.exit_code == 2, output
    assert f"{path}:{line}: " in output, output
    for word in words:
        assert word in output, (word, output)


def test_every_repeated_value_is_named():
    with pytest.raises(ConfigError) as caught:
        parse_config("sweep:\n  g: [1, 2, 2, 1]\n", "axis.yaml")
    assert caught.value.problems == [
        "axis.yaml:2: sweep.g[2]: 2 is listed twice (also item 1): axis values must be strictly "
        "increasing or strictly decreasing",
        "axis.yaml:2: sweep.g[3]: 1 is listed twice (also item 0): axis values must be strictly "
        "increasing or strictly decreasing"]


def test_a_decreasing_list_is_an_axis_in_the_given_order():
    config = parse_config("sweep:\n  g: [40, 30.5, 0]\n  Omega: {values: [5, 4]}\n")
    assert [list(axis.values) for axis in config.axes] == [[40.0, 30.5, 0.0], [5.0, 4.0]]


@pytest.mark.parametrize("sweep, lyapunov", [("g: {start: 0, stop: 40, num: 12}", "false"),
                                             ("g: {start: 20, stop: 30, num: 5, continuation: both}\n  Omega: [4.0, 5.0]",
                                              "false"),
                                             ("g: {start: 0, stop: 40, num: 12}", "true")])
def test_the_size_estimate_is_the_size_of_the_file(tmp_path, sweep, lyapunov):
    """validate estimated 3.2 kB for a 77 kB quickstart file (issue 15): HDF5's per-dataset bytes
    dominate small files. The estimate counts every array the run stores, and that overhead."""
    path = tmp_path / "small.yaml"
    path.write_text(f"model: effective\nsweep:\n  {sweep}\n"
                    f"integration: {{transient_periods: 2, measure_periods: 16, lyapunov: {lyapunov}}}\n")
    result, output = invoke("run", str(path), "-o", str(tmp_path / "small.h5"), "-q")
    assert result.exit_code == 0, output
    size = (tmp_path / "small.h5").stat().st_size
    guess = estimate(parse_config(path.read_text()), 1).output_bytes
    assert abs(guess - size) < 0.1 * size, (guess, size)


def test_a_continued_parameter_is_shown_fixed_when_a_sweep_holds_it(tmp_path):
    """`run` sweeps with the continued parameter at its value in parameters; `continue` starts it at
    continuation.from. With a sweep in the config the fixed line showed neither."""
    text = """\
        parameters: {g: 23.0, Omega: 4.0}
        initial: {x: 0.0, v: 0.0}
        sweep:
          Omega: [4.0, 5.0]
        continuation: {parameter: g, from: 25.0, to: [20.0, 30.0]}
        """
    result, output = invoke("validate", str(write(tmp_path, text)))
    assert result.exit_code == 0, output
    fixed = next(line for line in output.splitlines() if line.startswith("fixed:"))
    assert "g=23" in fixed, fixed
    alone = textwrap.dedent(text).replace("sweep:\n  Omega: [4.0, 5.0]\n", "")
    assert "sweep" not in alone
    result, output = invoke("validate", str(write(tmp_path, alone)))
    fixed = next(line for line in output.splitlines() if line.startswith("fixed:"))
    assert "g" not in [token.split("=")[0] for token in fixed.split()[1:]], fixed  # only continue uses it
    assert "Omega=4" in fixed, fixed


WRITTEN = """\
model:
  acceleration: "-2*zeta*v - x + F*cos(omega*t)"
  parameters: {zeta: 0.05, F: 1.0, omega: 0.8, Delta: 1.2, r: 0.8}
  barriers: [{position: Delta, side: above, restitution: r}]
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
"""


@pytest.mark.parametrize("name, text", [("quickstart.yaml", None), ("written.yaml", WRITTEN)])
def test_validate_says_a_first_run_compiles_its_kernel_first(tmp_path, name, text):
    """With nothing in the numba cache the estimate said 0.1 s for a run whose kernel then
    compiled for 30 s. It says so now, still importing no numba."""
    path = CONFIGS / name if text is None else write(tmp_path, text, name)
    script = textwrap.dedent(f"""\
        import sys
        from vrsweep.cli import main
        try:
            main(["validate", {str(path)!r}], standalone_mode=False)
        finally:
            print("numba imported:", "numba" in sys.modules)
        """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty cache")}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path, timeout=120,
                          env=env)
    assert done.returncode == 0, done.stderr
    (line,) = [line for line in done.stdout.splitlines() if line.startswith("estimate:")]
    assert line.endswith("after compiling the numba kernel (about 30 s, once: it is not in the cache yet)"), line
    assert "numba imported: False" in done.stdout


def test_the_numba_free_cache_lookup_finds_what_numba_cached(tmp_path):
    """execution.estimate.compiles_first looks for numba's index file by the function's file and
    name, without importing it (numba_cache.is_cached_function): it must find what numba writes,
    and nothing that numba did not."""
    import importlib.util

    from vrsweep.numerics import numba_cache

    numba_cache.configure()
    source = tmp_path / "cached_module.py"
    source.write_text("import numba\n\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2 * x\n\n\n"
                      "@numba.njit(cache=True)\ndef thrice(x):\n    return 3 * x\n")
    spec = importlib.util.spec_from_file_location("cached_module", source)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert not numba_cache.is_cached_function(source, "twice")
    assert module.twice(2.0) == 4.0
    assert numba_cache.is_cached_function(source, "twice") and numba_cache.is_compiled(module.twice)
    assert not numba_cache.is_cached_function(source, "thrice") and not numba_cache.is_compiled(module.thrice)


def test_a_continuation_without_a_sweep_is_described_as_continue_runs_it(tmp_path):
    """A config with a continuation and no sweep was shown as a one-point sweep: 'grid: 1 point',
    its 87 kB and '< 0.1 s' estimate and its records' memory, a run `continue` never does. It is
    described as a continuation now: no sweep (what `run` would do instead), no sweep estimate.
    The same config with a sweep keeps its sweep's lines."""
    alone = """\
        model: effective
        parameters: {gamma: 0.05, alpha: 0.05, g: 5.0, Omega: 4.0}
        initial: {x: 0.0, v: 0.0}
        continuation: {parameter: g, from: 23.0, to: [20.0, 27.0]}
        """
    result, output = invoke("validate", str(write(tmp_path, alone, "alone.yaml")))
    assert result.exit_code == 0, output
    lines = output.splitlines()
    assert not any(line.startswith(("grid:", "memory:", "axes:")) for line in lines), output
    (sweep,) = [line for line in lines if line.startswith("sweep:")]
    assert "vrsweep continue" in sweep and "g=5" in sweep, sweep  # run would hold g at parameters.g
    (guess,) = [line for line in lines if line.startswith("estimate:")]
    assert "continuation" in guess and " s on " not in guess and "B," not in guess, guess
    swept = textwrap.dedent(alone) + "sweep:\n  Omega: [4.0, 5.0]\n"
    result, output = invoke("validate", str(write(tmp_path, swept, "swept.yaml")))
    assert result.exit_code == 0, output
    assert "grid:        2 points (2)" in output and "memory:" in output and " s on " in output, output
    assert not any(line.startswith("sweep:") for line in output.splitlines()), output
