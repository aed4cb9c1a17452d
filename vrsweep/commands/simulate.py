"""vrsweep simulate CONFIG.yaml [--set ...] -o TRAJ.h5: one trajectory, densely sampled, to HDF5."""

from pathlib import Path

import click

from vrsweep.commands.options import (
    OUTPUT_FLAGS, WholeNumberRange, config_argument, flag_wording, output_option, overwrite_option, set_option,
)
from vrsweep.errors import one_line
from vrsweep.execution.simulate import DEFAULT_SAMPLES_PER_PERIOD, SAMPLES_PER_CYCLE


@click.command("simulate")
@config_argument
@set_option
@output_option
@click.option("--samples-per-period", type=WholeNumberRange(min=1), default=None,
              help="Samples of x and v per period (the paper's slow period 2 pi/omega, a written model's period "
                   "T), taken from "
                   f"the solver's dense output. Default: {DEFAULT_SAMPLES_PER_PERIOD}, or {SAMPLES_PER_CYCLE} per "
                   "cycle of the fastest force when that is more (the paper's model at Omega = 50, omega = 0.5: "
                   "2000).")
@click.option("--compare", type=click.Choice(["effective"]), default=None,
              help="The paper's original model only: also integrate its effective system (eq2.10) from the "
                   "same initial state, and reconstruct it from the slow flow (eq2.21, eq2.24) -- Fig. 3-6 "
                   "of the paper.")
@overwrite_option
@click.option("--quiet", "-q", is_flag=True, help="No summary.")
def command(config_path, overrides, output, samples_per_period, compare, overwrite, quiet):
    """Integrate one point of CONFIG.yaml and store its trajectory.

    The config must describe a single point: fix swept parameters with --set (e.g. --set g=5 in
    the paper's model). The run lasts the config's transient_periods + measure_periods periods (the
    paper's slow periods 2 pi/omega, a written model's period T). Stored: x and v
    at evenly spaced times, every impact (time, velocity before and after), every sticking
    interval, and impacts per period, transient included. Plot it with `vrsweep plot`.
    """
    from vrsweep.config import load_config
    from vrsweep.execution.simulate import check_single_point, simulate_point
    from vrsweep.store.trajectory_file import write_trajectory

    config = load_config(config_path, overrides)
    flags = {**OUTPUT_FLAGS, "samples_per_period": "--samples-per-period", "compare_effective": "--compare effective",
             "compare": "--compare", "model_original": "--set model=original", "set": "--set "}
    with flag_wording(flags):
        check_single_point(config)  # before compiling anything
    from vrsweep.store.fileio import output_target, prepare_output_directory

    with flag_wording(flags):  # say so before integrating, not after
        path = Path(output_target(config.output_path(output), overwrite=overwrite, inputs=(config_path,),
                                  inputs_are="the config being run", kind="trajectory"))

    prepare_output_directory(path)  # before integrating: a folder that cannot be written is known now
    if not quiet:
        from vrsweep.commands.options import say_cache_notice

        say_cache_notice()
    with flag_wording(flags):
        data = simulate_point(config, samples_per_period, compare_effective=compare == "effective")
        write_trajectory(path, data, config, overwrite=overwrite)
    if not quiet:
        per = "period T" if config.written else "slow period"  # a written model's period is its own
        for run in data.runs.values():
            counts = run.impacts_per_period
            counts = counts[counts >= 0]  # the periods reached (a failed run stops early)
            click.echo(f"{run.model}: {run.status.name.lower()}, {len(run.t)} samples, {len(run.impacts)} impacts "
                       f"({counts.sum() / max(1, len(counts)):.2f} per {per}), "
                       f"{len(run.sticks)} sticking intervals", err=True)
        click.echo(f"-> {one_line(path)}", err=True)
