"""Models written in the config: the expression language, the config's checks, and the numbers.

Every numerical check compares vrsweep's generated kernel with something it does not share: a
closed form (the two-sided oscillator's impact times and speeds, the Duffing oscillator's energy,
the linear oscillator's grazing amplitude), the paper's hand-written kernel, or SciPy's solve_ivp
with events (written here, with its own right-hand sides).
"""

import math
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from vrsweep.cli import main
from vrsweep.config import load_config, parse_config
from vrsweep.errors import ConfigError
from vrsweep.numerics import expressions, kernel
from vrsweep.numerics.models import kernels_for
from vrsweep.numerics.trajectory import settings_vector, simulate
from vrsweep.results import Motion, Status

EXAMPLES = Path(__file__).resolve().parents[1] / "vrsweep" / "examples"


def example(name, **overrides):
    config = load_config(EXAMPLES / f"{name}.yaml", [f"{k}={v}" for k, v in overrides.items()])
    return config


# --- the expression language: a whitelist over the syntax tree ---------------------------------

NAMES = ("x", "v", "t", "a", "b")


@pytest.mark.parametrize("text, values, expected", [
    ("-2*a*v - x + b*cos(a*t + 1)", dict(a=0.3, b=2.0, x=0.5, v=-1.0, t=2.0),
     -2 * 0.3 * -1.0 - 0.5 + 2.0 * math.cos(0.3 * 2.0 + 1)),
    ("sqrt(abs(x)) + exp(-t) * tanh(v) - log(b) / tan(a)", dict(a=0.3, b=2.0, x=-4.0, v=0.5, t=1.0),
     2.0 + math.exp(-1.0) * math.tanh(0.5) - math.log(2.0) / math.tan(0.3)),
    ("min(x, v) + max(a, b) + sign(-v) * pi + x**3 - +a", dict(a=0.3, b=2.0, x=1.5, v=0.5, t=0.0),
     0.5 + 2.0 - math.pi + 1.5 ** 3 - 0.3),
])
def test_expressions_evaluate_as_written(text, values, expected):
    tree = expressions.parse(text, NAMES)
    assert float(expressions.evaluate(tree, values)) == pytest.approx(expected, rel=1e-15)


@pytest.mark.parametrize("text, token", [
    ("__import__('os').system('true')", "__import__"),
    ("x.real", "an attribute"),
    ("x[0]", "a subscript"),
    ("(lambda: 1)()", "lambda"),
    ("[x for x in (1, 2)]", "a comprehension"),
    ("'text'", "'text'"),
    ("open", "unknown name 'open'"),
    ("y + 1", "unknown name 'y'"),
    ("sin", "without calling it"),
    ("sin(x, v)", "2 argument(s), not 1"),
    ("max(x)", "1 argument(s), not 2"),
    ("x if v else t", "a conditional"),
    ("x < v", "a comparison"),
    ("x and v", "a logical operator"),
    ("x // 2", "FloorDiv"),
    ("-x + a*x^3", "writes ^, which is not a power here: write ** for a power (x**2, not x^2)"),
    ("x ** 1000", "power beyond"),
    ("cos(x=1)", "keyword"),
    ("True", "True"),
    ("1e999", "too large"),
    ("cos(" * 70 + "x" + ")" * 70, "nested"),
    ("x + " * 1000 + "x", "longer than"),
    ("", "empty"),
    ("x +", "not a valid expression"),
    # constant parts are folded in doubles: a power beyond 64 however written, and no constant
    # that is not a finite real number (each reached sympy or numba and ended in a traceback)
    ("1" + "0" * 400 + " * x", "too large for a double"),
    ("x ** -100", "power beyond"),
    ("x ** 64 ** 64", "power beyond"),
    ("2 ** 10 ** 10", "power beyond"),
    ("x + 1 / 0", "1 / 0 = inf"),
    ("x + log(0)", "log(0) = -inf"),
    ("x + sqrt(-1)", "sqrt(-1) = nan"),
    ("x + (-8) ** (1 / 3)", "not a finite real number"),
    ("exp(1000) * x", "exp(1000) = inf"),
    ("-x\n+ 1", "spans lines"),  # a YAML literal block: "not a valid expression at character 1"
    ("sin(*x)", "unpacks an argument with *"),  # was "calls sin with 1 argument(s), not 1"
    ("max(*x)", "unpacks an argument with *"),
])
def test_expressions_refuse_anything_but_the_whitelist(text, token):
    with pytest.raises(expressions.ExpressionError, match=None) as caught:
        expressions.parse(text, NAMES)
    assert token in str(caught.value)


def test_canonical_form_ignores_spacing():
    assert expressions.canonical("-2*zeta*v-x") == expressions.canonical(" -2 * zeta*v -  x ")


# --- the config: one line per problem, with the file, the line and the field --------------------

MODEL = """\
model:
  acceleration: "-2*zeta*v - x + F*cos(omega*t)"
  parameters: {zeta: 0.05, F: 1.0, omega: 0.8, Delta: 1.2, r: 0.8}
  barriers:
    - {position: Delta, side: above, restitution: r}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
initial: {x: 0.0, v: 0.0}
"""


def problems(text, overrides=()):
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "m.yaml", overrides)
    return caught.value.problems


def test_a_written_model_is_read_with_its_parameters():
    config = parse_config(MODEL + "sweep: {omega: [0.5, 1.0]}\n", "m.yaml", ["zeta=0.1"])
    assert config.written
    assert config.parameter_names == ("zeta", "F", "omega", "Delta", "r")
    assert config.parameters["zeta"] == 0.1 and config.parameters["F"] == 1.0
    assert parse_config(config.to_yaml()) == config  # stored configs read back as the same run


def test_an_unknown_set_names_the_written_models_own_parameters():
    """--set of a name the model lacks listed the kinds of names only: a written model's parameters
    are the user's own, so the message lists them."""
    (problem,) = problems(MODEL, ["Fx=3"])
    assert problem.startswith("--set Fx=3: unknown name 'Fx' (did you mean 'F'?) "
                              "(allowed: a parameter (zeta, F, omega, Delta, r), an integration key"), problem


@pytest.mark.parametrize("change, expected", [
    (("F*cos(omega*t)", "G*cos(omega*t)"), "m.yaml:2: model.acceleration: refers to an unknown name 'G'"),
    (("F*cos(omega*t)", "__import__('os')"), "m.yaml:2: model.acceleration: calls __import__"),
    (("position: Delta", "position: Gap"), "m.yaml:5: model.barriers[0].position: refers to an unknown name 'Gap'"),
    (("side: above", "side: up"), "m.yaml:5: model.barriers[0].side: must be above"),
    (("2*pi/omega", "2*pi/x"), "m.yaml:6: model.period: depends on x, but it may depend on the parameters only"),
    (("position: Delta", "position: Delta + 0*t"), "m.yaml:5: model.barriers[0].position: depends on t"),
    (("position: Delta", "position: Delta*v"), "m.yaml:5: model.barriers[0].position: depends on v"),
    # a number that is not finite was written back as 'inf' and refused as "an unknown name 'inf'"
    (("position: Delta", "position: .inf"), "m.yaml:5: model.barriers[0].position: must be a finite number or an "
                                            "expression, got inf"),
    (("zeta: 0.05", "x: 0.05"), "m.yaml:3: model.parameters.x: x is taken"),
    (("r: 0.8}", "r: 1.5}"), "m.yaml:5: model.barriers[0].restitution: must be in [0, 1]"),
    (("omega: 0.8", "omega: -0.8"), "m.yaml:6: model.period: must be > 0 and finite, got -7.85"),
    (("x: 0.0,", "x: 1.5,"), "m.yaml:8: initial.x: must be below or on model.barriers[0]"),
    (("acceleration:", "acceleraton:"), "m.yaml:2: model.acceleraton: unknown key (did you mean 'acceleration'?)"),
])
def test_bad_models_name_the_file_line_and_field(change, expected):
    found = problems(MODEL.replace(*change))
    assert any(problem.startswith(expected) for problem in found), found


@pytest.mark.parametrize("name", ["R", "status", "period", "curve", "rtol", "max_period", "model"])
def test_a_parameter_may_not_take_a_name_vrsweep_stores_or_sets(name):
    """A parameter R swept was an axis beside the variable R: h5py refused it after the whole run
    ("name already exists", a traceback); a parameter rtol could not be set by --set rtol=."""
    found = problems(MODEL.replace("zeta: 0.05,", f"zeta: 0.05, {name}: 0.5,"))
    assert any(problem.startswith(f"m.yaml:3: model.parameters.{name}: {name} is taken") for problem in found), found


def test_the_taken_names_cover_every_array_a_result_file_names_itself():
    from vrsweep.config.models import STORED_NAMES
    from vrsweep.config.schema import Integration, INTEGRATION_DEFAULTS
    from vrsweep.store import curve_file
    from vrsweep.store.layout import BOOKKEEPING
    from vrsweep.store.variables import point_variables

    integration = Integration(**dict(INTEGRATION_DEFAULTS, lyapunov=True))
    stored = {spec[0] for spec in point_variables(integration)} | {"strobe"} | set(BOOKKEEPING)
    stored |= set(curve_file.layout([]))
    # and the dimensions: each variable's extra ones, and a two-way sweep's direction (a parameter
    # named direction, swept beside a continuation: both axis, stopped the run: duplicate axis names)
    stored |= {dim[0] if isinstance(dim, tuple) else dim for spec in point_variables(integration) for dim in spec[2]}
    from vrsweep.config import parse_config
    from vrsweep.config.grid import Grid

    grid = Grid.from_config(parse_config("sweep:\n  g: {values: [1, 2], continuation: both}\n"))
    stored |= set(grid.axis_names) - {"g"}
    assert stored <= STORED_NAMES | expressions.RESERVED, stored - STORED_NAMES - expressions.RESERVED


def test_a_symbol_matplotlib_cannot_draw_is_refused_when_the_config_is_read(tmp_path):
    """symbols: {zeta: '\\frac{'} passed validate and run; then plot failed with a traceback
    from matplotlib's mathtext parser."""
    text = MODEL.replace("  barriers:", "  symbols: {zeta: '\\frac{', omega: '\\omega_0'}\n  barriers:")
    found = problems(text)
    assert len(found) == 1 and found[0].startswith("m.yaml:4: model.symbols.zeta: matplotlib cannot draw $\\frac{$"), found
    path = tmp_path / "m.yaml"
    path.write_text(text)
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output


def test_the_messages_docs_models_shows_are_the_ones_given():
    """docs/models.md showed the unknown-name message without t, v, x and phi in its list."""
    import re
    import yaml

    page = (Path(__file__).resolve().parents[1] / "docs" / "models.md").read_text()
    section = yaml.safe_load(re.search(r"```yaml\n(model:.*?)```", page, re.S).group(1))["model"]
    shown = re.search(r"```text\n(m\.yaml:2: model\.acceleration: refers.*?)```", page, re.S).group(1).splitlines()
    for line, acceleration in zip(shown, ["G*x", "__import__('os')"]):
        model = {"acceleration": acceleration, **{k: v for k, v in section.items() if k not in ("name", "acceleration")}}
        text = yaml.safe_dump({"model": model, "initial": {"x": 0.0, "v": 0.0}}, sort_keys=False)
        found = problems(text)
        assert any(problem.startswith(line.removesuffix("...")) for problem in found), (line, found)


def test_a_start_the_user_never_wrote_is_called_the_default():
    """Without initial:, a written model starts at the paper's (0.99, 0.5): a refusal that named
    initial.x = 0.99 named a value the config does not hold."""
    text = MODEL.replace("initial: {x: 0.0, v: 0.0}\n", "").replace("Delta: 1.2", "Delta: 0.5")
    (problem,) = problems(text)
    assert problem.startswith("m.yaml:1: initial.x: must be below or on model.barriers[0]"), problem
    assert "the config gives no initial.x, and the default start is the paper's (x, v) = (0.99, 0.5)" in problem
    (problem,) = problems(MODEL.replace("x: 0.0,", "x: 1.5,"))
    assert "default" not in problem, problem


def test_a_bad_period_is_not_also_blamed_on_the_step_cap_it_sets():
    """max_step defaults to period/8: a negative period made a second problem at model.max_step,
    a key the config does not hold. A step cap of its own is still checked."""
    found = problems(MODEL.replace("omega: 0.8", "omega: -0.8"))
    assert not any("max_step" in problem for problem in found), found
    found = problems(MODEL.replace("omega: 0.8", "omega: -0.8").replace("initial:", '  max_step: "0.1*omega"\ninitial:'))
    assert any(problem.startswith("m.yaml:8: model.max_step: must be > 0") for problem in found), found


@pytest.mark.parametrize("acceleration", ["-x + 1/(x - x)", "sqrt(-1 - x**2) + F*cos(omega*t)",
                                          "log(-exp(v)) - x", "F*cos(omega*t) + 1/(0*t)"])
def test_an_acceleration_undefined_everywhere_is_refused(acceleration):
    """0/0 or the root of a negative number at every state: every point ended non_finite, after a
    30 s compile, with nothing said when the config was read."""
    (problem,) = problems(MODEL.replace("-2*zeta*v - x + F*cos(omega*t)", acceleration))
    assert problem.startswith("m.yaml:2: model.acceleration: is NaN or infinite at every one of the 105 states "
                              "tried"), problem


def test_an_acceleration_undefined_at_every_point_of_a_sweep_is_refused_and_at_some_is_not():
    text = MODEL.replace("-2*zeta*v - x + F*cos(omega*t)", "-x + sqrt(-c**2)").replace("{zeta: 0.05,", "{c: 1.0, zeta: 0.05,")
    (problem,) = problems(text + "sweep: {c: [1.0, 2.0, 3.0]}\n")
    assert "at each of 3 grid points tried, e.g. c = 1.0" in problem, problem
    parse_config(text + "sweep: {c: [3.0, 2.0, 0.0]}\n", "m.yaml")  # c = 0: sqrt(-0) = 0, a motion


def test_an_acceleration_singular_at_some_states_is_a_status_not_a_refusal():
    """1/x is infinite at x = 0 only: a start there is that point's non_finite (a numerical
    failure is a status on its grid point), and the config is valid."""
    config = parse_config(MODEL.replace("-2*zeta*v - x + F*cos(omega*t)", "-x + F*cos(omega*t)/x"), "m.yaml")
    assert config.model.acceleration.replace(" ", "") == "-x+F*cos(omega*t)/x"


def test_swept_values_are_checked_at_every_grid_point():
    found = problems(MODEL + "sweep: {r: [0.5, 0.9, 1.2]}\n")
    assert any("model.barriers[0].restitution: must be in [0, 1] (eq2.2: a rebound cannot gain energy), got 1.2 "
               "at r = 1.2" in problem for problem in found), found


def test_two_barriers_must_face_each_other_and_not_overlap():
    two = MODEL.replace("    - {position: Delta, side: above, restitution: r}\n",
                        "    - {position: Delta, side: above, restitution: r}\n"
                        "    - {position: -Delta, side: below, restitution: r}\n")
    assert parse_config(two, "m.yaml").model.barriers[1].side == "below"
    same = two.replace("side: below", "side: above")
    assert any("model.barriers[1].side: two barriers on the same side" in p for p in problems(same))
    crossed = two.replace("Delta: 1.2", "Delta: -1.2").replace("x: 0.0,", "x: 0.0,")
    assert any("must lie above the barrier below" in p for p in problems(crossed))


@pytest.mark.parametrize("change, expected", [
    (('"-2*zeta*v - x + F*cos(omega*t)"', "null"), "m.yaml:2: model.acceleration: is null"),
    (("{zeta: 0.05, F: 1.0, omega: 0.8, Delta: 1.2, r: 0.8}", "null"), "m.yaml:3: model.parameters: is null"),
    (('"2*pi/omega"', "null"), "m.yaml:6: model.period: is null"),
    (("{frequency: omega, scale: F}", "null"), "m.yaml:7: model.response: is null"),
    (("frequency: omega", "frequency: null"), "m.yaml:7: model.response.frequency: is null"),
    (("position: Delta", "position: null"), "m.yaml:5: model.barriers[0].position: is null"),
    (("restitution: r", "restitution: null"), "m.yaml:5: model.barriers[0].restitution: is null"),
    (("side: above", "side: null"), "m.yaml:5: model.barriers[0].side: is null"),
])
def test_a_required_key_written_as_null_is_refused_as_missing(change, expected, tmp_path):
    """A null passed the check for a missing key: ``acceleration: null`` was valid and the run a
    traceback, ``position: null`` dropped the barrier without a word, ``response: null`` a traceback."""
    assert problems(MODEL.replace(*change)) == [expected + ", which gives no value" + (
        " (a written model needs acceleration, parameters, period and response)" if "[" not in expected
        and "frequency" not in expected else ": the frequency of R's Fourier component"
        if "frequency" in expected else "")]
    path = tmp_path / "m.yaml"
    path.write_text(MODEL.replace(*change))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1, result.output


def test_a_bad_parameter_name_does_not_blame_the_acceleration_for_using_x():
    """With a parameter refused, the acceleration was checked without x, v and t, and a second
    line said "model.acceleration: depends on x, but it may depend on the parameters only"."""
    found = problems(MODEL.replace("zeta: 0.05", "sin: 0.05").replace("-2*zeta*v - x + F*cos(omega*t)", "-x"))
    assert len(found) == 1 and found[0].startswith("m.yaml:3: model.parameters.sin: sin is taken"), found


def test_the_cli_refuses_a_bad_model_in_one_line_with_exit_2(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(MODEL.replace("F*cos(omega*t)", "F*cos(omega*t).real"))
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 2
    assert "bad.yaml:2: model.acceleration: may not hold an attribute" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "out.h5").exists()


def test_an_integer_beyond_a_double_is_one_line_not_a_traceback(tmp_path):
    """float() of a 400-digit integer raised OverflowError out of the parser: a traceback."""
    path = tmp_path / "bad.yaml"
    path.write_text(MODEL.replace("F*cos(omega*t)", "1" + "0" * 400 + "*cos(omega*t)"))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2, result.output
    assert "bad.yaml:2: model.acceleration: holds a number too large for a double" in result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1


def test_the_paper_theory_is_refused_for_a_written_model(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(MODEL)
    result = CliRunner().invoke(main, ["theory", str(path)])
    assert result.exit_code == 2, result.output
    assert "written model" in result.output and "Traceback" not in result.output


# --- numbers: closed forms ------------------------------------------------------------------

def _run(config, method="rk45", lyapunov=False, periods=None, rtol=1e-11, parameters=None, **settings):
    """One point of ``config``'s model; ``parameters`` override the config's without its checks
    (an unforced run has R = |Q| / 0, which a config refuses)."""
    model = config.model
    coefficients = kernels_for(model).coefficients(dict(config.parameters, **(parameters or {})))
    integration = dict(vars(config.integration), rtol=rtol, atol=rtol * 1e-2, **settings)
    if periods is not None:
        integration.update(transient_periods=0, measure_periods=periods)
    vector = settings_vector(**{k: v for k, v in integration.items()
                                if k in kernel.SETTING_NAMES})
    return simulate(coefficients, [config.initial["x"], config.initial["v"]], vector, method=method,
                    lyapunov=lyapunov, model=model)


@pytest.mark.parametrize("method", ["rk45", "dop853"])
def test_two_sided_impacts_match_the_closed_form(method):
    """Undamped, unforced, started at x = 0 with speed v0: each flight from stop to stop takes
    2 asin(Delta / A) with A^2 = Delta^2 + u^2 (energy), u the speed leaving a stop, which drops by
    r at each impact; the first impact is at asin(Delta / v0). Both barriers, alternately."""
    delta, r, v0 = 1.0, 0.9, 2.5
    config = example("impact_two_sided", Delta=delta, r=r, omega=1.0, **{"initial.v": v0})
    run = _run(config, method, periods=3, parameters=dict(zeta=0.0, F=0.0))
    assert run.status == Status.OK
    times, speeds = [math.asin(delta / v0)], [math.sqrt(v0 * v0 - delta * delta)]
    while times[-1] < 3 * 2 * math.pi:
        u = r * speeds[-1]
        times.append(times[-1] + 2 * math.asin(delta / math.hypot(delta, u)))
        speeds.append(u)
    n = np.searchsorted(times, 3 * 2 * math.pi)
    assert n >= 8 and len(run.impacts) == n
    np.testing.assert_allclose(run.impacts[:, 0], times[:n], rtol=0, atol=1e-8)
    signs = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)  # up to +Delta first, then down to -Delta
    np.testing.assert_allclose(run.impacts[:, 1], signs * np.array(speeds[:n]), rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.impacts[:, 2], -r * signs * np.array(speeds[:n]), rtol=0, atol=1e-8)


def test_the_slowest_impact_of_an_orbit_is_a_speed_on_a_barrier_below_too():
    """Continuation's slowest impact (numerics.shooting.periodic_map) was the signed minimum of
    x'(-): with a barrier below, the fastest impact there, negative, which read as an impact past
    stopping at every orbit (a branch of a Duffing oscillator between two stops crawled 180
    points at min_step). The closed form of the two-sided flights (above): the last speed."""
    from vrsweep.numerics.shooting import periodic_map

    delta, r, v0 = 1.0, 0.9, 2.5
    config = example("impact_two_sided", Delta=delta, r=r, omega=1.0, **{"initial.v": v0})
    coefficients = kernels_for(config.model).coefficients(dict(config.parameters, zeta=0.0, F=0.0))
    settings = settings_vector(rtol=1e-11, atol=1e-13)
    orbit_map = periodic_map(coefficients, np.array([0.0, v0]), settings, 1, model=config.model)
    speeds = [math.sqrt(v0 * v0 - delta * delta)]
    while len(speeds) < orbit_map.impacts:
        speeds.append(r * speeds[-1])
    assert orbit_map.impacts >= 3 and (orbit_map.impact_speeds < 0).any()  # both barriers met
    assert orbit_map.slowest_impact == pytest.approx(speeds[-1], abs=1e-8)


def test_duffing_energy_is_conserved_through_elastic_impacts():
    """zeta = F1 = F2 = 0, r = 1: H = v^2/2 + x^2/2 + beta x^4/4 is a constant of the motion, and an
    elastic impact only flips v. Checked at every stroboscopic point and every impact."""
    beta = 0.5
    config = example("impact_duffing_two_forces", r=1.0, beta=beta, **{"initial.x": 0.2, "initial.v": 1.4})
    run = _run(config, periods=20, parameters=dict(zeta=0.0, F1=0.0, F2=0.0))
    assert run.status == Status.OK and len(run.impacts) >= 10

    def energy(x, v):
        return 0.5 * v * v + 0.5 * x * x + 0.25 * beta * x ** 4

    start = energy(0.2, 1.4)
    strobe = run.period_records
    np.testing.assert_allclose(energy(strobe[:, kernel.REC_X], strobe[:, kernel.REC_V]), start, rtol=1e-8)
    np.testing.assert_allclose(energy(config.parameters["Delta"], run.impacts[:, 1]), start, rtol=1e-8)
    np.testing.assert_allclose(run.impacts[:, 2], -run.impacts[:, 1], rtol=1e-15)


def _free_amplitude(zeta, F, omega):
    return F / np.hypot(1 - omega ** 2, 2 * zeta * omega)


@pytest.mark.slow
def test_continue_locates_the_linear_oscillators_graze_and_follows_it_in_omega(tmp_path):
    """The period-1 orbit continued in Delta from a barrier out of reach (the shipped example): it
    grazes where Delta equals the free amplitude F / sqrt((1 - omega^2)^2 + (2 zeta omega)^2); the
    graze followed in (Delta, omega) is that amplitude as a function of omega. From the command
    line, so that the branch and curves files, info and plot are tried on a written model too."""
    import h5py

    import vrsweep

    runner = CliRunner()
    branch, curve = tmp_path / "branch.h5", tmp_path / "curve.h5"
    result = runner.invoke(main, ["continue", str(EXAMPLES / "impact_linear.yaml"), "-o", str(branch)])
    assert result.exit_code == 0, result.output
    p = example("impact_linear").parameters
    with h5py.File(branch, "r") as f:
        kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in f["bifurcation_kind"][()]]
        grazes = f["bifurcation_parameter"][()][np.array(kinds) == "grazing"]
    assert len(grazes) == 1
    assert abs(grazes[0] - _free_amplitude(p["zeta"], p["F"], p["omega"])) < 1e-6
    with vrsweep.open_results(branch) as ds:  # measured to the barrier at each orbit's own Delta,
        delta, x_max = ds["parameter"].values, ds["x_max"].values  # not at the config's Delta = 1.2
        np.testing.assert_allclose(ds["barrier_distance"].values, delta - x_max, rtol=0, atol=1e-12)
        free = ds["impacts_per_period"].values == 0
        assert free.any() and np.all(ds["barrier_distance"].values[free] > 0)
    point = kinds.index("grazing")
    result = runner.invoke(main, ["continue", str(branch), "--point", str(point), "--along", "omega",
                                  "--to", "0.7", "0.9", "-o", str(curve)])
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(curve) as ds:
        delta, omega = ds["Delta"].values, ds["omega"].values
    assert len(omega) >= 10 and np.ptp(omega) > 0.1
    for path in (branch, curve):  # the model's own period and response, not the paper's omega and c
        with h5py.File(path, "r") as f:
            assert f["R"].attrs["long_name"].startswith("gain R = |Q|/|F| over the orbit, Q at the response "
                                                        "frequency omega"), path
            assert f["periods"].attrs["long_name"] == "orbit period in periods T = 2 * pi / omega", path
            assert "Roy" not in f.attrs["references"], path
    with h5py.File(curve, "r") as f:  # its own parameters, not the paper's slow forcing frequency
        assert f["omega"].attrs["long_name"] == "model parameter omega"
        assert f["special_omega"].attrs["long_name"] == "model parameter omega at the codimension-two point"
    np.testing.assert_allclose(delta, _free_amplitude(p["zeta"], p["F"], omega), rtol=0, atol=1e-6)
    for path in (branch, curve):
        assert runner.invoke(main, ["info", str(path)]).exit_code == 0
    # The continued parameters are not fixed (the branch's Delta was 'fixed: ... Delta=1.2').
    from vrsweep.commands.info import describe

    assert set(describe(branch)["fixed_parameters"]) == {"zeta", "F", "omega", "phi", "r"}
    assert set(describe(curve)["fixed_parameters"]) == {"zeta", "F", "phi", "r"}
    figure = runner.invoke(main, ["plot", str(branch), "-o", str(tmp_path / "branch.png")])
    assert figure.exit_code == 0, figure.output


# --- numbers: the paper's system written out against the hand-written kernel -----------------

PAPER_POINTS = [dict(g=30.0, Omega=4.0), dict(g=10.0, Omega=4.0)]  # period 1; period 3 with impacts


@pytest.mark.slow
@pytest.mark.parametrize("method", ["rk45", "dop853"])
@pytest.mark.parametrize("point", PAPER_POINTS, ids=["g30", "g10"])
def test_the_paper_written_out_gives_the_builtin_numbers(point, method):
    written = example("paper_written", **point)
    builtin = parse_config("model: original\n", "<builtin>", [f"{k}={v}" for k, v in point.items()])
    settings = dict(rtol=1e-10, atol=1e-12, transient_periods=100, measure_periods=100)
    vector = settings_vector(**settings)
    a = simulate(kernels_for(written.model).coefficients(written.parameters), [0.99, 0.5], vector,
                 method=method, lyapunov=method == "rk45", model=written.model)
    b = simulate(kernels_for("original").coefficients(builtin.parameters), [0.99, 0.5], vector,
                 method=method, lyapunov=method == "rk45")
    assert a.status == b.status == Status.OK
    assert a.summary[kernel.SUM_R] == pytest.approx(b.summary[kernel.SUM_R], rel=1e-6)
    assert a.summary[kernel.SUM_IMPACTS_PER_PERIOD] == b.summary[kernel.SUM_IMPACTS_PER_PERIOD]
    if method == "rk45":
        assert a.summary[kernel.SUM_LYAPUNOV] == pytest.approx(b.summary[kernel.SUM_LYAPUNOV], abs=1e-6)


# --- numbers: SciPy with events, written here ----------------------------------------------------

def scipy_reference(acceleration, barriers, x0, v0, period, frequency, scale, n_transient, n_measure):
    """R, impacts per period and the stroboscopic states of x'' = acceleration(t, x, v) with rigid
    stops [(position, side, r)], by solve_ivp (DOP853, rtol 1e-12) with an event per stop."""
    def rhs(t, y):
        return [y[1], acceleration(t, y[0], y[1]), y[0] * math.sin(frequency * t), y[0] * math.cos(frequency * t)]

    events = []
    for position, side, _ in barriers:
        def reach(t, y, position=position, side=side):
            return side * (y[0] - position)
        reach.terminal, reach.direction = True, 1.0
        events.append(reach)
    y = np.array([x0, v0, 0.0, 0.0])
    t = 0.0
    strobe, impacts, quadratures = [], 0, np.zeros(2)
    for k in range(n_transient + n_measure):
        y[2:] = 0.0
        end = (k + 1) * period
        while t < end:
            solution = solve_ivp(rhs, (t, end), y, method="DOP853", rtol=1e-12, atol=1e-13, events=events)
            t, y = solution.t[-1], solution.y[:, -1].copy()
            if solution.status == 1:  # a stop reached: the impact law
                hit = next(i for i, e in enumerate(solution.t_events) if len(e))
                position, side, r = barriers[hit]
                y[0], y[1] = position, -r * y[1]
                impacts += k >= n_transient
                if abs(y[1]) < 1e-9:
                    raise AssertionError("the reference does not model sticking: choose another point")
        if k >= n_transient:
            quadratures += y[2:]
            strobe.append(y[:2].copy())
    window = n_measure * period
    R = math.hypot(*(2.0 * quadratures / window)) / scale
    return R, impacts / n_measure, np.array(strobe)


def _period(strobe, tolerance=1e-6, longest=8):
    for p in range(1, longest + 1):
        if np.all(np.abs(strobe[p:] - strobe[:-p]) < tolerance * (1 + np.abs(strobe[p:]))):
            return p
    return 0


SCIPY_CASES = {
    "impact_linear": (dict(omega=1.0), lambda p: lambda t, x, v: -2 * p["zeta"] * v - x
                      + p["F"] * math.cos(p["omega"] * t + p["phi"])),
    "impact_two_sided": (dict(F=1.0), lambda p: lambda t, x, v: -2 * p["zeta"] * v - x
                         + p["F"] * math.cos(p["omega"] * t)),
    "impact_duffing_two_forces": (dict(phi=2.0), lambda p: lambda t, x, v: -2 * p["zeta"] * v - x - p["beta"] * x ** 3
                                  + p["F1"] * math.cos(p["omega"] * t) + p["F2"] * math.cos(2 * p["omega"] * t + p["phi"])),
    "paper_written": (dict(g=30.0), lambda p: lambda t, x, v: p["c"] * math.cos(p["omega"] * t)
                      + p["g"] * math.cos(p["Omega"] * t) - p["gamma"] * (x * x - 1) * v + p["omega0"] ** 2 * x
                      - p["alpha"] * x ** 3),
}


@pytest.mark.slow
@pytest.mark.parametrize("method", ["rk45", "dop853"])
@pytest.mark.parametrize("name", list(SCIPY_CASES))
def test_reference_models_agree_with_scipy(name, method):
    overrides, make = SCIPY_CASES[name]
    config = example(name, **overrides)
    p = config.parameters
    model = config.model
    values = kernels_for(model).coefficients(p)
    from vrsweep.numerics.coefficients import PERIOD, RESPONSE_FREQUENCY, RESPONSE_SCALE
    from vrsweep.numerics.written import header_values

    header = header_values(model, p)
    barriers = [(float(header[f"barriers.{i}.position"]), 1.0 if b.side == "above" else -1.0,
                 float(header[f"barriers.{i}.restitution"])) for i, b in enumerate(model.barriers)]
    n_transient, n_measure = 100, 40
    R, impacts, strobe = scipy_reference(make(p), barriers, config.initial["x"], config.initial["v"],
                                         values[PERIOD], values[RESPONSE_FREQUENCY], values[RESPONSE_SCALE],
                                         n_transient, n_measure)
    run = _run(config, method, rtol=1e-11, transient_periods=n_transient, measure_periods=n_measure)
    assert run.status == Status.OK
    ours = run.period_records[n_transient:, [kernel.REC_X, kernel.REC_V]]
    assert _period(strobe) == _period(ours) > 0  # a periodic point, where both are converged
    assert run.summary[kernel.SUM_IMPACTS_PER_PERIOD] == impacts
    assert run.summary[kernel.SUM_R] == pytest.approx(R, rel=1e-7)


def test_a_deeply_nested_sine_is_derived_in_seconds():
    """harmonics() ran sympy.simplify on every sine's argument: sin(sin(...sin(x))) sixty deep, a
    291-character acceleration within every limit, kept sympy busy for minutes before numba began.
    The harmonics a t are now recognised by expansion, after the cheap tests."""
    import time

    from vrsweep.numerics import codegen
    from vrsweep.numerics.written import WrittenModel

    text = "-x + F*cos(omega*t) + " + "sin(" * 58 + "x" + ")" * 58
    model = WrittenModel(acceleration=expressions.canonical(text), parameters=(("F", 1.0), ("omega", 0.8)),
                         period="2*pi/omega", response_frequency="omega")
    start = time.perf_counter()
    source = codegen.source(model)
    assert time.perf_counter() - start < 20
    assert "C_1" in source  # cos(omega t) is still the rotated harmonic


# --- compiled once, and never stale --------------------------------------------------------------

def test_a_second_run_of_the_same_model_compiles_nothing():
    """The two-sided model's kernel, compiled by the closed-form test above (or here), is loaded
    from numba's cache by a fresh process: no compilation, cache hits only."""
    config = example("impact_two_sided", **{"initial.v": 2.5})
    _run(config, periods=1)  # compiled (or loaded) in this process, so cached on disk
    script = (
        "from vrsweep.config import load_config\n"
        "from vrsweep.numerics.models import kernels_for\n"
        "from vrsweep.numerics.trajectory import settings_vector, simulate\n"
        f"config = load_config({str(EXAMPLES / 'impact_two_sided.yaml')!r}, ['initial.v=2.5'])\n"
        "kernels = kernels_for(config.model)\n"
        "simulate(kernels.coefficients(config.parameters), [0.0, 2.5], settings_vector(rtol=1e-11, atol=1e-13,"
        " transient_periods=0, measure_periods=1), model=config.model)\n"
        "function = kernels.integrator('rk45')\n"
        "print(sum(function.stats.cache_hits.values()), sum(function.stats.cache_misses.values()))\n"
        "import sys; print('sympy' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["1", "0", "False"]  # loaded, not compiled; not even sympy imported


def test_a_changed_equation_is_another_module():
    """The generated module is keyed by what its code depends on: a changed acceleration (or its
    parameters' order) is another file, so numba can never load the old equation's kernel."""
    from vrsweep.numerics import codegen

    base = example("impact_linear").model
    changed = parse_config(MODEL.replace("- x +", "- 1.01*x +"), "m.yaml").model
    reordered = parse_config(MODEL.replace("{zeta: 0.05, F: 1.0", "{F: 1.0, zeta: 0.05"), "m.yaml").model
    names = {codegen.module_name(m) for m in (base, changed, reordered, parse_config(MODEL, "m.yaml").model)}
    assert len(names) == 4
    assert "1.01" in codegen.source(changed) and "1.01" not in codegen.source(parse_config(MODEL, "m.yaml").model)
    same = parse_config(MODEL.replace("Delta: 1.2", "Delta: 1.5"), "m.yaml").model  # a default: header only
    assert codegen.module_name(same) == codegen.module_name(parse_config(MODEL, "m.yaml").model)


# --- the whole tool on a written model -------------------------------------------------------------

@pytest.mark.slow
def test_sweeps_shards_merge_lyapunov_and_overflow_on_a_written_model(tmp_path):
    """The two-sided oscillator through the Python API and the command line: shards merged give the
    whole run bit for bit, Lyapunov exponents come with it, and an overflowing point is a status."""
    import vrsweep

    text = (EXAMPLES / "impact_two_sided.yaml").read_text().replace(
        "F: {start: 0.1, stop: 3.0, num: 59}", "F: [0.2, 1.0, 2.0, 1.0e300]")
    config = tmp_path / "two.yaml"
    config.write_text(text.replace("transient_periods: 200", "transient_periods: 50")
                      .replace("measure_periods: 100", "measure_periods: 20"))
    runner = CliRunner()
    for shard in ("0/2", "1/2"):
        result = runner.invoke(main, ["run", str(config), "--shard", shard, "-o", str(tmp_path / "s.h5")])
        assert result.exit_code == 0, result.output
    shards = sorted(str(p) for p in tmp_path.glob("s.shard*.h5"))
    assert runner.invoke(main, ["merge", *shards, "-o", str(tmp_path / "merged.h5")]).exit_code == 0
    whole = vrsweep.sweep(str(config), output=str(tmp_path / "whole.h5"), lyapunov=True)
    with vrsweep.open_results(tmp_path / "merged.h5") as merged:
        np.testing.assert_array_equal(merged["R"].values, whole["R"].values)
        statuses = merged["status"].values
        assert merged.attrs["model"] == "written" and "two-sided" in merged.attrs["model_name"]
        # the paper is not this model's reference (every written model's file cited it), merged or not
        for attrs in (merged.attrs, whole.attrs):
            assert "Roy" not in attrs["references"] and "model_definition" in attrs["references"]
    assert list(statuses[:3]) == [Status.OK] * 3 and statuses[3] != Status.OK  # F = 1e300 overflows
    assert np.all(np.isfinite(whole["lyapunov"].values[:3]))
    info = runner.invoke(main, ["info", str(tmp_path / "merged.h5")])
    assert info.exit_code == 0 and "model_definition" in info.output


# --- figures of a written model: no paper theory, barriers where they are ----------------------

def _short_linear_sweep(tmp_path, name, sweep, *replacements):
    """The impact_linear example swept over ``sweep`` (YAML under sweep:) instead of its omega
    axis, 4 + 16 periods, with ``replacements`` (old, new) in its text: the result file's path."""
    import vrsweep

    text = (EXAMPLES / "impact_linear.yaml").read_text()
    for old, new in (("omega: {start: 0.4, stop: 1.6, num: 61}", sweep), ("transient_periods: 200",
                     "transient_periods: 4"), ("measure_periods: 100", "measure_periods: 16"), *replacements):
        assert old in text, old
        text = text.replace(old, new)
    config = tmp_path / f"{name}.yaml"
    config.write_text(text)
    output = tmp_path / f"{name}.h5"
    vrsweep.sweep(str(config), output=str(output))
    return output


def test_the_bifurcation_diagram_of_a_written_model_draws_its_barrier_where_it_is(tmp_path):
    """`plot --kind bifurcation` of a written model's sweep drew the paper's g_res lines from its
    nine parameters (KeyError: 'gamma', a traceback), and a barrier that moves with the swept
    parameter (position: "0.5*F + 0.2") as one horizontal line at the default F."""
    import vrsweep
    from vrsweep import plot

    output = _short_linear_sweep(tmp_path, "moving", "F: [0.2, 1.0, 2.0]",
                                 ("{position: Delta, side: above", '{position: "0.5*F + 0.2", side: above'))
    result = CliRunner().invoke(main, ["plot", str(output), "--kind", "bifurcation", "-o", str(tmp_path / "b.png")])
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(output) as ds:
        figure = plot.bifurcation_figure(ds)
    [barrier] = [line for line in figure.axes[0].get_lines() if line.get_label() == "barrier"]
    np.testing.assert_allclose(barrier.get_ydata(), [0.3, 0.7, 1.2])
    np.testing.assert_allclose(barrier.get_xdata(), [0.2, 1.0, 2.0])
    # Its own period, not the paper's slow one (the legend said 'last 16 slow periods').
    legend = [text.get_text() for text in figure.axes[0].get_legend().get_texts()]
    assert "x(nT), last 16 periods of each point" in legend, legend


def test_a_map_of_a_written_model_draws_no_resonance_curve(tmp_path):
    """`plot MAP.h5` (and `plot MAP.h5 CURVES.h5`) of a written model's sweep over two axes drew the
    paper's g_res(Omega) contour from its nine parameters: KeyError: 'alpha', a traceback."""
    import vrsweep
    from vrsweep import plot

    output = _short_linear_sweep(tmp_path, "map", "omega: [0.6, 0.8, 1.0]\n  F: [0.5, 1.0]")
    result = CliRunner().invoke(main, ["plot", str(output), "--kind", "map", "-o", str(tmp_path / "m.png")])
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(output) as ds:
        figure = plot.map_figure(ds, "R")
        counts = plot.map_figure(ds, "impacts_per_period")
    assert not any("g_{res}" in str(handle.get_label()) for handle in figure.axes[0].get_legend_handles_labels()[0])
    # Its own response and period, not the paper's |Q|/c and slow period 2 pi/omega.
    labels = [ax.get_ylabel() for ax in figure.axes] + [ax.get_ylabel() for ax in counts.axes]
    assert any(label.startswith("gain $R = |Q|$ / |F|") for label in labels), labels
    assert any(label.startswith("mean impacts per period $T$") for label in labels), labels
    assert not any("c$" in label or "slow" in label for label in labels), labels
    # Qs and Qc at its response frequency by its symbol; no paper's omega or eq3.1 (the words of --var).
    with vrsweep.open_results(output) as ds:
        sine = plot.map_figure(ds, "Qs").axes[-1].get_ylabel().replace("\n", " ")
    assert sine == "Qs: sine component of x at $\\omega$", sine


def test_a_written_models_axes_are_its_own_parameters_not_the_papers_namesakes(tmp_path):
    """A written model's parameter named as one of the paper's (omega, Delta, c...) was stored and
    shown by `info` with the paper's words: its forcing frequency omega as 'slow forcing frequency
    omega', a damping written `c` would be 'slow forcing amplitude c'."""
    import h5py

    output = _short_linear_sweep(tmp_path, "axes", "omega: [0.6, 0.8]\n  F: [0.5, 1.0]")
    with h5py.File(output, "r") as f:
        assert f["omega"].attrs["long_name"] == "model parameter omega"
        assert f["F"].attrs["long_name"] == "model parameter F"
    shown = CliRunner().invoke(main, ["info", str(output)]).output
    assert "slow forcing" not in shown, shown


def test_a_written_models_response_curve_and_basins_say_its_gain_is_over_the_scales_magnitude(tmp_path):
    """R is |Q| / |F| (a gain, never negative); the response curve's axis said |Q| / F and the basin
    legend the paper's |Q|/c (eq3.3)."""
    import vrsweep
    from vrsweep import plot

    curve = _short_linear_sweep(tmp_path, "curve", "F: [0.5, 1.0]")
    basins = _short_linear_sweep(tmp_path, "basins", "x0: [-0.5, 0.5]\n  v0: [-0.5, 0.5]")
    with vrsweep.open_results(curve) as ds:
        label = plot.response_figure(ds).axes[0].get_ylabel()
    assert label.startswith("gain $R = |Q|$ / |F|"), label
    # A bare parameter as the response frequency by its symbol, as on the x axis: the label read
    # 'Q at frequency omega' beside 'parameter $\omega$'.
    assert label.endswith("$Q$ at frequency $\\omega$"), label
    with vrsweep.open_results(basins) as ds:
        title = " ".join(legend.get_title().get_text() for legend in plot.basin_figure(ds).legends)
    assert "gain R = |Q|/|F|" in title and "/c" not in title, title
    with vrsweep.open_results(basins) as ds:
        description = plot.description(plot.basin_figure(ds))
    assert "4 transient + 16 measured periods T" in description and "slow" not in description, description
    # The attractor table's stored words and `info`'s: its period T and gain, not the paper's slow
    # period and |Q|/c (eq3.3).
    with vrsweep.open_results(basins) as ds:
        words = {name: ds[name].attrs["long_name"] for name in ds.data_vars if name.startswith("attractor_")}
    assert "per period T = 2 * pi / omega" in words["attractor_impacts_per_period"], words
    assert "|Q|/|F|" in words["attractor_R"] and "periods T" in words["attractor_period"], words
    assert not any("slow" in text or "/c" in text for text in words.values()), words
    from vrsweep.commands.info import _format_attractors

    quasi = {"label": 0, "period": 0, "R": 1.0, "R_err": 0.1, "impacts_per_cycle": -1,
             "impacts_per_period": 1.5, "fraction": 1.0, "points": 4}
    assert "1.5 impacts per period T" in "\n".join(_format_attractors([{"slice": "", "per": "period T",
                                                                         "attractors": [quasi]}]))
    info = CliRunner().invoke(main, ["info", "--json", str(basins)])
    assert info.exit_code == 0 and '"per": "period T"' in info.output, info.output


def test_a_response_scale_of_one_is_no_division_in_the_labels():
    """response.scale: 1 labelled R as "|Q| / |1.0|"; R is then |Q| itself."""
    from vrsweep.plot.labels import written_gain

    assert written_gain("1") == written_gain(1.0) == "gain $R = |Q|$"
    assert written_gain("1.0", mathtext=False) == "gain R = |Q|"
    assert written_gain("2") == "gain $R = |Q|$ / |2|"
    assert written_gain("F", mathtext=False) == "gain R = |Q|/|F|"


def test_a_written_models_branch_figure_labels_its_parameters_by_their_own_names(tmp_path):
    """A branch figure labelled a written model's parameters as the paper's: the axis of a branch in
    D read 'D D' and a parameter named c was set as the paper's $c$. No kernel: orbits by hand."""
    from tests.handmade import orbit

    import vrsweep
    from vrsweep import plot
    from vrsweep.analysis.continuation import Branch
    from vrsweep.config.validate import config_from_dict
    from vrsweep.store import branch_file

    config = config_from_dict({
        "model": {"acceleration": "-c*v - sin(x) + F*cos(w*t)",
                  "parameters": {"c": 0.1, "F": 0.3, "w": 0.9, "D": 0.5, "r": 0.8},
                  "barriers": [{"position": "D", "side": "above", "restitution": "r"}],
                  "period": "2*pi/w", "response": {"frequency": "w", "scale": "F"}},
        "initial": {"x": 0.0, "v": 0.0}, "continuation": {"parameter": "D", "from": 0.5, "to": [0.2, 1.5]}})
    orbits = [orbit(value, True) for value in np.linspace(0.4, 0.6, 5)]
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "D left"), "up": ("left_range", "D left")})]
    path = tmp_path / "branch.h5"
    branch_file.write_branch(path, branch_file.branch_arrays(branches, [], 0.5), config, "rk45")
    plot.labels.use_model(None)  # as after any figure of the paper's model in the same process
    with vrsweep.open_results(path) as ds:
        figure = plot.branch_figure(ds)
    assert figure.axes[1].get_xlabel() == "parameter D"
    title = " ".join(text.get_text() for text in figure.texts)
    assert "c = 0.1" in title and "$c$" not in title
    # The frequency Q is read at, as on a sweep's response axis (it said 'gain R = |Q| / |F|' alone).
    assert figure.axes[0].get_ylabel() == "gain $R = |Q|$ / |F|, $Q$ at frequency w"


def test_a_rotating_pendulum_counts_its_turns_as_docs_models_says():
    """docs/models.md, "What a written model does not have" (angles): x is never taken modulo 2 pi,
    so a pendulum running three turns a period the other way from its stop has x(nT) falling by
    6 pi a period, no period, a motion called quasi-periodic, and its orbit's lambda_1 (-0.033)
    all the same."""
    import vrsweep

    pendulum = {"model": {"acceleration": "-2*zeta*v - sin(x) + F*cos(omega*t)",
                          "parameters": {"zeta": 0.1, "F": 1.78, "omega": 0.6, "theta_s": 0.5, "r": 0.7},
                          "barriers": [{"position": "theta_s", "side": "above", "restitution": "r"}],
                          "period": "2*pi/omega", "response": {"frequency": "omega", "scale": "F"}},
                "initial": {"x": 0.0, "v": 0.0},
                "integration": {"transient_periods": 100, "measure_periods": 60, "lyapunov": True}}
    point = vrsweep.sweep(pendulum, progress=False)
    np.testing.assert_allclose(np.diff(point.strobe_x.values), -6 * math.pi, rtol=0, atol=1e-6)
    assert int(point.period) == 0 and int(point.motion) == Motion.QUASI_PERIODIC
    assert float(point.impacts_per_period) == 0.0 and float(point.x_max) < 0.5
    assert float(point.lyapunov) == pytest.approx(-0.033, abs=5e-4)
    assert float(point.lyapunov_err) < 1e-6


def test_a_start_where_the_acceleration_is_infinite_is_non_finite_not_a_step_too_small(tmp_path):
    """beta x**3 at x = -1e110 is inf: the first step's estimate is 0, which the kernel called
    step_too_small (advice: loosen rtol/atol). The derivative is not finite: non_finite, as a
    NaN or inf appearing later is; the point beside it is untouched."""
    import vrsweep

    text = (EXAMPLES / "impact_duffing_two_forces.yaml").read_text()
    text = text.replace("phi: {start: 0.0, stop: 6.283185307179586, num: 49}", "x0: [-0.5, -1.0e110]")
    config = tmp_path / "inf.yaml"
    config.write_text(text.replace("transient_periods: 200", "transient_periods: 4")
                      .replace("measure_periods: 100", "measure_periods: 16"))
    for method in ("rk45", "dop853"):
        result = vrsweep.sweep(str(config), output=str(tmp_path / f"{method}.h5"), method=method)
        assert list(result["status"].values) == [Status.OK, Status.NON_FINITE], method
        assert result["n_steps"].values[1] == 0


def test_large_exact_numbers_and_imaginary_parts_compile_as_doubles(tmp_path):
    """sympy keeps 10**20 exact: the kernel held the literal 100000000000000000000, which numba
    cannot type (TypingError on the first run), and sqrt(-c**2) became I*|c|, a complex number
    numba cannot store (NotImplementedError). Both are doubles now: 10**20*k + 10**-20*K = 1
    gives the free linear oscillator, R = 1/sqrt((1 - w^2)^2 + (2 zeta w)^2) in closed form, and
    an imaginary part is NaN as in real arithmetic: the point is non_finite."""
    import vrsweep

    text = MODEL.replace("- x + F*cos(omega*t)", "- (10**20*k + 10**-20*K)*x + F*cos(omega*t)")
    text = text.replace("{zeta: 0.05,", "{k: 0.5e-20, K: 0.5e+20, zeta: 0.05,").replace("Delta: 1.2", "Delta: 100")
    settings = "integration: {transient_periods: 200, measure_periods: 32}\n"
    (tmp_path / "big.yaml").write_text(text + settings)
    result = vrsweep.sweep(str(tmp_path / "big.yaml"), output=str(tmp_path / "big.h5"))
    zeta, w = 0.05, 0.8
    assert int(result["status"]) == Status.OK
    assert float(result["R"]) == pytest.approx(1 / math.hypot(1 - w * w, 2 * zeta * w), rel=1e-7)

    # sqrt(-c**2) is I*|c| to sympy, NaN in the kernel at every c; numpy's sqrt(-0) = 0 at c = 0
    # lets the config through (an acceleration NaN at every point is refused when it is read)
    imaginary = MODEL.replace("F*cos(omega*t)", "F*cos(omega*t) + sqrt(-c**2)").replace("{zeta: 0.05,", "{c: 0.0, zeta: 0.05,")
    (tmp_path / "i.yaml").write_text(imaginary + settings + "sweep: {c: [0.0, 1.0]}\n")
    with pytest.warns(RuntimeWarning, match="non_finite"):
        result = vrsweep.sweep(str(tmp_path / "i.yaml"), output=str(tmp_path / "i.h5"))
    assert [Status(int(s)) for s in result["status"].values] == [Status.NON_FINITE, Status.NON_FINITE]


def test_a_written_models_trajectory_file_names_its_own_barrier_and_period(tmp_path):
    """simulate's file described a written model's impacts as "at x = Delta" and its periods as
    T = 2 pi/omega, the paper's words; its summary line counted impacts "per slow period"."""
    import h5py

    text = (EXAMPLES / "impact_linear.yaml").read_text()
    config = tmp_path / "one.yaml"
    config.write_text(text.replace("transient_periods: 200", "transient_periods: 4")
                      .replace("measure_periods: 100", "measure_periods: 16"))
    output = tmp_path / "one_traj.h5"
    result = CliRunner().invoke(main, ["simulate", str(config), "--set", "omega=0.8", "--set", "Delta=0.5",
                                       "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert "per period T)" in result.output and "slow" not in result.output  # said so too
    with h5py.File(output, "r") as f:
        group = f["written"]
        assert len(group["impact_t"]) > 0
        assert group["impact_t"].attrs["long_name"] == "time of the impact at a barrier"
        assert "2 pi/omega" not in group["period"].attrs["long_name"]
        assert "slow" not in group["impacts_per_period"].attrs["long_name"]


def _continued(tmp_path, example_text, settings):
    """`vrsweep continue` of an example's model section with ``settings`` (integration and
    continuation) in place of its sweep: the branch file's path."""
    config = tmp_path / "continued.yaml"
    config.write_text(example_text.split("sweep:")[0] + settings)
    branch = tmp_path / "branch.h5"
    result = CliRunner().invoke(main, ["continue", str(config), "-o", str(branch)])
    assert result.exit_code == 0, result.output
    return branch


def test_no_period_doubling_is_reported_where_a_graze_makes_the_multipliers_jump(tmp_path):
    """A Duffing oscillator with a stop (the shipped example without its second force), continued in
    omega through its graze at 1.19345: the free orbit's multipliers 0.57 +- 0.64i jump to -10.9
    beyond, so det(M + I) changes sign across the step, and a 'period doubling' was located at
    omega = 1.1933562 with no multiplier near -1 (an independent SciPy map agreed: none). Every
    fold and period doubling in the file has its multiplier at +1 or -1."""
    import h5py

    text = (EXAMPLES / "impact_duffing_two_forces.yaml").read_text()
    text = text.replace("{zeta: 0.05, beta: 0.5, F1: 0.6, F2: 0.3, omega: 1.1, phi: 0.0, Delta: 0.8, r: 0.85}",
                        "{zeta: 0.03, beta: 0.3, F1: 0.25, F2: 0.0, omega: 1.0, phi: 0.0, Delta: 1.6, r: 0.7}")
    branch = _continued(tmp_path, text, "integration: {rtol: 1.0e-11, atol: 1.0e-13, transient_periods: 300}\n"
                        "continuation: {parameter: omega, from: 0.6, to: [0.5, 2.2], max_step: 0.05}\n")
    with h5py.File(branch, "r") as f:
        kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in f["bifurcation_kind"][()]]
        where = f["bifurcation_parameter"][()]
        mu = f["bifurcation_multiplier_real"][()] + 1j * f["bifurcation_multiplier_imag"][()]
    assert abs(where[kinds.index("grazing")] - 1.1934525) < 1e-6
    doublings = where[np.array(kinds) == "period_doubling"]
    assert len(doublings) == 1 and abs(doublings[0] - 1.2371) < 1e-3, (kinds, where)  # the genuine one stays
    assert kinds.count("fold") == 2, kinds
    for kind, multipliers in zip(kinds, mu):
        if kind in ("fold", "period_doubling"):
            assert np.min(np.abs(multipliers - (1.0 if kind == "fold" else -1.0))) < 1e-3, (kind, multipliers)


def test_a_branch_ending_where_an_impact_reaches_the_section_says_so(tmp_path):
    """The linear impact oscillator's orbit continued in the forcing's phase phi: the phase moves
    the section t = 0 mod pT along the orbit, and at phi = 5.9574 its impact lands on the section,
    where the section's point jumps from before the impact (x = Delta, v = 2.577) to after it. The
    branch ended 'integration stopped: step_too_small', blaming the integrator; the end now says
    where and why."""
    import h5py

    text = (EXAMPLES / "impact_linear.yaml").read_text().replace("Delta: 1.2", "Delta: 2.3")
    # The period-2 orbit in the phase whose impact reaches the section (the other phase's does at
    # phi 2 pi further on): started next to the state just before that impact.
    text = text.replace("initial: {x: 0.0, v: 0.0}", "initial: {x: 2.29, v: 2.58}")
    branch = _continued(tmp_path, text, "integration: {rtol: 1.0e-11, atol: 1.0e-13, transient_periods: 200}\n"
                        "continuation: {parameter: phi, from: 5.9, to: [5.8, 6.2], max_step: 0.05}\n")
    with h5py.File(branch, "r") as f:
        reasons = [r.decode() if isinstance(r, bytes) else str(r) for r in f["branch_end_last_status"][()]] + \
                  [r.decode() if isinstance(r, bytes) else str(r) for r in f["branch_end_last_reason"][()]]
        x, phi = f["x"][()], f["parameter"][()]
    reason = reasons[-1]
    assert "an impact lies on the stroboscopic section" in reason and "the barrier at 2.3" in reason, reasons
    assert abs(phi.max() - 5.9574) < 1e-3 and abs(x[np.argmax(phi)] - 2.3) < 1e-4
    assert reasons[0] == "integration_failed" and "phi = 5.957" in reason


# MODEL with a kink out of reach (d = 1000, beyond any stop here; k = 0: no force) unless a test moves it
# there: one kernel (rk45, tangent vectors) for the tests of linear orbits' gains and exponents,
# which each compiled a model of their own (30 to 40 s each, cold).
LINEAR_WITH_A_KINK = MODEL.replace("- x + F*cos(omega*t)", "- x - k*max(x - d, 0) + F*cos(omega*t)").replace(
    "{zeta: 0.05,", "{k: 0.0, d: 1000.0, zeta: 0.05,")
assert LINEAR_WITH_A_KINK.count("k*max(x - d, 0)") == LINEAR_WITH_A_KINK.count("{k: 0.0, d: 1000.0,") == 1


def test_a_negative_response_scale_gives_the_gain_of_its_magnitude():
    # R = |Q| / |scale|: the linear oscillator with its stop out of reach, forced by F cos(omega t)
    # with F swept through -1 and 1 (a force of amplitude 1, phase pi or 0), has the closed-form
    # gain 1 / sqrt((1 - omega^2)^2 + (2 zeta omega)^2) at both, never a negative R.
    import vrsweep

    text = LINEAR_WITH_A_KINK.replace("Delta: 1.2", "Delta: 5.0") + textwrap.dedent("""\
        sweep: {F: [-1.0, 1.0]}
        integration: {transient_periods: 150, measure_periods: 20, lyapunov: true, rtol: 1.0e-11, atol: 1.0e-13}
        """)
    ds = vrsweep.sweep(text, progress=False)
    zeta, omega = 0.05, 0.8
    gain = 1.0 / math.hypot(1.0 - omega ** 2, 2.0 * zeta * omega)
    assert (ds["impacts_per_period"].values == 0).all()
    np.testing.assert_allclose(ds["R"].values, gain, rtol=1e-8)
    np.testing.assert_allclose(ds["Q_amplitude"].values, gain, rtol=1e-8)


def test_a_phased_force_repeating_after_11_periods_is_found_periodic():
    """A fast force cos(W t + phi) with W T / (2 pi) = 78/11 repeats after q = 11 periods T, beyond
    max_period (8): the period is found through the forcing's q (diagnostics.forcing_periods).
    Its frequency was read only from the header's two harmonics, which dop853 rotates and which
    are phase-free: with phi = 0.3 the point was period 0, "chaotic", R from weighted averages
    (R_err 8e-4); with phi = 0 period 11 (R_err 1e-13). SciPy, written here, decides."""
    import vrsweep

    parameters = {"zeta": 0.1, "beta": 0.2, "F": 0.3, "F2": 2.0, "omega": 0.5, "W": 39.0 / 11.0, "phi": 0.3,
                  "Delta": 1.0, "r": 0.8}
    model = {"acceleration": "-2*zeta*v - x - beta*x**3 + F*cos(omega*t) + F2*cos(W*t + phi)",
             "parameters": parameters, "barriers": [{"position": "Delta", "side": "above", "restitution": "r"}],
             "period": "2*pi/omega", "response": {"frequency": "omega", "scale": "F"},
             "max_step": "min(period/6, 2*pi/W/8)"}
    n_transient, n_measure = 100, 44  # the window: four whole cycles
    ds = vrsweep.sweep({"model": model, "initial": {"x": 0.0, "v": 0.0}, "sweep": {"phi": [0.3]},
                        "integration": {"transient_periods": n_transient, "measure_periods": n_measure,
                                        "rtol": 1e-11, "atol": 1e-13}}, progress=False).isel(phi=0)
    p = parameters

    def acceleration(t, x, v):
        return (-2 * p["zeta"] * v - x - p["beta"] * x ** 3 + p["F"] * math.cos(p["omega"] * t)
                + p["F2"] * math.cos(p["W"] * t + p["phi"]))

    R, impacts, strobe = scipy_reference(acceleration, [(1.0, 1.0, 0.8)], 0.0, 0.0, 4.0 * math.pi, 0.5, 0.3,
                                         n_transient, n_measure)
    assert _period(strobe, longest=11) == 11  # the reference's motion repeats after 11 periods, no sooner
    assert int(ds["period"]) == 11 and int(ds["motion"]) == Motion.PERIODIC
    assert float(ds["R"]) == pytest.approx(R, rel=1e-7)
    assert float(ds["impacts_per_period"]) == pytest.approx(impacts, rel=1e-12)


def test_every_frequency_of_the_forcing_is_found_with_or_without_a_phase():
    import sympy

    from vrsweep.numerics import codegen

    t, W, w, phi = sympy.symbols("t W w phi", real=True)
    x = sympy.Symbol("x", real=True)
    acceleration = (-x + sympy.cos(W * t + phi) + 2 * sympy.sin(w * (t - 1)) + sympy.cos(-W * t) + sympy.cos(3 * t)
                    + sympy.sin(x + t))
    found = codegen.frequencies([acceleration], t)
    assert {sympy.srepr(sympy.expand(a)) for a in found} == {sympy.srepr(a) for a in (W, w, sympy.Integer(3))}
    assert codegen.frequencies([-x], t) == []


def test_the_forcings_spectrum_holds_the_frequencies_of_products_and_powers():
    """Product-to-sum: cos(w t)**9 = (126 cos(w t) + 84 cos(3 w t) + 36 cos(5 w t) + 9 cos(7 w t)
    + cos(9 w t)) / 256, sin(w t) cos(2 w t) = (sin(3 w t) - sin(w t)) / 2, x cos(w t/2)**2 =
    x (1 + cos(w t)) / 2. Only the terms' own frequencies were found (w, w, w/2): a stuck mass's
    release scan stepped over pulls of cos(w t)**9, and a force cos(w t/2)**2, which repeats every
    2 pi / w, was said to repeat after two such periods."""
    import sympy

    from vrsweep.numerics import codegen

    t, w, W, phi, a, b = sympy.symbols("t omega W phi a b", real=True)
    x, v = sympy.symbols("x v", real=True)

    def spectrum(expression):
        return {sympy.srepr(sympy.expand(f)) for f in codegen.forcing_spectrum(expression, t)}

    def expected(*frequencies):
        return {sympy.srepr(sympy.expand(f)) for f in frequencies}

    assert spectrum(sympy.cos(w * t) ** 9) == expected(w, 3 * w, 5 * w, 7 * w, 9 * w)
    assert spectrum(sympy.cos(w * t) ** sympy.Float(3.0)) == expected(w, 3 * w)  # written cos(w*t)**3.0
    assert spectrum(sympy.sin(w * t) * sympy.cos(2 * w * t)) == expected(w, 3 * w)
    assert spectrum(-x + x * sympy.cos(w * t / 2) ** 2) == expected(w)
    assert spectrum(sympy.cos(w * t + phi) ** 2 - v * sympy.sin(W * t)) == expected(2 * w, W)
    assert spectrum(sympy.sin(x + w * t)) == expected(w)  # on a stop x is a constant: a phase
    assert spectrum(t * sympy.cos(w * t) + sympy.sin(t ** 2) + sympy.sin(x * t)) == expected(w)
    # not polynomials in them: their arguments' frequencies, harmonics of which they hold
    assert spectrum(sympy.exp(sympy.cos(w * t)) * sympy.cos(2 * w * t)) == expected(w, 2 * w, 3 * w)
    assert spectrum(1 / (2 + sympy.cos(w * t))) == expected(w)
    assert spectrum(-x) == set()
    # too many to list: the terms' frequencies and the bound n max|a| of a degree-n polynomial
    assert spectrum((sympy.cos(a * t) + sympy.cos(b * t) + sympy.cos(w * t)) ** 64) == expected(
        a, b, w, 64 * a, 64 * b, 64 * w)
    # and a bounded amount of work: forty such powers, 2000 characters, took 160 s (now about 1 s)
    k = sympy.symbols("k0:40", real=True)
    started = time.perf_counter()
    assert spectrum(sum((sympy.cos(w * t) + sympy.cos(2 * w * t) + sympy.cos(3 * w * t) + sympy.cos(4 * w * t)
                         + k_i) ** 64 for k_i in k)) == expected(w, 2 * w, 3 * w, 4 * w, 64 * w, 128 * w, 192 * w,
                                                                 256 * w)
    assert time.perf_counter() - started < 30.0


@pytest.mark.parametrize("acceleration, repeats, cycles", [
    ("-x + F*cos(omega*t/2)**2", 1, 1.0),
    ("-x + F*cos(omega*t)**9", 1, 9.0),
    ("-x + F*sin(omega*t)*cos(2*omega*t)", 1, 3.0),
    ("-x + F*cos(omega*t/3)*cos(omega*t/3)", 3, 2.0 / 3.0),
])
def test_when_a_written_forcing_repeats_and_how_fast_it_varies(acceleration, repeats, cycles):
    """analysis.diagnostics.sampling_of_forcing of forces written as products and powers: the
    periods T = 2 pi / omega after which each repeats, and its fastest cycles per T, from the
    product-to-sum identities (cos(omega t/3)**2 = (1 + cos(2 omega t/3)) / 2: three periods)."""
    from vrsweep.analysis.diagnostics import sampling_of_forcing
    from vrsweep.config import parse_config

    text = textwrap.dedent(f"""\
        model:
          acceleration: "{acceleration}"
          parameters: {{F: 1.0, omega: 0.8}}
          period: "2*pi/omega"
          response: {{frequency: omega, scale: F}}
        initial: {{x: 0.0, v: 0.0}}
        """)
    config = parse_config(text, "m.yaml")
    q, fastest = sampling_of_forcing(config.model, [config.parameters], 8)
    assert int(q[0]) == repeats
    assert float(fastest[0]) == pytest.approx(cycles, rel=1e-14)


def test_a_response_at_no_harmonic_of_the_motion_is_zero_whatever_the_window():
    """A linear oscillator forced at omega (and, with F2 > 0, at omega/2), the response read at
    w = omega/2, over 21 periods T = 2 pi / omega (an odd number). The closed form: the steady
    state holds omega and omega/2 only, so |Q(omega/2)| = F2 |H(omega/2)| with H(s) = 1 / (1 - s**2
    + 2 i zeta s), which is 0 for F2 = 0. Over the period-1 motion (F2 = 0) the window was read as
    21 whole cycles, which are not whole cycles of e^{iwt}: R was 0.06 with an R_err of 1e-13 (0
    over any even number of periods). diagnostics.gain_cycles makes R's cycle span both."""
    import vrsweep

    zeta, omega, F = 0.05, 0.8, 1.0
    model = {"acceleration": "-2*zeta*v - x + F*cos(omega*t) + F2*cos(omega*t/2)",
             "parameters": {"zeta": zeta, "F": F, "F2": 0.0, "omega": omega, "Delta": 100.0, "r": 0.8},
             "barriers": [{"position": "Delta", "side": "above", "restitution": "r"}],
             "period": "2*pi/omega", "response": {"frequency": "omega/2", "scale": "F"}}
    ds = vrsweep.sweep({"model": model, "initial": {"x": 0.0, "v": 0.0}, "sweep": {"F2": [0.0, 0.5]},
                        "integration": {"transient_periods": 300, "measure_periods": 21}}, progress=False)
    s = omega / 2
    gain = 0.5 * abs(1.0 / complex(1.0 - s * s, 2.0 * zeta * s)) / F
    assert list(ds["period"].values) == [1, 2]
    assert float(ds["R"][0]) < 1e-9 and float(ds["R_err"][0]) < 1e-9
    assert float(ds["R"][1]) == pytest.approx(gain, rel=1e-7)
    assert float(ds["R_err"][1]) < 1e-7 * gain


@pytest.mark.parametrize("F2", [0.0, 0.5])
def test_a_continued_orbits_response_at_no_harmonic_of_it_is_zero(tmp_path, F2):
    """The same oscillator and response w = omega/2 continued in Delta, out of reach: the period-1
    orbit (F2 = 0) has no component at w, and its R, read over one cycle (half a cycle of
    e^{iwt}), was 1.23 (the shipped linear example's at Delta = 3); the period-2 orbit (F2 = 0.5)
    has F2 |H(omega/2)| / F there, the closed form."""
    import vrsweep

    zeta, omega, F = 0.05, 0.8, 1.0
    text = textwrap.dedent(f"""\
        model:
          acceleration: "-2*zeta*v - x + F*cos(omega*t) + F2*cos(omega*t/2)"
          parameters: {{zeta: {zeta}, F: {F}, F2: {F2}, omega: {omega}, Delta: 50.0, r: 0.8}}
          barriers: [{{position: Delta, side: above, restitution: r}}]
          period: "2*pi/omega"
          response: {{frequency: omega/2, scale: F}}
        initial: {{x: 0.0, v: 0.0}}
        integration: {{rtol: 1.0e-11, atol: 1.0e-13, transient_periods: 300}}
        continuation: {{parameter: Delta, from: 50.0, to: [49.0, 51.0], max_step: 0.5}}
        """)
    branch = _continued(tmp_path, text + "sweep:", "")
    s = omega / 2
    with vrsweep.open_results(branch) as ds:
        periods, R = ds["periods"].values, ds["R"].values
    assert len(R) >= 3 and (periods == (2 if F2 else 1)).all()
    np.testing.assert_allclose(R, F2 * abs(1.0 / complex(1.0 - s * s, 2.0 * zeta * s)) / F, rtol=1e-7, atol=1e-12)


@pytest.mark.parametrize("forcing, response, expected", [
    ("F*cos(2*pi*f*t)", "2*pi*f", lambda f, k: [2 * math.pi * f]),
    ("F*sin(sqrt(k)*t + 1) + F*cos(t/sqrt(2))", "sqrt(k)", lambda f, k: [math.sqrt(k), 1 / math.sqrt(2)]),
    ("F*cos(exp(f)*t) + F*cos(abs(k - 3)*t) + F*cos(max(k, 3)*t)", "exp(f)", lambda f, k: [math.exp(f), abs(k - 3), max(k, 3)]),
])
def test_frequencies_with_named_functions_and_constants_are_computed(forcing, response, expected):
    """A force written cos(2*pi*f*t), or with sqrt, exp or abs in a frequency: the generated frequency
    functions (which the coefficient vectors and the forcing period read, before any kernel runs)
    used numpy.pi and numpy.sqrt in a module that had imported numpy as np: NameError, a traceback
    for every sweep of such a model."""
    text = MODEL.replace("F*cos(omega*t)", forcing).replace("F: 1.0, omega: 0.8", "F: 1.0, f: 0.15, k: 2.0") \
        .replace("2*pi/omega", "1/f").replace("frequency: omega", f"frequency: '{response}'")
    config = parse_config(text, "m.yaml")
    kernels = kernels_for(config.model)
    values = np.array([kernels.coefficients(dict(config.parameters, f=f, k=k)) for f, k in [(0.15, 2.0), (0.2, 5.0)]])
    from vrsweep.numerics.coefficients import RESPONSE_FREQUENCY

    response_values = [expected(0.15, 2.0)[0], expected(0.2, 5.0)[0]]
    np.testing.assert_allclose(values[:, RESPONSE_FREQUENCY], response_values, rtol=1e-15)
    frequencies = kernels.forcing_frequencies(values)
    for row, (f, k) in zip(frequencies, [(0.15, 2.0), (0.2, 5.0)]):
        assert sorted(np.abs(row)) == pytest.approx(sorted(expected(f, k)), rel=1e-15)


@pytest.mark.slow
def test_a_periodic_orbit_with_complex_multipliers_has_its_exact_exponent():
    """x'' + 2 zeta x' + x = cos(omega t): both multipliers are exp(-zeta T) in modulus, so the
    largest exponent is -zeta exactly; with one impact a period at a stop x <= 0 (Shaw and Holmes)
    |det M| = r^2 exp(-2 zeta T), a complex pair: ln(r)/T - zeta. The mean stretch of one tangent
    vector gave -0.04995985 with lyapunov_err 6.7e-6 at omega = 2.5 (6 half-widths off)."""
    import vrsweep

    text = LINEAR_WITH_A_KINK + textwrap.dedent("""\
        integration: {transient_periods: 200, measure_periods: 100, lyapunov: true}
        """)
    free = vrsweep.sweep(text.replace("initial:", "sweep: {omega: [0.8, 1.0, 2.5]}\ninitial:"), Delta=100.0,
                         progress=False)
    assert (free.impacts_per_cycle.values == 0).all() and (free.period.values == 1).all()
    np.testing.assert_allclose(free.lyapunov.values, -0.05, atol=1e-8)
    omega = 1.5
    shaw = vrsweep.sweep(text.replace("{x: 0.0, v: 0.0}", "{x: -0.5, v: 0.0}"), Delta=0.0, omega=omega,
                         progress=False)
    assert int(shaw.period) == 1 and int(shaw.impacts_per_cycle) == 1
    assert float(shaw.lyapunov) == pytest.approx(math.log(0.8) * omega / (2 * math.pi) - 0.05, abs=1e-8)
    # Its band is the stored estimate's: the batches of one tangent vector's stretch, which swings
    # with the pair's rotation, gave half-widths up to 0.026 about an exact -0.03 (a bilinear
    # spring's orbits: its kink keeps the trace -2 zeta, so a complex pair's exponent is -zeta).
    assert (free.lyapunov_err.values < 1e-8).all() and float(shaw.lyapunov_err) < 1e-8
    bilinear = vrsweep.sweep(text.replace("{k: 0.0, d: 1000.0,", "{k: 4.0, d: 0.5,").replace(
        "measure_periods: 100", "measure_periods: 50").replace(
        "initial:", "sweep: {omega: [0.638, 1.146, 1.315]}\ninitial:"), Delta=100.0, F=0.5, zeta=0.03,
        progress=False)
    assert (bilinear.period.values == 1).all() and (bilinear.x_max.values > 0.5).all()
    np.testing.assert_allclose(bilinear.lyapunov.values, -0.03, atol=1e-8)
    assert (bilinear.lyapunov_err.values < 1e-8).all(), bilinear.lyapunov_err.values


def test_a_long_flat_sum_is_refused_with_the_way_out_and_grouped_it_is_read():
    # 79 terms of a sum are a chain of 78 operators, past MAX_DEPTH: the message called the flat
    # sum "nested more than 60 deep" and said no more; grouped in two halves it is 40 deep.
    terms = [f"sin({k}*x + v)" for k in range(1, 80)]
    with pytest.raises(expressions.ExpressionError, match=r"group a long sum or product in parentheses"):
        expressions.parse(" + ".join(terms), ["x", "v", "t"])
    grouped = f"({' + '.join(terms[:40])}) + ({' + '.join(terms[40:])})"
    assert expressions.parse(grouped, ["x", "v", "t"]) is not None


def test_a_hash_inside_a_quoted_expression_is_refused_not_taken_as_a_comment(tmp_path):
    # YAML keeps a # inside quotes; Python's parser then dropped the rest: the model ran as -x.
    text = MODEL.replace('"-2*zeta*v - x + F*cos(omega*t)"', '"-x # - 2*zeta*v + F*cos(omega*t)"')
    (problem,) = problems(text)
    assert problem.startswith("m.yaml:2: model.acceleration: holds a '#'"), problem
    with pytest.raises(expressions.ExpressionError, match="after the closing quote"):
        expressions.parse("x + 1 # + v", ["x", "v", "t"])
    config = tmp_path / "hash.yaml"
    config.write_text(text)
    result = CliRunner().invoke(main, ["validate", str(config)])
    assert result.exit_code == 2 and "holds a '#'" in result.output and "Traceback" not in result.output


def test_a_greek_parameter_name_is_told_to_use_latin_letters_and_a_symbol():
    """'ζ' is a letter, and "must be a name (letters, digits and _ ...)" refused it as if not."""
    found = problems(MODEL.replace("zeta", "ζ"))
    assert found[0].startswith("m.yaml:3: model.parameters.ζ: must be a name in ASCII letters, digits and _, "
                               "got 'ζ': write it in Latin letters"), found


@pytest.mark.parametrize("text, character, advice", [
    ("-2*zeta*v - x + \uff26*cos(omega*t)", "U+FF26 FULLWIDTH LATIN CAPITAL LETTER F", "silently read it as 'F'"),
    ("-2*zeta*v - \U0001d465 + F*cos(omega*t)", "U+1D465 MATHEMATICAL ITALIC SMALL X", "silently read it as 'x'"),
    ("-2*zeta*v - x**\u00b2 + F*cos(omega*t)", "U+00B2 SUPERSCRIPT TWO", "silently read it as '2'"),
    ("-2*zeta*v \u2212 x + F*cos(omega*t)", "U+2212 MINUS SIGN", "write '-' instead"),
    ("-2*\u03b6*v - x + F*cos(omega*t)", "U+03B6 GREEK SMALL LETTER ZETA", "under model.symbols"),
])
def test_a_look_alike_of_an_ascii_name_is_refused_not_read_as_it(text, character, advice, tmp_path):
    """Python's parser folds identifiers by NFKC: a fullwidth F and a mathematical italic x (pasted
    from a typeset paper) ran as the parameter F and the position x, an equation other than the
    one written, without a word."""
    with pytest.raises(expressions.NonAsciiError) as caught:
        expressions.parse(text, ("x", "v", "t", "zeta", "F", "omega"))
    assert character in str(caught.value) and advice in str(caught.value)
    (problem,) = problems(MODEL.replace("-2*zeta*v - x + F*cos(omega*t)", text))
    assert problem.startswith(f"m.yaml:2: model.acceleration: holds "), problem
    assert character in problem and advice in problem
    config = tmp_path / "pasted.yaml"
    config.write_text(MODEL.replace("-2*zeta*v - x + F*cos(omega*t)", text), encoding="utf-8")
    result = CliRunner().invoke(main, ["validate", str(config)])
    assert result.exit_code == 2 and character in result.output and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1, result.output


@pytest.mark.parametrize("change, expected", [
    # 300 periods of 1e-300 moved nothing in doubles: every point "ok", period 1, R = 2|x0| (the mean)
    (("period: \"2*pi/omega\"", "period: 1e-300"),
     "m.yaml:6: model.period: T = 1e-300 is too short to be integrated against the response frequency's cycle "
     "2*pi/w = 7.85"),
    (("period: \"2*pi/omega\"", "period: 1e-20"), "m.yaml:6: model.period: T = 1e-20 is too short"),
    # a cycle of 7.85 against the rounding of t = 2e22: every point ended step_too_small, "loosen rtol"
    (("period: \"2*pi/omega\"", "period: 1e20"),
     "m.yaml:7: model.response.frequency: w = 0.8 turns too fast for the time of the run in doubles"),
    (("period: \"2*pi/omega\"", "period: 1e14"), "m.yaml:7: model.response.frequency: w = 0.8 turns too fast"),
    # 1e6 steps a period at the cap, 200 periods: 2e8 steps, ten times the budget
    (("response: {frequency: omega, scale: F}", "response: {frequency: omega, scale: F}\n  max_step: period/1e6"),
     "m.yaml:8: model.max_step: the step cap 7.853981633974482e-06 makes at least 2e+08 steps over the run (200 periods of "
     "T = 7.85"),
])
def test_a_period_out_of_scale_with_the_models_other_time_scales_is_refused(change, expected):
    found = problems(MODEL.replace(*change))
    assert len(found) == 1 and found[0].startswith(expected), found


def test_periods_and_step_caps_within_doubles_reach_are_taken(tmp_path):
    """The bounds are double precision's and the step budget's, not a taste in time scales: a
    period a millionth or ten billion times the forcing's, and a cap just within the budget, are read."""
    for period in ("1e-12", "1e9"):
        parse_config(MODEL.replace('period: "2*pi/omega"', f"period: {period}"), "m.yaml")
    parse_config(MODEL.replace("scale: F}", "scale: F}\n  max_step: period/1e5"), "m.yaml")
    # the default cap, period/8, with a small budget is a status on the point, as before
    parse_config(MODEL, "m.yaml", ["max_steps=100"])
    config = tmp_path / "short.yaml"
    config.write_text(MODEL.replace('period: "2*pi/omega"', "period: 1e-300") + "sweep: {omega: [0.5, 0.8]}\n")
    result = CliRunner().invoke(main, ["validate", str(config)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert result.output.strip().splitlines() == [
        f"Error: {config}:6: model.period: T = 1e-300 is too short to be integrated against the response "
        f"frequency's cycle 2*pi/w = 12.566370614359172: the whole run (200 periods) is below that cycle's "
        f"rounding in doubles, so nothing moves and R is no Fourier component at omega = 0.5"]
