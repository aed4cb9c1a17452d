"""One validation run: YAML text (+ ``--set`` overrides) -> :class:`Config`, or a ConfigError listing
every problem found, each with its file, line and field (vrsweep.config.report words them).

How: ruamel.yaml's round-trip loader reads the text (YAML 1.2, so ``1e-9`` is a float, and every
key and item keeps its line in ``.lc``); the data is copied to plain Python, overrides are applied,
pydantic (strict: no ``"abc"`` -> float, ints accepted for floats) checks types, unknown keys and
ranges, and a few cross-field rules (Delta above the initial x, strobe_periods <= measure_periods,
sweep values in their parameter's range) are checked by hand. Each pydantic error location is
mapped back to a line through the ruamel tree.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
from pydantic import ValidationError
from ruamel.yaml.constructor import DuplicateKeyError
from ruamel.yaml.error import YAMLError

from vrsweep.config.report import Report, without_missing_typos
from vrsweep.config.schema import (
    AXIS_FORMS, KEY_HOME, SECTIONS, AXIS_DOMAINS, AXIS_NAMES, INITIAL_DEFAULTS, INITIAL_DOMAINS,
    INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS, PARAMETER_DOMAINS, Axis, Config, Integration, Document,
    integral_float_to_int, LinearAxis, ListAxis, ValuesAxis,
)
from vrsweep.config.wording import did_you_mean, show_number, show
from vrsweep.config.yaml import CyclicAlias, error_line, parse_scalar, plain_data, load_round_trip
from vrsweep.errors import ConfigError
from vrsweep.model import DEFAULT_PARAMETERS, INITIAL_STATE_AXES, INITIAL_STATE_KEYS, PARAMETER_NAMES


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


def same_config(stored_text: str, config: Config) -> bool:
    """Whether ``stored_text`` (a config as a result file stores it, written by this version or an
    earlier one) describes the same run as ``config``: compared parsed, not as text, so that a
    change in how the text is written never makes an old checkpoint refuse to resume."""
    try:
        stored = parse_config(stored_text, "<the stored config>")
    except ConfigError:
        return False
    return stored == config


class _Validator(Report):
    """One validation run: reads the YAML, applies overrides, collects problems, builds the Config."""

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
                home = KEY_HOME.get(name)  # e.g. x -> initial.x
                hint = f" (did you mean {home}?)" if home in targets else did_you_mean(name, list(targets))
                self.report_raw(self.setting_order(setting), f"--set {setting}: unknown name {name!r}{hint} (allowed: {allowed})")
                continue
            try:
                value = parse_scalar(value_text)
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
            return Document.model_validate(data)
        except ValidationError as error:
            for item in error.errors(include_url=False):
                if item["loc"][:1] == ("sweep",) and item["type"] == "dict_type":
                    self.report(("sweep",), f"must be a mapping of parameter name -> values, got "
                                            f"{show(item['input'])}", allowed=AXIS_FORMS)
                else:
                    self.report_pydantic(item, ())
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
                self.report(path, f"not a parameter{did_you_mean(name, AXIS_NAMES)}",
                            allowed=", ".join(AXIS_NAMES))
                continue
            if isinstance(spec, list):
                model, data, kind = ListAxis, {"values": spec}, "list"
            elif isinstance(spec, dict):
                model, data, kind = ((ValuesAxis, spec, "values") if "values" in spec
                                     else (LinearAxis, spec, "linear"))
            else:
                self.report(path, f"must be {{start, stop, num}}, a list or {{values: [...]}}, got "
                                  f"{show(spec)} (to fix {name} at one value, set {_home(name)})",
                            allowed=AXIS_FORMS)
                continue
            try:
                axis = model.model_validate(data)
            except ValidationError as error:
                for item in without_missing_typos(error.errors(include_url=False)):
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
                self.report(path + ("stop",), f"must be >= start = {show(axis.start)}, got {show(axis.stop)}; "
                                              "use an explicit list or swap start and stop; "
                                              "continuation: down sweeps downwards")
                return None
            if axis.num == 1 and axis.start != axis.stop:
                self.report(path + ("num",), f"num = 1 needs start == stop, got start = {show(axis.start)}, "
                                             f"stop = {show(axis.stop)}; use num >= 2 or a one-element list")
                return None
            with np.errstate(all="ignore"):
                values = np.linspace(axis.start, axis.stop, axis.num, dtype=np.float64)
            if not np.all(np.isfinite(values)):  # start and stop so far apart that stop - start overflows
                self.report(path, f"{show(axis.start)} .. {show(axis.stop)} cannot be divided into "
                                  f"{axis.num} finite values")
                return None
            if axis.num > 1 and axis.stop == axis.start:  # every point the same: like a repeated value
                self.report(path + ("stop",), f"must be > start = {show(axis.start)} when num = {axis.num}, "
                                              f"got {show(axis.stop)} (the same point {axis.num} times); "
                                              f"to fix {name} at one value, set {_home(name)}")
                return None
            if not np.all(np.diff(values) > 0):  # so close together that float64 rounding repeats values
                self.report(path, f"{show(axis.start)} .. {show(axis.stop)} cannot be divided into "
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
                self.report(path + (index,), f"{show_number(value)} is listed twice (also {where}): axis values "
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
            self.report(path + (index,), f"{show_number(values[index])} after {show_number(values[index - 1])} breaks "
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
                                    f"must be above initial.x = {show(x)} (the mass starts below the barrier), "
                                    f"got {show(delta)}")
                    else:
                        self.report(("initial", "x"),
                                    f"must be below parameters.Delta = {show(delta)} (the mass starts below "
                                    f"the barrier), got {show(x)}")

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
                                             f"the barrier), got x0 up to {show(highest)} and Delta from "
                                             f"{show(lowest)}")
        elif delta is not None and not delta > highest:
            self.report(("sweep", "x0"), f"every x0 must be below parameters.Delta = {show(delta)} (the mass "
                                         f"starts below the barrier), got {show(highest)}")

    def check_delta_axis(self, axis, spec, x):
        values, _, kind = axis
        if kind == "linear":
            if not values[0] > x:  # start is the lowest value
                self.report(("sweep", "Delta", "start"),
                            f"must be above initial.x = {show(x)} (the mass starts below the barrier), "
                            f"got {show(float(values[0]))}")
            return
        item_path = ("sweep", "Delta") if kind == "list" else ("sweep", "Delta", "values")
        for index, value in enumerate(values):
            if not value > x:
                self.report(item_path + (index,),
                            f"must be above initial.x = {show(x)} (the mass starts below the barrier), "
                            f"got {show(float(value))}")


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
        value = integral_float_to_int(value)
        good_type = isinstance(value, int)
    else:
        try:
            good_type = isinstance(value, (int, float)) and math.isfinite(float(value))
        except OverflowError:  # an int too large for a float
            good_type = False
    return value if good_type and domain.contains(value) else None
