"""Issue 33, class 4: tracebacks from options, environments and the API. Each is refused in one
line naming the option, setting or argument (exit 2 at the command line; a UsageError or
ConfigError from Python), before anything is written:

- a PNG canvas beyond MAX_PIXELS or MAX_SIDE_PIXELS (--size 40,40 --dpi 1200: 48000^2 pixels);
- text.usetex without LaTeX, a colour cycle with no colour (a style, or the user's matplotlibrc);
- --size with anything but a comma between its numbers (3x2);
- NUMBA_THREADING_LAYER naming a layer numba cannot load (bogus; tbb without TBB): since 0.7.17
  vrsweep starts no numba threads, so it is no fault and the run computes;
- --threads beyond any machine's CPUs;
- records beyond the memory the process may have (ulimit -v, a cgroup), not only the machine's;
- output=123 / b"o.h5", a dict nested thousands deep or holding itself, np.bool_ as a number.
"""

import os
import resource
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vrsweep
from vrsweep.errors import ConfigError, PathTypeError, UsageError

SETTINGS = settings(max_examples=25, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
POINT = {"model": "effective", "parameters": {"g": 5.0},
         "integration": {"transient_periods": 1, "measure_periods": 2, "strobe_periods": 1}}
TINY = """\
    sweep:
      g: [0.0, 10.0]
    integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 1}
    """


def _one_error_line(result, code=2):
    lines = result.output.strip().splitlines()
    assert result.exit_code == code and len(lines) == 1 and lines[0].startswith("Error: "), result.output
    return lines[0]


@pytest.fixture(scope="module")
def branch(tmp_path_factory):
    """A branch file made by hand (tests/handmade.py): its figure needs no kernel."""
    from handmade import write_branch_file

    return write_branch_file(tmp_path_factory.mktemp("branch") / "branch.h5")


# ---------------------------------------------------------------------------------------------
# Figures: canvas, LaTeX, colour cycle, --size
# ---------------------------------------------------------------------------------------------


@SETTINGS
@given(width=st.floats(0.5, 100), height=st.floats(0.5, 100), dpi=st.integers(20, 1200),
       file_format=st.sampled_from(["png", "pdf", "svg"]))
def test_a_canvas_is_refused_exactly_beyond_its_stated_limit(width, height, dpi, file_format):
    from matplotlib.figure import Figure

    from vrsweep.plot.labels import MAX_PIXELS, MAX_SIDE_PIXELS, check_canvas

    fig = Figure(figsize=(width, height))
    too_large = file_format == "png" and (width * dpi * height * dpi > MAX_PIXELS
                                          or max(width, height) * dpi > MAX_SIDE_PIXELS)
    if too_large:
        with pytest.raises(UsageError, match=r"^size and dpi: .* pixels, more than a PNG may have here"):
            check_canvas(fig, file_format, dpi)
    else:
        check_canvas(fig, file_format, dpi)


@pytest.mark.parametrize("args", [("--size", "40,40", "--dpi", "1200"), ("--size", "100,100", "--dpi", "400"),
                                  ("--size", "3,90", "--dpi", "1000")])
def test_a_huge_canvas_is_one_line_at_the_command_line(branch, tmp_path, invoke, args):
    out = tmp_path / "huge.png"
    line = _one_error_line(invoke("plot", branch, "-o", out, *args))
    assert line.startswith("Error: --size and --dpi: ") and "lower --dpi or --size" in line, line
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, words", [
    (("plot", "F.h5", "--dpi", "5"), "--dpi 5: expected a whole number from 20 to 1200"),
    (("plot", "F.h5", "--dpi", "0"), "--dpi 0: expected a whole number from 20 to 1200"),
    (("plot", "F.h5", "--dpi", "-1"), "--dpi -1: expected a whole number from 20 to 1200"),
    (("plot", "F.h5", "--dpi", "1e9"), "--dpi 1e9: expected a whole number from 20 to 1200"),
    (("plot", "F.h5", "--kind", "nope"), "'--kind': 'nope' is not one of"),
    (("plot", "F.h5", "--vmin", "abc"), "--vmin abc: is not a finite number"),
    (("plot", "F.h5", "--bogus"), "No such option '--bogus'"),
    (("plot",), "Missing argument"),
    (("simulate", "c.yaml", "--samples-per-period", "0"), "--samples-per-period 0: expected a whole number of at least 1"),
    (("run", "c.yaml", "--threads", "0"), "--threads 0: expected a whole number from 1 to"),
    (("nope",), "No such command 'nope'"),
])
def test_an_option_click_refuses_is_one_line(tmp_path, invoke, args, words):
    """click's own refusals were four lines (usage, a hint, a blank line, the error): one now, with
    the help to read, exit 2, as every other bad input."""
    line = _one_error_line(invoke(*args))
    assert words in line and line.endswith("--help)"), line


@pytest.mark.parametrize("where", ["style", "matplotlibrc"])
@pytest.mark.parametrize("suffix", ["png", "pdf"])
def test_usetex_without_latex_is_one_line(branch, tmp_path, invoke, monkeypatch, where, suffix):
    import shutil

    import matplotlib

    monkeypatch.setattr(shutil, "which", lambda name, *args, **kwargs: None)  # no LaTeX here
    args = []
    if where == "style":
        style = tmp_path / "tex.mplstyle"
        style.write_text("text.usetex: True\n")
        args = ["--style", style]
    else:
        monkeypatch.setitem(matplotlib.rcParams, "text.usetex", True)
    out = tmp_path / f"figure.{suffix}"
    line = _one_error_line(invoke("plot", branch, "-o", out, *args))
    prefix = f"Error: --style {args[1]}: " if args else "Error: matplotlib's settings (matplotlibrc): "
    assert line.startswith(prefix) and "text.usetex is on, but latex" in line and "is not installed" in line, line
    assert not out.exists()


def test_a_png_with_usetex_needs_dvipng_too(monkeypatch):
    import shutil

    import matplotlib

    from vrsweep.plot.labels import _usetex_problem

    monkeypatch.setattr(shutil, "which", lambda name, *a, **k: "/usr/bin/latex" if name == "latex" else None)
    with matplotlib.rc_context({"text.usetex": True}):
        assert _usetex_problem() is None  # a PDF or SVG needs latex only
        assert "but dvipng (which it runs for every label) is not installed" in _usetex_problem(("latex", "dvipng"))
    assert _usetex_problem(("latex", "dvipng")) is None  # usetex off: nothing to say


@pytest.mark.parametrize("cycle", ["cycler(color=[])", "cycler('color', [])"])
def test_a_colour_cycle_without_a_colour_is_one_line(branch, tmp_path, invoke, cycle):
    style = tmp_path / "empty.mplstyle"
    style.write_text(f"axes.prop_cycle: {cycle}\n")
    out = tmp_path / "figure.png"
    line = _one_error_line(invoke("plot", branch, "-o", out, "--style", style))
    assert line == f"Error: --style {style}: axes.prop_cycle holds no colour: a figure needs at least one", line
    assert not out.exists()


def test_a_colour_cycle_without_a_colour_from_matplotlibrc_is_one_line(branch, tmp_path, invoke, monkeypatch):
    import matplotlib
    from cycler import cycler

    monkeypatch.setitem(matplotlib.rcParams, "axes.prop_cycle", cycler(color=[]))
    line = _one_error_line(invoke("plot", branch, "-o", tmp_path / "figure.png"))
    assert line == "Error: matplotlib's settings (matplotlibrc): axes.prop_cycle holds no colour: a figure needs at " \
                   "least one", line


def test_a_cycle_of_line_styles_only_still_draws(branch, tmp_path, invoke):
    style = tmp_path / "dashes.mplstyle"
    style.write_text('axes.prop_cycle: cycler(linestyle=["-", "--"])\n')
    assert invoke("plot", branch, "-o", tmp_path / "figure.png", "--style", style).exit_code == 0


@SETTINGS
@given(width=st.floats(0.5, 100), height=st.floats(0.5, 100), separator=st.sampled_from(["x", "X", "*", ";", " "]))
def test_size_takes_a_comma_and_nothing_else(width, height, separator):
    from vrsweep.plot.labels import parse_size

    assert parse_size(f"{width!r},{height!r}") == (width, height)
    with pytest.raises(UsageError, match=r"^size .*: expected WIDTH,HEIGHT in inches"):
        parse_size(f"{width!r}{separator}{height!r}")


def test_size_3x2_is_one_line(branch, tmp_path, invoke):
    line = _one_error_line(invoke("plot", branch, "-o", tmp_path / "f.png", "--size", "3x2"))
    assert line == "Error: --size 3x2: expected WIDTH,HEIGHT in inches, e.g. 3.4,2.6", line


def test_out_of_memory_anywhere_is_one_line(branch, tmp_path, invoke, monkeypatch):
    import vrsweep.plot

    def exhausted(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(vrsweep.plot, "render", exhausted)
    line = _one_error_line(invoke("plot", branch, "-o", tmp_path / "f.png"), code=1)
    assert line.startswith("Error: out of memory"), line
    assert not (tmp_path / "f.png").exists()


# ---------------------------------------------------------------------------------------------
# Environments and resources: numba's threading layer, --threads, memory
# ---------------------------------------------------------------------------------------------


def test_a_threading_layer_numba_cannot_load_does_not_stop_a_run(tmp_path, write_config):
    """A real process (one: it may have to compile the kernel). numba's threading layers are for its
    parallel loops, and vrsweep's lines run on Python's threads (numerics/lines.py): the settings are
    read by nothing, and the run computes. Up to 0.7.16 each was refused in one line, exit 2, where
    numba would have failed at the first loop."""
    config = write_config(tmp_path, TINY)
    out = tmp_path / "out.h5"
    setting = {"NUMBA_THREADING_LAYER": "bogus", "NUMBA_THREADING_LAYER_PRIORITY": "tbb omp"}
    done = subprocess.run([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(out), "-q",
                           "--threads", "2"],
                          capture_output=True, text=True, env={**os.environ, **setting}, timeout=300)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    import h5py

    with h5py.File(out) as results:
        assert results["status"][()].tolist() == [0, 0]


@SETTINGS
@given(threads=st.integers(65537, 2 ** 80))
def test_threads_beyond_any_machine_are_refused(tmp_path_factory, invoke, write_config, threads):
    tmp_path = tmp_path_factory.mktemp("threads")
    config = write_config(tmp_path, TINY)
    for command in (["run", config, "-o", tmp_path / "out.h5", "-q"], ["validate", config]):
        result = invoke(*command, "--threads", threads)
        assert result.exit_code == 2 and "--threads" in result.output and "from 1 to 65536" in result.output, result.output
    assert not (tmp_path / "out.h5").exists()


def test_memory_is_counted_against_the_process_limit(monkeypatch):
    from vrsweep.config import config_from_dict
    from vrsweep.execution import estimate

    real = resource.getrlimit

    def limited(which):
        if which == resource.RLIMIT_AS:
            return (2 * 2 ** 30, resource.RLIM_INFINITY)
        return real(which)

    monkeypatch.setattr(resource, "getrlimit", limited)
    assert estimate.memory_allowance() == (2 ** 30, "this process may use (half its ulimit -v limit)")
    # max_steps: 1e8 periods need at least as many steps (config/rules.check_periods_can_finish)
    config = config_from_dict({**POINT, "integration": {"measure_periods": 100_000_000, "max_steps": 100_000_000}})
    problem = estimate.memory_problem(config)
    assert "more than the 1.1 GB this process may use (half its ulimit -v limit)" in problem, problem


def test_measure_periods_beyond_ulimit_is_one_line(tmp_path, write_config):
    """vrsweep validate and run under ulimit -v 3 GiB: 1e8 measured periods need 8 GB of records
    (it was a 7.45 GiB allocation traceback); refused before any file is made."""
    config = write_config(tmp_path, "parameters: {g: 5}\nintegration: {measure_periods: 100000000, max_steps: 100000000}\n")
    out = tmp_path / "out.h5"

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (3 * 2 ** 30, resource.RLIM_INFINITY))

    for command in (["validate", str(config)], ["run", str(config), "-o", str(out)]):
        done = subprocess.run([sys.executable, "-m", "vrsweep", *command], capture_output=True, text=True,
                              preexec_fn=limit, timeout=120)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and lines[-1].startswith("Error: "), done.stderr
        assert "half its ulimit -v limit" in lines[-1] and "lower integration.measure_periods" in lines[-1], lines
        assert "Traceback" not in done.stderr
    assert not out.exists()


@pytest.mark.parametrize("command", [["validate"], ["run", "--dry-run"], ["run", "--allow-large"]])
def test_a_grid_too_large_to_order_is_one_line(tmp_path, write_config, invoke, command):
    """Three axes of 3000 values, 2.7e10 points: ordering them (config/grid.py shuffled_lines, 24
    bytes a point, measured 24.1) needs 648 GB before any point runs. `run --dry-run` ended in
    "out of memory", exit 1; it is refused first, with the remedy, on any machine."""
    config = write_config(tmp_path, "sweep:\n  g: {start: 1, stop: 30, num: 3000}\n"
                                    "  Omega: {start: 1, stop: 6, num: 3000}\n  c: {start: 0.05, stop: 0.2, num: 3000}\n")
    out = tmp_path / "out.h5"
    result = invoke(command[0], config, *command[1:], *(["-o", out] if command[0] == "run" else []))
    _one_error_line(result)
    assert "27000000000 points needs 648.0 GB to order its points" in result.output, result.output
    assert "use fewer values on the axes" in result.output
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# The Python API
# ---------------------------------------------------------------------------------------------

NOT_PATHS = st.one_of(st.integers(), st.floats(allow_nan=False), st.binary(min_size=1, max_size=20),
                      st.lists(st.text(max_size=3), max_size=2), st.just(object()), st.just(True))


@SETTINGS
@given(output=NOT_PATHS)
def test_an_output_that_is_not_a_path_is_refused_first(tmp_path_factory, output, monkeypatch):
    folder = tmp_path_factory.mktemp("api")
    monkeypatch.chdir(folder)
    for call in (lambda: vrsweep.sweep(POINT, output=output, progress=False),
                 lambda: vrsweep.simulate(POINT, output=output)):
        with pytest.raises(PathTypeError, match=r"^output must be a path \(a str or an os.PathLike") as caught:
            call()
        assert isinstance(caught.value, TypeError) and isinstance(caught.value, UsageError)
        assert ("os.fsdecode" in str(caught.value)) == isinstance(output, bytes)
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("path", [123, 4.5, None, ["a.h5"]])
def test_open_results_of_something_that_is_not_a_path(path):
    with pytest.raises(PathTypeError, match=r"^path must be a path"):
        vrsweep.open_results(path)


def _nested(depth, key="a"):
    data = {}
    inner = data
    for _ in range(depth):
        inner[key] = {}
        inner = inner[key]
    return data


@SETTINGS
@given(depth=st.integers(65, 6000), where=st.sampled_from(["top", "parameters", "list"]))
def test_a_dict_nested_too_deep_is_one_config_error(depth, where):
    deep = _nested(depth)
    config = {"top": deep, "parameters": {"g": deep}, "list": {"sweep": {"g": [deep]}}}[where]
    with pytest.raises(ConfigError) as caught:
        vrsweep.sweep(config, progress=False)
    assert len(caught.value.problems) == 1
    assert "nested more than 64 levels deep" in caught.value.problems[0], caught.value.problems


def test_a_dict_that_holds_itself_is_one_config_error():
    looped = {"parameters": {}}
    looped["parameters"]["g"] = looped
    with pytest.raises(ConfigError, match="contains itself"):
        vrsweep.sweep(looped, progress=False)
    listed = {"sweep": {"g": []}}
    listed["sweep"]["g"].append(listed["sweep"]["g"])
    with pytest.raises(ConfigError, match="contains itself"):
        vrsweep.sweep(listed, progress=False)


def test_a_shallow_dict_keeps_its_own_messages():
    with pytest.raises(ConfigError) as caught:
        vrsweep.sweep(_nested(10), progress=False)
    assert "nested" not in str(caught.value) and "a:" in str(caught.value), caught.value


NUMBERS = ["g", "Omega", "gamma", "alpha", "c", "e", "omega", "Delta", "measure_periods", "rtol"]


@SETTINGS
@given(name=st.sampled_from(NUMBERS), value=st.sampled_from([np.bool_(True), np.bool_(False), True, False]))
def test_a_boolean_is_no_number(name, value):
    """g=np.bool_(True) was taken as 1.0: numpy's booleans are booleans, as Python's are."""
    from vrsweep.execution.api import setting_text

    assert setting_text(name, value) == f"{name}={'true' if value else 'false'}"
    for call in (lambda: vrsweep.sweep(POINT, progress=False, **{name: value}),
                 lambda: vrsweep.theory(POINT, **{name: value})):
        with pytest.raises(ConfigError, match=r"must be (a number|an integer), got (true|false)"):
            call()
