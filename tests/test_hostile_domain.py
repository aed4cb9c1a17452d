"""Issue 33, class 1: answers outside the model's domain.

Continuation stepped wherever the parameter went, although the config refuses the same values: a
branch in e over [0.5, 1.5] held orbits at e = 1.06-1.31 (a restitution above one creates energy
at each impact), one in c went through 0 (R = |Q|/c is undefined there), one in Omega below 0; a
start at e = 1.2, c = -0.04 or Omega = -4 was continued without a word. One rule decides
(config/domains.outside_domain: the table the config validates with, or a written model's own
rules): a branch or a curve stops at the edge with the status domain_edge, never holding a point
outside, and a start outside is refused, exit 2.

Issue 32, item 2, with it: a curve is followed to both ends of its range (an e-curve over
[0.9, 0.97] had 2 points and said left_range with no point past its start), its step at most
1/40 of either range by default, and settable on a branch file (--set continuation.max_step=...).

Cheap on purpose: the effective model's period-1 orbits (seconds each); omega's edge (omega -> 0,
an infinite slow period) is checked where the config is read only, as the kernel's step limit
ends a branch long before it.
"""

import math
import re
import signal

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vrsweep
from vrsweep.cli import main
from vrsweep.config import config_from_dict
from vrsweep.config.domains import outside_domain
from vrsweep.errors import ConfigError
from vrsweep.execution import continuation as execution
from vrsweep.numerics.model import DEFAULT_PARAMETERS, PARAMETER_NAMES

# The paper's bounded parameters and their edges: (low, high), None where unbounded.
EDGES = {"c": (0.0, None), "omega": (0.0, None), "e": (0.0, 1.0), "Omega": (0.0, None)}

# The hysteresis example's large orbit (docs/bifurcation-curves.md): one impact per slow period at
# g = 30, a period doubling at g = 27.837; depends on e and c. With g = 0 the effective model has no
# fast term: the orbit does not depend on Omega, which can then be followed to its edge cheaply.
LARGE = {"model": "effective", "parameters": {"gamma": 0.05, "alpha": 0.05, "Omega": 4.0, "g": 30.0},
         "initial": {"x": 0.0, "v": 0.0},
         "integration": {"rtol": 1.0e-8, "atol": 1.0e-10, "transient_periods": 200}}
NO_FAST = dict(LARGE, parameters={"gamma": 0.05, "alpha": 0.05, "Omega": 4.0, "g": 0.0},
               integration={"rtol": 1.0e-8, "atol": 1.0e-10, "transient_periods": 100})
WRITTEN_MODEL = {
    "acceleration": "-2*zeta*v - x + F*cos(omega*t + phi)",
    "parameters": {"zeta": 0.05, "F": 1.0, "omega": 0.8, "phi": 0.0, "Delta": 1.2, "r": 0.8},
    "barriers": [{"position": "Delta", "side": "above", "restitution": "r"}],
    "period": "2*pi/omega", "response": {"frequency": "omega", "scale": "F"}}
WRITTEN = {"model": WRITTEN_MODEL, "initial": {"x": 0.0, "v": 0.0},
           "integration": {"rtol": 1.0e-8, "atol": 1.0e-10, "transient_periods": 100}}
# How close to its edge a branch or curve ends: its last step is bisected to min_step (1e-5) in
# arclength, which bounds the parameter's distance too; 1e-3 leaves room for a corrector that
# fails on the way.
NEAR_EDGE = 1e-3


def _values():
    edges = [0.0, -0.0, 1.0, math.nextafter(1.0, 2.0), math.nextafter(0.0, 1.0), -math.nextafter(0.0, 1.0)]
    return st.one_of(st.sampled_from(edges), st.floats(-3.0, 3.0), st.floats(-1e300, 1e300))


@settings(max_examples=300, deadline=None)
@given(name=st.sampled_from([n for n in PARAMETER_NAMES if n != "Delta"]), value=_values())
def test_the_domain_is_the_one_the_config_validates(name, value):
    """One source of truth: outside_domain refuses exactly the values a config refuses."""
    try:
        config_from_dict({"parameters": {name: value}})
        accepted = True
    except ConfigError:
        accepted = False
    assert (outside_domain("original", dict(DEFAULT_PARAMETERS, **{name: value})) is None) == accepted


def _outside_value(name):
    low, high = EDGES[name]
    below = st.floats(-1e6, low, exclude_max=True) | st.just(low)  # the low edges are all open
    return below if high is None else below | st.floats(high, 1e6, exclude_min=True)


@settings(max_examples=60, deadline=None)
@given(data=st.data(), name=st.sampled_from(sorted(EDGES)))
def test_a_start_outside_the_domain_is_refused_where_the_config_is_read(data, name):
    value = data.draw(_outside_value(name))
    section = {"parameter": name, "from": value, "to": [value - 1.0, value + 1.0]}
    with pytest.raises(ConfigError) as error:
        config_from_dict(dict(LARGE, continuation=section))
    assert len(error.value.problems) == 1
    assert f"continuation.from: lies outside the model's domain: {name} must be" in str(error.value)


@pytest.mark.parametrize("name, start", [("e", 1.2), ("c", -0.04), ("Omega", -4.0), ("e", 0.0), ("omega", 0.0)])
def test_the_issues_starts_are_refused_by_continue_in_one_line(tmp_path, write_config, name, start, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "empty-cache"))  # a compile notice would show
    config = write_config(tmp_path, f"model: effective\ncontinuation: {{parameter: {name}, from: {start}, "
                                    f"to: [-5.0, 5.0]}}\n", "start.yaml")
    for command in ("continue", "validate"):
        result = CliRunner().invoke(main, [command, str(config), "-o", str(tmp_path / "b.h5")][:2 if command ==
                                                                                               "validate" else 4])
        assert result.exit_code == 2, result.output
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"Error: {config}:2: continuation.from: lies outside the "
                                                       f"model's domain: {name} must be"), result.output
    assert not (tmp_path / "b.h5").exists()


def test_a_written_model_keeps_its_own_rules():
    with pytest.raises(ConfigError, match=r"continuation.from: lies outside the model's domain: "
                                          r"model.barriers\[0\].restitution must be in \[0, 1\]"):
        config_from_dict(dict(WRITTEN, continuation={"parameter": "r", "from": 1.2, "to": [0.5, 1.5]}))
    with pytest.raises(ConfigError, match="model.period must be > 0"):
        config_from_dict(dict(WRITTEN, continuation={"parameter": "omega", "from": -0.5, "to": [-1, 1]}))


# --- branches at the edges -----------------------------------------------------------------------
def _branch(base, name, start, low, high, **options):
    config = config_from_dict(dict(base, continuation={"parameter": name, "from": start, "to": [low, high],
                                                       "max_step": 0.3, **options}))
    branches, _ = execution.run_continuation(config)
    return config, branches[0]


def _check_branch_at_edge(config, branch, name, edge, side):
    """Every orbit inside the domain; the end towards the edge is domain_edge, next to it."""
    values = [orbit.parameter for orbit in branch.orbits]
    for value in values:
        assert outside_domain(config.model, dict(config.parameters, **{name: value})) is None, value
    status, reason = branch.ends[side]
    assert status == "domain_edge", (status, reason)
    assert reason.startswith(f"stops at {name} = ") and "the edge of the model's domain: beyond it" in reason
    last = values[0] if side == "down" else values[-1]
    assert abs(last - edge) < NEAR_EDGE, (last, edge)


SLOW = settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@SLOW
@given(beyond=st.floats(1e-9, 5.0))
def test_a_branch_in_e_stops_at_one(beyond):
    """The issue's example: over [0.5, 1.5] the branch held orbits at e = 1.06-1.31."""
    config, branch = _branch(LARGE, "e", 0.8, 0.7, 1.0 + beyond)
    _check_branch_at_edge(config, branch, "e", 1.0, "up")
    assert branch.ends["down"][0] == "left_range"


@SLOW
@given(beyond=st.floats(0.0, 5.0))
def test_a_branch_in_e_stops_above_zero(beyond):
    config, branch = _branch(LARGE, "e", 0.5, -beyond, 0.6)
    _check_branch_at_edge(config, branch, "e", 0.0, "down")


@SLOW
@given(beyond=st.floats(0.0, 5.0))
def test_a_branch_in_c_stops_above_zero(beyond):
    """c through 0: R = |Q|/c has no meaning there, and the branch went on with plausible R."""
    config, branch = _branch(LARGE, "c", 0.04, -beyond, 0.045)
    _check_branch_at_edge(config, branch, "c", 0.0, "down")
    assert all(orbit.parameter > 0 for orbit in branch.orbits)


@SLOW
@given(beyond=st.floats(0.0, 10.0))
def test_a_branch_in_Omega_stops_above_zero(beyond):
    config, branch = _branch(NO_FAST, "Omega", 1.0, -beyond, 1.5)
    _check_branch_at_edge(config, branch, "Omega", 0.0, "down")


def test_a_written_models_branch_stops_where_its_restitution_reaches_one():
    config, branch = _branch(WRITTEN, "r", 0.8, 0.7, 1.5, max_step=0.1)
    _check_branch_at_edge(config, branch, "r", 1.0, "up")
    assert "model.barriers[0].restitution must be in [0, 1]" in branch.ends["up"][1]


# A declared range (model.ranges) is the model's domain as much as its rules: zeta in [0.02, 0.2].
RANGED = dict(WRITTEN, model=dict(WRITTEN_MODEL, ranges={"zeta": [0.02, 0.2], "r": [0.0, None], "phi": [-0.3, 0.3]}))


def test_a_declared_range_refuses_values_starts_and_axes_beyond_it():
    with pytest.raises(ConfigError, match=r"parameters.zeta: must be in \[0.02, 0.2\], got 0.5"):
        config_from_dict(dict(RANGED, parameters={"zeta": 0.5}))
    with pytest.raises(ConfigError, match=r"sweep.zeta\[2\]: must be in \[0.02, 0.2\], got 0.3"):
        config_from_dict(dict(RANGED, sweep={"zeta": [0.05, 0.1, 0.3]}))
    with pytest.raises(ConfigError, match=r"continuation.from: lies outside the model's domain: zeta must be in "
                                          r"\[0.02, 0.2\], got 0.01 \(the model's declared range, model.ranges.zeta\)"):
        config_from_dict(dict(RANGED, continuation={"parameter": "zeta", "from": 0.01, "to": [0.0, 0.1]}))
    with pytest.raises(ConfigError, match=r"model.parameters.zeta: the default must be in \[0.1, 0.2\], got 0.05"):
        config_from_dict(dict(RANGED, model=dict(WRITTEN_MODEL, ranges={"zeta": [0.1, 0.2]})))


@pytest.mark.parametrize("bounds, message", [
    ([0.2, 0.1], "must have low < high"), ([None, None], "bounds nothing"), ("0..1", "must be [low, high]"),
    ([0, float("inf")], "must be [low, high]"), ([True, 1], "must be [low, high]"), ([0, 1, 2], "must be [low, high]"),
])
def test_a_bad_declared_range_is_refused_at_its_field(bounds, message):
    with pytest.raises(ConfigError, match=r"model.ranges.zeta: " + re.escape(message)):
        config_from_dict(dict(RANGED, model=dict(WRITTEN_MODEL, ranges={"zeta": bounds})))
    with pytest.raises(ConfigError, match=r"model.ranges.zetta: not a parameter of the model"):
        config_from_dict(dict(RANGED, model=dict(WRITTEN_MODEL, ranges={"zetta": [0, 1]})))


def test_a_written_models_branch_stops_at_its_declared_range():
    # the forcing's phase phi only shifts the orbit in time: nothing but the range stops it
    config, branch = _branch(RANGED, "phi", 0.0, -0.1, 1.0, max_step=0.1)
    _check_branch_at_edge(config, branch, "phi", 0.3, "up")
    assert "model.ranges.phi" in branch.ends["up"][1]


def test_a_declared_range_is_kept_in_the_files_config(tmp_path, invoke, write_config):
    from vrsweep.config import parse_config
    from vrsweep.config.dump import dump_config

    config = config_from_dict(dict(RANGED, sweep={"zeta": [0.05, 0.1]}, integration={"transient_periods": 20,
                                                                                     "measure_periods": 20}))
    again = parse_config(dump_config(config), "dumped.yaml")
    assert again.model.ranges == config.model.ranges == (("zeta", 0.02, 0.2), ("r", 0.0, None), ("phi", -0.3, 0.3))


def test_the_branch_file_and_info_say_domain_edge(tmp_path, invoke, write_config):
    config = write_config(tmp_path, """\
        model: effective
        parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0, g: 30.0}
        initial: {x: 0.0, v: 0.0}
        integration: {rtol: 1.0e-8, atol: 1.0e-10, transient_periods: 200}
        continuation: {parameter: e, from: 0.8, to: [0.5, 1.5], max_step: 0.3}
        """)
    out = tmp_path / "e.h5"
    result = invoke("continue", config, "-o", out)
    assert result.exit_code == 0, result.output
    assert "last end: domain_edge: stops at e = 0.99999" in result.output, result.output
    with vrsweep.open_results(out) as ds:
        assert ds["parameter"].values.max() <= 1.0
        assert str(ds["branch_end_last_status"].values[0]) == "domain_edge"
    info = invoke("info", out)
    assert info.exit_code == 0 and "last end:   domain_edge: stops at e = 0.99999" in info.output, info.output


# --- curves at the edges, and at the resolution asked ----------------------------------------------
@pytest.fixture(scope="module")
def large_branch(tmp_path_factory, write_config, invoke):
    """The large orbit's branch over g in [27, 30]: bifurcation 0 is its period doubling at g = 27.837."""
    folder = tmp_path_factory.mktemp("domain")
    config = write_config(folder, """\
        model: effective
        parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
        initial: {x: 0.0, v: 0.0}
        integration: {rtol: 1.0e-10, atol: 1.0e-12, transient_periods: 200}
        continuation: {parameter: g, from: 30.0, to: [27.0, 30.0], max_step: 0.3}
        """, "large.yaml")
    branch = folder / "large.h5"
    assert invoke("continue", config, "-o", branch, "-q").exit_code == 0
    with vrsweep.open_results(branch) as ds:
        assert str(ds["bifurcation_kind"].values[0]) == "period_doubling"
    return branch


def _curve(invoke, branch, out, *args):
    result = invoke("continue", branch, "--point", "0", "--along", "e", "-o", out, *args)
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(out) as ds:
        ends = [(str(ds[f"curve_end_{side}_status"].values[0]), str(ds[f"curve_end_{side}_reason"].values[0]))
                for side in ("first", "last")]
        return np.asarray(ds["e"].values), ends, result.output


def test_an_e_curve_reaches_both_ends_of_its_range_with_30_points(large_branch, invoke, tmp_path):
    """Issue 32's curve: --to 0.9 0.97 gave 2 points, and left_range with none kept past the start."""
    e, ends, output = _curve(invoke, large_branch, tmp_path / "e.h5", "--to", "0.9", "0.97")
    assert len(e) >= 30, output
    assert abs(e.min() - 0.9) < NEAR_EDGE and abs(e.max() - 0.97) < NEAR_EDGE, (e.min(), e.max())
    assert np.all((e >= 0.9) & (e <= 0.97))
    assert [status for status, _ in ends] == ["left_range", "left_range"], ends
    assert ends[0][1].startswith("e left [0.9, 0.97]; the last point at g = ")
    last_e = float(ends[0][1].rpartition("e = ")[2])  # the reason names the point the curve ends at
    assert last_e == pytest.approx(e.min(), abs=1e-7)


def test_a_curves_step_and_points_are_set_on_a_branch_file(large_branch, invoke, tmp_path):
    e, ends, _ = _curve(invoke, large_branch, tmp_path / "fine.h5", "--to", "0.9", "0.97",
                        "--set", "continuation.max_step=0.0005", "--set", "continuation.max_points=1000")
    assert len(e) >= 0.07 / 0.0005 and np.max(np.abs(np.diff(e))) <= 0.0005 * (1 + 1e-9)
    with vrsweep.open_results(tmp_path / "fine.h5") as ds:
        assert "max_step: 0.0005" in ds.attrs["config"]
    few, ends, _ = _curve(invoke, large_branch, tmp_path / "few.h5", "--to", "0.9", "0.97",
                          "--set", "continuation.max_points=10")
    assert len(few) == 11 and [status for status, _ in ends] == ["max_points", "max_points"]
    for setting, words in (("g=3", "--set g=3: a branch file takes the settings of its curves only: "
                                   "continuation.max_points, "),
                           ("continuation.max_step=-1", "--set continuation.max_step=-1: continuation.max_step: "
                                                        "must be > 0")):
        result = invoke("continue", large_branch, "--point", "0", "--along", "e", "--to", "0.9", "0.97",
                        "--set", setting, "-o", tmp_path / "no.h5")
        assert result.exit_code == 2 and result.output.startswith(f"Error: {words}"), result.output
        assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "no.h5").exists()
    result = invoke("continue", large_branch, "--point", "0", "--along", "e", "--at", "g=28", "-o", tmp_path / "no.h5")
    assert result.exit_code == 2 and "--start and --at go with a config" in result.output  # it was ignored


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(beyond=st.floats(1e-9, 5.0), low=st.floats(0.5, 0.94))
def test_an_e_curve_stops_at_one(large_branch, invoke, tmp_path_factory, beyond, low):
    out = tmp_path_factory.mktemp("edge") / "e.h5"
    e, ends, output = _curve(invoke, large_branch, out, "--to", repr(low), repr(1.0 + beyond))
    assert np.all(e <= 1.0) and abs(e.max() - 1.0) < NEAR_EDGE, output
    status, reason = ends[1]
    assert status == "domain_edge" and reason.startswith("stops at g = ") and "e must be in (0, 1]" in reason
    assert ends[0][0] == "left_range" and abs(e.min() - low) < NEAR_EDGE


def test_an_e_curve_stops_above_zero(large_branch, invoke, tmp_path):
    e, ends, output = _curve(invoke, large_branch, tmp_path / "e0.h5", "--to", "-0.5", "0.96")
    assert np.all(e > 0.0) and e.min() < NEAR_EDGE, output
    assert ends[0][0] == "domain_edge" and ends[1][0] == "left_range", ends


@pytest.mark.parametrize("along, to", [("c", ("-0.1", "0.06")), ("Omega", ("-1", "4.5"))])
def test_curves_towards_an_edge_never_hold_a_point_outside(large_branch, invoke, tmp_path, along, to):
    """Other reasons may end these first (a graze, Newton as Omega -> 0), never a point past 0."""
    out = tmp_path / "c.h5"
    result = invoke("continue", large_branch, "--point", "0", "--along", along, "--to", *to, "--within", "0", "60",
                    "-o", out, "-q")
    assert result.exit_code == 0, result.output
    with vrsweep.open_results(out) as ds:
        values = ds[along].values
        assert np.all(values > 0.0) and len(values) > 5
        assert str(ds["curve_end_first_status"].values[0]) != "left_range"


def test_a_branch_file_point_outside_the_domain_is_refused(tmp_path, invoke):
    """A branch file of an earlier vrsweep may hold orbits at e > 1: no curve starts there."""
    from handmade import orbit

    from vrsweep.analysis.continuation import Bifurcation, Branch
    from vrsweep.store import branch_file

    config = config_from_dict({"model": "effective", "parameters": {"gamma": 0.05, "alpha": 0.05, "g": 30.0},
                               "continuation": {"parameter": "e", "from": 0.95, "to": [0.5, 1.5]}})
    orbits = [orbit(e, True) for e in (0.9, 1.0, 1.1, 1.2, 1.3)]
    branch = Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "e left"), "up": ("left_range", "e left")})
    path = tmp_path / "old.h5"
    branch_file.write_branch(path, branch_file.branch_arrays([branch], [Bifurcation("fold", orbits[3])], 1.0),
                             config, "rk45")
    result = invoke("continue", path, "--point", "0", "--along", "Omega", "--to", "3", "5", "-o", tmp_path / "c.h5")
    assert result.exit_code == 2, result.output
    assert result.output.strip() == ("Error: --point = 0 lies outside the model's domain (e must be in (0, 1], got "
                                     "1.2 (eq2.2: 0 < e <= 1; a restitution above one creates energy at each "
                                     "impact)): there is no curve to follow from it"), result.output


# --- issue 33's leftovers: --at refused before the compile notice; a signal in a switched branch --------
def test_a_bad_at_is_refused_before_the_compile_notice(tmp_path, write_config, sweep_file, monkeypatch):
    _, sweep = sweep_file(tmp_path, """\
        model: effective
        parameters: {gamma: 0.05, alpha: 0.05}
        sweep: {g: [24.0, 25.0]}
        integration: {transient_periods: 5, measure_periods: 5, strobe_periods: 4}
        """)
    config = write_config(tmp_path, "model: effective\ncontinuation: {parameter: g, from: 24.0, to: [23.0, 25.0]}\n",
                          "c.yaml")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "empty-cache"))  # would say "Compiling ..."
    for at in ("g=24.3", "Omega=4", "g=nan"):
        result = CliRunner().invoke(main, ["continue", str(config), "--start", str(sweep), "--at", at,
                                           "-o", str(tmp_path / "b.h5")])
        assert result.exit_code == 2, result.output
        assert "Compiling" not in result.output and len(result.output.strip().splitlines()) == 1, result.output
        assert "--at" in result.output or "axis" in result.output


SWITCHED = """\
    model: effective
    parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
    initial: {x: 0.0, v: 0.0}
    integration: {rtol: 1.0e-10, atol: 1.0e-12, transient_periods: 200}
    continuation: {parameter: g, from: 27.5, to: [27.5, 28.3], max_step: 0.3, max_period: 2}
    """


def test_a_signal_inside_a_switched_branch_keeps_both_branches(tmp_path, invoke, write_config, monkeypatch):
    """The period-1 branch has 5 orbits after its start (then --switch follows the period-2 one born at
    g = 27.837): a SIGINT at the 8th orbit lands in the switched branch."""
    from test_hostile_signals import _stop_after

    config = write_config(tmp_path, SWITCHED)
    out = tmp_path / "switched.h5"
    calls = _stop_after(monkeypatch, 8, signal.SIGINT)
    result = invoke("continue", config, "-o", out, "--switch", "-q")
    assert result.exit_code == 130, result.output
    assert calls[0] == 8
    assert "marked incomplete" in result.output.strip().splitlines()[-1], result.output
    with h5py.File(out, "r") as f:
        assert int(f.attrs["vrsweep_complete"]) == 0
    with vrsweep.open_results(out) as ds:
        assert list(ds["branch_periods"].values) == [1, 2]
        # Branch 0 whole (its start and 5 orbits), the switched branch's first orbit and the 3 after it.
        assert ds.sizes["point"] == 6 + 1 + 3
        first = [str(ds[f"branch_end_{side}_status"].values[0]) for side in ("first", "last")]
        second = [str(ds[f"branch_end_{side}_status"].values[1]) for side in ("first", "last")]
        assert "interrupted" not in first and "interrupted" in second, (first, second)
    info = invoke("info", out)
    assert info.exit_code == 0 and "NOT complete (stopped by a signal" in info.output, info.output
