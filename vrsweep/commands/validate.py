"""``vrsweep validate CONFIG.yaml``: check a config and say what running it would mean.

Prints the model, the axes, the grid size, the continuation (a config's continuation section,
checked as ``vrsweep continue`` checks it), the output path and an estimate of the output size and
run time (for a config with a continuation and no sweep, what ``continue`` will do: no sweep
estimate), without compiling or running anything (numba is imported only to check a continuation
section's model rule, and compiles nothing). Exit 0 for a valid
config, 2 with every problem listed for an invalid one.
"""

import click

from vrsweep.commands.options import announce_fixed_axes, config_argument, set_option, threads_option
from vrsweep.config import INTEGRATION_DEFAULTS, load_config
from vrsweep.errors import ConfigError, one_line
from vrsweep.execution.estimate import (beyond_int64_problem, compiles_first, estimate, format_bytes, format_duration,
                                        memory_problem, size_problem)
from vrsweep.execution.threads import available_threads


@click.command("validate")
@config_argument
@set_option
@threads_option
def command(config_path, overrides, threads):
    """Check CONFIG.yaml (and any --set) and print the grid size and a time estimate.

    Nothing is compiled or run. Exit 0 if the config is valid, 2 otherwise, with every problem
    listed as FILE:LINE: field.path: message.
    """
    config = load_config(config_path, overrides)  # ConfigError -> every problem, exit 2 (cli.py)
    if config.continuation is not None:
        _check_continuation(config)
    announce_fixed_axes(config_path, overrides, config)
    threads = threads or available_threads()  # not capped: the run may be planned for another machine
    for problem in (beyond_int64_problem(config), memory_problem(config, threads)):
        if problem is not None:  # no machine-independent way to run it: refused as run refuses it
            raise ConfigError([problem], source=config.source_name)
    guess = estimate(config, threads)

    click.echo(f"{one_line(config.source_name)}: valid")
    click.echo(f"model:       {config.model}")
    if config.written:
        model = config.model
        click.echo(f"equation:    x'' = {model.acceleration}")
        for index, barrier in enumerate(model.barriers):
            keeps = "x <=" if barrier.side == "above" else "x >="
            click.echo(f"{'barriers:' if index == 0 else '':<12} {barrier.side} at {barrier.position} ({keeps} it), "
                       f"restitution {barrier.restitution}")
        if not model.barriers:
            click.echo("barriers:    none")
        click.echo(f"period:      T = {model.period}; R = |Q| / |{model.response_scale}|, Q at frequency "
                   f"{model.response_frequency}")
    # The continued parameter is not fixed for `continue` (continuation.from starts it), but a sweep
    # in the same config (`run`) holds it at its value in parameters: shown then.
    continued = [config.continuation.parameter] if config.continuation and not config.axes else []
    moving = {*config.axis_names, *continued}
    fixed = [f"{name}={config.parameters[name]:g}" for name in config.parameter_names if name not in moving]
    click.echo(f"fixed:       {' '.join(fixed)}")
    initial = [f"{key}=swept ({axis})" if axis in config.axis_names else f"{key}={config.initial[key]:g}"
               for axis, key in (("x0", "x"), ("v0", "v"))]
    click.echo(f"initial:     {' '.join(initial)}")
    # A config with a continuation and no sweep is one for `continue`: a one-point sweep's grid,
    # estimate and memory described a run nobody asked for (`run` would integrate the continued
    # parameter at its `parameters` value, not along the branch).
    continues_only = config.continuation is not None and not config.axes
    if config.axes:
        for index, axis in enumerate(config.axes):
            label = "axes:" if index == 0 else ""
            click.echo(f"{label:<12} {axis.name}: {_describe_axis(axis)}")
    elif continues_only:
        name = config.continuation.parameter
        click.echo(f"sweep:       none: this config is for `vrsweep continue` (`vrsweep run` would integrate one "
                   f"point, at {name}={config.parameters[name]:g} from parameters)")
    else:
        click.echo("axes:        none (a single point)")
    if not continues_only:
        shape = f" ({' x '.join(str(n) for n in config.shape)})" if config.axes else ""
        both = " x 2 directions (continuation: both)" if config.n_runs != config.n_points else ""
        click.echo(f"grid:        {config.n_points} point{'s' if config.n_points != 1 else ''}{shape}{both}")
    integration = config.integration
    click.echo(f"integration: {integration.method}, rtol={integration.rtol:g} atol={integration.atol:g}, "
               f"{integration.transient_periods} transient + {integration.measure_periods} measured "
               f"{'periods T' if config.written else 'slow periods'}{_other_settings(integration)}")
    if config.continuation is not None:
        click.echo(f"continuation: {_describe_continuation(config.continuation)}")
    click.echo(f"output:      {one_line(config.output_path())}")
    if continues_only:
        click.echo(f"estimate:    {_continuation_cost()}")
        return
    duration = format_duration(guess.seconds)
    click.echo(f"estimate:    {format_bytes(guess.output_bytes)}, {'' if duration.startswith('<') else 'about '}{duration} "
               f"on {threads} thread{'s' if threads != 1 else ''} (rough: from per-period cost constants)"
               f"{_compiling(config)}")
    click.echo(f"memory:      {format_bytes(guess.memory_bytes)} of per-period records held at once")
    problem = size_problem(config, threads, allow="--allow-large")
    if problem is not None:
        # A valid config, just a big one: `run` will ask for --allow-large.
        click.echo(f"warning:     {problem}")


def _compiling(config) -> str:
    """What a first run adds to the estimate: its kernel's compilation (30 s where the estimate
    said 0.1 s for a written model's first run)."""
    from vrsweep.execution.api import COMPILE_SECONDS, GPU_COMPILE_SECONDS
    from vrsweep.numerics.numba_cache import enabled

    first = compiles_first(config)
    if first is None:
        return f", after compiling the CUDA kernel where it is not cached ({GPU_COMPILE_SECONDS})"
    if not first:
        return ""
    return (f", after compiling the numba kernel ({COMPILE_SECONDS}, "
            f"{'once: it is not in the cache yet' if enabled() else 'on every run: not cached'})")


def _check_continuation(config):
    """The continuation section refused as ``vrsweep continue`` refuses it (before integrating):
    a config that validates is one that continue starts on."""
    from vrsweep.errors import UsageError
    from vrsweep.execution.continuation import check_section

    try:
        check_section(config)
    except UsageError as error:
        raise ConfigError([f"{config.source_name}: {error}"], source=config.source_name) from None


def _describe_continuation(section) -> str:
    """``g from 23 within [21, 27]; steps 0.05 (1e-05 to 0.5), at most 400 points, periods up to 16``."""
    text = (f"{section.parameter} from {section.start:g} within [{section.low:g}, {section.high:g}]; "
            f"steps {section.initial_step:g} ({section.min_step:g} to {section.max_step:g}), at most "
            f"{section.max_points} points, periods up to {section.max_period}")
    return text + ("; the branches of 2p periods too (switch)" if section.switch else "")


def _continuation_cost() -> str:
    """What is known of a continuation's cost before it runs: its size is bounded by max_points
    (the continuation line), its time is the branch's (how many Newton corrections, at which
    periods), which no per-period constant predicts."""
    from vrsweep.commands.continue_ import COMPILE_DURATION

    return ("none for a continuation: its time depends on the branch (a Newton solve on the period map per "
            f"orbit); the first continue on a machine compiles its kernels first ({COMPILE_DURATION}, once)")


# Always on the integration line, whatever their values; every other setting is named when it
# differs from its default (INTEGRATION_DEFAULTS), so that the line shows all that was changed.
ALWAYS_SHOWN = ("method", "rtol", "atol", "transient_periods", "measure_periods")


def _other_settings(integration) -> str:
    """``; strobe_periods=32 lyapunov=true`` for the settings off their defaults, '' if none is."""
    changed = []
    for key, default in INTEGRATION_DEFAULTS.items():
        value = getattr(integration, key)
        if key in ALWAYS_SHOWN or value == default:
            continue
        if isinstance(value, bool):
            changed.append(f"{key}={'true' if value else 'false'}")
        elif isinstance(value, str):  # device
            changed.append(f"{key}={value}")
        elif isinstance(value, int):  # a count as given: max_steps=123456789 was shown as 1.23457e+08
            changed.append(f"{key}={value}")
        else:
            changed.append(f"{key}={value:g}")
    return f"; {' '.join(changed)}" if changed else ""


def _describe_axis(axis) -> str:
    values = axis.values
    n = len(values)
    if n == 1:
        text = f"1 value, {values[0]:g}"
    elif n <= 6:
        text = f"{n} values: {', '.join(f'{value:g}' for value in values)}"
    else:
        text = f"{n} values from {values[0]:g} to {values[-1]:g}"
    if axis.continuation:
        text += f", continuation {axis.continuation}"
    return text
