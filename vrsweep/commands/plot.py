"""vrsweep plot FILE.h5 [-o FIG.png|.pdf|.svg] [--kind ...]: a figure from a sweep or a trajectory;
vrsweep plot MAP.h5 CURVES.h5 ...: bifurcation curves over a map."""

import os
from pathlib import Path

import click

from vrsweep.commands.options import FiniteFloatRange, PathText, WholeNumberRange, file_name_only
from vrsweep.errors import one_line

FORMATS = (".png", ".pdf", ".svg")
# The library names its arguments (vrsweep.plot); messages at the command line name these flags.
FLAGS = {"at": "--at", "x_axis": "--x", "kind": "--kind", "amplitude": "--amplitude", "log": "--log",
         "linear": "--linear", "periods": "--periods", "var": "--var", "style": "--style", "size": "--size",
         "vmin": "--vmin", "vmax": "--vmax", "title": "--title", "dpi": "--dpi", "xlim": "--xlim", "ylim": "--ylim",
         "legend": "--legend", "zoom": "--zoom", "table": "--table",
         "finish": "'vrsweep run CONFIG --resume -o FILE'", "simulate_compare": "vrsweep simulate --compare effective"}


def _parse_at(items):
    """--at NAME=VALUE (repeatable) -> {name: value}; values stay text until the axis is known."""
    from vrsweep.errors import UsageError

    at = {}
    for item in items:
        name, equals, value = item.partition("=")
        if not equals or not name.strip() or not value.strip():
            raise UsageError(f"--at {item}: expected NAME=VALUE, e.g. --at Omega=4")
        if name.strip() in at:  # the later value was taken silently
            raise UsageError(f"--at {name.strip()} is given twice: one value per axis")
        at[name.strip()] = value.strip()
    return at


def default_output(path, kind):
    """RESULTS.h5 -> RESULTS.png next to it; an explicit --kind adds itself: RESULTS.bifurcation.png."""
    path = Path(path)
    return path.with_name(f"{path.stem}.{kind}.png" if kind else f"{path.stem}.png")


@click.command("plot")
@click.argument("paths", nargs=-1, required=True, metavar="FILE.h5 [FILE.h5 ...]",
                type=PathText(dir_okay=True))
@click.option("-o", "--output", type=PathText(dir_okay=False), default=None, callback=file_name_only,
              help="Figure file, .png, .pdf or .svg (default: FILE.png, or FILE.KIND.png with --kind).")
@click.option("--kind", type=click.Choice(["response", "map", "impacts", "status", "motion", "bifurcation", "lyapunov",
                                           "bifurcation+lyapunov", "trajectory", "slowflow", "basin"]),
              default=None,
              help="What to draw (default: chosen from the file, see above).")
@click.option("--amplitude", is_flag=True,
              help="Plot the amplitude |Q| instead of the gain R, |Q| over the model's response scale (the "
                   "paper's model: A instead of A/c too, eq3.3).")
@click.option("--at", "at_items", multiple=True, metavar="NAME=VALUE",
              help="Fix a swept axis at one of its values, e.g. --at Omega=4 in the paper's model (repeatable; "
                   "direction=up|down for a two-way continuation).")
@click.option("--x", "x_axis", default=None, metavar="NAME", help="The swept parameter on the horizontal axis.")
@click.option("--var", default=None, metavar="NAME",
              help="The stored variable to draw, any one per grid point (e.g. R_err, period, impact_speed_min, "
                   "x_min, attractor): mapped over two axes (--kind map), drawn against one (--kind response, the "
                   "default for one axis); default R (|Q| with --amplitude).")
@click.option("--log/--linear", "log", default=None,
              help="Logarithmic (or linear) response axis; on maps, colour scale. Default: response "
                   "plots choose log when the measured values span two decades or more, maps are linear.")
@click.option("--periods", default=None, metavar="FIRST:LAST",
              help="Trajectory files: show periods FIRST to LAST only (1-based; the paper's slow periods "
                   "2 pi/omega, a written model's period T), e.g. 1:20.")
@click.option("--dpi", type=WholeNumberRange(min=20, max=1200), default=150, show_default=True,
              help="Resolution of a .png (pixels = --size x --dpi).")
@click.option("--title/--no-title", "title", default=True, show_default=True,
              help="Draw the title and caption above the figure. Either way the full description is in "
                   "the file's metadata (PNG/SVG Description, PDF Subject); vrsweep info FILE.h5 shows "
                   "the parameters.")
@click.option("--size", default=None, metavar="W,H", help="Figure size in inches, e.g. --size 3.4,2.6.")
@click.option("--overwrite", is_flag=True,
              help="Replace an existing file at the figure's path that is not a figure vrsweep wrote "
                   "(vrsweep's own figures are replaced without it).")
@click.option("--style", default=None, metavar="NAME|FILE",
              help="A matplotlib style sheet (e.g. seaborn-v0_8-paper, ggplot) or a .mplstyle file: fonts, "
                   "colours and line widths follow it.")
@click.option("--vmin", type=FiniteFloatRange(), default=None, help="Maps: the bottom of the colour scale.")
@click.option("--vmax", type=FiniteFloatRange(), default=None,
              help="Maps: the top of the colour scale (default: the 99th percentile, said on the colour "
                   "bar when it caps; lyapunov: symmetric about 0, --vmax alone sets both ends).")
@click.option("--xlim", default=None, metavar="LOW,HIGH",
              help="The horizontal axis from LOW to HIGH (every panel with the same axis; the vertical axes "
                   "refit to the data in view unless --ylim is given), e.g. --xlim 17.82,17.84.")
@click.option("--ylim", default=None, metavar="LOW,HIGH",
              help="The vertical axis of the main panel from LOW to HIGH (and of every panel with the same axis).")
@click.option("--legend", type=click.Choice(["best", "outside", "none"]), default=None,
              help="Where the legend goes: inside the main panel where it hides least (best), below the "
                   "panels (outside), or nowhere (none). Default: each figure's own place, inside when "
                   "below it would leave the panels under half the figure.")
@click.option("--zoom", type=click.Choice(["bifurcations", "none"]), default=None,
              help="Branch files: narrow the parameter axis to where the bifurcations are (bifurcations), or "
                   "never (none). Default: zoomed when they span under 1 % of the axis, said on the figure.")
@click.option("--table", is_flag=True,
              help="Branch files: list the bifurcations (tag, kind, parameter, R, branch) in a table below the "
                   "figure, which grows by a row each.")
def command(paths, output, kind, amplitude, at_items, x_axis, log, periods, var, dpi, title, size, overwrite, style,
            vmin, vmax, xlim, ylim, legend, zoom, table):
    """Draw a figure from a vrsweep file.

    \b
    Sweep results (vrsweep run), --kind:
      response     R (or |Q| with --amplitude) against the axis -- default for one
                   axis, or two axes when one has at most 5 values (one curve each);
                   --var NAME draws any stored variable (impact_speed_min, x_max...);
                   the paper's model: with the analytic branches (stable solid,
                   unstable dashed) and g_res
      map          heat map over two axes -- default for two axes; --var NAME maps
                   any stored variable (R_err, period, x_min...); the paper's model
                   over g and Omega: with g_res(Omega) drawn on it
      impacts      mean impacts per period (the paper's slow period, a written model's T)
      status       how each point's integration ended
      motion       the kind of motion: periodic, quasi-periodic, chaotic, not settled
      bifurcation  stroboscopic x(nT) against the axis (2 axes: pick one with --at)
      lyapunov     largest Lyapunov exponent against the axis, with its 95% band and the
                   zero line (sweeps run with integration.lyapunov: true); -inf (stuck on
                   a barrier) as triangles in a strip under the panel
      bifurcation+lyapunov
                   both, the exponent aligned under the bifurcation diagram
      basin        the x0-v0 plane coloured by the attractor each start reached
                   (sweeps with x0 / v0 axes, their default; other axes: pick a slice
                   with --at)
    Bifurcation curves over a map: vrsweep plot MAP.h5 CURVES.h5 [CURVES2.h5 ...]
      the map of --var (default R) with the curves of each curves file (vrsweep
      continue BRANCH.h5 --point K --along NAME) over it: fold, period doubling and
      grazing each in its own style, codimension-two points marked; for the paper's
      effective model the corrected theory's fold and Hopf curves too. The map's two
      axes must be the curves' two parameters.
    Trajectory files (vrsweep simulate), --kind:
      trajectory   position, velocity, phase portrait (default); the paper's model
                   with --compare effective: original above effective
      impacts      impacts per period, period by period (several files: one panel each)
      slowflow     the paper's effective system against the slow-flow reconstruction
                   (needs simulate --compare effective)

    On response plots a filled marker is an R to trust (R_err <= 10% of R), a hollow one is not
    (R depends on the window: chaos or a transient); a circle is a motion with a period, a
    square one without (period 0). Failed points are x marks in a strip under the panel. The response
    axis turns logarithmic by itself when the measured values span two decades (--log/--linear to choose).
    """
    from vrsweep.errors import VrsweepError

    try:
        options = dict(title=title, size=size, style=style, vmin=vmin, vmax=vmax, xlim=xlim, ylim=ylim, legend=legend)
        path, file_format = _output(paths, output, kind, overwrite)
        figure = _figure(paths, kind, amplitude, at_items, x_axis, log, periods, var, options, zoom, table)
        # Rendered in memory, then written whole: a full disk leaves no half figure, and the
        # message can say how many bytes the figure needs.
        from vrsweep.plot import render

        image = render(figure, file_format, dpi)
    except VrsweepError as error:
        raise error.reworded(FLAGS) from None
    from vrsweep.store.fileio import write_bytes

    write_bytes(path, image)
    from vrsweep.plot import layout_note, legend_note

    if legend_note(figure):  # the other places, never the one it took
        places = "outside or best to draw it" if "left off" in legend_note(figure) else "outside or none to choose"
        click.echo(f"Note: {one_line(path)}: {legend_note(figure)} (--legend {places})", err=True)
    if layout_note(figure):
        # Only what was not already done: --no-title given is never advised again.
        advice = ("--no-title, " if title else "") + "a larger --size" + (", --legend none" if legend != "none" else "")
        click.echo(f"Note: {one_line(path)}: {layout_note(figure)} ({advice})", err=True)
    from vrsweep import mpl_folder

    if mpl_folder.notice():  # matplotlib's own two warnings are not printed (mpl_folder.py)
        click.echo(f"Note: {one_line(mpl_folder.notice())}", err=True)
    click.echo(f"-> {one_line(path)}", err=True)


def _output(paths, output, kind, overwrite):
    """(the path to write the figure at, its format png/pdf/svg): the format from the suffix of the
    name given (a link's target may have any name), the path from fileio.output_target."""
    from vrsweep.errors import UsageError
    from vrsweep.plot.labels import made_by_vrsweep
    from vrsweep.store.fileio import output_target, prepare_output_directory

    given = Path(output) if output else default_output(paths[0], kind)
    if given.suffix.lower() not in FORMATS:
        raise UsageError(f"-o {given}: the figure's format comes from its suffix, one of {', '.join(FORMATS)}")
    # Never an input, results or anything other than a regular file; a link is followed (output_target).
    target = output_target(given, overwrite=True, inputs=paths, inputs_are="one of the files being plotted",
                           writes="a figure")
    shown = str(given) if os.fspath(target) == os.fspath(given) else f"{given} (a link to {target})"
    option = "-o " if output else "the default figure path "
    # A figure vrsweep wrote is replaced unasked (a figure is redrawn often); any other file is
    # someone's, and the default path in particular was never named by the user.
    if os.path.exists(target) and not overwrite and not made_by_vrsweep(target):
        raise UsageError(f"{option}{shown} already exists and is not a figure vrsweep wrote: pass --overwrite "
                         "to replace it, or choose another output with -o")
    # Before drawing: a folder no file can be written in is known now. A missing one is made only
    # when the figure is written, so that a plot refused for its inputs leaves no folder behind.
    if os.path.isdir(os.path.dirname(os.path.abspath(target))):
        prepare_output_directory(target)
    return Path(target), given.suffix.lower()[1:]


def _figure(paths, kind, amplitude, at_items, x_axis, log, periods, var, options, zoom=None, table=False):
    from vrsweep import plot
    from vrsweep.errors import UsageError
    from vrsweep.store.trajectory_file import TrajectoryData

    data = [plot.load(p) for p in paths]
    for path_in, loaded in zip(paths, data):
        if isinstance(loaded, TrajectoryData):
            shard, complete = None, loaded.complete
        else:  # a sweep's Dataset
            shard, complete = loaded.attrs.get("shard"), bool(loaded.attrs.get("vrsweep_complete", 0))
        if shard:
            click.echo(f"Note: {one_line(path_in)} is shard {shard}: plotting its points only "
                       "(vrsweep merge joins the shards into the whole grid)", err=True)
        elif not complete and not isinstance(loaded, TrajectoryData) and \
                loaded.attrs.get("vrsweep_file") in ("branch", "curves"):
            click.echo(f"Warning: {one_line(path_in)} is a continuation stopped by a signal: plotting what it had "
                       "followed (vrsweep continue again follows the whole of it)", err=True)
        elif not complete:
            click.echo(f"Warning: {one_line(path_in)} is unfinished: plotting the points done so far "
                       "(finish it with vrsweep run CONFIG --resume)", err=True)
    window = plot.parse_periods(periods) if periods else None
    if window is not None and window[1] is not None:
        for path_in, loaded in zip(paths, data):
            n_periods = plot.slow_periods_in(loaded) if isinstance(loaded, TrajectoryData) else None
            if n_periods is not None and window[0] <= n_periods < window[1]:
                click.echo(f"--periods {periods}: {one_line(path_in)} has {n_periods} slow periods; showing "
                           f"{window[0]}-{n_periods}", err=True)
    if kind is None and var is None and len(data) == 1 and not isinstance(data[0], TrajectoryData) \
            and "attractor" in data[0].data_vars:
        kind = "basin"  # a sweep over the initial state: its basins are what it is for
    if kind == "basin":
        if len(data) > 1:
            raise UsageError("--kind basin draws one file; plot the others one at a time")
        if x_axis or amplitude or log or periods or var or zoom or table:
            raise UsageError("--x, --amplitude, --log, --periods, --var, --zoom and --table do not apply to --kind basin")
        return plot.basin_plot(data[0], at=_parse_at(at_items), **options)
    return plot.plot(data, kind=kind, amplitude=amplitude, at=_parse_at(at_items), x_axis=x_axis,
                     log=log, periods=window, var=var, zoom=zoom, table=table, **options)
