"""vrsweep continue CONFIG.yaml [-o OUT.h5] [--start results.h5 --at g=23]: periodic orbits followed;
vrsweep continue BRANCH.h5 --point K --along NAME [--to LOW HIGH] [-o CURVES.h5]: a bifurcation
point of a branch followed in a second parameter (a bifurcation curve)."""

import dataclasses

import click

from vrsweep.commands.options import (
    OUTPUT_FLAGS, FiniteFloatRange, PathText, WholeNumberRange, config_argument, flag_wording, output_option, overwrite_option, set_option,
)
from vrsweep.errors import clip, one_line
from vrsweep.numbertext import read_float


def _parse_at(values):
    at = {}
    for text in values:
        name, sep, value = text.partition("=")
        name = name.strip()
        try:
            number = read_float(value)  # the one rule of numbers as text: not "١٢", nan or 1e400
        except ValueError:  # NumberTextError is one
            # as text: store/reading.axis_index says what is wrong with it (nan: "not a finite
            # number", "١٢": digits other than 0-9) or reads up/down for the direction
            number = value.strip()
            if not number:
                sep = ""
        if not sep or not name:
            raise click.BadParameter(f"expected AXIS=VALUE, e.g. g=23, got {clip(text)!r}", param_hint="--at")
        if name in at:  # the later value was taken silently
            raise click.BadParameter(f"{name} is named twice: one value per axis", param_hint="--at")
        at[name] = number
    return at


@click.command("continue")
@config_argument
@set_option
@output_option
@click.option("--start", "start_path", type=PathText(dir_okay=False), default=None,
              help="A sweep file: the first orbit is looked for from the final state of its point --at.")
@click.option("--at", "at", multiple=True, metavar="AXIS=VALUE",
              help="The grid point of --start (nearest value per axis), e.g. --at g=23; repeatable.")
@click.option("--switch", is_flag=True,
              help="Also follow the branch of 2p periods born at each period doubling, and the second "
                   "branch through each branch point (as continuation.switch: true).")
@click.option("--point", "point", type=WholeNumberRange(), multiple=True, metavar="K",
              help="With a branch file: the bifurcation (its index in the file's table, counted from 0 in the "
                   "order vrsweep info lists them) to follow; repeatable: one curve each, in one file.")
@click.option("--along", "along", default=None, metavar="NAME",
              help="With a branch file: the second parameter the bifurcation point moves along, e.g. Omega in "
                   "the paper's model.")
@click.option("--to", "to", type=FiniteFloatRange(), nargs=2, default=None, metavar="LOW HIGH",
              help="The range of --along (default: the config's sweep axis of that name).")
@click.option("--within", "within", type=FiniteFloatRange(), nargs=2, default=None, metavar="LOW HIGH",
              help="The range of the branch's parameter (default: the branch's continuation.to).")
@overwrite_option
@click.option("--quiet", "-q", is_flag=True, help="No summary.")
def command(config_path, overrides, output, start_path, at, switch, point, along, to, within, overwrite, quiet):
    """Follow the periodic orbits of CONFIG.yaml's continuation section, stable and unstable.

    The first orbit is found at continuation.from by integrating the config's initial state
    (or, with --start, the final state of a sweep point) over the transient; its period p is
    detected, and the fixed point of the p-period stroboscopic map is followed both ways in
    continuation.parameter within continuation.to, with its Floquet multipliers, folds, period
    doublings, Neimark-Sacker points and grazings (docs/continuation.md). With --switch (or
    continuation.switch: true) the branch of 2p periods born at each period doubling is followed
    too, and at its own doublings while 2p <= continuation.max_period, and so is the second branch
    through each branch point (a symmetric branch's asymmetric orbits): several branches per file.

    Given a branch file instead (the output of the above), --point K --along NAME follows its
    bifurcation K (a fold, period doubling or grazing) in the second parameter NAME, both ways
    to the ends of --to and --within, into a curves file (docs/commands.md); --set
    continuation.max_step=... (or max_points, or another numeric key of the section) sets the
    curve's step and points. Branches and curves stop at the edge of the model's domain
    (domain_edge: the paper's model's e in (0, 1], c, omega, Omega > 0; a written model's own
    rules).
    """
    from vrsweep.store.branch_file import check_branch, is_branch_file
    from vrsweep.store.fileio import is_hdf5

    if is_hdf5(config_path) and not is_branch_file(config_path):
        # Not a config; a branch file whose kind cannot be read, or another HDF5 file: its reader
        # says which, in one line.
        check_branch(config_path)
    if is_branch_file(config_path):
        if switch:
            from vrsweep.errors import UsageError

            raise UsageError(f"--switch goes with a config (vrsweep continue CONFIG.yaml --switch); {config_path} "
                             "is a branch file, whose bifurcations --point K --along NAME follows")
        _curves(config_path, overrides, output, start_path or at, point, along, to, within, overwrite, quiet)
        return
    if point or along is not None or to or within:
        from vrsweep.errors import UsageError

        raise UsageError("--point, --along, --to and --within go with a branch file (the output of vrsweep "
                         f"continue CONFIG.yaml), and {config_path} is not one")
    from vrsweep.config import load_config
    from vrsweep.errors import UsageError
    from vrsweep.execution import continuation as execution
    from vrsweep.store.branch_file import branch_arrays, write_branch

    if bool(start_path) != bool(at):
        raise UsageError("--start and --at go together: --start SWEEP.h5 --at g=23")
    at = _parse_at(at)
    config = load_config(config_path, overrides)
    if switch and config.continuation is not None:  # the stored config says what was run
        config = dataclasses.replace(config, continuation=dataclasses.replace(config.continuation, switch=True))
    flags = {**OUTPUT_FLAGS, "start": "--start", "at": "--at"}
    with flag_wording(flags):
        execution.problem_of(config)  # refuse a bad request before integrating anything
        # --start's point read (and a bad --at refused) before the compile notice: nothing compiles
        # for a request that is refused.
        start_state = execution.start_state_from_sweep(start_path, at) if start_path else None
    path = config.output_path(output)
    inputs = (config_path, start_path) if start_path else (config_path,)
    with flag_wording(flags):
        target = _prepare_output(path, overwrite, quiet, config, inputs, "an input of this continuation", "branch")
    from vrsweep.analysis.continuation import interrupted
    from vrsweep.execution.signals import GracefulStop

    # SIGINT or SIGTERM stops the continuation at its next orbit, and what it has followed is
    # written (marked incomplete); a second signal stops at once, keeping nothing.
    with GracefulStop(announce=False) as stop, flag_wording(flags):
        stop.announce_with(f"stopping at the next orbit: the branch followed so far will be written to {path}")
        missed = []
        branches, bifurcations = execution.run_continuation(config, start_state, failures=missed,
                                                            progress=lambda orbit: stop.check())
        stopped = any(interrupted(branch) for branch in branches)
        # The stored config holds the start's value of the continued parameter, not its unused default.
        section = config.continuation

        def delta(value, config=config, name=section.parameter):
            """The barrier at the orbit's own value of the continued parameter (it may move the
            barrier: Delta, or a written position such as "s*F + 0.2")."""
            return execution.barrier_of(dataclasses.replace(config, parameters={**config.parameters, name: value}))

        config = dataclasses.replace(config, parameters={**config.parameters, section.parameter: section.start})
        write_branch(target, branch_arrays(branches, bifurcations, delta), config, config.integration.method,
                     overwrite=overwrite, complete=not stopped)
    if stop.signum is not None:
        _say_interrupted(stop.signum, path, sum(len(branch.orbits) for branch in branches), stopped, "orbits",
                         "branch")
    if not quiet:
        name = config.continuation.parameter
        for number, branch in enumerate(branches):
            stable = sum(orbit.stable for orbit in branch.orbits)
            click.echo(f"branch {number}: period {branch.periods}, {len(branch.orbits)} points "
                       f"({stable} stable), {name} from {min(o.parameter for o in branch.orbits):.6g} "
                       f"to {max(o.parameter for o in branch.orbits):.6g}", err=True)
            for side, (status, reason) in (("first", branch.ends["down"]), ("last", branch.ends["up"])):
                click.echo(f"  {side} end: {status}: {reason}", err=True)
        several = len(branches) > 1
        for bifurcation in bifurcations:
            where = f"branch {bifurcation.branch}, " if several else ""
            click.echo(f"{bifurcation.kind} at {name} = {bifurcation.orbit.parameter:.8g} "
                       f"({where}R = {bifurcation.orbit.R:.6g})", err=True)
        for value, kind, reason in missed:
            born = "no branch of twice its period" if kind == "period_doubling" else "no second branch through it"
            click.echo(f"{kind.replace('_', ' ')} at {name} = {value:.8g}: {born} found ({reason})", err=True)
        click.echo(f"-> {one_line(path)}", err=True)


def _curves(path, overrides, output, start_path, point, along, to, within, overwrite, quiet):
    """continue BRANCH.h5 --point K --along NAME: the bifurcation curve (execution/curves.py)."""
    from pathlib import Path

    import numpy as np

    from vrsweep.errors import UsageError
    from vrsweep.execution import curves as execution
    from vrsweep.store.curve_file import curve_arrays, write_curves

    if not point or along is None:
        raise UsageError(f"{path} is a branch file: say which bifurcation to follow in which parameter, "
                         "e.g. --point 0 --along Omega (vrsweep info lists its bifurcations)")
    if start_path:
        raise UsageError("--start and --at go with a config, not with a branch file")
    repeated = next((index for number, index in enumerate(point) if index in point[:number]), None)
    if repeated is not None:  # it followed the same curve twice, into one file, as two curves
        raise UsageError(f"--point {repeated} is given twice: each --point follows its bifurcation into a curve "
                         "of its own; give each once")
    flags = {**OUTPUT_FLAGS, "point": "--point", "along": "--along", "to": "--to", "within": "--within",
             "set": "--set", **{key: f"continuation.{key}" for key in ("initial_step", "min_step", "max_step")}}
    with flag_wording(flags):
        # --set continuation.max_step=... (or max_points, ...): the curve's own settings over the branch's.
        requests = [execution.read_request(path, index, along, to, within, overrides) for index in point]
    name = "_".join(str(index) for index in point)
    branch_path = path
    path = Path(output) if output else Path(path).with_name(Path(path).stem + f"_curve_{name}_{along}.h5")
    with flag_wording(flags):
        target = _prepare_output(path, overwrite, quiet, requests[0].config, (branch_path,),
                                 "the branch file being followed", "curves")
    from vrsweep.analysis.curves import ENDED_INTERRUPTED
    from vrsweep.execution.signals import GracefulStop

    # As for a branch: a signal stops at the next point, and the curves so far are written.
    with GracefulStop(announce=False) as stop, flag_wording(flags):
        stop.announce_with(f"stopping at the next point: the curves followed so far will be written to {path}")
        curves, specials = [], []
        stopped = False
        for request in requests:
            found, found_specials = execution.run_curve(request, progress=lambda point: stop.check())
            for special in found_specials:
                special.curve = len(curves)
            curves += found
            specials += found_specials
            stopped = any(end[0] == ENDED_INTERRUPTED for curve in found for end in curve.ends.values())
            if stopped:
                break  # the other --point requests are not followed
        write_curves(target, curve_arrays(curves, specials, request.names), request.names, request.config,
                     request.config.integration.method, overwrite=overwrite, complete=not stopped)
    if stop.signum is not None:
        _say_interrupted(stop.signum, path, sum(len(curve.points) for curve in curves), stopped, "points",
                         "curves")
    if not quiet:
        first, second = request.names
        for number, curve in enumerate(curves):
            values = np.array([p.values for p in curve.points])
            click.echo(f"curve {number}: {curve.kind.replace('_', ' ')}, period {curve.periods}, "
                       f"{len(curve.points)} points, {first} from {values[:, 0].min():.6g} to "
                       f"{values[:, 0].max():.6g}, {second} from {values[:, 1].min():.6g} to "
                       f"{values[:, 1].max():.6g}", err=True)
            for side in ("first", "last"):
                status, reason = curve.ends[side]
                click.echo(f"  {side} end: {status}: {reason}", err=True)
        for special in specials:
            click.echo(f"{special.kind} at {first} = {special.values[0]:.8g}, {second} = {special.values[1]:.8g} "
                       f"(curve {special.curve})", err=True)
        click.echo(f"-> {one_line(path)}", err=True)


# As issue 35 measured it: the first continue, with an empty cache, was silent for up to 3 minutes.
COMPILE_DURATION = "up to 3 minutes"


def _say_interrupted(signum, path, count, stopped, what, whole):
    """The one line after a signal, and the exit code of the signal (128 + its number)."""
    import signal
    import sys

    name = signal.Signals(signum).name
    if stopped:
        click.echo(f"Interrupted ({name}): the {count} {what} followed so far are in {one_line(path)}, marked incomplete "
                   f"(info and plot read it); run vrsweep continue again for the whole {whole}", err=True)
    else:
        click.echo(f"Interrupted ({name}) as the continuation finished: {one_line(path)} is complete", err=True)
    sys.exit(128 + signum)


def _prepare_output(path, overwrite, quiet, config, inputs, inputs_are, kind):
    """The path to write (fileio's one rule, as run, merge and plot: a link followed to its target;
    a folder, a device or a pipe refused; an existing file only with --overwrite; an input never),
    its folder made, and (unless quiet) the notice that the first run compiles the kernels: before
    any work, for branches and curves alike."""
    from pathlib import Path

    from vrsweep.store.fileio import output_target, prepare_output_directory

    target = Path(output_target(path, overwrite=overwrite, inputs=inputs, inputs_are=inputs_are, kind=kind))
    prepare_output_directory(target)
    if not quiet:
        from vrsweep.commands.options import say_if_compiling

        say_if_compiling(lambda: _kernels_cached(config), "the numba kernels of continuation", COMPILE_DURATION,
                         "them")
    return target


def _kernels_cached(config) -> bool:
    """Whether the kernels a continuation integrates with are cached: the one-point integrator (the
    start's transient) and the one with each period's tangent map (every orbit after)."""
    from vrsweep.numerics.models import kernels_for
    from vrsweep.numerics.numba_cache import is_compiled

    kernels, method = kernels_for(config.model), config.integration.method
    return is_compiled(kernels.integrator(method)) and is_compiled(kernels.monodromy(method))
