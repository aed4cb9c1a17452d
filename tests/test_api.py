"""The Python API (``vrsweep.sweep``, ``vrsweep.simulate``, ``vrsweep.theory``): the command line's
numbers, files and messages, from a path, YAML text or a dict (issue 22, item 1).

Tiny configs (a few points, a few slow periods): what is tested is that the API and the command
line are the same computation, which a short window shows as well as a long one."""

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import vrsweep
from vrsweep.config import load_config
from vrsweep.errors import ConfigError, UsageError
from vrsweep.execution.api import resolve_config, setting_text
from vrsweep.store.reading import load_results

SWEEP_TEXT = textwrap.dedent("""\
    # two axes, four points, five slow periods each
    parameters: {Omega: 4.0}
    sweep:
      g: [5.0, 10.0]
      Omega: [4.0, 5.0]
    integration: {transient_periods: 2, measure_periods: 3, strobe_periods: 1}
    """)
SWEEP_DICT = {"parameters": {"Omega": 4.0},
              "sweep": {"g": [5.0, 10.0], "Omega": [4.0, 5.0]},
              "integration": {"transient_periods": 2, "measure_periods": 3, "strobe_periods": 1}}
CONFIGS = Path(__file__).resolve().parent.parent / "vrsweep" / "examples"
POINT_TEXT = "parameters: {g: 5.0}\nintegration: {transient_periods: 2, measure_periods: 3, strobe_periods: 1}\n"

# When and by which command a file was written: the only attributes that may differ.
WHEN_AND_HOW = ("created", "date_created", "history")


@pytest.fixture(scope="module")
def sweep_yaml(tmp_path_factory):
    path = tmp_path_factory.mktemp("api") / "tiny.yaml"
    path.write_text(SWEEP_TEXT)
    return path


@pytest.fixture(scope="module")
def cli_file(sweep_yaml, invoke):
    """The file ``vrsweep run`` writes for the tiny config."""
    out = sweep_yaml.with_name("cli.h5")
    result = invoke("run", str(sweep_yaml), "-o", str(out), "-q")
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def api_dataset(sweep_yaml, cli_file):  # after the CLI's run: the kernel is compiled by then
    return vrsweep.sweep(sweep_yaml, progress=False)


def comparable(attrs, leave_out=()):
    """Attributes as comparable values (arrays, such as flag_values, as dtype and bytes)."""
    return {key: (np.asarray(value).dtype.str, np.asarray(value).tobytes()) if isinstance(value, np.ndarray)
            else value for key, value in attrs.items() if key not in leave_out}


def assert_same_dataset(a, b):
    """Same variables, coordinates, dimensions, dtypes and values (bit for bit, NaN where NaN) and
    the same attributes but when and how they were written."""
    assert list(a.data_vars) == list(b.data_vars)
    assert list(a.coords) == list(b.coords)
    assert dict(a.sizes) == dict(b.sizes)
    for name in [*a.coords, *a.data_vars]:
        x, y = a[name], b[name]
        assert x.dims == y.dims and x.dtype == y.dtype, name
        assert x.values.tobytes() == y.values.tobytes(), name  # bit for bit, NaN payloads included
        assert comparable(x.attrs) == comparable(y.attrs), name
    assert comparable(a.attrs, WHEN_AND_HOW) == comparable(b.attrs, WHEN_AND_HOW)


# -- sweep -----------------------------------------------------------------------------------


def test_sweep_returns_the_command_lines_file_bit_for_bit(api_dataset, cli_file):
    cli = load_results(cli_file)
    assert_same_dataset(api_dataset, cli)
    assert api_dataset["R"].dims == ("g", "Omega") and api_dataset["R"].shape == (2, 2)
    assert np.isfinite(api_dataset["R"].values).all()
    assert "source" not in api_dataset.encoding  # held in memory: no file behind it
    assert api_dataset.attrs["vrsweep_file"] == "sweep"


def test_a_continuation_both_sweep_has_its_direction_last():
    """sweep's docstring: one dimension per axis in the config's order (config.shape), then
    direction (up, down) for continuation: both."""
    config = {"model": "effective", "sweep": {"g": {"start": 21.0, "stop": 22.0, "num": 3, "continuation": "both"}},
              "integration": {"transient_periods": 2, "measure_periods": 3, "strobe_periods": 1}}
    ds = vrsweep.sweep(config, progress=False)
    assert ds["R"].dims == ("g", "direction") and ds["R"].shape == (*resolve_config(config).shape, 2)
    assert list(ds["direction"].values) == [1, -1]


def test_a_dict_a_yaml_string_and_a_path_give_the_same_result(sweep_yaml, api_dataset):
    assert resolve_config(SWEEP_DICT) == resolve_config(SWEEP_TEXT) == load_config(sweep_yaml)
    assert_same_dataset(vrsweep.sweep(SWEEP_DICT, progress=False), api_dataset)
    assert_same_dataset(vrsweep.sweep(SWEEP_TEXT, progress=False), api_dataset)
    assert_same_dataset(vrsweep.sweep(str(sweep_yaml), progress=False), api_dataset)


def test_a_dict_may_hold_numpy_arrays_and_tuples():
    as_numpy = dict(SWEEP_DICT, sweep={"g": np.array([5.0, 10.0]), "Omega": (np.float64(4.0), 5)})
    assert resolve_config(as_numpy) == resolve_config(SWEEP_DICT)


def test_keyword_overrides_are_set_options(sweep_yaml, tmp_path, invoke, describe):
    settings = ["g=7.5", "rtol=1e-08", "initial.x=0.5"]
    out = tmp_path / "set.h5"
    result = invoke("run", str(sweep_yaml), "-o", str(out), "-q", *[w for s in settings for w in ("--set", s)])
    assert result.exit_code == 0, result.output
    api = vrsweep.sweep(sweep_yaml, progress=False, g=7.5, rtol=1e-8, **{"initial.x": 0.5})
    assert_same_dataset(api, load_results(out))
    assert api["R"].dims == ("Omega",)  # g=7.5 fixed the swept g, as --set does

    assert (resolve_config(sweep_yaml, dict(method="dop853", lyapunov=True, x0=0.25, max_steps=1000, model="effective"))
            == load_config(sweep_yaml, ["method=dop853", "lyapunov=true", "x0=0.25", "max_steps=1000",
                                        "model=effective"]))


def test_an_override_is_the_text_set_takes_and_a_float_reads_back_bit_for_bit():
    assert setting_text("g", 5) == "g=5" and setting_text("method", "dop853") == "method=dop853"
    assert setting_text("lyapunov", True) == "lyapunov=true" and setting_text("g", "5") == "g=5"
    assert setting_text("rtol", 1e-10) == "rtol=1e-10" and setting_text("g", np.float64(2.5)) == "g=2.5"
    assert setting_text("g", float("inf")) == "g=.inf" and setting_text("max_steps", np.int64(7)) == "max_steps=7"
    for value in (0.1 + 0.2, 1 / 3, 21.065_123_456_789_01, 5e-324):
        assert resolve_config("sweep: {}\n", {"g": value}).parameters["g"] == value


def test_output_writes_the_command_lines_file(sweep_yaml, cli_file, tmp_path, assert_same_result):
    out = tmp_path / "api.h5"
    ds = vrsweep.sweep(sweep_yaml, output=out, progress=False)
    assert_same_result(out, cli_file)  # every dataset, attribute and chunk but the time written
    assert_same_dataset(ds, load_results(cli_file))

    with pytest.raises(UsageError) as error:
        vrsweep.sweep(sweep_yaml, output=out, progress=False)
    assert str(error.value) == (f"output {out} already exists: pass overwrite=True to replace it, or "
                                "resume=True to continue the run that wrote it")
    vrsweep.sweep(sweep_yaml, output=out, progress=False, overwrite=True)
    assert_same_result(out, cli_file)
    resumed = vrsweep.sweep(sweep_yaml, output=out, progress=False, resume=True)  # nothing left to do
    assert_same_dataset(resumed, ds)


def test_progress_false_prints_nothing_and_progress_true_draws_a_bar(sweep_yaml, api_dataset, capfd):
    capfd.readouterr()
    vrsweep.sweep(sweep_yaml, progress=False)
    vrsweep.simulate(POINT_TEXT, samples_per_period=10)
    vrsweep.theory(sweep_yaml)
    assert capfd.readouterr() == ("", "")
    vrsweep.sweep(sweep_yaml)
    out, err = capfd.readouterr()
    assert out == "" and "4/4" in err and "vrsweep" in err  # tqdm.auto: text on stderr outside Jupyter


def test_the_bar_is_tqdm_auto_the_notebook_form_in_jupyter(sweep_yaml, api_dataset, monkeypatch):
    """tqdm.auto picks tqdm.notebook's widget in a Jupyter kernel: the bar must come from it."""
    import tqdm.auto

    made = []

    class Recording(tqdm.auto.tqdm):
        def __init__(self, *args, **kwargs):
            made.append(kwargs)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(tqdm.auto, "tqdm", Recording)
    vrsweep.sweep(sweep_yaml)
    assert len(made) == 1 and made[0]["total"] == 4


def test_threads_are_checked_and_capped(sweep_yaml, api_dataset):
    with pytest.raises(UsageError, match=r"^threads must be a whole number of at least 1, got 0$"):
        vrsweep.sweep(sweep_yaml, threads=0)
    with pytest.warns(RuntimeWarning, match=r"^threads=100000: numba can run \d+ threads? here"):
        capped = vrsweep.sweep(sweep_yaml, threads=100_000, progress=False)
    assert_same_dataset(capped, api_dataset)
    assert_same_dataset(vrsweep.sweep(sweep_yaml, threads=1, progress=False), api_dataset)


def test_many_failed_points_warn_with_the_setting_to_change(sweep_yaml, api_dataset):
    with pytest.warns(RuntimeWarning, match=r"^4 of 4 points \(100%\) ended with max_steps: raise "
                                            r"integration.max_steps \(now 10\), e.g. max_steps=100$"):
        failed = vrsweep.sweep(sweep_yaml, max_steps=10, progress=False)
    assert (failed.status.values != 0).all()


def test_resume_needs_a_file_and_excludes_overwrite(sweep_yaml, tmp_path):
    with pytest.raises(UsageError, match=r"^resume=True and overwrite=True exclude each other$"):
        vrsweep.sweep(sweep_yaml, output=tmp_path / "x.h5", resume=True, overwrite=True)
    with pytest.raises(UsageError, match=r"^resume=True continues the run in a file: give its output$"):
        vrsweep.sweep(sweep_yaml, resume=True)


FLAGS = [(vrsweep.sweep, name) for name in ("progress", "overwrite", "resume", "allow_large")] + [
    (vrsweep.simulate, "overwrite")]


@pytest.mark.parametrize("function,flag", FLAGS, ids=[f"{f.__name__}-{name}" for f, name in FLAGS])
@pytest.mark.parametrize("value", ["no", "False", 1, 0, None, [True]])
def test_a_flag_is_a_bool_and_nothing_else(sweep_yaml, tmp_path, function, flag, value):
    """Issue 35: overwrite="no" replaced an existing file (any truthy value acted as True)."""
    from vrsweep.errors import FlagTypeError

    existing = tmp_path / "existing.h5"
    existing.write_bytes(b"keep me")
    config = SWEEP_TEXT if function is vrsweep.sweep else "parameters: {g: 5.0}\n"
    with pytest.raises(TypeError, match=rf"^{flag} must be True or False, got {re.escape(repr(value))}$") as error:
        function(config, output=existing, **{flag: value})
    assert isinstance(error.value, UsageError) and isinstance(error.value, FlagTypeError)
    assert existing.read_bytes() == b"keep me"


def test_numpys_bools_are_bools(tmp_path):
    existing = tmp_path / "existing.h5"
    existing.write_bytes(b"keep me")
    with pytest.raises(UsageError, match="already exists"):
        vrsweep.simulate("parameters: {g: 5.0}\n", output=existing, overwrite=np.bool_(False))


# -- errors: the command line's messages -----------------------------------------------------


def cli_problems(invoke, *args):
    result = invoke(*args)
    assert result.exit_code == 2, result.output
    lines = [line.strip() for line in result.stderr.splitlines()]
    return [line.removeprefix("Error: ") for line in lines if not line.endswith("problems:")]


def test_a_bad_config_raises_the_command_lines_messages(tmp_path, invoke):
    bad = tmp_path / "bad.yaml"
    bad.write_text("parameters:\n  e: 1.5\nintegration: {lyapunov: yes, method: rk4}\n")
    expected = cli_problems(invoke, "validate", str(bad), "--set", "rtol=abc")
    assert len(expected) == 4, expected
    # The same messages, but the keyword argument is named as the caller wrote it, not as --set.
    in_python = [problem.replace("--set rtol=abc:", "keyword argument rtol='abc':") for problem in expected]
    with pytest.raises(ConfigError) as error:
        vrsweep.sweep(bad, rtol="abc")
    assert error.value.problems == in_python
    assert expected[0] == "%s:2: parameters.e: must be in (0, 1], got 1.5" % bad
    assert expected[-1].startswith("--set rtol=abc: integration.rtol: must be a number")
    with pytest.raises(ConfigError) as error:
        vrsweep.theory(bad.read_text(), rtol="abc")  # YAML text: <string> and the same lines
    assert error.value.problems == [problem.replace(str(bad), "<string>") for problem in in_python]


@pytest.mark.parametrize("config", ["path", "text", "dict", "Config"])
def test_a_bad_keyword_argument_is_named_as_one(tmp_path, config):
    """`vrsweep.sweep(config, g="abc")` said "--set g=abc: ...": the caller passed no --set."""
    from vrsweep.config import load_config

    path = tmp_path / "c.yaml"
    path.write_text("model: effective\nsweep:\n  g: [1, 2]\n")
    given = {"path": path, "text": path.read_text(), "dict": {"model": "effective", "sweep": {"g": [1, 2]}},
             "Config": load_config(path)}[config]
    cases = [({"g": "abc"}, "keyword argument g='abc': parameters.g: must be a number, got 'abc'"),
             ({"gg": 5}, "keyword argument gg=5: unknown name 'gg' (did you mean 'g'?)"),
             ({"initial.x": 2.0}, "keyword argument initial.x=2.0: initial.x: must be at or below parameters.Delta")]
    for overrides, words in cases:
        with pytest.raises(ConfigError) as error:
            vrsweep.theory(given, **overrides)
        (problem,) = error.value.problems
        assert problem.startswith(words) and "--set" not in problem, problem


def test_a_misspelt_keyword_of_the_function_is_named(tmp_path):
    """A misspelt keyword (progres=False) is a setting to the function, and was refused among the
    config's names only: the refusal names the keyword meant, and nothing runs or is written."""
    path = tmp_path / "c.yaml"
    path.write_text("model: effective\nsweep:\n  g: [1, 2]\n")
    cases = [(vrsweep.sweep, {"progres": False}, "keyword argument progres=False (did you mean the keyword progress?)"),
             (vrsweep.sweep, {"overwite": True}, "keyword argument overwite=True (did you mean the keyword overwrite?)"),
             (vrsweep.sweep, {"alow_large": True}, "(did you mean the keyword allow_large?)"),
             (vrsweep.simulate, {"samples_per_perod": 3}, "(did you mean the keyword samples_per_period?)"),
             # another function's keyword: it said only "unknown name 'progress'" among the config's names
             (vrsweep.simulate, {"progress": False}, "keyword argument progress=False (a keyword of vrsweep.sweep, "
              "not of this function: its own are output, samples_per_period, compare, overwrite)")]
    for function, overrides, words in cases:
        with pytest.raises(ConfigError) as error:
            function(path, output=str(tmp_path / "o.h5"), **overrides)
        (problem,) = error.value.problems
        assert words in problem and "unknown name" in problem, problem
    assert not (tmp_path / "o.h5").exists()
    with pytest.raises(ConfigError) as error:  # a setting's own near miss keeps its own hint alone
        vrsweep.sweep(path, Omgea=3)
    (problem,) = error.value.problems
    assert "(did you mean 'Omega'?)" in problem and "the keyword" not in problem, problem


def test_a_bad_dict_names_the_field_without_a_line():
    with pytest.raises(ConfigError) as error:
        vrsweep.sweep({"parameters": {"e": 1.5, "gama": 0.2}, "integration": {"lyapunov": "yes"}})
    assert error.value.problems == [
        "<dict>: parameters.e: must be in (0, 1], got 1.5",
        "<dict>: parameters.gama: unknown key (did you mean 'gamma'?) "
        "(allowed: gamma, alpha, c, omega0, omega, Delta, e, g, Omega)",
        "<dict>: integration.lyapunov: must be true or false, got 'yes'",
    ]
    with pytest.raises(ConfigError, match=r"^<dict>: sweep.g: must be a number, a string, true/false, a list or "
                                          r"a mapping, got a set"):
        vrsweep.theory({"sweep": {"g": {1.0, 2.0}}})
    with pytest.raises(ConfigError, match="^missing.yaml: no such config file$"):
        vrsweep.theory("missing.yaml")
    with pytest.raises(ConfigError, match="^configs/missing: no such config file$"):
        vrsweep.theory("configs/missing")  # one line without ':' is a path, not a YAML word
    assert resolve_config("{sweep: {g: [5.0, 10.0]}}").axis_names == ("g",)  # one line of YAML
    with pytest.raises(UsageError, match="^config must be a path, YAML text, a dict or a vrsweep Config, got int$"):
        vrsweep.theory(3)


def test_simulate_of_a_sweep_says_how_to_fix_a_point_in_pythons_words(sweep_yaml, invoke):
    cli = cli_problems(invoke, "simulate", str(sweep_yaml), "-o", "never.h5")
    with pytest.raises(UsageError) as error:
        vrsweep.simulate(sweep_yaml)
    # the command line's message, its "--set g=5" written as the keyword g=5
    assert [str(error.value)] == [line.replace("--set ", "") for line in cli]
    assert str(error.value).endswith("fix every swept parameter, e.g. g=5 Omega=4")
    with pytest.raises(UsageError, match=r"^compare='effective' compares .* drop compare, or model='original'$"):
        vrsweep.simulate(POINT_TEXT, model="effective", compare="effective")
    with pytest.raises(UsageError, match=r"^compare 'original': must be None or one of 'effective'$"):
        vrsweep.simulate(POINT_TEXT, compare="original")


# -- simulate and theory ---------------------------------------------------------------------


def test_simulate_returns_the_command_lines_trajectory(tmp_path, invoke):
    config = tmp_path / "point.yaml"
    config.write_text(POINT_TEXT)
    out = tmp_path / "cli.h5"
    result = invoke("simulate", str(config), "-o", str(out), "-q", "--samples-per-period", "10",
                    "--compare", "effective")
    assert result.exit_code == 0, result.output

    groups = vrsweep.simulate(config, samples_per_period=10, compare="effective")
    assert list(groups) == ["original", "effective", "slow_flow/state", "slow_flow/paper", "slow_flow/paper_literal"]
    for group, dataset in groups.items():
        assert_same_dataset(dataset, load_results(out, group))
    alone = vrsweep.simulate(config, samples_per_period=10)
    assert_same_dataset(alone, load_results(out, "original"))
    assert alone["x"].dims == ("time",) and alone.sizes["time"] == 5 * 10 + 1
    assert alone["x"].values[0] == 0.99 and alone["v"].values[0] == 0.5  # the initial state

    kept = tmp_path / "api.h5"
    vrsweep.simulate(config, output=kept, samples_per_period=10, compare="effective")
    for group in groups:
        assert_same_dataset(load_results(kept, group), load_results(out, group))


def _drawn(fig):
    """What a figure draws: every line's and collection's data, axes by axes."""
    return [([line.get_xydata().tobytes() for line in ax.get_lines()],
             [np.asarray(c.get_offsets()).tobytes() for c in ax.collections]) for ax in fig.axes]


def test_the_figures_take_what_the_functions_return(tmp_path, invoke, sweep_yaml, api_dataset, cli_file):
    """vrsweep.plot.plot(ds) read a Dataset as the names of its variables, each then refused as a
    missing file ("results file not found: R"); a trajectory's Dataset (vrsweep.simulate's,
    open_results') failed in a KeyError, and simulate's dict was read as paths too. Each is now drawn
    as its file is: the trajectory the same arrays and attributes, the figures the same lines."""
    import matplotlib

    matplotlib.use("Agg")
    from vrsweep import plot
    from vrsweep.store.trajectory_file import from_datasets, read_trajectory

    config = tmp_path / "point.yaml"
    config.write_text(POINT_TEXT)
    out = tmp_path / "traj.h5"
    groups = vrsweep.simulate(config, output=out, samples_per_period=10, compare="effective")
    from_file, from_api = read_trajectory(out), from_datasets(groups)
    assert list(from_api.runs) == list(from_file.runs) and list(from_api.slow_flow) == list(from_file.slow_flow)
    for name, run in from_file.runs.items():
        for field, value in vars(run).items():
            assert np.asarray(getattr(from_api.runs[name], field)).tobytes() == np.asarray(value).tobytes(), field
    for name, flow in from_file.slow_flow.items():
        assert vars(from_api.slow_flow[name]).keys() == vars(flow).keys()
        for field, value in vars(flow).items():
            assert np.asarray(getattr(from_api.slow_flow[name], field)).tobytes() == np.asarray(value).tobytes()
    assert ({k: v for k, v in from_api.attrs.items() if k not in WHEN_AND_HOW}
            == {k: v for k, v in from_file.attrs.items() if k not in WHEN_AND_HOW})

    for kind in ("trajectory", "slowflow", "impacts"):
        assert _drawn(plot.plot(groups, kind=kind)) == _drawn(plot.plot(out, kind=kind)), kind
    alone = vrsweep.simulate(config, samples_per_period=10)  # the original run only: no file behind it
    with vrsweep.open_results(out) as opened:
        assert _drawn(plot.plot(alone)) == _drawn(plot.plot([opened]))
    assert _drawn(plot.plot(api_dataset)) == _drawn(plot.plot(cli_file))
    assert _drawn(plot.plot(api_dataset, kind="map")) == _drawn(plot.plot([cli_file], kind="map"))

    for source, words in [(api_dataset.R, "a DataArray ('R'): pass its Dataset"),
                          (groups["slow_flow/state"], "a slow flow alone is no trajectory"),
                          (3, "cannot plot int 3")]:
        with pytest.raises(UsageError, match=re.escape(words)):
            plot.plot(source)
    with pytest.raises(UsageError, match="^the trajectory holds no effective trajectory"):  # not "None holds"
        plot.plot(alone, kind="slowflow")


def test_theory_is_what_theory_json_prints(sweep_yaml, invoke):
    result = invoke("theory", str(sweep_yaml), "--json", "--set", "alpha=0.12")
    assert result.exit_code == 0, result.output
    rows = vrsweep.theory(sweep_yaml, alpha=0.12)
    assert json.loads(json.dumps(rows)) == json.loads(result.stdout)
    assert [row["Omega"] for row in rows] == [4.0, 5.0]


# -- the package -----------------------------------------------------------------------------


def test_the_functions_are_in_the_package_and_imported_only_when_used():
    assert {"sweep", "simulate", "theory", "open_results"} <= set(dir(vrsweep)) and \
        {"sweep", "simulate", "theory"} <= set(vrsweep.__all__)
    from vrsweep import simulate, sweep, theory  # noqa: F401 -- the names import

    script = textwrap.dedent("""\
        import sys
        import vrsweep
        print(*sorted(name for name in ("vrsweep.execution.api", "xarray", "tqdm") if name in sys.modules))
        vrsweep.theory
        print("vrsweep.execution.api" in sys.modules)
        """)
    child = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                           env=dict(os.environ))
    assert child.returncode == 0, child.stderr
    assert child.stdout.splitlines() == ["", "True"], child.stdout


# -- the guide -------------------------------------------------------------------------------

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "python-api.md"


def guide_snippets():
    return re.findall(r"```python\n(.*?)```", GUIDE.read_text(encoding="utf-8"), flags=re.S)


def test_the_guide_shows_each_function_and_argument():
    joined = "\n".join(guide_snippets())
    for needle in ("vrsweep.sweep(", "vrsweep.simulate(", "vrsweep.theory(", "compare=\"effective\"", "output=",
                   "except ConfigError", "progress=False", "Omega=5.0, rtol=1e-8"):
        assert needle in joined, needle


def test_every_snippet_of_the_guide_runs(tmp_path, monkeypatch):
    """docs/python-api.md's python blocks, as written, in order, in one namespace (as a notebook
    runs them), from a folder whose configs/ is the shipped examples'."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "configs").symlink_to(CONFIGS, target_is_directory=True)
    namespace = {}
    for number, code in enumerate(guide_snippets(), 1):
        exec(compile(code, f"docs/python-api.md, snippet {number}", "exec"), namespace)
    assert (tmp_path / "results" / "effective_map.h5").exists() and (tmp_path / "fig3_x.png").stat().st_size > 0
    assert namespace["ds"].R.shape == (21, 2)


def test_simulate_never_writes_over_its_own_config(tmp_path):
    """vrsweep.simulate("x.yaml", output="x.yaml", overwrite=True) replaced the config with the
    trajectory (vrsweep simulate refuses it): the output goes through fileio's one rule, with the
    config as its input, before anything is integrated."""
    config = tmp_path / "point.yaml"
    config.write_text(POINT_TEXT)
    for output in (config, str(config), tmp_path / "link.yaml"):
        if output == tmp_path / "link.yaml":
            output.symlink_to(config.name)
        with pytest.raises(UsageError, match="is the config being run"):
            vrsweep.simulate(config, output=output, overwrite=True)
        assert config.read_text() == POINT_TEXT


@pytest.mark.parametrize("value", [1.5, 5.0, "5", True])  # None: the default (200, or 20 a cycle of the fastest force)
def test_samples_per_period_is_a_whole_number(value):
    """samples_per_period=5.0 (or "5") was a TypeError from deep inside the trajectory's sampling."""
    with pytest.raises(UsageError, match="samples_per_period must be a whole number of at least 1"):
        vrsweep.simulate(POINT_TEXT, samples_per_period=value)


def test_a_killed_sweeps_temporary_folder_is_removed_by_the_next(sweep_yaml, tmp_path, monkeypatch, capfd):
    """Without output, a sweep runs through a file as large as its grid in TMPDIR; a kill -9 (a
    notebook's kernel restarted mid-sweep) left it there for good, one more at each restart.
    The next sweep on this host removes those of processes that are gone, and no other."""
    import socket
    import tempfile

    from vrsweep.store import fileio

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    host = fileio._HOST
    assert host == re.sub(r"[^A-Za-z0-9_-]", "_", socket.gethostname().split(".")[0])
    stale = tmp_path / f"vrsweep-{host}.{gone.pid}.abc123_x"
    alive = tmp_path / f"vrsweep-{host}.{os.getpid()}.def456"
    elsewhere = tmp_path / f"vrsweep-node17.{gone.pid}.ghi789"
    for folder in (stale, alive, elsewhere):
        folder.mkdir()
        (folder / "sweep.h5").write_bytes(b"a partial sweep")
        pid = folder.name.split(".")[1]
        (folder / fileio.SCRATCH_MARKER).write_text(fileio._scratch_marker_text(folder.name[8:].split(".")[0], pid))
    dataset = vrsweep.sweep(sweep_yaml, progress=False)
    assert int(dataset.done.sum()) == dataset.done.size
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([alive.name, elsewhere.name])
    assert f"Removed {stale}, left by an interrupted vrsweep (process {gone.pid})" in capfd.readouterr().err


def test_a_folder_named_like_a_scratch_folder_is_removed_only_if_vrsweep_made_it(tmp_path, monkeypatch, capfd):
    """scratch_folder removed any folder of TMPDIR named vrsweep-HOST.PID.anything whose process
    was gone, with everything in it: a user's own folder (vrsweep-myhost.123.results, their
    results) was deleted by the next vrsweep.sweep(). Only a folder with vrsweep's marker that
    holds nothing but what vrsweep writes there is removed now."""
    import tempfile

    from vrsweep.store import fileio

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    host = fileio._HOST

    def folder(tag, files, with_marker=None):
        path = tmp_path / f"vrsweep-{host}.{gone.pid}.{tag}"
        path.mkdir()
        for name in files:
            (path / name).write_bytes(b"data")
        if with_marker is not None:
            (path / fileio.SCRATCH_MARKER).write_text(with_marker)
        return path

    users = folder("results", ["sweep.h5", "notes.txt"])   # a user's, named like ours
    no_marker = folder("abc123", ["sweep.h5"])              # as vrsweep made them before the marker
    with fileio.scratch_folder():
        pass
    assert (users / "notes.txt").read_bytes() == b"data" and (no_marker / "sweep.h5").exists()

    marker = fileio._scratch_marker_text(host, gone.pid)
    other_pid = folder("def456", ["sweep.h5"], with_marker=fileio._scratch_marker_text(host, gone.pid + 1))
    extra = folder("ghi789", ["sweep.h5", "thesis.tex"], marker)             # a file vrsweep never writes
    ours = folder("jkl012", ["sweep.h5", f".sweep.h5.{host}.{gone.pid}.0123abcd.tmp"], marker)
    link = folder("mno345", [], marker)
    (link / "trajectory.h5").symlink_to(users / "notes.txt")                 # never followed, never removed
    with fileio.scratch_folder() as made:
        assert (tmp_path / os.path.basename(made) / fileio.SCRATCH_MARKER).is_file()
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
            [users.name, no_marker.name, other_pid.name, extra.name, link.name, os.path.basename(made)])
    assert (users / "notes.txt").read_bytes() == b"data" and (extra / "thesis.tex").exists()
    assert not os.path.exists(made)
    err = capfd.readouterr().err
    assert err.count("Removed") == 1 and f"Removed {ours}, left by an interrupted vrsweep" in err


def test_a_scratch_folder_of_a_vrsweep_before_the_marker_is_named_once(tmp_path, monkeypatch, capfd):
    """Scratch folders of a killed vrsweep from before the marker (vrsweep-8CHARS of 0.1.0 to
    0.6.8, vrsweep-HOST.PID.tag of 0.6.9 to 0.7.2), each maybe as large as a grid, were left in
    TMPDIR with nothing ever saying so. They cannot be told from a user's folder, so they are kept;
    one line each, once a process, says where they are and how large. A folder holding anything
    vrsweep never writes there, or nothing, is not named."""
    import tempfile

    from vrsweep.store import fileio

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(fileio, "_named_scratch", set(), raising=False)
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()

    def folder(name, files):
        path = tmp_path / name
        path.mkdir()
        for file in files:
            (path / file).write_bytes(b"x" * 1500)
        return path

    oldest = folder("vrsweep-k2j_9xq1", ["sweep.h5"])
    unmarked = folder(f"vrsweep-{fileio._HOST}.{gone.pid}.abc123_x", ["trajectory.h5"])
    users = folder("vrsweep-myresult", ["sweep.h5", "notes.txt"])
    empty = folder("vrsweep-a1b2c3d4", [])
    with fileio.scratch_folder():
        pass
    err = capfd.readouterr().err.splitlines()
    assert sorted(err) == sorted([
        f"Note: {oldest} looks like the scratch folder of a vrsweep interrupted before scratch folders were "
        "marked (process unknown; 1.5 kB): it is kept, as vrsweep cannot tell it made it; delete it if no "
        "vrsweep is using it",
        f"Note: {unmarked} looks like the scratch folder of a vrsweep interrupted before scratch folders were "
        f"marked (process {gone.pid}, gone; 1.5 kB): it is kept, as vrsweep cannot tell it made it; delete it "
        "if no vrsweep is using it"])
    assert all(path.is_dir() for path in (oldest, unmarked, users, empty))
    with fileio.scratch_folder():
        pass
    assert capfd.readouterr().err == ""
