"""One validation run: YAML text (+ ``--set`` overrides) -> :class:`Config`, or a ConfigError listing
every problem found, each with its file, line and field (vrsweep.config.report words them).

How: ruamel.yaml's round-trip loader reads the text (YAML 1.2, so ``1e-9`` is a float, and every
key and item keeps its line in ``.lc``); the data is copied to plain Python, overrides are applied,
pydantic (strict: no ``"abc"`` -> float, ints accepted for floats) checks types, unknown keys and
ranges, and a few cross-field rules (Delta above the initial x, strobe_periods <= measure_periods,
sweep values in their parameter's range) are checked by hand. Each pydantic error location is
mapped back to a line through the ruamel tree.

The run is one object, :class:`_Validator`, whose methods are kept by what they check: reading
and overrides here, each sweep axis in ``axes.py``, rules across fields in ``rules.py``, and the
wording and location of problems in ``report.py``.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

from pydantic import ValidationError
from ruamel.yaml.constructor import DuplicateKeyError
from ruamel.yaml.error import YAMLError

from vrsweep.config.axes import SweepAxes
from vrsweep.config.models import ModelSection, parameter_defaults, parameter_domains, parameter_names
from vrsweep.config.report import Report
from vrsweep.config.rules import CrossFieldRules
from vrsweep.config.schema import (
    AXIS_FORMS, CONTINUATION_DEFAULTS, INITIAL_DEFAULTS, INITIAL_DOMAINS, INTEGRATION_DEFAULTS, KEY_HOME, SECTIONS,
    ANY, Axis, Config, Continuation, Document, Integration, written_document,
)
from vrsweep.config.wording import did_you_mean, dotted, show
from vrsweep.config.yaml import (
    MAX_EXPANDED_VALUES, CyclicAlias, TooManyValues, Unrepresentable, error_line, load_round_trip, parse_scalar,
    plain_data, yaml_text,
)
from vrsweep.errors import ConfigError, one_line
from vrsweep.numerics.model import INITIAL_STATE_AXES, INITIAL_STATE_KEYS, PARAMETER_NAMES
from vrsweep.numerics.written import WrittenModel


# A config is a few kB; a sweep listing every value of a long axis some hundred kB at most.
MAX_CONFIG_BYTES = 2 ** 20


def load_config(path, overrides=(), *, override_words=None) -> Config:
    """Read and validate the config file at ``path``; messages name the file as given."""
    name = str(path)
    try:
        with open(path, "rb") as file:  # bounded: /dev/zero or a huge file is not read to its end
            raw = file.read(MAX_CONFIG_BYTES + 1)
        if len(raw) > MAX_CONFIG_BYTES:
            raise ConfigError([f"{name}: larger than {MAX_CONFIG_BYTES // 2 ** 20} MiB, not a config file"],
                              source=name)
        text = raw.decode("utf-8")
        if "\r" in text:  # as read_text's universal newlines did
            text = text.replace("\r\n", "\n").replace("\r", "\n")
    except FileNotFoundError:
        raise ConfigError([f"{name}: no such config file"], source=name) from None
    except IsADirectoryError:
        raise ConfigError([f"{name}: is a directory, not a config file"], source=name) from None
    except UnicodeDecodeError as error:
        raise ConfigError([f"{name}: not a text (UTF-8) file: {error.reason} at byte {error.start}"],
                          source=name) from None
    except OSError as error:
        raise ConfigError([f"{name}: cannot read: {error.strerror or error}"], source=name) from None
    return parse_config(text, source_name=name, overrides=overrides, override_words=override_words)


def parse_config(text: str, source_name: str = "<string>", overrides=(), *, line_numbers=True,
                 override_words=None) -> Config:
    """Validate config ``text``; raise ConfigError listing every problem found.

    ``line_numbers=False``: problems name the source and the field but no line (for text written
    out from a Python dict, whose lines the user never saw). ``override_words``: {"NAME=VALUE":
    how a problem it causes names it}, for overrides not given as ``--set`` (the default wording).
    """
    return _Validator(text, source_name, tuple(overrides), line_numbers, override_words).run()


def config_from_dict(data, source_name: str = "<dict>", overrides=(), *, override_words=None) -> Config:
    """Validate a config given as a dict nested as the YAML is (``{"sweep": {"g": [5, 10]}}``).

    The dict is written out as YAML text and validated as a file is, so every message is the one
    a file would get; problems name ``source_name`` and the field, without a line (the text's
    lines are not the user's).
    """
    if not isinstance(data, dict):
        raise ConfigError([f"{source_name}: the config must be a mapping of sections, got {show(data)}"],
                          source=source_name)
    try:
        text = yaml_text(data)
    except Unrepresentable as error:
        raise ConfigError([f"{source_name}: {dotted(error.path)}: {error}"], source=source_name) from None
    return parse_config(text, source_name, overrides, line_numbers=False, override_words=override_words)


def with_overrides(config: Config, overrides, *, override_words=None) -> Config:
    """``config`` with more ``NAME=VALUE`` overrides applied on top of it.

    Works from ``config.to_yaml()`` (so a Config changed with dataclasses.replace keeps its
    changes); that text is valid, so any problem is one of the new overrides and says so.
    """
    overrides = tuple(overrides)
    changed = parse_config(config.to_yaml(), f"{config.source_name} (resolved)", overrides,
                           override_words=override_words)
    return dataclasses.replace(changed, source_name=config.source_name, source_text=config.source_text,
                               overrides=config.overrides + overrides)


def same_config(stored_text: str, config: Config) -> bool:
    """Whether ``stored_text`` (a config as a result file stores it, written by this version or an
    earlier one) describes the same run as ``config``: compared parsed, not as text, so that a
    change in how the text is written never makes an old checkpoint refuse to resume."""
    try:
        stored = parse_config(stored_text, "<the stored config>")
    except ConfigError:
        return False
    # Where the file goes and how `continue` follows an orbit change no point of a sweep: a config
    # given an output: key, or a continuation section, after its run stopped was refused to resume
    # ("first difference at line 30: 'output: null' vs 'output: ...'"), and so was the file of
    # `vrsweep run CONFIG` resumed by vrsweep.sweep, which leaves a config's output unused.
    return dataclasses.replace(stored, output=config.output, continuation=config.continuation) == config



# What --set continuation.to takes: the pair as the config writes it, [20, 27], or bare, 20,27.
RANGE_EXPECTED = "continuation.to: expected two numbers LOW,HIGH, e.g. --set continuation.to=20,27 or '[20, 27]'"


def _range_value(text):
    """[low, high] of a --set continuation.to VALUE: "20,27" or the config's own "[20, 27]".
    Each part is a YAML scalar (the schema then says which is not a number); anything else is one
    ValueError naming the field and what it takes (a "[20, 27]" was split at its comma and read
    as the scalars "[20" and " 27]", refused as "not a YAML scalar (expected ',' or ']', but got
    '<stream end>')", up to 0.7.1)."""
    inner = text.strip()
    if inner.startswith("[") and inner.endswith("]"):
        inner = inner[1:-1]
    parts = inner.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return [parse_scalar(part) for part in parts]
    except ValueError:
        raise ValueError(f"{RANGE_EXPECTED}, got {text.strip()!r}") from None

class _Validator(Report, ModelSection, SweepAxes, CrossFieldRules):
    """One validation run: reads the YAML, applies overrides, collects problems, builds the Config."""

    # -- the run -----------------------------------------------------------------------------

    def run(self) -> Config:
        data = self.read_yaml()
        # The model decides which parameters there are: what --set may name, what the parameters
        # section and the sweep may hold. So it is read first (from --set model=..., if given).
        self.model = self.read_model(self.model_value(data))
        if self.model is None:
            self.use_model(None)
            self.fail_if_problems()  # a broken written model: its parameters are unknown
        self.use_model(self.model)
        settings = self.parse_overrides()
        if data is None:
            self.fail_if_problems()  # YAML syntax error: nothing more can be checked
        data = self.apply_overrides(data, settings)
        document = self.validate_document(data)
        axes = self.validate_sweep(data.get("sweep"))
        self.check_across_fields(data, axes)
        self.fail_if_problems()
        return Config(
            model=self.model,
            parameters={name: float(getattr(document.parameters, name)) for name in self.parameter_names},
            initial={key: float(getattr(document.initial, key)) for key in INITIAL_DEFAULTS},
            axes=tuple(Axis(name, values, continuation) for name, (values, continuation, _) in axes.items()),
            integration=Integration(**document.integration.model_dump()),
            output=document.output,
            continuation=_continuation(document.continuation),
            source_name=self.source,
            source_text=self.text,
            overrides=self.overrides,
        )

    # -- the model ---------------------------------------------------------------------------

    def model_value(self, data):
        """The config's ``model`` as given: from ``--set model=NAME`` if there is one, else the file's."""
        for setting in self.overrides:
            name, sep, value = str(setting).partition("=")
            if sep and name.strip() == "model":
                self.overridden[("model",)] = str(setting)
                try:
                    return parse_scalar(value)
                except ValueError:
                    # reported by parse_overrides ("VALUE must be a single number or word"); the
                    # file's model is not checked in its place (validate_document)
                    self.model_setting_unreadable = True
                    return value
        return data.get("model") if isinstance(data, dict) else None

    def use_model(self, model):
        """The names and domains every later check reads: the paper's, or the written model's."""
        self.parameter_names = parameter_names(model)
        self.parameter_domains = parameter_domains(model)
        self.parameter_defaults = parameter_defaults(model)
        self.axis_names = self.parameter_names + INITIAL_STATE_AXES
        self.axis_domains = {**self.parameter_domains,
                             **{axis: INITIAL_DOMAINS[key] for axis, key in INITIAL_STATE_KEYS.items()}}

    # -- YAML --------------------------------------------------------------------------------

    def read_yaml(self):
        """The document as plain dicts/lists/scalars ({} if empty), or None after a syntax error."""
        # %YAML 1.1 makes ruamel read by YAML 1.1's rules: yes, no, on and off as true and false,
        # 010 as 8, 1:30 as 90; the config meant something else than it says to a reader of
        # vrsweep's docs (YAML 1.2), and lyapunov: yes was refused without it, accepted with it.
        directive = re.search(r"^%YAML[ \t]+(\S*)", self.text, flags=re.MULTILINE)
        if directive and directive.group(1) != "1.2":
            line = self.text.count("\n", 0, directive.start()) + 1
            self.report_raw((0, line, ""), f"{self.source}:{line}: %YAML {one_line(directive.group(1))}: vrsweep "
                            "reads configs as YAML 1.2 (YAML 1.1 reads yes and on as true, 010 as 8, 1:30 as "
                            "90): remove the directive, or write %YAML 1.2")
            return None
        try:
            try:
                self.root = load_round_trip(self.text, allow_duplicate_keys=False)
            except DuplicateKeyError:
                # ruamel stops at the first duplicate; find them all, then read on for the rest.
                self.report_duplicates()
                self.root = load_round_trip(self.text, allow_duplicate_keys=True)
        except YAMLError as error:
            self.report_raw((0, error_line(error, self.text), ""), self.yaml_error_text(error))
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
            data = plain_data(self.root)
        except CyclicAlias:
            self.report_raw((0, 1, ""), f"{self.source}:1: the YAML refers to itself through an alias")
            return None
        except TooManyValues:
            self.report_raw((0, 1, ""), f"{self.source}:1: the YAML's aliases expand to more than "
                                        f"{MAX_EXPANDED_VALUES} values; a config holds a few hundred")
            return None
        except RecursionError:
            self.report_raw((0, 1, ""), f"{self.source}:1: YAML nested too deeply to read")
            return None
        if not isinstance(data, dict):
            self.report((), f"the config must be a mapping of sections, got {show(data)}",
                        allowed=", ".join(SECTIONS))
            return None
        return data

    # -- overrides ---------------------------------------------------------------------------

    def parse_overrides(self):
        """[(path, value, "NAME=VALUE")] for the good overrides; bad ones are reported."""
        targets = _override_targets(self.parameter_names)
        settings = []
        given = {}  # path -> (value, setting) of the first override that set it
        for setting in self.overrides:
            setting = str(setting)
            name, sep, value_text = setting.partition("=")
            name = name.strip()
            # the model's own parameter names: a written model's are the user's, not the paper's
            allowed = (f"a parameter ({', '.join(self.parameter_names)}), an integration key, initial.x (or x0), "
                       "initial.v (or v0), model or continuation.KEY")
            if not sep or not name:
                self.report_raw(self.setting_order(setting), f"{self.said(setting)}: expected NAME=VALUE, e.g. --set g=5")
                continue
            if name not in targets:
                home = KEY_HOME.get(name)  # e.g. x -> initial.x
                hint = f" (did you mean {home}?)" if home in targets else did_you_mean(name, list(targets))
                self.report_raw(self.setting_order(setting), f"{self.said(setting)}: unknown name {name!r}{hint} (allowed: {allowed})")
                continue
            try:
                if targets[name] == ("continuation", "to"):
                    value = _range_value(value_text)
                else:
                    value = parse_scalar(value_text)
            except ValueError as error:
                self.report_raw(self.setting_order(setting), f"{self.said(setting)}: {error}")
                continue
            path = targets[name]
            if path in given and not _same_value(given[path][0], value):
                # --set g=5 ... --set parameters.g=6 (a script's setting and its user's): which one
                # was meant cannot be told, and the later one was taken without a word.
                self.report_raw(self.setting_order(setting),
                                f"{self.said(setting)}: {dotted(path)} is already set by {self.said(given[path][1])}: "
                                f"give one value")
                continue
            given.setdefault(path, (value, setting))
            settings.append((path, value, setting))
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
        written = isinstance(self.model, WrittenModel)
        if written or getattr(self, "model_setting_unreadable", False):
            # read_model's; or a --set model=[1, 2] that was no value: the file's written model
            # was then refused under that setting's name, "must be one of original, effective"
            data = {key: value for key, value in data.items() if key != "model"}
        try:
            document = (written_document(self.model.parameters, tuple(sorted(
                (name, domain) for name, domain in self.parameter_domains.items() if domain != ANY)))
                if written else Document)
            return document.model_validate(data)
        except ValidationError as error:
            for item in error.errors(include_url=False):
                if item["loc"][:1] == ("sweep",) and item["type"] == "dict_type":
                    self.report(("sweep",), f"must be a mapping of parameter name -> values, got "
                                            f"{show(item['input'])}", allowed=AXIS_FORMS)
                else:
                    self.report_pydantic(item, ())
            return None


def _same_value(a, b) -> bool:
    """Two --set values that say the same (g=5 and parameters.g=5.0); a bool is no number here."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    return a == b


def _continuation(section):
    if section is None:
        return None
    settings = {key: getattr(section, key) for key in CONTINUATION_DEFAULTS}
    if "initial_step" not in section.model_fields_set:
        # Not written: the default first step, brought within the steps the section allows (as a
        # curve's --set continuation.max_step alone does). `max_step: 0.02` alone was refused for
        # an initial_step = 0.05 the user never wrote.
        settings["initial_step"] = min(max(settings["initial_step"], settings["min_step"]), settings["max_step"])
    return Continuation(parameter=section.parameter, start=float(section.start), low=float(section.to[0]),
                        high=float(section.to[1]), switch=section.switch, **settings)


def _override_targets(names=PARAMETER_NAMES):
    """--set NAME -> path in the document; both 'g' and 'parameters.g' spellings."""
    targets = {"model": ("model",), "initial.x": ("initial", "x"), "initial.v": ("initial", "v"),
               "x0": ("initial", "x"), "v0": ("initial", "v")}  # x0, v0: the names of the sweep axes
    for name in names:
        targets[name] = targets[f"parameters.{name}"] = ("parameters", name)
    for key in INTEGRATION_DEFAULTS:
        targets[key] = targets[f"integration.{key}"] = ("integration", key)
    # Only with their section's name: max_period is an integration key too.
    for key in ("parameter", "from", "to", "switch", *CONTINUATION_DEFAULTS):
        targets[f"continuation.{key}"] = ("continuation", key)
    return targets
