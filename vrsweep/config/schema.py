"""The config's schema: allowed values and defaults as data, the pydantic models generated from them,
and the validated result (:class:`Config`).

This module is the ONE source of defaults: the integration defaults here are the kernel's
(the kernel's own settings take theirs from ``numerics.kernel.SETTING_DEFAULTS``), the parameter defaults are the paper's
(``model.DEFAULT_PARAMETERS``), and the error messages and docs/design.md read the same tables.
"""

from __future__ import annotations

import functools
import math
import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, create_model
from pydantic_core import PydanticCustomError

from vrsweep.config.wording import folder_ending, show_number, show
from vrsweep.numerics.settings import CONTINUATION_DEFAULTS, DEFAULT_METHOD, SETTING_DEFAULTS as KERNEL_SETTING_DEFAULTS
from vrsweep.numerics.model import (
    DEFAULT_PARAMETERS, INITIAL_STATE_AXES, INITIAL_STATE_KEYS, MODELS, PARAMETER_NAMES,
)


# --------------------------------------------------------------------------------------------
# Allowed values, as data: the pydantic schema, the error messages and the docs all read these.
# --------------------------------------------------------------------------------------------

# The largest count a config may give (periods, steps, impacts, points...). The kernel reads its
# counts from a vector of doubles (numerics/settings.py), which hold whole numbers exactly up to
# 2^53: above it transient_periods: 2^63 - 1 reached the kernel as 2^63, whose conversion to int64
# overflows, and 2^53 + 1 as 2^53. No count anywhere near it can be computed anyway.
COUNT_MAX = 2**53


@dataclass(frozen=True)
class Domain:
    """An interval of allowed values, open or closed at either end; ``integer`` for counts."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = True
    high_open: bool = True
    integer: bool = False

    def describe(self) -> str:
        """The interval in words, e.g. ``(0, 1]``, ``> 0``, ``an integer >= 1``; a count says int64's limit too."""
        low, high = show_number(self.low), show_number(self.high)
        has_low, has_high = self.low > -math.inf, self.high < math.inf
        if has_low and self.high == COUNT_MAX:  # said as a limit, not as an interval [1, 9007199254740992]
            text = f"{'>' if self.low_open else '>='} {low} and <= 2^53 = {COUNT_MAX} (the whole numbers a double holds)"
        elif has_low and has_high:
            text = f"in {'(' if self.low_open else '['}{low}, {high}{')' if self.high_open else ']'}"
        elif has_low:
            text = f"{'>' if self.low_open else '>='} {low}"
        elif has_high:
            text = f"{'<' if self.high_open else '<='} {high}"
        else:
            text = ""
        kind = "an integer" if self.integer else "a number"
        return f"{kind} {text}".rstrip()

    def contains(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def range_message(self, value) -> str:
        """``must be in (0, 1], got 1.5`` -- the message for a value of the right type outside."""
        domain = self
        if self.high == COUNT_MAX and value <= COUNT_MAX:  # a count below its least: the ceiling is noise
            domain = replace(self, high=math.inf)
        allowed = domain.describe().replace("an integer ", "").replace("a number ", "")
        if self.integer:
            allowed = "an integer " + allowed
        return f"must be {allowed}, got {show(value)}"


ANY = Domain()
_POSITIVE = Domain(low=0.0)
_COUNT = Domain(low=1, low_open=False, high=COUNT_MAX, high_open=False, integer=True)

PARAMETER_DOMAINS = {
    "gamma": ANY, "alpha": ANY, "omega0": ANY,
    "c": _POSITIVE,  # R = |Q|/c (eq3.3) is a gain: undefined without a drive; -c is c half a period on
    "omega": _POSITIVE,                                  # the slow period 2 pi/omega sets the time unit
    "Delta": ANY,                                       # must lie above initial.x: checked across fields
    "e": Domain(low=0.0, high=1.0, high_open=False),     # eq2.2: 0 < e <= 1
    "g": ANY,
    "Omega": _POSITIVE,
}
# Why each bounded parameter stops where it does: said when a continuation or a curve meets the edge
# (config/domains.py), which the table above sets for configs, branches and curves alike.
PARAMETER_DOMAIN_REASONS = {
    "c": "R = |Q|/c (eq3.3) is undefined at c = 0",
    "omega": "the slow period 2 pi/omega sets the time unit",
    "e": "eq2.2: 0 < e <= 1; a restitution above one creates energy at each impact",
    "Omega": "cos(-Omega t) = cos(Omega t): a negative Omega repeats the positive one, and 0 is no fast forcing",
}

INITIAL_DEFAULTS = {"x": 0.99, "v": 0.5}  # the paper's Fig. 6 caption
INITIAL_DOMAINS = {"x": ANY, "v": ANY}
# What a sweep axis may be named: a parameter, or x0 / v0 (the initial state, basins of attraction).
AXIS_NAMES = PARAMETER_NAMES + INITIAL_STATE_AXES
AXIS_DOMAINS = {**PARAMETER_DOMAINS, **{axis: INITIAL_DOMAINS[key] for axis, key in INITIAL_STATE_KEYS.items()}}

# The integration methods (kernel.INTEGRATORS): rk45 is Dormand-Prince 5(4), dop853 Hairer's 8(5,3).
METHODS = ("rk45", "dop853")
# Where a sweep's points are integrated (docs/gpu.md): the CPU's cores, or an NVIDIA GPU through the
# optional extra vrsweep[cuda]. Continuation and trajectories always run on the CPU.
DEVICES = ("cpu", "cuda")

# The kernel's own settings (rtol ... stick_velocity) default to the kernel's values.
INTEGRATION_DEFAULTS = {
    "method": DEFAULT_METHOD, **KERNEL_SETTING_DEFAULTS, "strobe_periods": 16, "max_period": 8,
    "period_tolerance": 1.0e-6, "lyapunov": False, "device": "cpu",
}
INTEGRATION_DOMAINS = {
    # Bounds where the settings mean what they say (docs/config.md): below 1e-14 a step's rounding
    # is larger than the tolerance asked for; above 1e-2 the step controller's error estimate no
    # longer bounds R's error (rtol 0.99 gave R 7e-4 off with an R_err of 3e-14).
    "rtol": Domain(low=1e-14, high=1e-2, low_open=False, high_open=False),
    "atol": Domain(low=0.0, high=1e-2, high_open=False),
    "transient_periods": Domain(low=0, low_open=False, high=COUNT_MAX, high_open=False, integer=True),
    "measure_periods": _COUNT,
    "max_steps": _COUNT,
    "max_impacts_per_period": _COUNT,
    "divergence_bound": _POSITIVE,
    "stick_velocity": _POSITIVE,
    "strobe_periods": _COUNT,       # must also be <= measure_periods: checked across fields
    "max_period": _COUNT,
    # A period is repetition of the stroboscopic state to this relative tolerance: at 10 a chaotic
    # point (lambda1 = 0.23) passed as period 1; 1e-3 is far above any solver error asked for.
    "period_tolerance": Domain(low=0.0, high=1e-3, high_open=False),
}

CONTINUATIONS = ("up", "down", "both")

# One axis is materialised as an array when the config is read, so its length must stay sane;
# the size of the whole grid is judged later by vrsweep.execution.estimate with the run's thread count.
MAX_AXIS_POINTS = 10_000_000
NUM_DOMAIN = Domain(low=1, low_open=False, high=MAX_AXIS_POINTS, high_open=False, integer=True)

SECTIONS = ("model", "parameters", "initial", "sweep", "integration", "output", "continuation")

# The continuation section (vrsweep continue; analysis/continuation.py, docs/continuation.md).
# Separate from a sweep axis's `continuation: up|down|both` (hysteresis sweeps), which it leaves alone.
CONTINUATION_DOMAINS = {
    "max_points": _COUNT, "initial_step": _POSITIVE, "min_step": _POSITIVE, "max_step": _POSITIVE,
    "newton_tolerance": _POSITIVE, "max_newton_iterations": _COUNT, "max_period": _COUNT,
    "location_tolerance": _POSITIVE,
}
# switch: start the branch of 2p periods at every period doubling and the second branch through
# every branch point (analysis/switching.py).
CONTINUATION_KEYS = ("parameter", "from", "to", *CONTINUATION_DEFAULTS, "switch")
LINEAR_KEYS = ("start", "stop", "num", "continuation")
VALUES_KEYS = ("values", "continuation")


# --------------------------------------------------------------------------------------------
# The validated result
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Axis:
    """One sweep axis: a parameter name (or x0 / v0, the initial state) and its values (float64,
    1-D, read-only, in config order).

    ``continuation`` (``up``, ``down``, ``both`` or None) asks the sweep to run this axis in order,
    each point starting from the previous point's final state; the values themselves stay as given.
    """

    name: str
    values: np.ndarray
    continuation: str | None = None

    def __eq__(self, other):
        if not isinstance(other, Axis):
            return NotImplemented
        return (self.name, self.continuation) == (other.name, other.continuation) and np.array_equal(
            self.values, other.values)

    def __hash__(self):
        return hash((self.name, self.continuation, self.values.tobytes()))

    def __len__(self):
        return len(self.values)


@dataclass(frozen=True)
class Integration:
    """Solver settings (see INTEGRATION_DEFAULTS for the defaults and INTEGRATION_DOMAINS for ranges)."""

    method: str
    rtol: float
    atol: float
    transient_periods: int
    measure_periods: int
    max_steps: int
    max_impacts_per_period: int
    divergence_bound: float
    stick_velocity: float
    strobe_periods: int
    max_period: int
    period_tolerance: float
    lyapunov: bool = False
    device: str = "cpu"


@dataclass(frozen=True)
class Continuation:
    """The config's continuation section: which parameter, where the first orbit is found
    (``start``, the key ``from``), the range [low, high] the branch stays in, and the numerics'
    settings (CONTINUATION_DEFAULTS); ``switch``: follow the 2p-branch born at each period doubling
    and the second branch through each branch point."""

    parameter: str
    start: float
    low: float
    high: float
    max_points: int
    initial_step: float
    min_step: float
    max_step: float
    newton_tolerance: float
    max_newton_iterations: int
    max_period: int
    location_tolerance: float
    switch: bool = False

    def options(self) -> dict:
        """The settings analysis.continuation reads (its DEFAULTS' keys)."""
        return {key: getattr(self, key) for key in CONTINUATION_DEFAULTS}


# $NAME or ${NAME} in a config's output (Config.output_path), and the line that sets output.
_VARIABLE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}|\$([A-Za-z_][A-Za-z0-9_]*)")
_OUTPUT_KEY = re.compile(r"^output\s*:")


@dataclass(frozen=True)
class Config:
    """A validated config with every default filled in and every override applied.

    Equality compares content only (not the file name, text or overrides it came from), so
    ``parse_config(c.to_yaml()) == c``. ``parameters`` holds all the model's parameters (the paper's
    nine, or a written model's); a swept one keeps
    its fixed value there, which the sweep ignores (so does ``initial`` for a swept x0 or v0).
    """

    model: Any  # "original", "effective", or a numerics.written.WrittenModel
    parameters: dict[str, float]
    initial: dict[str, float]
    axes: tuple[Axis, ...]
    integration: Integration
    output: str | None = None
    continuation: Continuation | None = None
    source_name: str = field(default="<string>", compare=False)
    source_text: str = field(default="", compare=False, repr=False)
    overrides: tuple[str, ...] = field(default=(), compare=False)

    @property
    def shape(self) -> tuple[int, ...]:
        """Grid shape, one dimension per axis in config order; () for a single point."""
        return tuple(len(axis.values) for axis in self.axes)

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(axis.name for axis in self.axes)

    @property
    def n_points(self) -> int:
        return math.prod(self.shape)

    @property
    def n_runs(self) -> int:
        """Integrations the grid takes: twice the points for ``continuation: both``."""
        both = any(axis.continuation == "both" for axis in self.axes)
        return self.n_points * (2 if both else 1)

    def grid_parameters(self) -> dict[str, np.ndarray]:
        """Every parameter as a float64 array of shape ``self.shape`` (writable, C-contiguous).

        Axis k's values vary along dimension k; fixed parameters are constant arrays. An x0 or v0
        axis is a dimension of every array but not a parameter: it is not in the result.
        """
        from vrsweep.config.grid import Grid

        grid = Grid.from_config(self)
        flat = np.arange(grid.n_points, dtype=np.int64).reshape(grid.shape)
        if len(grid.directions) == 2:  # the direction axis repeats the grid: one copy is enough
            flat = flat[..., 0]
        table = grid.parameters_at(self, flat.reshape(-1))
        return {name: table[name].reshape(self.shape) for name in self.parameter_names}

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The model's parameters: the paper's nine, or a written model's in declared order."""
        return getattr(self.model, "parameter_names", PARAMETER_NAMES)

    @property
    def written(self) -> bool:
        """Whether the model is written in the config (not one of the paper's)."""
        return not isinstance(self.model, str)

    def output_path(self, override=None) -> Path:
        """Where results go: ``override`` (the -o option) beats the config's ``output``, which beats
        the config file's name with ``.h5``.

        Relative paths are taken relative to the current directory, like any command-line path --
        never relative to the config file -- and the default file is written in the current
        directory too (``vrsweep run configs/fig1.yaml`` writes ``./fig1.h5``). A config read from
        a string (no file name) defaults to ``vrsweep.h5``. The config's ``~`` or ``~user`` at the
        start of ``output`` is that home folder, as in a shell.
        """
        if override is not None:
            return Path(override)
        if self.output is not None:
            # No shell reads a config: "~/results/x.h5" made a folder named "~" in the current
            # directory (where `rm -r ~` is one slip away) and wrote the results there, and
            # "$SCRATCH/x.h5" a folder named "$SCRATCH". Expanded here, where the path is used,
            # not when the config is read: a stored config is read again on other machines.
            if re.match(r"~(?:[/\\]|$)", self.output) and os.environ.get("HOME") == "":
                # expanduser reads an empty HOME as the home folder "": "~/x.h5" was "/x.h5", the
                # results written at the file system's root
                raise self._output_error("starts with ~, the home folder, but HOME is empty: set HOME, "
                                         "or give the path with -o")
            expanded = os.path.expanduser(self.output)
            if expanded.startswith("~"):
                # "~nosuchuser/x.h5" (a typo, or a user of another machine: the stored config is
                # read again elsewhere) stays as written, and a folder named "~nosuchuser" was made
                # in the current directory, as "~" once was
                user = re.split(r"[/\\]", expanded, maxsplit=1)[0][1:]
                raise self._output_error(f"starts with ~{user}, the home folder of {user or 'this user'}, "
                                         f"{'who is not a user of this machine' if user else 'which is not known'}: "
                                         f"give the folder, or the path with -o")
            return Path(self._expand_variables(expanded))
        if self.source_name.startswith("<"):
            return Path("vrsweep.h5")
        return Path(Path(self.source_name).stem + ".h5")

    def _expand_variables(self, text: str) -> str:
        """``$NAME`` and ``${NAME}`` replaced by the environment's values, as a shell does after
        ``~`` (a value's own ``~`` stays); a variable that is not set is a ConfigError naming it,
        where a shell would leave the path's start empty (``/x.h5``). Any other ``$`` is kept."""
        def value(match):
            name = match.group(1) or match.group(2)
            if name not in os.environ:
                raise self._output_error(f"uses the environment variable {name}, which is not set: set it, or "
                                         f"give the path with -o")
            if not os.environ[name].strip():
                # "$SCRATCH/x.h5" with SCRATCH set but empty (an export in a job script that found
                # nothing) was "/x.h5": the results written at the file system's root
                raise self._output_error(f"uses the environment variable {name}, which is empty: set it, or "
                                         f"give the path with -o")
            return os.environ[name]

        return _VARIABLE.sub(value, text)

    def _output_error(self, problem):
        """A ConfigError at the config's output line: ``FILE:LINE: output: 'VALUE' PROBLEM``."""
        from vrsweep.errors import ConfigError

        line = next((f":{number}" for number, row in enumerate(self.source_text.splitlines(), 1)
                     if _OUTPUT_KEY.match(row)), "")
        return ConfigError([f"{self.source_name}{line}: output: {show(self.output)} {problem}"])

    def to_yaml(self) -> str:
        """Canonical YAML of this config, fully resolved (defaults filled, overrides applied).

        Canonical: fixed key order, floats as ``repr`` (exact round trip), a linear axis written as
        ``{start, stop, num}`` whenever its values are exactly ``np.linspace`` of those (however
        the user wrote it), so two equal configs give the same text. Stored in results files.
        """
        from vrsweep.config.dump import dump_config

        return dump_config(self)


# --------------------------------------------------------------------------------------------
# The pydantic schema, generated from the tables above
# --------------------------------------------------------------------------------------------


def _check_range(domain: Domain):
    def check(value):
        if not domain.contains(value):
            raise PydanticCustomError("out_of_range", "{message}", {"message": domain.range_message(value)})
        return value
    return check


def integral_float_to_int(value):
    # YAML 1.2 reads 2e7 as a float; a count written that way is still meant as a count.
    if isinstance(value, float) and value.is_integer() and abs(value) <= COUNT_MAX:
        return int(value)
    return value


def _integral_count(domain: Domain):
    def convert(value):
        value = integral_float_to_int(value)
        # 1e23 is a whole number, only too large: its range says so, "must be an integer" would not
        if isinstance(value, float) and value.is_integer():
            raise PydanticCustomError("out_of_range", "{message}", {"message": domain.range_message(value)})
        return value
    return convert


def _number_type(domain: Domain):
    if domain.integer:
        return Annotated[int, BeforeValidator(_integral_count(domain)), AfterValidator(_check_range(domain))]
    return Annotated[float, AfterValidator(_check_range(domain))]


def _check_path(value: str) -> str:
    if not value.strip():
        raise PydanticCustomError("bad_path", "must be a file path, got an empty string")
    if "\0" in value:
        raise PydanticCustomError("bad_path", "must be a file path, got a string containing a NUL character")
    if any("\ud800" <= char <= "\udfff" for char in value):
        raise PydanticCustomError("bad_path", "must be a file path, got a string with an unpaired surrogate")
    ending = folder_ending(value)
    if ending:  # a folder: Path() drops the slash (and a '/.') and a file of its name was written
        folder = value[:-1] if value.endswith(".") else value
        raise PydanticCustomError("bad_path", "{message}", {"message": (
            f"must name a file, got {show(value)}, which ends in {ending} (a folder): give the file's name, "
            f"e.g. {folder}{'results.h5' if folder.strip('/') else ''}")})
    return value


# strict: "1.5" stays a string and fails as a number; ints are still accepted for floats.
_STRICT = ConfigDict(strict=True, extra="forbid", allow_inf_nan=False)


def _section_model(name, domains, defaults):
    fields = {key: (_number_type(domain), defaults[key]) for key, domain in domains.items()}
    return create_model(name, __config__=_STRICT, **fields)


_ParametersModel = _section_model("Parameters", PARAMETER_DOMAINS, DEFAULT_PARAMETERS)
_InitialModel = _section_model("Initial", INITIAL_DOMAINS, INITIAL_DEFAULTS)
_IntegrationModel = create_model(
    "Integration", __base__=_section_model("NumericIntegration", INTEGRATION_DOMAINS, INTEGRATION_DEFAULTS),
    method=(Literal[METHODS], INTEGRATION_DEFAULTS["method"]),
    lyapunov=(bool, INTEGRATION_DEFAULTS["lyapunov"]),
    device=(Literal[DEVICES], INTEGRATION_DEFAULTS["device"]))


def _check_range_pair(value):
    if not value[0] < value[1]:
        raise PydanticCustomError("bad_range", "must be [low, high] with low < high, got {value}",
                                  {"value": show(list(value))})
    return value


_ContinuationModel = create_model(
    "Continuation", __base__=_section_model("NumericContinuation", CONTINUATION_DOMAINS, CONTINUATION_DEFAULTS),
    parameter=(Literal[PARAMETER_NAMES], ...),
    start=(float, Field(alias="from")),
    switch=(bool, False),
    to=(Annotated[list[float], Field(min_length=2, max_length=2), AfterValidator(_check_range_pair)], ...))


class Document(BaseModel):
    model_config = _STRICT

    model: Literal[MODELS] = "original"
    parameters: _ParametersModel = Field(default_factory=_ParametersModel)
    initial: _InitialModel = Field(default_factory=_InitialModel)
    sweep: dict[str, Any] = Field(default_factory=dict)  # each axis validated by the models below
    integration: _IntegrationModel = Field(default_factory=_IntegrationModel)
    output: Annotated[str, AfterValidator(_check_path)] | None = None
    continuation: _ContinuationModel | None = None


@functools.lru_cache(maxsize=64)
def written_document(parameters: tuple[tuple[str, float], ...], domains: tuple[tuple[str, Domain], ...] = ()):
    """Document for a written model (config/models.py checks its ``model`` mapping): its parameters
    are the model's own, with the model's defaults, and any value within the model's declared
    ranges (``domains``: name -> Domain; the model's rules are checked at the grid's points); the
    continuation may follow any of them."""
    declared = dict(domains)
    fields = {name: (_number_type(declared.get(name, ANY)), default) for name, default in parameters}
    parameters_model = create_model("WrittenParameters", __config__=_STRICT, **fields)
    continuation_model = create_model(
        "WrittenContinuation", __base__=_ContinuationModel,
        parameter=(Literal[tuple(name for name, _ in parameters)] if parameters else str, ...))
    return create_model(
        "WrittenDocument", __base__=Document,
        model=(Any, None),
        parameters=(parameters_model, Field(default_factory=parameters_model)),
        continuation=(continuation_model | None, None))


_Continuation = Literal[CONTINUATIONS] | None


class LinearAxis(BaseModel):
    model_config = _STRICT

    start: float
    stop: float
    num: _number_type(NUM_DOMAIN)
    continuation: _Continuation = None


class ValuesAxis(BaseModel):
    model_config = _STRICT

    values: Annotated[list[float], Field(min_length=1)]
    continuation: _Continuation = None


class ListAxis(BaseModel):  # a bare list, wrapped so that it is validated like the others
    model_config = _STRICT

    values: Annotated[list[float], Field(min_length=1)]


# What a key can be, for "(allowed: ...)" and "did you mean" (and "did you mean parameters.g?"
# when a key sits in the wrong section).
ALLOWED_KEYS = {
    (): SECTIONS,
    ("parameters",): PARAMETER_NAMES,
    ("initial",): tuple(INITIAL_DEFAULTS),
    ("integration",): tuple(INTEGRATION_DEFAULTS),
    ("continuation",): CONTINUATION_KEYS,
}
KEY_HOME = {
    **{name: f"parameters.{name}" for name in PARAMETER_NAMES},
    **{key: f"integration.{key}" for key in INTEGRATION_DEFAULTS},
    "x": "initial.x", "v": "initial.v", "x0": "initial.x", "v0": "initial.v",
    **{key: key for key in SECTIONS},
}

AXIS_FORMS = "{start, stop, num}, a list of values, or {values: [...]}; optional continuation: up|down|both"
