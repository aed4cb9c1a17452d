"""YAML config -> validated, fully resolved :class:`Config`.

The schema (docs/design.md, "Config"); every key is optional and defaults to the paper's values::

    model: original                  # or: effective
    parameters: {gamma: 0.22, alpha: 0.1, c: 0.04, omega0: 0.1, omega: 0.5,
                 Delta: 1.0, e: 0.95, g: 0.0, Omega: 4.0}
    initial: {x: 0.99, v: 0.5}
    sweep:                           # ordered axes, each named after a parameter, or x0 / v0
      g: {start: 0.0, stop: 40.0, num: 81}            # linear, start < stop (or num: 1)
      Omega: [4.0, 5.0]                               # explicit list, strictly monotonic
      # or {values: [...], continuation: up|down|both}, or {start, stop, num, continuation}
    integration: {method: rk45, rtol: 1.0e-9, atol: 1.0e-11, transient_periods: 100, ...}
    output: results/fig1.h5

Paths: a relative ``output`` is relative to the current directory, like any path given on the
command line (not to the config file's directory), so ``vrsweep run configs/x.yaml`` run from the
project root writes where ``output`` says, seen from the project root. Without ``output`` the
result goes to the config's file name with ``.h5``, also in the current directory.

Errors: every problem found is collected and raised together as one :class:`ConfigError`, each
formatted ``FILE:LINE: field.path: message (allowed: ...)``, e.g.
``fig1.yaml:7: parameters.e: must be in (0, 1], got 1.5``. A problem caused by a command-line
override reads ``--set e=1.5: parameters.e: must be in (0, 1], got 1.5``.

The package, one module per concern:

- ``schema``: allowed values and defaults as data (the one source of defaults), the pydantic
  models generated from them, and the result types Config, Axis, Integration;
- ``validate``: one validation run (text + overrides -> Config) and the entry points
  load_config, parse_config, config_from_dict (a dict nested as the YAML, for the Python API),
  with_overrides, and same_config (what --resume compares);
- ``axes``: each sweep axis checked on its own; ``rules``: the rules across fields;
- ``domains``: where a model is defined (outside_domain), for the config, branches and curves alike;
- ``report``: problems worded and located (file, line, field path), pydantic's and ruamel's
  errors in this project's words;
- ``yaml``: reading and writing YAML through ruamel (the canonical text of a resolved config);
- ``grid``: the grid a config spans (axes, continuation lines, the parameters at grid points);
- ``wording``: small text helpers shared by the messages.
"""

from vrsweep.config.grid import DIRECTION_VALUES, Grid
from vrsweep.config.schema import (
    AXIS_DOMAINS, AXIS_NAMES, CONTINUATIONS, INITIAL_DEFAULTS, INITIAL_DOMAINS, INTEGRATION_DEFAULTS,
    INTEGRATION_DOMAINS, MAX_AXIS_POINTS, METHODS, PARAMETER_DOMAINS, Axis, Config, Domain, Integration,
)
from vrsweep.config.validate import config_from_dict, load_config, parse_config, same_config, with_overrides
from vrsweep.errors import ConfigError

__all__ = [
    "Axis", "Integration", "Config", "load_config", "parse_config", "config_from_dict", "with_overrides", "same_config",
    "Domain", "PARAMETER_DOMAINS", "INITIAL_DEFAULTS", "INITIAL_DOMAINS", "INTEGRATION_DEFAULTS",
    "INTEGRATION_DOMAINS", "AXIS_NAMES", "AXIS_DOMAINS", "CONTINUATIONS", "MAX_AXIS_POINTS", "METHODS",
    "Grid", "DIRECTION_VALUES", "ConfigError",
]
