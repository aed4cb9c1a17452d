"""Where a model is defined: the one test of a point's parameter values that a config's
validation, a branch (analysis/continuation.py) and a curve (analysis/curves.py) all apply.

For the paper's models the domains are the table config/schema.PARAMETER_DOMAINS (e in (0, 1],
c, omega and Omega > 0), which the config's schema validates ``parameters`` and sweep axes with;
for a model written in the config they are its declared ``ranges`` and its rules at a point
(config/models.check_written_model: a positive period, restitutions in [0, 1], barriers that do
not overlap...). A continuation
steps wherever the parameter goes, so it asks this module at every point: outside, the branch or
curve stops (status ``domain_edge``), and a start outside is refused.
"""

from __future__ import annotations

import math

from vrsweep.config.models import check_written_model, range_domain
from vrsweep.config.schema import PARAMETER_DOMAIN_REASONS, PARAMETER_DOMAINS
from vrsweep.config.wording import dotted
from vrsweep.numerics.written import WrittenModel


def outside_domain(model, values: dict) -> str | None:
    """Why the parameter values ``values`` (name -> number; those of the model's parameters that
    are given) lie outside the model's domain, in one line naming the parameter or the model's
    field (``e must be in (0, 1], got 1.2 (eq2.2: ...)``); None inside."""
    if isinstance(model, WrittenModel):
        for name, low, high in model.ranges:
            if name in values:
                value = float(values[name])
                domain = range_domain(low, high)
                if math.isnan(value) or not domain.contains(value):
                    return f"{name} {domain.range_message(value)} (the model's declared range, model.ranges.{name})"
        if set(model.parameter_names) - set(values):
            return None  # the rules read every parameter: checked where all are known
        problems = []
        check_written_model(lambda path, message, **_: problems.append(f"{dotted(path)} {message}"), model,
                            {name: float(values[name]) for name in model.parameter_names}, {}, {"x": None}, {})
        return problems[0] if problems else None
    for name, value in values.items():
        domain = PARAMETER_DOMAINS.get(name)
        if domain is None:
            continue
        value = float(value)
        if math.isnan(value) or not domain.contains(value):
            reason = PARAMETER_DOMAIN_REASONS.get(name)
            return f"{name} {domain.range_message(value)}" + (f" ({reason})" if reason else "")
    return None


def domain_test(model, parameters: dict):
    """``inside(changed) -> None or a reason``: outside_domain of ``parameters`` with the values
    ``changed`` (name -> number) put in; what a branch or a curve checks each point with."""
    base = dict(parameters)

    def test(changed):
        return outside_domain(model, {**base, **changed})

    return test
