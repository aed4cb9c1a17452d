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

How: ruamel.yaml's round-trip loader reads the text (YAML 1.2, so ``1e-9`` is a float, and every
key and item keeps its line in ``.lc``); the data is copied to plain Python, overrides are applied,
pydantic (strict: no ``"abc"`` -> float, ints accepted for floats) checks types, unknown keys and
ranges, and a few cross-field rules (Delta above the initial x, strobe_periods <= measure_periods,
sweep values in their parameter's range) are checked by hand. Each pydantic error location is
mapped back to a line through the ruamel tree.
"""

from __future__ import annotations

import dataclasses
import datetime
import difflib
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, create_model,
)
from pydantic_core import PydanticCustomError
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq, TaggedScalar
from ruamel.yaml.constructor import DuplicateKeyError
from ruamel.yaml.error import MarkedYAMLError, YAMLError
from ruamel.yaml.nodes import MappingNode, SequenceNode
from ruamel.yaml.reader import ReaderError

from vrsweep.errors import ConfigError
from vrsweep.model import (
    DEFAULT_PARAMETERS, INITIAL_STATE_AXES, INITIAL_STATE_KEYS, MODELS, PARAMETER_NAMES,
)

__all__ = [
    "Axis", "Integration", "Config", "load_config", "parse_config", "with_overrides",
    "Domain", "PARAMETER_DOMAINS", "INITIAL_DEFAULTS", "INTEGRATION_DEFAULTS", "INTEGRATION_DOMAINS",
    "CONTINUATIONS", "MAX_AXIS_POINTS", "METHODS",
]


# --------------------------------------------------------------------------------------------
# Allowed values, as data: the pydantic schema, the error messages and the docs all read these.
# --------------------------------------------------------------------------------------------

_INT64_MAX = 2**63 - 1  # the kernel counts in int64; a larger count would overflow silently


@dataclass(frozen=True)
class Domain:
    """An interval of allowed values, open or closed at either end; ``integer`` for counts."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = True
    high_open: bool = True
    integer: bool = False

    def describe(self) -> str:
        """The interval in words, e.g. ``(0, 1]``, ``> 0``, ``an integer >= 1``."""
        low, high = _number(self.low), _number(self.high)
        has_low, has_high = self.low > -math.inf, self.high < math.inf and self.high != _INT64_MAX
        if has_low and has_high:
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
        allowed = self.describe().replace("an integer ", "").replace("a number ", "")
        if self.integer:
            allowed = "an integer " + allowed
        return f"must be {allowed}, got {_show(value)}"


_ANY = Domain()
_POSITIVE = Domain(low=0.0)
_COUNT = Domain(low=1, low_open=False, high=_INT64_MAX, high_open=False, integer=True)

PARAMETER_DOMAINS = {
    "gamma": _ANY, "alpha": _ANY, "omega0": _ANY,
    "c": _POSITIVE,  # R = |Q|/c (eq3.3) is a gain: undefined without a drive; -c is c half a period on
    "omega": _POSITIVE,                                  # the slow period 2 pi/omega sets the time unit
    "Delta": _ANY,                                       # must lie above initial.x: checked across fields
    "e": Domain(low=0.0, high=1.0, high_open=False),     # eq2.2: 0 < e <= 1
    "g": _ANY,
    "Omega": _POSITIVE,
}

INITIAL_DEFAULTS = {"x": 0.99, "v": 0.5}  # the paper's Fig. 6 caption
INITIAL_DOMAINS = {"x": _ANY, "v": _ANY}
# What a sweep axis may be named: a parameter, or x0 / v0 (the initial state, basins of attraction).
AXIS_NAMES = PARAMETER_NAMES + INITIAL_STATE_AXES
AXIS_DOMAINS = {**PARAMETER_DOMAINS, **{axis: INITIAL_DOMAINS[key] for axis, key in INITIAL_STATE_KEYS.items()}}

# The integration methods (kernel.INTEGRATORS): rk45 is Dormand-Prince 5(4), dop853 Hairer's 8(5,3).
METHODS = ("rk45", "dop853")

INTEGRATION_DEFAULTS = {
    "method": "rk45", "rtol": 1e-9, "atol": 1e-11, "transient_periods": 100, "measure_periods": 100,
    "max_steps": 20_000_000, "max_impacts_per_period": 100_000, "divergence_bound": 1.0e6,
    "stick_velocity": 1.0e-7, "strobe_periods": 16, "max_period": 8, "period_tolerance": 1.0e-6,
    "lyapunov": False,
}
INTEGRATION_DOMAINS = {
    "rtol": Domain(low=0.0, high=1.0),
    "atol": _POSITIVE,
    "transient_periods": Domain(low=0, low_open=False, high=_INT64_MAX, high_open=False, integer=True),
    "measure_periods": _COUNT,
    "max_steps": _COUNT,
    "max_impacts_per_period": _COUNT,
    "divergence_bound": _POSITIVE,
    "stick_velocity": _POSITIVE,
    "strobe_periods": _COUNT,       # must also be <= measure_periods: checked across fields
    "max_period": _COUNT,
    "period_tolerance": _POSITIVE,
}

CONTINUATIONS = ("up", "down", "both")

# One axis is materialised as an array when the config is read, so its length must stay sane;
# the size of the whole grid is judged later by vrsweep.estimate with the run's thread count.
MAX_AXIS_POINTS = 10_000_000
_NUM = Domain(low=1, low_open=False, high=MAX_AXIS_POINTS, high_open=False, integer=True)

_SECTIONS = ("model", "parameters", "initial", "sweep", "integration", "output")
_LINEAR_KEYS = ("start", "stop", "num", "continuation")
_VALUES_KEYS = ("values", "continuation")


# --------------------------------------------------------------------------------------------
# The public result
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


@dataclass(frozen=True)
class Config:
    """A validated config with every default filled in and every override applied.

    Equality compares content only (not the file name, text or overrides it came from), so
    ``parse_config(c.to_yaml()) == c``. ``parameters`` holds all nine parameters; a swept one keeps
    its fixed value there, which the sweep ignores (so does ``initial`` for a swept x0 or v0).
    """

    model: str
    parameters: dict[str, float]
    initial: dict[str, float]
    axes: tuple[Axis, ...]
    integration: Integration
    output: str | None = None
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
        shape = self.shape
        grid = {name: np.full(shape, self.parameters[name], dtype=np.float64) for name in PARAMETER_NAMES}
        for k, axis in enumerate(self.axes):
            if axis.name not in grid:
                continue
            along_k = [1] * len(shape)
            along_k[k] = len(axis.values)
            grid[axis.name] = np.array(np.broadcast_to(axis.values.reshape(along_k), shape), dtype=np.float64)
        return grid

    def output_path(self, override=None) -> Path:
        """Where results go: ``override`` (the -o option) beats the config's ``output``, which beats
        the config file's name with ``.h5``.

        Relative paths are taken relative to the current directory, like any command-line path --
        never relative to the config file -- and the default file is written in the current
        directory too (``vrsweep run configs/fig1.yaml`` writes ``./fig1.h5``). A config read from
        a string (no file name) defaults to ``vrsweep.h5``.
        """
        if override is not None:
            return Path(override)
        if self.output is not None:
            return Path(self.output)
        if self.source_name.startswith("<"):
            return Path("vrsweep.h5")
        return Path(Path(self.source_name).stem + ".h5")

    def to_yaml(self) -> str:
        """Canonical YAML of this config, fully resolved (defaults filled, overrides applied).

        Canonical: fixed key order, floats as ``repr`` (exact round trip), a linear axis written as
        ``{start, stop, num}`` whenever its values are exactly ``np.linspace`` of those (however
        the user wrote it), so two equal configs give the same text. Stored in results files.
        """
        swept = set(self.axis_names)
        lines = ["# vrsweep config, fully resolved: every default filled in, every --set applied.",
                 f"model: {self.model}", "parameters:"]
        for name in PARAMETER_NAMES:
            note = f"  # swept: see sweep.{name}" if name in swept else ""
            lines.append(f"  {name}: {_yaml_float(self.parameters[name])}{note}")
        lines.append("initial:")
        for axis, key in INITIAL_STATE_KEYS.items():
            note = f"  # swept: see sweep.{axis}" if axis in swept else ""
            lines.append(f"  {key}: {_yaml_float(self.initial[key])}{note}")
        lines.append("sweep:" if self.axes else "sweep: {}")
        lines += [f"  {axis.name}: {_yaml_axis(axis)}" for axis in self.axes]
        lines.append("integration:")
        for key, value in dataclasses.asdict(self.integration).items():
            if key == "method":
                # Written only when not the default: files written before the key existed store
                # the same text for the same run, so they still resume (the check compares text).
                if value != INTEGRATION_DEFAULTS["method"]:
                    lines.append(f"  method: {value}")
                continue
            if key == "lyapunov":  # the same: only when on
                if value:
                    lines.append("  lyapunov: true")
                continue
            lines.append(f"  {key}: {value if isinstance(value, int) else _yaml_float(value)}")
        lines.append(f"output: {'null' if self.output is None else _yaml_string(self.output)}")
        return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# Entry points
# --------------------------------------------------------------------------------------------


def load_config(path, overrides=()) -> Config:
    """Read and validate the config file at ``path``; messages name the file as given."""
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError([f"{name}: no such config file"], source=name) from None
    except IsADirectoryError:
        raise ConfigError([f"{name}: is a directory, not a config file"], source=name) from None
    except UnicodeDecodeError as error:
        raise ConfigError([f"{name}: not a text (UTF-8) file: {error.reason} at byte {error.start}"],
                          source=name) from None
    except OSError as error:
        raise ConfigError([f"{name}: cannot read: {error.strerror or error}"], source=name) from None
    return parse_config(text, source_name=name, overrides=overrides)


def parse_config(text: str, source_name: str = "<string>", overrides=()) -> Config:
    """Validate config ``text``; raise ConfigError listing every problem found."""
    return _Validator(text, source_name, tuple(overrides)).run()


def with_overrides(config: Config, overrides) -> Config:
    """``config`` with more ``NAME=VALUE`` overrides applied on top of it.

    Works from ``config.to_yaml()`` (so a Config changed with dataclasses.replace keeps its
    changes); that text is valid, so any problem is one of the new overrides and says so.
    """
    overrides = tuple(overrides)
    changed = parse_config(config.to_yaml(), f"{config.source_name} (resolved)", overrides)
    return dataclasses.replace(changed, source_name=config.source_name, source_text=config.source_text,
                               overrides=config.overrides + overrides)


# --------------------------------------------------------------------------------------------
# The pydantic schema, generated from the tables above
# --------------------------------------------------------------------------------------------


def _check_range(domain: Domain):
    def check(value):
        if not domain.contains(value):
            raise PydanticCustomError("out_of_range", "{message}", {"message": domain.range_message(value)})
        return value
    return check


def _integral_float_to_int(value):
    # YAML 1.2 reads 2e7 as a float; a count written that way is still meant as a count.
    if isinstance(value, float) and value.is_integer() and abs(value) <= _INT64_MAX:
        return int(value)
    return value


def _number_type(domain: Domain):
    if domain.integer:
        return Annotated[int, BeforeValidator(_integral_float_to_int), AfterValidator(_check_range(domain))]
    return Annotated[float, AfterValidator(_check_range(domain))]


def _check_path(value: str) -> str:
    if not value.strip():
        raise PydanticCustomError("bad_path", "must be a file path, got an empty string")
    if "\0" in value:
        raise PydanticCustomError("bad_path", "must be a file path, got a string containing a NUL character")
    if any("\ud800" <= char <= "\udfff" for char in value):
        raise PydanticCustomError("bad_path", "must be a file path, got a string with an unpaired surrogate")
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
    lyapunov=(bool, INTEGRATION_DEFAULTS["lyapunov"]))


class _Document(BaseModel):
    model_config = _STRICT

    model: Literal[MODELS] = "original"
    parameters: _ParametersModel = Field(default_factory=_ParametersModel)
    initial: _InitialModel = Field(default_factory=_InitialModel)
    sweep: dict[str, Any] = Field(default_factory=dict)  # each axis validated by the models below
    integration: _IntegrationModel = Field(default_factory=_IntegrationModel)
    output: Annotated[str, AfterValidator(_check_path)] | None = None


_Continuation = Literal[CONTINUATIONS] | None


class _LinearAxis(BaseModel):
    model_config = _STRICT

    start: float
    stop: float
    num: _number_type(_NUM)
    continuation: _Continuation = None


class _ValuesAxis(BaseModel):
    model_config = _STRICT

    values: Annotated[list[float], Field(min_length=1)]
    continuation: _Continuation = None


class _ListAxis(BaseModel):  # a bare list, wrapped so that it is validated like the others
    model_config = _STRICT

    values: Annotated[list[float], Field(min_length=1)]


# What a key can be, for "(allowed: ...)" and "did you mean" (and "did you mean parameters.g?"
# when a key sits in the wrong section).
_ALLOWED_KEYS = {
    (): _SECTIONS,
    ("parameters",): PARAMETER_NAMES,
    ("initial",): tuple(INITIAL_DEFAULTS),
    ("integration",): tuple(INTEGRATION_DEFAULTS),
}
_KEY_HOME = {
    **{name: f"parameters.{name}" for name in PARAMETER_NAMES},
    **{key: f"integration.{key}" for key in INTEGRATION_DEFAULTS},
    "x": "initial.x", "v": "initial.v", "x0": "initial.x", "v0": "initial.v",
    **{key: key for key in _SECTIONS},
}

_AXIS_FORMS = "{start, stop, num}, a list of values, or {values: [...]}; optional continuation: up|down|both"


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------


class _Validator:
    """One validation run: reads the YAML, applies overrides, collects problems, builds the Config."""

    def __init__(self, text, source_name, overrides):
        self.text = text if isinstance(text, str) else str(text)
        self.source = source_name
        self.overrides = overrides
        self.root = None          # the ruamel tree (CommentedMap ...), for line numbers
        self.overridden = {}      # path tuple -> the "--set NAME=VALUE" that set it
        self.problems = []        # (order key, text)

    # -- reporting ---------------------------------------------------------------------------

    def report(self, path, message, allowed=None):
        """Record one problem at ``path`` (a tuple of keys and list indices)."""
        path = tuple(path)
        text = f"{_dotted(path)}: {message}" if path else message
        if allowed:
            text += f" (allowed: {allowed})"
        for length in range(len(path), 0, -1):
            setting = self.overridden.get(path[:length])
            if setting is not None:
                self.problems.append((self.setting_order(setting), f"--set {setting}: {text}"))
                return
        line = self.line_of(path)
        self.problems.append(((0, line, ""), f"{self.source}:{line}: {text}"))

    def setting_order(self, setting):
        """Problems with --set options come after the file's, in the order the options were given."""
        return (1, self.overrides.index(setting) if setting in self.overrides else 0, "")

    def report_raw(self, order, text):
        self.problems.append((order, text))

    def line_of(self, path) -> int:
        """1-based line of the deepest node of ``path`` present in the YAML (1 if none is)."""
        node, line = self.root, 1
        for key in path:
            try:
                if isinstance(node, CommentedMap):
                    real_key = next(k for k in node if _key(k) == key)
                    line = node.lc.key(real_key)[0] + 1
                    node = node[real_key]
                elif isinstance(node, CommentedSeq) and isinstance(key, int) and 0 <= key < len(node):
                    line = node.lc.item(key)[0] + 1
                    node = node[key]
                else:
                    break
            except (StopIteration, KeyError, TypeError, AttributeError, IndexError):
                break  # e.g. a key brought in by a YAML merge (<<) has no line of its own here
        return line

    def fail_if_problems(self):
        if self.problems:
            ordered = [text for _, text in sorted(self.problems, key=lambda item: item[0])]
            raise ConfigError(ordered, source=self.source)

    # -- the run -----------------------------------------------------------------------------

    def run(self) -> Config:
        settings = self.parse_overrides()
        data = self.read_yaml()
        if data is None:
            self.fail_if_problems()  # YAML syntax error: nothing more can be checked
        data = self.apply_overrides(data, settings)
        document = self.validate_document(data)
        axes = self.validate_sweep(data.get("sweep"))
        self.check_across_fields(data, axes)
        self.fail_if_problems()
        return Config(
            model=document.model,
            parameters={name: float(getattr(document.parameters, name)) for name in PARAMETER_NAMES},
            initial={key: float(getattr(document.initial, key)) for key in INITIAL_DEFAULTS},
            axes=tuple(Axis(name, values, continuation) for name, (values, continuation, _) in axes.items()),
            integration=Integration(**document.integration.model_dump()),
            output=document.output,
            source_name=self.source,
            source_text=self.text,
            overrides=self.overrides,
        )

    # -- YAML --------------------------------------------------------------------------------

    def read_yaml(self):
        """The document as plain dicts/lists/scalars ({} if empty), or None after a syntax error."""
        try:
            try:
                self.root = self.load(allow_duplicate_keys=False)
            except DuplicateKeyError:
                # ruamel stops at the first duplicate; find them all, then read on for the rest.
                self.report_duplicates()
                self.root = self.load(allow_duplicate_keys=True)
        except YAMLError as error:
            self.report_raw((0, _error_line(error, self.text), ""), self.yaml_error_text(error))
            return None
        except RecursionError:
            self.report_raw((0, 1, ""), f"{self.source}:1: YAML nested too deeply to read")
            return None
        except Exception as error:  # noqa: BLE001 -- ruamel raises e.g. ValueError for "!!float abc"
            self.report_raw((0, 1, ""), f"{self.source}: cannot read YAML: {error}")
            return None
        if self.root is None:
            return {}
        try:
            data = _plain(self.root)
        except _CyclicAlias:
            self.report_raw((0, 1, ""), f"{self.source}:1: the YAML refers to itself through an alias")
            return None
        except RecursionError:
            self.report_raw((0, 1, ""), f"{self.source}:1: YAML nested too deeply to read")
            return None
        if not isinstance(data, dict):
            self.report((), f"the config must be a mapping of sections, got {_show(data)}",
                        allowed=", ".join(_SECTIONS))
            return None
        return data

    def load(self, allow_duplicate_keys):
        yaml = YAML(typ="rt")
        yaml.allow_duplicate_keys = allow_duplicate_keys
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # e.g. ReusedAnchorWarning: not the user's concern here
            return yaml.load(self.text)

    def report_duplicates(self):
        """Report every key given twice in one mapping, with both lines."""
        node = YAML(typ="rt").compose(self.text)
        seen_nodes = set()

        def walk(node, path):
            if id(node) in seen_nodes:
                return
            seen_nodes.add(id(node))
            if isinstance(node, MappingNode):
                lines = {}  # key -> lines it appears on, in order
                for key_node, value_node in node.value:
                    key = getattr(key_node, "value", None)
                    if isinstance(key, str) and key != "<<":
                        lines.setdefault(key, []).append(key_node.start_mark.line + 1)
                        walk(value_node, path + (key,))
                for key, where in lines.items():
                    if len(where) > 1:
                        times = "twice" if len(where) == 2 else f"{len(where)} times"
                        if path == ("sweep",):
                            what, hint = "parameter", "; sweep each parameter on one axis only"
                        else:
                            what, hint = "key", ""
                        self.report_raw((0, where[1], ""), f"{self.source}:{where[1]}: {_dotted(path + (key,))}: "
                                                           f"{what} given {times} (lines {_and(where)}){hint}")
            elif isinstance(node, SequenceNode):
                for index, item in enumerate(node.value):
                    walk(item, path + (index,))

        walk(node, ())

    def yaml_error_text(self, error) -> str:
        """``FILE:LINE:COLUMN: YAML syntax error: <the parser's problem>``."""
        if isinstance(error, ReaderError):
            line, column = _position(self.text, error.position)
            character = error.character
            if isinstance(character, int):
                character = f"#x{character:04x}"
            return (f"{self.source}:{line}:{column}: YAML syntax error: "
                    f"unacceptable character {character}: {error.reason}")
        if isinstance(error, MarkedYAMLError):
            mark = error.problem_mark or error.context_mark
            problem = error.problem or error.context or "invalid YAML"
            where = f"{self.source}:{mark.line + 1}:{mark.column + 1}" if mark else self.source
            text = f"{where}: YAML syntax error: {problem}"
            if error.context and error.problem and error.context_mark:
                text += f" ({error.context} started on line {error.context_mark.line + 1})"
            return text
        return f"{self.source}: YAML syntax error: {error}"

    # -- overrides ---------------------------------------------------------------------------

    def parse_overrides(self):
        """[(path, value, "NAME=VALUE")] for the good overrides; bad ones are reported."""
        targets = _override_targets()
        settings = []
        for setting in self.overrides:
            setting = str(setting)
            name, sep, value_text = setting.partition("=")
            name = name.strip()
            allowed = "a parameter, an integration key, initial.x (or x0), initial.v (or v0) or model"
            if not sep or not name:
                self.report_raw(self.setting_order(setting), f"--set {setting}: expected NAME=VALUE, e.g. --set g=5")
                continue
            if name not in targets:
                home = _KEY_HOME.get(name)  # e.g. x -> initial.x
                hint = f" (did you mean {home}?)" if home in targets else _did_you_mean(name, list(targets))
                self.report_raw(self.setting_order(setting), f"--set {setting}: unknown name {name!r}{hint} (allowed: {allowed})")
                continue
            try:
                value = _parse_scalar(value_text)
            except ValueError as error:
                self.report_raw(self.setting_order(setting), f"--set {setting}: {error}")
                continue
            settings.append((targets[name], value, setting))
        return settings

    def apply_overrides(self, data, settings):
        data = dict(data)
        for path, value, setting in settings:
            if len(path) == 1:
                data[path[0]] = value
            else:
                section, key = path
                if data.get(section) is None:
                    data[section] = {}
                if not isinstance(data[section], dict):
                    continue  # the section itself is reported as not being a mapping
                data[section] = {**data[section], key: value}
                sweep = data.get("sweep")
                axis = {"x": "x0", "v": "v0"}.get(key) if section == "initial" else key
                if section in ("parameters", "initial") and isinstance(sweep, dict) and axis in sweep:
                    # Fixing a swept parameter removes its axis: `simulate fig1.yaml --set g=5`;
                    # so does fixing a swept initial state: `--set x0=0.5` (or initial.x=0.5).
                    data["sweep"] = {name: spec for name, spec in sweep.items() if name != axis}
            self.overridden[path] = setting
        return data

    # -- sections ----------------------------------------------------------------------------

    def validate_document(self, data):
        """Validate every section but the sweep's axes; returns the model, or None on problems."""
        # An empty section ("parameters:" with nothing under it) reads as null: treat it as {}.
        data = {key: ({} if value is None and key in ("parameters", "initial", "sweep", "integration")
                      else value) for key, value in data.items()}
        try:
            return _Document.model_validate(data)
        except ValidationError as error:
            for item in error.errors(include_url=False):
                if item["loc"][:1] == ("sweep",) and item["type"] == "dict_type":
                    self.report(("sweep",), f"must be a mapping of parameter name -> values, got "
                                            f"{_show(item['input'])}", allowed=_AXIS_FORMS)
                else:
                    self.report_pydantic(item, ())
            return None

    def report_pydantic(self, item, prefix):
        """Turn one pydantic error into a problem in this module's words."""
        path = prefix + tuple(item["loc"])
        kind, value = item["type"], item.get("input")
        if kind == "extra_forbidden":
            key = path[-1]
            parent = path[:-1]
            allowed = self.allowed_keys(parent)
            self.report(path, f"unknown key{self.key_hint(key, parent, allowed)}", allowed=", ".join(allowed))
        elif kind == "missing":
            self.report(path, "missing", allowed=_AXIS_FORMS if path[:1] == ("sweep",) else None)
        elif kind in ("out_of_range", "bad_path"):
            self.report(path, item["msg"])
        elif kind == "literal_error":
            choices = {("model",): MODELS, ("method",): METHODS}.get(path[-1:], CONTINUATIONS)
            hint = _did_you_mean(value, choices) if isinstance(value, str) else ""
            self.report(path, f"must be one of {', '.join(choices)}, got {_show(value)}{hint}")
        elif kind in ("model_type", "dict_type"):
            self.report(path, f"must be a mapping, got {_show(value)}",
                        allowed=", ".join(self.allowed_keys(path)) or None)
        elif kind == "list_type":
            self.report(path, f"must be a list of numbers, got {_show(value)}")
        elif kind == "too_short":
            self.report(path, "must not be empty", allowed="a list of one or more numbers")
        elif kind == "finite_number":
            self.report(path, f"must be a finite number, got {_show(value)}", allowed=self.describe(path))
        elif kind in ("float_type", "float_parsing"):
            self.report(path, f"must be a number, got {_show(value)}", allowed=self.describe(path))
        elif kind in ("int_type", "int_parsing", "int_from_float"):
            self.report(path, f"must be an integer, got {_show(value)}", allowed=self.describe(path))
        elif kind == "string_type":
            self.report(path, f"must be a string, got {_show(value)}", allowed="a file path")
        else:  # something pydantic says that this module does not rephrase
            self.report(path, item["msg"])

    def allowed_keys(self, parent):
        if parent in _ALLOWED_KEYS:
            return _ALLOWED_KEYS[parent]
        if len(parent) == 2 and parent[0] == "sweep":
            return _LINEAR_KEYS[:3] + _VALUES_KEYS
        return ()

    def key_hint(self, key, parent, allowed):
        """`` (did you mean 'e'?)``, or where the key belongs if it is in the wrong section."""
        if len(parent) == 2 and parent[0] == "sweep":
            if key in _LINEAR_KEYS or key in _VALUES_KEYS:
                return "; use either {start, stop, num} or {values: [...]}, not both"
        home = _KEY_HOME.get(str(key))
        if home is not None and home != _dotted(parent + (key,)):
            return f" (did you mean {home}?)"
        return _did_you_mean(str(key), allowed)

    def describe(self, path) -> str | None:
        """What is allowed at ``path``, in words, for type errors."""
        if len(path) == 2:
            section, key = path
            table = {"parameters": PARAMETER_DOMAINS, "initial": INITIAL_DOMAINS,
                     "integration": INTEGRATION_DOMAINS}.get(section, {})
            if key in table and table[key] != _ANY:
                return table[key].describe()
        if path[:1] == ("sweep",):
            if path[-1:] == ("num",):
                return _NUM.describe()
        return None

    # -- sweep -------------------------------------------------------------------------------

    def validate_sweep(self, sweep):
        """{name: (values, continuation, spec_kind)} for the axes that are valid."""
        axes = {}
        if not isinstance(sweep, dict):
            return axes  # None: no sweep; anything else was reported by validate_document
        for name, spec in sweep.items():
            path = ("sweep", name)
            if name not in AXIS_NAMES:
                self.report(path, f"not a parameter{_did_you_mean(name, AXIS_NAMES)}",
                            allowed=", ".join(AXIS_NAMES))
                continue
            if isinstance(spec, list):
                model, data, kind = _ListAxis, {"values": spec}, "list"
            elif isinstance(spec, dict):
                model, data, kind = ((_ValuesAxis, spec, "values") if "values" in spec
                                     else (_LinearAxis, spec, "linear"))
            else:
                self.report(path, f"must be {{start, stop, num}}, a list or {{values: [...]}}, got "
                                  f"{_show(spec)} (to fix {name} at one value, set {_home(name)})",
                            allowed=_AXIS_FORMS)
                continue
            try:
                axis = model.model_validate(data)
            except ValidationError as error:
                for item in _without_missing_typos(error.errors(include_url=False)):
                    loc = tuple(item["loc"])
                    if kind == "list":
                        loc = loc[1:]  # the wrapper's "values" is not in the YAML
                    self.report_pydantic({**item, "loc": loc}, path)
                continue
            continuation = getattr(axis, "continuation", None)
            if continuation and name in INITIAL_STATE_AXES:
                # A continuation line starts each point from the previous one's final state, which
                # is exactly what an initial-state axis overrides: the two contradict each other.
                key = INITIAL_STATE_KEYS[name]
                self.report(path + ("continuation",),
                            f"{name} is the initial state, not a parameter: there is nothing to continue "
                            f"along it (each point starts from its own {name}); remove continuation, or "
                            f"put it on a parameter axis (each line then starts from its {name})",
                            allowed=f"continuation on a parameter axis; initial.{key} or sweep.{name} "
                                    "without continuation")
                continue
            values = self.axis_values(path, axis, kind)
            if values is not None:
                axes[name] = (values, continuation, kind)
        return axes

    def axis_values(self, path, axis, kind):
        """The axis's values after the per-axis rules, or None (reported)."""
        name = path[1]
        if kind == "linear":
            if axis.stop < axis.start:
                self.report(path + ("stop",), f"must be >= start = {_show(axis.start)}, got {_show(axis.stop)}; "
                                              "use an explicit list or swap start and stop; "
                                              "continuation: down sweeps downwards")
                return None
            if axis.num == 1 and axis.start != axis.stop:
                self.report(path + ("num",), f"num = 1 needs start == stop, got start = {_show(axis.start)}, "
                                             f"stop = {_show(axis.stop)}; use num >= 2 or a one-element list")
                return None
            with np.errstate(all="ignore"):
                values = np.linspace(axis.start, axis.stop, axis.num, dtype=np.float64)
            if not np.all(np.isfinite(values)):  # start and stop so far apart that stop - start overflows
                self.report(path, f"{_show(axis.start)} .. {_show(axis.stop)} cannot be divided into "
                                  f"{axis.num} finite values")
                return None
            if axis.num > 1 and axis.stop == axis.start:  # every point the same: like a repeated value
                self.report(path + ("stop",), f"must be > start = {_show(axis.start)} when num = {axis.num}, "
                                              f"got {_show(axis.stop)} (the same point {axis.num} times); "
                                              f"to fix {name} at one value, set {_home(name)}")
                return None
            if not np.all(np.diff(values) > 0):  # so close together that float64 rounding repeats values
                self.report(path, f"{_show(axis.start)} .. {_show(axis.stop)} cannot be divided into "
                                  f"{axis.num} distinct float64 values")
                return None
            # The domains are intervals, so the ends decide for the whole linspace.
            ok = self.check_values(name, path + ("start",), [axis.start])
            ok &= self.check_values(name, path + ("stop",), [axis.stop])
        else:
            values = np.array(axis.values, dtype=np.float64)
            item_path = path if kind == "list" else path + ("values",)
            ok = self.check_values(name, item_path, axis.values, indexed=True)
            ok = ok and self.check_monotonic(item_path, axis.values)
        if not ok:
            return None
        values.flags.writeable = False  # Axis is frozen; so are its values
        return values

    def check_monotonic(self, path, values) -> bool:
        """An explicit list must be strictly increasing or strictly decreasing.

        A repeated value would compute and store the same grid point twice (and make the axis
        useless for selecting by value); an unordered one draws a zigzag. Decreasing lists are
        allowed: the stored axis keeps the config's order.
        """
        first_index = {}
        repeated = False
        for index, value in enumerate(values):
            if value in first_index:
                first = first_index[value]
                where = f"item {first}"
                first_line, line = self.line_of(path + (first,)), self.line_of(path + (index,))
                if first_line != line:
                    where += f", line {first_line}"
                self.report(path + (index,), f"{_number(value)} is listed twice (also {where}): axis values "
                                             "must be strictly increasing or strictly decreasing")
                repeated = True
            else:
                first_index[value] = index
        if repeated:
            return False
        steps = np.sign(np.diff(values))
        breaks = np.flatnonzero(steps != steps[0]) if len(steps) else []
        if len(breaks):
            index = int(breaks[0]) + 1
            order = "increasing" if steps[0] > 0 else "decreasing"
            self.report(path + (index,), f"{_number(values[index])} after {_number(values[index - 1])} breaks "
                                         f"the order of the list ({order} up to item {index - 1}): axis values "
                                         "must be strictly increasing or strictly decreasing")
            return False
        return True

    def check_values(self, name, path, values, indexed=False) -> bool:
        """Each swept value must obey its parameter's domain."""
        domain = AXIS_DOMAINS[name]
        ok = True
        for index, value in enumerate(values):
            if not domain.contains(value):
                self.report(path + ((index,) if indexed else ()), domain.range_message(value))
                ok = False
        return ok

    # -- rules across fields -----------------------------------------------------------------

    def check_across_fields(self, data, axes):
        """Rules that tie fields together; each runs when the fields it reads are valid."""
        parameters = _section(data, "parameters")
        initial = _section(data, "initial")
        integration = _section(data, "integration")

        sweep = data.get("sweep") if isinstance(data.get("sweep"), dict) else {}
        x = _valid(initial, "x", INITIAL_DEFAULTS, INITIAL_DOMAINS)
        if "x0" in sweep:
            if "x0" in axes:
                self.check_x0_axis(axes["x0"][0], axes["Delta"][0] if "Delta" in axes else None,
                                   None if "Delta" in sweep else
                                   _valid(parameters, "Delta", DEFAULT_PARAMETERS, PARAMETER_DOMAINS))
        elif x is not None:
            if "Delta" in sweep:
                if "Delta" in axes:
                    self.check_delta_axis(axes["Delta"], sweep["Delta"], x)
            else:
                delta = _valid(parameters, "Delta", DEFAULT_PARAMETERS, PARAMETER_DOMAINS)
                if delta is not None and not delta > x:
                    if self.blame(("parameters", "Delta"), ("initial", "x"), "Delta" in parameters, "x" in initial):
                        self.report(("parameters", "Delta"),
                                    f"must be above initial.x = {_show(x)} (the mass starts below the barrier), "
                                    f"got {_show(delta)}")
                    else:
                        self.report(("initial", "x"),
                                    f"must be below parameters.Delta = {_show(delta)} (the mass starts below "
                                    f"the barrier), got {_show(x)}")

        strobe = _valid(integration, "strobe_periods", INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
        measure = _valid(integration, "measure_periods", INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
        if strobe is not None and measure is not None and strobe > measure:
            if self.blame(("integration", "strobe_periods"), ("integration", "measure_periods"),
                          "strobe_periods" in integration, "measure_periods" in integration):
                self.report(("integration", "strobe_periods"),
                            f"must be <= integration.measure_periods = {measure}, got {strobe}")
            else:
                self.report(("integration", "measure_periods"),
                            f"must be >= integration.strobe_periods = {strobe}, got {measure}")

        with_continuation = [name for name, (_, continuation, _) in axes.items() if continuation]
        for name in with_continuation[1:]:
            self.report(("sweep", name, "continuation"),
                        f"only one axis may have continuation, and sweep.{with_continuation[0]} has it")

    def blame(self, first, second, first_given, second_given) -> bool:
        """Whether a broken rule between two fields is reported at ``first`` (else at ``second``):
        at a --set one if either is, else at one written in the file, ``first`` if both are."""
        if first in self.overridden or second in self.overridden:
            return first in self.overridden
        return first_given or not second_given

    def check_x0_axis(self, x0_values, delta_values, delta):
        """Every x0 must lie below the barrier: below parameters.Delta, or below every swept Delta."""
        highest = float(np.max(x0_values))
        if delta_values is not None:
            lowest = float(np.min(delta_values))
            if not lowest > highest:
                self.report(("sweep", "x0"), f"every x0 must be below every swept Delta (the mass starts below "
                                             f"the barrier), got x0 up to {_show(highest)} and Delta from "
                                             f"{_show(lowest)}")
        elif delta is not None and not delta > highest:
            self.report(("sweep", "x0"), f"every x0 must be below parameters.Delta = {_show(delta)} (the mass "
                                         f"starts below the barrier), got {_show(highest)}")

    def check_delta_axis(self, axis, spec, x):
        values, _, kind = axis
        if kind == "linear":
            if not values[0] > x:  # start is the lowest value
                self.report(("sweep", "Delta", "start"),
                            f"must be above initial.x = {_show(x)} (the mass starts below the barrier), "
                            f"got {_show(float(values[0]))}")
            return
        item_path = ("sweep", "Delta") if kind == "list" else ("sweep", "Delta", "values")
        for index, value in enumerate(values):
            if not value > x:
                self.report(item_path + (index,),
                            f"must be above initial.x = {_show(x)} (the mass starts below the barrier), "
                            f"got {_show(float(value))}")


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


class _CyclicAlias(Exception):
    pass


def _plain(node, _active=None):
    """ruamel's tree as plain dict/list/float/int/str/bool (keys as str), keeping order."""
    active = set() if _active is None else _active
    if isinstance(node, (dict, list)):
        if id(node) in active:
            raise _CyclicAlias
        active.add(id(node))
        try:
            if isinstance(node, dict):
                return {_key(key): _plain(value, active) for key, value in node.items()}
            return [_plain(item, active) for item in node]
        finally:
            active.discard(id(node))
    if isinstance(node, bool):
        return bool(node)
    if isinstance(node, int):
        return int(node)
    if isinstance(node, float):
        return float(node)
    if isinstance(node, str):
        return _join_surrogates(str(node))
    if isinstance(node, TaggedScalar):
        return _Opaque(f"{node.tag} {node.value}")
    if isinstance(node, (datetime.date, datetime.datetime)):
        return _Opaque(node.isoformat())
    return node  # anything else is rejected as a wrong type by the schema


class _Opaque:
    """A YAML value of a kind no field accepts (a date, a !tagged scalar), shown as written."""

    def __init__(self, text):
        self.text = text

    def __repr__(self):
        return self.text


def _join_surrogates(text: str) -> str:
    """ruamel reads the escapes "\\ud83d\\ude00" as two lone surrogates; make them one character."""
    if not any("\ud800" <= char <= "\udfff" for char in text):
        return text
    try:
        return text.encode("utf-16", "surrogatepass").decode("utf-16")
    except UnicodeDecodeError:
        return text  # an unpaired surrogate: rejected where it matters (output)


def _key(key):
    return key if type(key) is str else str(key)


def _parse_scalar(text):
    """A --set VALUE read as a YAML scalar: 5 -> int, 1e-9 -> float, effective -> str."""
    if not text.strip():
        raise ValueError("missing VALUE after '='")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = _plain(YAML(typ="rt").load(text))
    except Exception as error:  # noqa: BLE001 -- any ruamel failure means "not a YAML scalar"
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ValueError(f"VALUE is not a YAML scalar ({problem})") from None
    if isinstance(value, (dict, list)) or value is None:
        raise ValueError(f"VALUE must be a single number or word, got {_show(value)}")
    return value


def _override_targets():
    """--set NAME -> path in the document; both 'g' and 'parameters.g' spellings."""
    targets = {"model": ("model",), "initial.x": ("initial", "x"), "initial.v": ("initial", "v"),
               "x0": ("initial", "x"), "v0": ("initial", "v")}  # x0, v0: the names of the sweep axes
    for name in PARAMETER_NAMES:
        targets[name] = targets[f"parameters.{name}"] = ("parameters", name)
    for key in INTEGRATION_DEFAULTS:
        targets[key] = targets[f"integration.{key}"] = ("integration", key)
    return targets


def _home(axis_name) -> str:
    """Where a sweep axis's fixed value lives: parameters.g, initial.x (for x0)."""
    key = INITIAL_STATE_KEYS.get(axis_name)
    return f"initial.{key}" if key else f"parameters.{axis_name}"


def _section(data, name) -> dict:
    value = data.get(name)
    return value if isinstance(value, dict) else {}


def _valid(section, key, defaults, domains):
    """The section's value for ``key`` (or its default) if it passes its own checks, else None."""
    value = section.get(key, defaults[key])
    domain = domains[key]
    if isinstance(value, bool):
        return None
    if domain.integer:
        value = _integral_float_to_int(value)
        good_type = isinstance(value, int)
    else:
        try:
            good_type = isinstance(value, (int, float)) and math.isfinite(float(value))
        except OverflowError:  # an int too large for a float
            good_type = False
    return value if good_type and domain.contains(value) else None


def _without_missing_typos(errors):
    """Drop "missing start" when "strat: unknown key (did you mean 'start'?)" already says it."""
    suggested = set()
    for item in errors:
        if item["type"] == "extra_forbidden":
            parent, key = tuple(item["loc"][:-1]), str(item["loc"][-1])
            for choice in _LINEAR_KEYS + _VALUES_KEYS:
                if _did_you_mean(key, [choice]):
                    suggested.add(parent + (choice,))
    return [item for item in errors if not (item["type"] == "missing" and tuple(item["loc"]) in suggested)]


def _did_you_mean(word, choices) -> str:
    """`` (did you mean 'Delta'?)`` for a near miss, case-insensitively first; else ''."""
    word = str(word)
    by_case = [choice for choice in choices if choice.lower() == word.lower()]
    close = by_case or difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _dotted(path) -> str:
    """('sweep', 'g', 'values', 3) -> 'sweep.g.values[3]'."""
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


def _show(value) -> str:
    """A value as the user wrote it, kept short."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif value is None:
        text = "null"
    else:
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _number(value) -> str:
    """0.0 -> '0', 1.0 -> '1', 1e-9 -> '1e-09' (for intervals in messages)."""
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def _and(items) -> str:
    """[2, 5, 7] -> '2, 5 and 7'."""
    items = [str(item) for item in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _position(text, index):
    """1-based (line, column) of character ``index``."""
    before = text[:index]
    return before.count("\n") + 1, index - (before.rfind("\n") + 1) + 1


def _error_line(error, text) -> int:
    mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
    if mark is not None:
        return mark.line + 1
    if isinstance(error, ReaderError):
        return _position(text, error.position)[0]
    return 1


def _yaml_float(value) -> str:
    return repr(float(value))  # repr round-trips exactly and YAML 1.2 reads 1e-09 as a float


def _yaml_string(value: str) -> str:
    """A YAML double-quoted scalar, escaping anything not printable."""
    out = []
    for char in value:
        if char in '"\\':
            out.append("\\" + char)
        elif char.isprintable():
            out.append(char)
        elif ord(char) <= 0xFF:
            out.append(f"\\x{ord(char):02x}")
        elif ord(char) <= 0xFFFF:
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(f"\\U{ord(char):08x}")
    return '"' + "".join(out) + '"'


def _yaml_axis(axis: Axis) -> str:
    values = axis.values
    n = len(values)
    if n >= 3 and values[-1] > values[0] and np.array_equal(values, np.linspace(values[0], values[-1], n)):
        text = f"start: {_yaml_float(values[0])}, stop: {_yaml_float(values[-1])}, num: {n}"
    else:
        text = "values: [" + ", ".join(_yaml_float(value) for value in values) + "]"
    if axis.continuation:
        text += f", continuation: {axis.continuation}"
    elif text.startswith("values"):
        return text[len("values: "):]
    return "{" + text + "}"
