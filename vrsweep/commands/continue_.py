"""vrsweep continue CONFIG.yaml [-o OUT.h5] [--start results.h5 --at g=23]: periodic orbits followed."""

import dataclasses

import click

from vrsweep.commands.options import (
    OUTPUT_FLAGS, config_argument, flag_wording, output_option, overwrite_option, set_option,
)


def _parse_at(values):
    at = {}
    for text in values:
        name, sep, value = text.partition("=")
        try:
            at[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name.strip():
            raise click.BadParameter(f"expected AXIS=VALUE, e.g. g=23, got {text!r}", param_hint="--at")
    return at


@click.command("continue")
@config_argument
@set_option
@output_option
@click.option("--start", "start_path", type=click.Path(dir_okay=False), default=None,
              help="A sweep file: the first orbit is looked for from the final state of its point --at.")
@click.option("--at", "at", multiple=True, metavar="AXIS=VALUE",
              help="The grid point of --start (nearest value per axis), e.g. --at g=23; repeatable.")
@overwrite_option
@click.option("--quiet", "-q", is_flag=True, help="No summary.")
def command(config_path, overrides, output, start_path, at, overwrite, quiet):
    """Follow the periodic orbits of CONFIG.yaml's continuation section, stable and unstable.

    The first orbit is found at continuation.from by integrating the config's initial state
    (or, with --start, the final state of a sweep point) over the transient; its period p is
    detected, and the fixed point of the p-period stroboscopic map is followed both ways in
    continuation.parameter within continuation.to, with its Floquet multipliers, folds, period
    doublings, Neimark-Sacker points and grazings (docs/continuation.md).
    """
    from vrsweep.config import load_config
    from vrsweep.errors import UsageError
    from vrsweep.execution import continuation as execution
    from vrsweep.store.branch_file import branch_arrays, write_branch
    from vrsweep.store.fileio import prepare_output_directory

    if bool(start_path) != bool(at):
        raise UsageError("--start and --at go together: --start SWEEP.h5 --at g=23")
    at = _parse_at(at)
    config = load_config(config_path, overrides)
    flags = {**OUTPUT_FLAGS, "start": "--start", "at": "--at"}
    with flag_wording(flags):
        execution.problem_of(config)  # refuse a bad request before integrating anything
    path = config.output_path(output)
    if path.exists() and not overwrite:
        raise UsageError(f"output {path} already exists: pass --overwrite to replace it")
    prepare_output_directory(path)
    if not quiet:
        from vrsweep.commands.options import say_cache_notice

        say_cache_notice()
    with flag_wording(flags):
        start_state = execution.start_state_from_sweep(start_path, at) if start_path else None
        branches, bifurcations = execution.run_continuation(config, start_state)
        delta = config.parameters["Delta"]
        # The stored config holds the start's value of the continued parameter, not its unused default.
        section = config.continuation
        config = dataclasses.replace(config, parameters={**config.parameters, section.parameter: section.start})
        write_branch(path, branch_arrays(branches, bifurcations, delta), config, config.integration.method,
                     overwrite=overwrite)
    if not quiet:
        name = config.continuation.parameter
        for number, branch in enumerate(branches):
            stable = sum(orbit.stable for orbit in branch.orbits)
            click.echo(f"branch {number}: period {branch.periods}, {len(branch.orbits)} points "
                       f"({stable} stable), {name} from {min(o.parameter for o in branch.orbits):.6g} "
                       f"to {max(o.parameter for o in branch.orbits):.6g}", err=True)
            for side, (status, reason) in (("first", branch.ends["down"]), ("last", branch.ends["up"])):
                click.echo(f"  {side} end: {status}: {reason}", err=True)
        for bifurcation in bifurcations:
            click.echo(f"{bifurcation.kind} at {name} = {bifurcation.orbit.parameter:.8g} "
                       f"(R = {bifurcation.orbit.R:.6g})", err=True)
        click.echo(f"-> {path}", err=True)
