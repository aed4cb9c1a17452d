"""Rules that tie fields together: Delta above the initial x (or every x0), strobe_periods at most
measure_periods, one continuation axis. Each rule runs only when the fields it reads are valid on
their own, and a broken rule is reported at the field the user is likeliest to have got wrong
(``blame``).

Methods of one validation run (vrsweep.config.validate._Validator), kept here by what they check.
"""

from __future__ import annotations

import math

import numpy as np

from vrsweep.config.schema import (
    INITIAL_DEFAULTS, INITIAL_DOMAINS, INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS, PARAMETER_DOMAINS,
    integral_float_to_int,
)
from vrsweep.config.domains import outside_domain
from vrsweep.config.wording import show
from vrsweep.config.models import check_written_model
from vrsweep.numerics.written import WrittenModel
from vrsweep.numerics.model import DEFAULT_PARAMETERS


class CrossFieldRules:
    """Rules across fields: mixed into the validation run, which provides ``report`` and ``overridden``."""

    def check_across_fields(self, data, axes):
        """Rules that tie fields together; each runs when the fields it reads are valid."""
        parameters = _section(data, "parameters")
        initial = _section(data, "initial")
        integration = _section(data, "integration")

        sweep = data.get("sweep") if isinstance(data.get("sweep"), dict) else {}
        x = _valid(initial, "x", INITIAL_DEFAULTS, INITIAL_DOMAINS)
        v = _valid(initial, "v", INITIAL_DEFAULTS, INITIAL_DOMAINS)
        if isinstance(self.model, WrittenModel):
            self.check_written_rules(parameters, initial, sweep, axes, x, v, _run_length(integration))
        elif "x0" in sweep:
            if "x0" in axes:
                self.check_x0_axis(axes["x0"][0], axes["Delta"][0] if "Delta" in axes else None,
                                   None if "Delta" in sweep else
                                   _valid(parameters, "Delta", DEFAULT_PARAMETERS, PARAMETER_DOMAINS))
                self.check_start_on_barrier(float(np.max(axes["x0"][0])), sweep, axes, parameters, initial, v)
        elif x is not None:
            if "Delta" in sweep:
                if "Delta" in axes:
                    self.check_delta_axis(axes["Delta"], sweep["Delta"], x)
            else:
                delta = _valid(parameters, "Delta", DEFAULT_PARAMETERS, PARAMETER_DOMAINS)
                if delta is not None and not delta >= x:
                    if self.blame(("parameters", "Delta"), ("initial", "x"), "Delta" in parameters, "x" in initial):
                        self.report(("parameters", "Delta"),
                                    f"must be at or above initial.x = {show(x)} (the mass starts below or on the "
                                    f"barrier), got {show(delta)}")
                    else:
                        self.report(("initial", "x"),
                                    f"must be at or below parameters.Delta = {show(delta)} (the mass starts below "
                                    f"or on the barrier), got {show(x)}")
                    x = None
            if x is not None:
                self.check_start_on_barrier(x, sweep, axes, parameters, initial, v)

        strobe = _valid(integration, "strobe_periods", INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
        measure = _valid(integration, "measure_periods", INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
        if strobe is not None and measure is not None and strobe > measure:
            if self.blame(("integration", "strobe_periods"), ("integration", "measure_periods"),
                          "strobe_periods" in integration, "measure_periods" in integration):
                self.report(("integration", "strobe_periods"),
                            f"must be <= integration.measure_periods = {measure}, got {strobe}")
            else:
                # strobe_periods unset: name its default, which the user never wrote (measure_periods: 10
                # was refused as below "integration.strobe_periods = 16" with no strobe_periods in sight)
                default = "" if "strobe_periods" in integration else \
                    f" (its default; set integration.strobe_periods <= {measure} for a shorter window)"
                self.report(("integration", "measure_periods"),
                            f"must be >= integration.strobe_periods = {strobe}{default}, got {measure}")

        self.check_periods_can_finish(integration, measure)

        self.check_continuation_start(parameters, _section(data, "continuation"))

        with_continuation = [name for name, (_, continuation, _) in axes.items() if continuation]
        for name in with_continuation[1:]:
            self.report(("sweep", name, "continuation"),
                        f"only one axis may have continuation, and sweep.{with_continuation[0]} has it")

    def check_periods_can_finish(self, integration, measure):
        """Slow periods no point can integrate: each period takes at least one step (its last one
        lands on the period's end), or one scan of the force on a stuck mass, and a point stops
        after max_steps of either (kernel._integrate), so past 2 * max_steps periods every point ends
        max_steps. transient_periods: 2^63 - 1 was valid, estimated at 1.4e10 days, and ran (with
        --allow-large) to max_steps at every point."""
        transient = _valid(integration, "transient_periods", INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
        max_steps = _valid(integration, "max_steps", INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
        if transient is None or measure is None or max_steps is None or transient + measure <= 2 * max_steps:
            return
        key = "transient_periods" if transient >= measure else "measure_periods"
        if self.blame(("integration", "max_steps"), ("integration", key),
                      "max_steps" in integration and key not in integration, key in integration):
            key = "max_steps"
        self.report(("integration", key),
                    f"{transient} transient + {measure} measured slow periods cannot be integrated within "
                    f"max_steps = {max_steps}: each period takes at least one step (or one scan of a stuck "
                    f"mass), and a point stops after max_steps of either, so every point would end max_steps; "
                    f"lower the periods, or raise integration.max_steps to at least {-(-(transient + measure) // 2)}")

    def check_written_rules(self, parameters, initial, sweep, axes, x, v, run=None):
        """A written model's rules at the grid's points (config/models.check_written_model), once
        every value they read is valid on its own."""
        fixed = {}
        for name in self.parameter_names:
            value = _valid(parameters, name, self.parameter_defaults, self.parameter_domains)
            if value is None and name not in axes:
                return  # reported at the parameter itself
            fixed[name] = value
        if any(name in sweep and name not in axes for name in self.parameter_names + ("x0", "v0")):
            return  # a broken axis is reported on its own
        swept = {name: values for name, (values, _, _) in axes.items() if name in self.parameter_names}
        swept_initial = {name: axes[name][0] for name in ("x0", "v0") if name in axes}
        check_written_model(self.report, self.model, fixed, swept, {"x": x, "v": v}, swept_initial,
                            initial_given="x" in initial, velocity_given="v" in initial, run=run)

    def check_continuation_start(self, parameters, section):
        """continuation.from inside the model's domain (config/domains.py, the rule every point of
        a branch keeps): a start at e = 1.2, c = -0.04 or Omega = -4 was continued without a word."""
        name, start = section.get("parameter"), section.get("from")
        if name not in self.parameter_names or isinstance(start, bool) or not isinstance(start, (int, float)) \
                or not math.isfinite(start):
            return  # reported at the key itself
        values = {name: float(start)}
        for other in self.parameter_names:
            if other != name:
                value = _valid(parameters, other, self.parameter_defaults, self.parameter_domains)
                if value is None:
                    return  # reported at the parameter itself
                values[other] = float(value)
        reason = outside_domain(self.model, values)
        if reason is not None:
            self.report(("continuation", "from"), f"lies outside the model's domain: {reason}")

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
            if not lowest >= highest:
                self.report(("sweep", "x0"), f"every x0 must be at or below every swept Delta (the mass starts "
                                             f"below or on the barrier), got x0 up to {show(highest)} and Delta "
                                             f"from {show(lowest)}")
        elif delta is not None and not delta >= highest:
            self.report(("sweep", "x0"), f"every x0 must be at or below parameters.Delta = {show(delta)} (the "
                                         f"mass starts below or on the barrier), got {show(highest)}")

    def check_start_on_barrier(self, x, sweep, axes, parameters, initial, v):
        """A start on the barrier (x = Delta) rests or moves away from it: the state after a rebound
        or a release. Moving into it (v > 0) is the instant before an impact, which has no after."""
        if "Delta" in sweep:
            if "Delta" not in axes:
                return  # reported at the axis
            on = bool(np.any(np.asarray(axes["Delta"][0], dtype=np.float64) == x))
        else:
            delta = _valid(parameters, "Delta", DEFAULT_PARAMETERS, PARAMETER_DOMAINS)
            on = delta is not None and delta == x
        velocities = axes["v0"][0] if "v0" in axes else (None if "v0" in sweep else v)
        if not on or velocities is None:
            return
        into = float(np.max(velocities))
        if into > 0.0 and "v0" not in axes and "v" not in initial:
            self.report(("sweep", "x0") if "x0" in axes else ("initial", "x"),
                        f"must be below parameters.Delta = {show(x)}, or on it only at rest or moving away: the "
                        f"config gives no initial.v, and the default {show(into)} moves into the barrier (the "
                        f"instant before an impact, not a state), got {show(x)}")
        elif into > 0.0:
            field = "sweep.v0" if "v0" in axes else "initial.v"
            self.report(("sweep", "v0") if "v0" in axes else ("initial", "v"),
                        f"must be <= 0 where the mass starts on the barrier (x = Delta = {show(x)}): a velocity "
                        f"into the barrier is the instant before an impact, not a state; give the velocity after "
                        f"it, got {field} = {show(into)}")

    def check_delta_axis(self, axis, spec, x):
        values, _, kind = axis
        if kind == "linear":
            if not values[0] >= x:  # start is the lowest value
                self.report(("sweep", "Delta", "start"),
                            f"must be at or above initial.x = {show(x)} (the mass starts below or on the "
                            f"barrier), got {show(float(values[0]))}")
            return
        item_path = ("sweep", "Delta") if kind == "list" else ("sweep", "Delta", "values")
        for index, value in enumerate(values):
            if not value >= x:
                self.report(item_path + (index,),
                            f"must be at or above initial.x = {show(x)} (the mass starts below or on the "
                            f"barrier), got {show(float(value))}")


def _section(data, name) -> dict:
    value = data.get(name)
    return value if isinstance(value, dict) else {}


def _run_length(integration):
    """(periods integrated, max_steps) where both are valid on their own, else None."""
    counts = [_valid(integration, key, INTEGRATION_DEFAULTS, INTEGRATION_DOMAINS)
              for key in ("transient_periods", "measure_periods", "max_steps")]
    if None in counts:
        return None
    return counts[0] + counts[1], counts[2]


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
