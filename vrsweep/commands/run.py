"""vrsweep run CONFIG.yaml: sweep the response over the config's grid into an HDF5 file."""

import shlex
import sys
import time

import click

from vrsweep.commands.options import (
    FiniteFloatRange, announce_fixed_axes, capped_threads, config_argument, device_option, flag_wording, output_option,
    overwrite_option, quiet_option, set_option, threads_option,
)
from vrsweep.errors import one_line

PROGRESS_INTERVAL = 60.0  # seconds between two progress lines in a batch log


@click.command("run")
@config_argument
@output_option
@threads_option
@device_option
@set_option
@quiet_option
@click.option("--resume", is_flag=True, help="Continue an interrupted run: compute only the missing points.")
@overwrite_option
@click.option("--shard", default=None, metavar="I/N|auto",
              help="Compute shard I of N (0-based) into its own file; 'auto' reads SLURM_ARRAY_TASK_ID/COUNT.")
@click.option("--dask", "dask_address", default=None, metavar="ADDRESS",
              help="Send chunks to a dask.distributed scheduler (or 'local:N' for a local cluster of N workers).")
@click.option("--allow-large", is_flag=True, help="Run a grid whose estimated size or time is out of proportion.")
@click.option("--dry-run", is_flag=True,
              help="Write nothing: run a sample of the grid's points on this machine (a few seconds, after "
                   "compiling) and print how long the whole run would take.")
@click.option("--progress-interval", type=FiniteFloatRange(min=0), default=PROGRESS_INTERVAL, show_default=True,
              metavar="SECONDS",
              help="When stderr is not a terminal (a batch job's log): a progress line every SECONDS "
                   "(points done, percent, points/s, ETA) instead of a progress bar.")
def command(config_path, output, threads, device, overrides, quiet, resume, overwrite, shard, dask_address, allow_large,
            dry_run, progress_interval):
    """Sweep the gain R over the config's grid and write it to HDF5.

    R is |Q| over the model's response scale: the paper's model's |Q|/c (eq3.3).

    The file is written chunk by chunk: after Ctrl-C, a crash or a kill, --resume computes only
    what is missing. Ctrl-C, SIGTERM, SIGHUP (the terminal closed) or SIGUSR1/SIGUSR2 (sbatch
    --signal=USR1@60) stop once the chunk in progress is saved; exit 128 + the signal (130, 143,
    129, 138, 140).

    Progress goes to stderr: a bar in a terminal, else (a batch log) one line every
    --progress-interval seconds. On a first run (an empty numba cache) it first says that the
    kernel is being compiled.
    """
    from vrsweep.config import load_config
    from vrsweep.errors import UsageError
    from vrsweep.execution.estimate import check_size, format_duration
    from vrsweep.execution.threads import available_threads

    if resume and overwrite:
        raise UsageError("--resume and --overwrite exclude each other")
    words = {}
    if device is not None:  # --device is --set device=... spelled as an option
        overrides = (*overrides, f"integration.device={device}")
        words[f"integration.device={device}"] = f"--device {device}"  # a conflict names what was typed
    config = load_config(config_path, overrides, override_words=words)
    announce_fixed_axes(config_path, overrides, config)
    requested_threads = threads
    # A remote Dask worker's thread count is the worker's business; a local one's is this machine's.
    if not dask_address or dask_address.startswith("local:"):
        threads = capped_threads(threads)

    from vrsweep.execution.distributed import parse_local
    from vrsweep.errors import InvalidArgument, RunFailed, clip
    from vrsweep.execution.job import GracefulStop, parse_shard, run_job

    try:
        shard_pair = parse_shard(shard)
    except InvalidArgument as error:
        raise error.as_option("--shard") from None
    n_lines = config.n_runs // max(1, _line_length(config))
    if shard_pair[1] > n_lines:  # shards past the grid's lines would hold nothing: not a question to answer
        raise UsageError(f"--shard {clip(shard)}: the grid has {n_lines} line{'s' if n_lines != 1 else ''} of work "
                         f"(points, or continuation lines), so at most {n_lines} shards")
    executor = None
    workers = 1
    stop = GracefulStop()
    if dask_address:
        from vrsweep.execution.distributed import dask_executor

        try:
            executor = dask_executor(dask_address, threads, stop)
        except InvalidArgument as error:
            raise error.as_option("--dask") from None
        workers = parse_local(dask_address) or 1  # a remote cluster's size is not known here
    # The size check is per process: a shard or a local Dask cluster shares the grid's time, while
    # a shard's file is still the whole grid's size (see store/layout.py).
    guess = check_size(config, (threads or available_threads()) * shard_pair[1] * workers, allow_large or dry_run,
                       allow="--allow-large")
    if dry_run:
        _dry_run(config, threads or available_threads(), shard_pair, guess, dask_address,
                 (output,) if resume else None)
        return
    bars = []

    def progress_factory(total, already_done):
        # Called once the output file is open, just before the first chunk.
        if quiet:
            return None
        if already_done < total and (not dask_address or parse_local(dask_address)):
            _say_if_compiling(config.integration, config.model)  # a remote cluster's workers have caches of their own
        if not sys.stderr.isatty():  # a batch log: lines, not a bar's redraws
            from vrsweep.execution.progress import ProgressLog

            return ProgressLog(total, already_done, progress_interval, sys.stderr).update
        from tqdm import tqdm

        bar = tqdm(total=total, initial=already_done, unit="pt", desc="vrsweep", dynamic_ncols=True,
                   file=sys.stderr)
        bars.append(bar)
        return bar.update

    began = time.perf_counter()
    try:
        with stop, flag_wording():
            report = run_job(config, output, threads=threads, resume=resume, overwrite=overwrite,
                             shard=shard_pair, progress_factory=progress_factory, executor=executor,
                             stop=stop)
    except RunFailed as error:
        raise RunFailed(f"{error} (finished chunks are saved; --resume continues)") from error
    except KeyboardInterrupt as interrupt:
        for bar in bars:
            bar.close()
        words = ["vrsweep", "run", config_path, "--resume"]
        if output:
            words += ["-o", output]
        for item in overrides:
            words += ["--set", item]
        if device:
            words += ["--device", device]
        if shard:
            words += ["--shard", shard]
        if dask_address:
            words += ["--dask", dask_address]
        if requested_threads:
            words += ["--threads", str(requested_threads)]
        if allow_large:
            words += ["--allow-large"]
        if progress_interval != PROGRESS_INTERVAL:
            words += ["--progress-interval", f"{progress_interval:g}"]
        click.echo(f"\nInterrupted ({interrupt or 'SIGINT'}): finished chunks are saved. Resume with:\n  "
                   + shlex.join(words), err=True)
        sys.exit(getattr(interrupt, "exit_code", 130))
    finally:
        for bar in bars:  # before an error message, so that it does not land inside the bar's line
            bar.close()
    if not quiet:
        if report.n_run:
            click.echo(f"time:        {format_duration(time.perf_counter() - began)} (the cost model's estimate: "
                       f"{format_duration(guess.seconds * report.n_run / max(1, guess.n_points))}; "
                       "--dry-run measures one)", err=True)
        for note in (report.motion_note(), report.lyapunov_note()):
            if note:
                click.echo(note, err=True)
        click.echo(one_line(report.summary_line()), err=True)
    for item in report.advice():  # even with --quiet: the file holds mostly failures
        example = f", e.g. --set {item.setting}" if item.setting else ""
        click.echo(f"Warning: {item.n} of {item.n_run} points ({item.n / item.n_run:.0%}) ended with "
                   f"{item.status.name.lower()}: {item.remedy}{example}, and run again with --overwrite", err=True)


def _dry_run(config, threads, shard, guess, dask_address, resume):
    """--dry-run: time a sample of the grid's lines here and say how long the run would take;
    with --resume (``resume``: (output,)), how much of it the file leaves, read without writing."""
    from vrsweep.errors import UsageError
    from vrsweep.execution.estimate import format_duration
    from vrsweep.execution.job import points_left
    from vrsweep.execution.timing import describe, measure, rough_and_measured_agree

    if dask_address:
        raise UsageError("--dry-run times this machine, not a Dask cluster's workers: leave out --dask")
    # The file first: a resume it would refuse needs no timing.
    left = points_left(config, resume[0], shard) if resume is not None else None
    _say_if_compiling(config.integration, config.model)
    timing = measure(config, threads, shard)
    click.echo(f"estimate:    {describe(timing, threads, config.integration.device)}")
    agreement = "" if rough_and_measured_agree(guess.seconds, timing) else " (more than 2x off: the measurement counts)"
    click.echo(f"cost model:  {format_duration(guess.seconds)}{agreement}; nothing was written")
    if left is not None:
        path, n_left, n_owned = left
        if n_left is None:
            click.echo(f"resume:      {one_line(path)} does not exist: --resume would compute all {n_owned} points")
        else:
            click.echo(f"resume:      {n_left} of {n_owned} points are not done in {one_line(path)}: about "
                       f"{format_duration(timing.seconds * n_left / max(1, n_owned))} at the pace above")


def _line_length(config):
    from vrsweep.config.grid import Grid

    grid = Grid.from_config(config)
    return len(grid.axis_values[grid.continuation_axis]) if grid.continuation_axis is not None else 1


def _say_if_compiling(integration, model="original"):
    from vrsweep.commands.options import say_if_compiling
    from vrsweep.execution.api import COMPILE_SECONDS, GPU_COMPILE_SECONDS
    from vrsweep.numerics.models import kernels_for

    gpu = integration.device == "cuda"
    if gpu:
        from vrsweep.execution.device import cuda_problem

        if cuda_problem() is not None:  # nothing compiles: the run stops first, in one line
            return
    say_if_compiling(lambda: kernels_for(model).is_cached(integration.method, integration.lyapunov, integration.device),
                     what="the CUDA kernel" if gpu else "the numba kernel",
                     duration=GPU_COMPILE_SECONDS if gpu else COMPILE_SECONDS)
