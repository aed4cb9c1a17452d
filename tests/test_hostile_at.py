"""--at names a point: every axis of a map once (issue 33, class 1's last example). Naming an axis
twice took the later value silently, and naming one axis of two took the other's first value."""

import textwrap

import pytest

MAP = """\
    model: effective
    sweep:
      g: {values: [10.0, 20.0]}
      Omega: {values: [4.0, 5.0]}
    integration: {transient_periods: 4, measure_periods: 16}
    continuation: {parameter: g, from: 10.0, to: [5.0, 30.0]}
    """


@pytest.fixture(scope="module")
def a_map(tmp_path_factory, sweep_file):
    folder = tmp_path_factory.mktemp("map")
    return sweep_file(folder, textwrap.dedent(MAP), "map")


@pytest.mark.parametrize("at, words", [
    (["g=10"], ["sweeps g, Omega", "--at Omega=4"]),
    (["Omega=4"], ["sweeps g, Omega", "--at g=10"]),
    (["g=10", "g=20"], ["g is named twice"]),
])
def test_continue_from_a_map_needs_its_point_on_every_axis_once(a_map, tmp_path, invoke, at, words):
    config, path = a_map
    args = [item for value in at for item in ("--at", value)]
    result = invoke("continue", config, "--start", path, *args, "-o", tmp_path / "branch.h5")
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and all(word in result.output for word in words), result.output
    assert not (tmp_path / "branch.h5").exists()


def test_plot_refuses_an_axis_named_twice(a_map, tmp_path, invoke):
    _, path = a_map
    result = invoke("plot", path, "--kind", "response", "--at", "Omega=4", "--at", "Omega=5", "-o", tmp_path / "p.png")
    assert result.exit_code == 2, result.output
    assert "--at Omega is given twice" in result.output
    assert not (tmp_path / "p.png").exists()


HYSTERESIS = """\
    model: effective
    parameters: {gamma: 0.05, alpha: 0.05, Omega: 4.0}
    sweep:
      g: {values: [23.0, 24.0], continuation: both}
    integration: {transient_periods: 4, measure_periods: 16}
    continuation: {parameter: g, from: 23.0, to: [20.0, 27.0]}
    """


@pytest.mark.parametrize("direction, index", [("-1", 1), ("down", 1), ("1", 0), ("+1", 0), ("up", 0)])
def test_continue_starts_on_the_direction_named(tmp_path, sweep_file, direction, index):
    # docs/continuation.md's --at direction=-1 was refused: --at's value reached the direction
    # check as the number -1.0, whose text "-1.0" was not one of the words it knew.
    from vrsweep.commands.continue_ import _parse_at
    from vrsweep.execution.continuation import start_state_from_sweep

    _, path = sweep_file(tmp_path, textwrap.dedent(HYSTERESIS), "hysteresis")
    state = start_state_from_sweep(path, _parse_at(["g=23", f"direction={direction}"]))
    import h5py

    with h5py.File(path, "r") as f:
        assert list(f["direction"][()]) == [1.0, -1.0]
        want = [f["x_final"][0, index], f["v_final"][0, index]]
    assert list(state) == want


def test_continue_refuses_a_direction_that_is_neither(tmp_path, sweep_file, invoke):
    config, path = sweep_file(tmp_path, textwrap.dedent(HYSTERESIS), "hysteresis")
    result = invoke("continue", config, "--start", path, "--at", "g=23", "--at", "direction=0",
                    "-o", tmp_path / "branch.h5")
    assert result.exit_code == 2 and "the direction is up or down" in result.output, result.output


def test_a_value_that_is_no_number_names_the_axis_values_once(a_map, tmp_path, invoke):
    # It said "g takes values 41 values from 0 to 40" for a long axis.
    _, path = a_map
    result = invoke("plot", path, "--kind", "map", "--at", "g=nan", "-o", tmp_path / "p.png")
    assert result.exit_code == 2 and "not a finite number; the axis g: 10, 20" in result.output, result.output
