"""Round 5 of the hostile inputs: text from outside drawn in figures, and written models that
cost sympy minutes before anything compiles."""

import numpy as np
import pytest
from matplotlib.cbook import is_math_text

from vrsweep.analysis.continuation import Bifurcation, Branch, Orbit
from vrsweep.config.validate import config_from_dict
from vrsweep.store import branch_file

WRITTEN = {
    "model": {"name": None, "acceleration": "-2*zeta*v - x + F*cos(omega*t)",
              "parameters": {"zeta": 0.05, "F": 1.0, "omega": 0.8, "Delta": 3.0, "r": 0.8},
              "symbols": {"zeta": "\\zeta", "omega": "\\omega"},
              "barriers": [{"position": "Delta", "side": "above", "restitution": "r"}],
              "period": "2*pi/omega", "response": {"frequency": "omega", "scale": "F"}},
    "initial": {"x": 0.0, "v": 0.0},
    "continuation": {"parameter": "Delta", "from": 3.0, "to": [2.0, 3.5]},
}


def _written_branch_file(path, name):
    """A branch file of a written model named ``name``: nine orbits in Delta, a fold at the fifth."""
    config = {**WRITTEN, "model": {**WRITTEN["model"], "name": name}}
    orbits = [Orbit(parameter=value, state=np.array([0.5, -0.2]), periods=1,
                    monodromy=np.diag([0.5 if value < 2.75 else 1.5, 0.3]), R=2.0 + value, Q_amplitude=0.4,
                    impacts_per_period=1.0, x_max=1.0, slowest_impact=0.5, residual=1e-11, newton_iterations=2)
              for value in np.linspace(2.5, 3.0, 9)]
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "Delta left [2, 3.5]"),
                                                       "up": ("left_range", "Delta left [2, 3.5]")})]
    branch_file.write_branch(path, branch_file.branch_arrays(branches, [Bifurcation("fold", orbits[4])], 1.0),
                             config_from_dict(config), "rk45")
    return path


@pytest.mark.parametrize("name, file_name", [
    ("a $\\frac{$ b", "branch.h5"),        # mathtext matplotlib's parser refuses: a traceback
    ("cost $5 model", "branch.h5"),         # one $: the caption's count odd, its symbols drawn raw
    ("oscillator", "p$\\frac{$.h5"),       # the same from the file's name
    ("oscillator", "run$1.h5"),
])
def test_a_dollar_in_a_model_or_file_name_is_drawn_as_text(tmp_path, invoke, name, file_name):
    """A written model's name and a file's name are text: a figure draws their $ as $. A model
    named 'a $\\frac{$ b', or a file 'p$\\frac{$.h5', stopped `vrsweep plot` with a traceback from
    matplotlib's mathtext parser (exit 1); one $ in either ('run$1.h5') made the caption's $ odd,
    and matplotlib drew the whole caption as text: '$\\zeta$ = 0.05' with its markup."""
    from vrsweep import plot
    from vrsweep.plot.labels import description

    path = _written_branch_file(tmp_path / file_name, name)
    figure = plot.plot(str(path))
    caption = figure._suptitle.get_text()
    assert is_math_text(caption), caption  # the symbols' $ pairs are mathtext, the names' $ escaped
    assert f"{name}:" in description(figure) and file_name in description(figure)
    result = invoke("plot", path, "-o", tmp_path / "f.png")
    assert result.exit_code == 0, result.output
    shown = invoke("info", tmp_path / "f.png")
    assert name in shown.output and file_name in shown.output, shown.output


@pytest.mark.parametrize("keywords, says", [
    ({"rtol": [1e-8, 1e-9]}, "integration.rtol is a setting, not a sweep axis"),
    ({"integration.method": ("rk45", "dop853")}, "integration.method is a setting, not a sweep axis"),
    ({"continuation.from": [20, 30]}, "continuation.from is a setting, not a sweep axis"),
    ({"model": {"acceleration": "-x", "parameters": {}}}, "a written model is the config's model section"),
    ({"model": ["original", "effective"]}, "model= takes one model's name"),
    ({"parameters.g": [5, 6]}, 'give its axis in the config, e.g. {"sweep": {"g": [5.0, 6.0]}}'),
    ({"initial.x": [0.1, 0.2]}, 'give its axis in the config, e.g. {"sweep": {"x0": [5.0, 6.0]}}'),
])
def test_several_values_for_a_setting_are_not_told_to_be_swept(keywords, says):
    """vrsweep.sweep(config, rtol=[...]) or model={...} (a written model as a keyword) was told
    to give 'its axis in the config, e.g. {"sweep": {"model": [5.0, 6.0]}}', an axis no config
    can have; parameters.g=[...] to write sweep: {parameters.g: ...}, which is no axis's name."""
    from vrsweep.errors import ConfigError
    from vrsweep.execution.api import resolve_config

    with pytest.raises(ConfigError) as caught:
        resolve_config("model: effective\ncontinuation: {parameter: g, from: 20, to: [10, 30]}\n", keywords)
    message = str(caught.value)
    assert says in message, message
    assert "sweep: {model" not in message and "sweep: {rtol" not in message and "{parameters." not in message


def test_kinks_of_different_surfaces_are_told_apart_without_simplify(monkeypatch):
    """An acceleration with eight kinks abs(sin(x + k*v)) spent 86 s in sympy.simplify (twenty:
    274 s) before numba compiled anything, the notice saying about 30 s: each switch was compared
    with every other by simplify, at each look-up. Surfaces that differ at a point are two, told
    by their values; simplify is left for those that agree there."""
    import sympy

    from vrsweep.config import parse_config
    from vrsweep.numerics import codegen

    terms = " + ".join(f"abs(sin(x + {k}*v))" for k in range(1, 9))
    model = parse_config(f"""
model:
  acceleration: "-x + F*cos(omega*t) - 0.01*({terms})"
  parameters: {{F: 1.0, omega: 0.8}}
  period: "2*pi/omega"
  response: {{frequency: omega}}
initial: {{x: 0.0, v: 0.0}}
""").model
    acceleration, _, _, _, state = codegen.derived(model)
    calls = []
    simplify = sympy.simplify
    monkeypatch.setattr(sympy, "simplify", lambda *args, **kwargs: calls.append(args) or simplify(*args, **kwargs))
    switches = codegen.switching_functions(acceleration, state)
    assert len(switches) == 8 and calls == []
    frozen, sides = codegen.frozen_acceleration(acceleration, switches)
    assert len(sides) == 8 and not frozen.has(sympy.Abs) and calls == []
    # The same surface written otherwise is still one switch, oriented: simplify confirms it
    x, v, t = state
    assert codegen._switch_index(-sympy.sin(x + 3 * v), switches) == (2, -1)
    assert codegen._switch_index(sympy.sin(x + 3 * v) + sympy.cos(x)**2 + sympy.sin(x)**2 - 1, switches) == (2, 1)
    assert codegen._switch_index(sympy.sin(x + 3.5 * v), switches) is None


def _kinked(count, function="abs"):
    terms = [f"{function}(x - {k / 100})" for k in range(count)]
    groups = " + ".join("(" + " + ".join(terms[i:i + 20]) + ")" for i in range(0, count, 20))
    return f"""
model:
  acceleration: "-x + F*cos(omega*t) - 0.01*({groups})"
  parameters: {{F: 1.0, omega: 0.8}}
  period: "2*pi/omega"
  response: {{frequency: omega}}
initial: {{x: 0.0, v: 0.0}}
"""


@pytest.mark.parametrize("text, surfaces", [
    (_kinked(53), 53), (_kinked(60, "sign"), 60),
    # nested max calls merge into one: every pair of its 11 arguments is a surface
    (_kinked(0).replace("0.01*()", "max(x, max(v, max(x + v, max(x - v, max(2*x, max(2*v, max(t, "
                                   "max(x*v, max(x + t, max(v + t, 1))))))))))"), 55),
])
def test_more_kinks_than_the_kernel_locates_are_refused(text, surfaces):
    """An acceleration with 60 kinks abs(x - k/100) ran: the kernel located the first 52
    (a bit each of its mode) and stepped across the others unlocated, losing the method's
    order there (R 1.5e-6 off at rtol 1e-6 for one kink, docs/models.md), without a word."""
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    with pytest.raises(ConfigError) as caught:
        parse_config(text, "m.yaml")
    assert len(caught.value.problems) == 1
    assert caught.value.problems[0].startswith("m.yaml:3: model.acceleration: has kinks or jumps")
    assert f"on {surfaces} surfaces; the kernel locates at most 52" in caught.value.problems[0]


def test_as_many_kinks_as_the_kernel_locates_are_all_located():
    from vrsweep.config import parse_config
    from vrsweep.numerics import codegen

    model = parse_config(_kinked(52)).model
    acceleration, _, _, _, state = codegen.derived(model)
    assert len(codegen.switching_functions(acceleration, state)) == 52
    # the same surface written twice, or a kink in the parameters alone, counts once or not at all
    assert parse_config(_kinked(52).replace("0.01*(", "abs(x - 0.0) + abs(-(x - 0.0)) + abs(F) + 0.01*(")).model


@pytest.mark.parametrize("option", ["--xlim", "--ylim"])
@pytest.mark.parametrize("ends", ["-8e307,8e307", "-1e301,0", "0,1.7e308"])
def test_axis_limits_beyond_what_ticks_can_span_are_one_line(tmp_path, invoke, option, ends):
    """`plot --xlim -8e307,8e307` drew the figure, then matplotlib's tick locator overflowed:
    a traceback, "ValueError: arange: cannot compute length", exit 1."""
    path = _written_branch_file(tmp_path / "branch.h5", "oscillator")
    result = invoke("plot", path, "-o", tmp_path / "f.png", option, ends)
    assert result.exit_code == 2, result.output
    assert result.output.startswith(f"Error: {option} {ends}: both ends must be of magnitude at most 1e+300")
    assert not (tmp_path / "f.png").exists()


def test_axis_limits_up_to_1e300_are_drawn(tmp_path, invoke):
    path = _written_branch_file(tmp_path / "branch.h5", "oscillator")
    result = invoke("plot", path, "-o", tmp_path / "f.png", "--xlim", "-1e300,1e300", "--ylim", "-1e300,1e300")
    assert result.exit_code == 0, result.output


def test_options_a_trajectory_figure_cannot_use_are_refused_not_ignored():
    """`plot TRAJ.h5 --var R` drew the trajectory, the option dropped without a word, and
    `--kind impacts --periods 1:2` drew every period."""
    from test_plot_trajectory_titles import PAPER, trajectory

    from vrsweep import plot
    from vrsweep.errors import UsageError

    data = trajectory(PAPER.replace("E", "0.9"), "original", "t.h5")
    with pytest.raises(UsageError, match="^at, x_axis, var, amplitude and log/linear are for sweep results"):
        plot.plot(data, var="R")
    with pytest.raises(UsageError, match="^periods is for kind trajectory and kind slowflow; kind impacts draws"):
        plot.plot(data, kind="impacts", periods=(1, 2))
    assert plot.plot(data, periods=(1, 2)) is not None
    assert plot.plot(data, kind="impacts") is not None


def test_a_bifurcation_named_twice_is_refused_before_anything_is_followed(tmp_path, invoke):
    """`continue BRANCH.h5 --point 0 --point 0 --along Omega` followed the fold twice, into one
    file holding the same curve twice (and named it BRANCH_curve_0_0_Omega.h5)."""
    from handmade import write_branch_file

    path = write_branch_file(tmp_path / "branch.h5")
    result = invoke("continue", path, "--point", "0", "--point", "0", "--along", "Omega", "--to", "3", "5")
    assert result.exit_code == 2
    assert result.output.strip() == ("Error: --point 0 is given twice: each --point follows its bifurcation into a "
                                     "curve of its own; give each once")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["branch.h5"]


@pytest.mark.parametrize("options, says", [
    (dict(title="no"), "title must be True or False, got 'no'"),
    (dict(amplitude="no"), "amplitude must be True or False, got 'no'"),
    (dict(log="no"), "log must be True or False, got 'no'"),
    (dict(table="yes"), "table must be True or False, got 'yes'"),
    (dict(at="Delta=2.75"), "at must be a mapping of axis -> value, e.g. {'g': 20}, got 'Delta=2.75'"),
    (dict(at=[("Delta", 2.75)]), "at must be a mapping of axis -> value"),
    (dict(style=5), "style must be a style sheet's name or a .mplstyle file's path, got 5"),
])
def test_plots_arguments_of_the_wrong_type_are_refused(tmp_path, options, says):
    """vrsweep.plot.plot(..., title="no") drew the title and log="no" a logarithmic axis (a
    non-empty string is true); at="g=20" was an AttributeError, style=5 a TypeError from inside
    matplotlib. As vrsweep.sweep's flags are (FlagTypeError), they are checked first."""
    from vrsweep import plot
    from vrsweep.errors import UsageError

    path = _written_branch_file(tmp_path / "branch.h5", "oscillator")
    with pytest.raises(UsageError) as caught:
        plot.plot(str(path), **options)
    assert str(caught.value).startswith(says), str(caught.value)


@pytest.mark.parametrize("value", ["a", True, [1.0]])
def test_a_colour_scale_end_that_is_no_number_is_refused(value):
    from vrsweep.errors import UsageError
    from vrsweep.plot import map_figure

    with pytest.raises(UsageError, match="^vmin must be a number, got "):
        map_figure(None, vmin=value)


def _many_axes(count, both=False):
    import yaml

    names = [f"p{i}" for i in range(count)]
    sweep = {name: [1.0] for name in names}
    if both:
        sweep[names[0]] = {"values": [1.0, 2.0], "continuation": "both"}
    return yaml.safe_dump({
        "model": {"acceleration": "-x + cos(t)*(" + " + ".join(names) + ")", "parameters": dict.fromkeys(names, 1.0),
                  "period": "2*pi", "response": {"frequency": 1}},
        "initial": {"x": 0.0, "v": 0.0}, "sweep": sweep,
        "integration": {"transient_periods": 1, "measure_periods": 2, "strobe_periods": 1}}, sort_keys=False)


@pytest.mark.parametrize("count, both, limit", [(32, False, 31), (40, False, 31), (31, True, 30)])
def test_more_axes_than_a_file_holds_are_refused(count, both, limit):
    """A written model swept over 32 axes (of one value each) ran, then h5py stopped it: "Chunk
    dimensionality is too large" (HDF5 holds 32 dimensions, and each variable has one more, the
    strobe's, and a two-way sweep's direction); over 33, validate stopped in numpy's "only supports
    up to 32 dimensions". Both were tracebacks."""
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    with pytest.raises(ConfigError) as caught:
        parse_config(_many_axes(count, both), "m.yaml")
    assert [problem.split(": ", 2)[1:] for problem in caught.value.problems] == [
        ["sweep", f"has {count} axes; a result file holds at most {limit} (HDF5's 32 dimensions, less the strobe's"
                  + (" and the direction" if both else "") + "): fix the others at one value in the parameters"]]


def test_as_many_axes_as_a_file_holds_are_read():
    from vrsweep.config import parse_config

    assert len(parse_config(_many_axes(31)).axes) == 31
    assert len(parse_config(_many_axes(30, both=True)).axes) == 30


@pytest.mark.parametrize("steps", ["min_step: 1, max_step: 0.1", "max_step: 1.0e-6"])
def test_a_smallest_step_above_the_largest_is_named_not_the_first_step(tmp_path, invoke, steps):
    """continuation: {min_step: 1, max_step: 0.1} was refused as 'continuation.initial_step = 0.1
    must lie between continuation.min_step = 1 and continuation.max_step = 0.1', of a first step
    the config never gave (its default, set between the two)."""
    path = tmp_path / "c.yaml"
    path.write_text(f"model: effective\ncontinuation: {{parameter: g, from: 20, to: [10, 30], {steps}}}\n")
    result = invoke("validate", path)
    assert result.exit_code == 2
    assert "is above continuation.max_step" in result.output and "initial_step" not in result.output, result.output


def test_a_curves_smallest_step_above_the_largest_is_named(tmp_path, invoke):
    from handmade import write_branch_file

    path = write_branch_file(tmp_path / "branch.h5")
    result = invoke("continue", path, "--point", "0", "--along", "Omega", "--to", "3", "5",
                    "--set", "continuation.min_step=1", "--set", "continuation.max_step=0.1")
    assert result.exit_code == 2
    assert result.output.strip() == ("Error: continuation.min_step = 1 is above continuation.max_step = 0.1: the "
                                     "smallest step cannot exceed the largest")


@pytest.mark.parametrize("value", ["[1, 2]", "{acceleration: -x}"])
def test_a_model_setting_that_is_no_value_is_one_problem(value):
    """`--set model={acceleration: -x}` on a config with a written model gave two problems, the
    second blaming the config's own (valid) model under the setting's name: "--set model=...:
    model: must be one of original, effective, got {'name': 'lin', 'acceleration': ...}"."""
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    text = ("model:\n  acceleration: \"-x + F*cos(omega*t)\"\n  parameters: {F: 1.0, omega: 0.8}\n"
            "  period: \"2*pi/omega\"\n  response: {frequency: omega}\ninitial: {x: 0.0, v: 0.0}\n")
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "m.yaml", (f"model={value}",))
    assert len(caught.value.problems) == 1, caught.value.problems
    assert "VALUE must be a single number or word" in caught.value.problems[0]
