"""A vrsweep Config given to the Python API is validated again, as a file or a dict is: a Config is
a dataclass, and one changed with dataclasses.replace ran as given (docs/python-api.md)."""

import dataclasses

import pytest

import vrsweep
from vrsweep.config import parse_config
from vrsweep.errors import ConfigError

TINY = "model: effective\nintegration: {transient_periods: 2, measure_periods: 16}\n"


def _replaced(config, section, **changes):
    if section == "parameters":
        return dataclasses.replace(config, parameters={**config.parameters, **changes})
    if section == "integration":
        return dataclasses.replace(config, integration=dataclasses.replace(config.integration, **changes))
    return dataclasses.replace(config, **changes)


@pytest.mark.parametrize("function", [vrsweep.sweep, vrsweep.simulate, vrsweep.theory])
@pytest.mark.parametrize("section, changes, words", [
    # e = 1.5 and rtol = 5 were integrated and written to a file; c = 0 gave R = nan at an ok point
    ("parameters", {"e": 1.5}, "parameters.e: must be in (0, 1], got 1.5"),
    ("parameters", {"c": 0.0}, "parameters.c: must be > 0, got 0.0"),
    ("integration", {"rtol": 5.0}, "integration.rtol: must be in [1e-14, 0.01], got 5.0"),
    (None, {"model": "bogus"}, "model: must be one of original, effective, got 'bogus'"),  # a TypeError
    ("parameters", {"g": "abc"}, "this Config cannot be read back as a config"),  # a ValueError
])
def test_a_changed_config_is_validated_again(function, section, changes, words):
    config = _replaced(parse_config(TINY), section, **changes)
    kwargs = {} if function is vrsweep.theory else {"progress": False}
    with pytest.raises(ConfigError, match=words.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        function(config, **kwargs)


def test_a_config_missing_a_parameter_is_one_config_error():
    config = parse_config(TINY)
    broken = dataclasses.replace(config, parameters={k: v for k, v in config.parameters.items() if k != "g"})
    with pytest.raises(ConfigError, match="cannot be read back as a config"):  # a KeyError from the theory
        vrsweep.theory(broken)


def test_a_valid_config_runs_as_before():
    config = parse_config(TINY)
    assert vrsweep.theory(config) == vrsweep.theory(TINY)


@pytest.mark.parametrize("value", [[5.0, 6.0], (5.0,), range(3), "array"])
def test_several_values_for_a_parameter_say_how_to_sweep_it(value):
    # vrsweep.sweep(config, g=[5, 6]) reads as a sweep over g; it was refused in --set's words,
    # "VALUE must be a single number or word", which this caller never typed.
    import numpy as np

    from vrsweep.execution.api import resolve_config

    value = np.array([5.0, 6.0]) if value == "array" else value
    with pytest.raises(ConfigError) as caught:
        resolve_config("model: effective\n", {"g": value})
    assert str(caught.value).startswith("keyword argument g=")
    assert "a keyword sets one value (g=5 fixes g); to sweep g over values, give its axis in the config" in str(caught.value)
    assert "VALUE" not in str(caught.value)


def test_one_value_and_a_continuation_range_are_still_keywords():
    import numpy as np

    from vrsweep.execution.api import resolve_config

    assert resolve_config("model: effective\n", {"g": np.float64(5.0)}).parameters["g"] == 5.0
    assert resolve_config("model: effective\n", {"g": np.array(5.0)}).parameters["g"] == 5.0
    text = "model: effective\ncontinuation: {parameter: g, from: 20, to: [10, 30]}\n"
    config = resolve_config(text, {"continuation.to": [15, 25]})
    assert (config.continuation.low, config.continuation.high) == (15.0, 25.0)
