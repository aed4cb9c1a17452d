"""A sweep job: config -> result file, checkpointed chunk by chunk, resumable, shardable.

Glue between sweep (numerics), store (HDF5) and theory (the analytic columns). The CLI's
``run`` command is a thin wrapper around ``run_job``.
"""

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np

from vrsweep import __version__
from vrsweep.store.provenance import cf_attributes, model_attributes
from vrsweep.errors import InvalidArgument, clip
from vrsweep.numbertext import read_int, to_int
from vrsweep.results import Motion, Status
from vrsweep.execution.signals import GracefulStop, Interrupted  # noqa: F401 - the run's, re-exported
from vrsweep.numerics.model import AXIS_UNITS, axis_long_name
from vrsweep.store import ResultWriter, VariableSpec
from vrsweep.config.grid import Grid
from vrsweep.execution.sweep import run_sweep
from vrsweep.store.variables import point_variables, written_model_words


FAILURE_ADVICE_FRACTION = 0.03
# More than this fraction of a run's points called chaotic without Lyapunov exponents: a note.
CHAOTIC_NOTE_FRACTION = 0.3
"""Above this share of failed points (of those computed now), the summary says what to change."""


def _remedy(status, run):
    """What to change when many points end with ``status`` (run: the config's integration):
    (the advice, a setting ``NAME=VALUE`` to try or None)."""
    if status == Status.MAX_STEPS:
        return f"raise integration.max_steps (now {run.max_steps})", f"max_steps={run.max_steps * 10}"
    if status == Status.CHATTER_LIMIT:
        return (f"raise integration.max_impacts_per_period (now {run.max_impacts_per_period}), or "
                f"integration.stick_velocity (now {run.stick_velocity:g}) so that a chattering mass sticks sooner",
                None)
    if status == Status.DIVERGED:
        return (f"if the motion is bounded, raise integration.divergence_bound (now {run.divergence_bound:g}); "
                "otherwise these parameters blow up", None)
    if status == Status.STEP_TOO_SMALL:
        # The step fell below what a double can add to t: a tolerance the motion's scale cannot
        # meet, or a scale no tolerance meets (c = 1e300 makes every step too small).
        return (f"loosen integration.rtol/atol (now {run.rtol:g}/{run.atol:g}), unless the parameters there are "
                "extreme (a force of 1e300 moves beyond what doubles integrate, at any tolerance)", None)
    if status == Status.SLIDING:
        return ("the written force has a jump (sign) that holds the motion on it there (stick-slip), on a surface "
                "other than v = constant, the one vrsweep slides on: write a "
                "smooth law instead, such as -mu*tanh(v/v0) with v0 small against the motion's speeds", None)
    if status == Status.NON_FINITE:
        # Where the motion is bounded, a NaN is mostly a force undefined on the way: a written
        # model's sqrt or log of a quantity that turns negative, or a division by one that passes 0.
        return ("check the parameters of those points (vrsweep info FILE lists them), and that the force is "
                "defined along the motion (a square root, power or log of a quantity that turns negative, "
                "a division by one that passes zero)", None)
    return "check the parameters of those points (vrsweep info FILE lists them)", None


@dataclass(frozen=True)
class FailureAdvice:
    """Many points of a run ended with ``status``: what to change before running it again."""

    status: Status
    n: int          # points that ended with status
    n_run: int      # points computed in this run
    remedy: str     # e.g. "raise integration.max_steps (now 500)"
    setting: str | None = None  # a NAME=VALUE override to try, e.g. "max_steps=5000"


@dataclass
class JobReport:
    output: Path
    n_points: int          # points this job owns (the whole grid, or its shard)
    n_run: int             # points computed now (less than n_points when resuming)
    counts: dict = field(default_factory=dict)  # Status -> points, over the points run now
    integration: object = None  # the config's Integration, for advice on failed points
    motions: dict = field(default_factory=dict)  # Motion -> points, over the points run now
    lyapunov_nan: int = 0  # points run now that ended ok with a NaN lyapunov (their tangents failed)

    def motion_note(self) -> str | None:
        """A note when many points were called chaotic without Lyapunov exponents: a response
        locked to a quasi-periodic forcing converges slowly and is called chaotic then, and a
        negative exponent would tell it apart (analysis/motion.py); None otherwise."""
        from vrsweep.results import Motion

        computed = sum(self.motions.values())
        chaotic = self.motions.get(Motion.CHAOTIC, 0)
        # Under 8 measured periods nothing converges or not (motion.convergence): no note.
        if self.integration is None or self.integration.lyapunov or self.integration.measure_periods < 8 \
                or not computed or chaotic <= CHAOTIC_NOTE_FRACTION * computed:
            return None
        return (f"Note: {chaotic} of the {computed} points have no period and averages that do not converge in "
                f"the window ({chaotic / computed:.0%}), and are called chaotic; some may be responses locked to "
                "a quasi-periodic forcing, which integration.lyapunov: true tells apart (a negative exponent; "
                "docs/trust.md)")

    def lyapunov_note(self) -> str | None:
        """A note when points ended ok but their tangent vectors did not: the point's other results
        stand, and its lyapunov is NaN (a force whose stiffness is infinite on the way, such as a
        written sqrt(abs(x)), or overflowing tangents); None otherwise."""
        if not self.lyapunov_nan:
            return None
        return (f"Note: {self.lyapunov_nan} of the {self.n_run} points ended ok with a NaN lyapunov: their "
                "tangent vectors became non-finite (a force whose stiffness is infinite somewhere on the motion, "
                "such as sqrt(abs(x)) at x = 0, or one that overflows); their other results stand")

    def summary_line(self):
        parts = [f"{n} {status.name.lower()}" for status, n in sorted(self.counts.items())]
        detail = ", ".join(parts) if parts else "nothing left to compute"
        return f"{self.n_run} of {self.n_points} points computed ({detail}) -> {self.output}"

    def advice(self) -> list[FailureAdvice]:
        """One item per kind of failure that hit more than FAILURE_ADVICE_FRACTION of the points."""
        if not self.n_run or self.integration is None:
            return []
        items = []
        for status, n in sorted(self.counts.items()):
            if status in (Status.OK, Status.NOT_COMPUTED) or n <= FAILURE_ADVICE_FRACTION * self.n_run:
                continue
            items.append(FailureAdvice(status, n, self.n_run, *_remedy(status, self.integration)))
        return items


def parse_shard(text, environ=None):
    """'I/N' (0-based I) or 'auto': the shard of this task of a SLURM job array; None: the whole run.

    A job array need not start at 0 (``--array=1-8``) nor step by 1 (``--array=0-30:10``), so
    the index is (SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN) / SLURM_ARRAY_TASK_STEP, and N is
    SLURM_ARRAY_TASK_COUNT. An array given as a list (``--array=1,4,7``) cannot be mapped.
    Raises InvalidArgument (``shard x: expected I/N ...``; the run command says ``--shard x``).
    """
    environ = os.environ if environ is None else environ
    if text is None:
        return (0, 1)
    if text == "auto":
        if "SLURM_ARRAY_TASK_ID" not in environ or "SLURM_ARRAY_TASK_COUNT" not in environ:
            raise InvalidArgument("shard", text, "needs SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT "
                                                 "(run it inside a SLURM job array, or give the shard as I/N)")
        task, count, first, step = (_slurm_int(environ, text, name, default) for name, default in (
            ("SLURM_ARRAY_TASK_ID", None), ("SLURM_ARRAY_TASK_COUNT", None), ("SLURM_ARRAY_TASK_MIN", 0),
            ("SLURM_ARRAY_TASK_STEP", 1)))
        offset = task - first
        if step < 1 or offset % step:
            raise InvalidArgument(
                "shard", text, f"array task {task} is not on the range {first}, {first + step}, ...; "
                               "submit the array as a range A-B (or A-B:STEP), not a list")
        index = offset // step
        where = f"SLURM array task {task} (first {first}, {count} tasks): "
    else:
        try:
            index_text, count_text = text.split("/")
            index, count = read_int(index_text), read_int(count_text)
        except ValueError:  # NumberTextError is one: "١/٢" was shard 1 of 2
            raise InvalidArgument("shard", text, "expected I/N (e.g. 0/8) or 'auto'") from None
        where = ""
    if count < 1:  # before the index: a range 0..N-1 of N <= 0 ("0..-1") means nothing
        raise InvalidArgument("shard", text, f"{where}the number of shards N must be >= 1, got {clip(count)}")
    if not 0 <= index < count:
        hint = "; submit the array as a range A-B (or A-B:STEP), not a list" if text == "auto" else ""
        raise InvalidArgument("shard", text, f"{where}shard index {clip(index)} is not in 0..{clip(count - 1)}{hint}")
    return (index, count)


def _slurm_int(environ, text, name, default):
    """The whole number SLURM set in ``name`` (``default`` where it is unset or empty, if any).
    One that is not a whole number is named with its value: SLURM_ARRAY_TASK_STEP=abc was refused
    as "needs SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT", both of which were set."""
    value = environ.get(name, "")
    if value == "" and default is not None:
        return default
    try:
        return to_int(value)
    except ValueError:
        raise InvalidArgument("shard", text, f"{name}={clip(repr(value))} is not a whole number (SLURM sets it in a "
                                             "job array; run it inside one, or give the shard as I/N)") from None


SHARD_SUFFIX = re.compile(r"\.shard([0-9]+)of([0-9]+)$")  # [0-9]: re's \d is any Unicode digit  # OUT.shardIofN.h5's, as merge reads it too


def shard_output_path(path, shard):
    """Shard I of N's file: OUT.shardIofN.h5 for ``-o OUT.h5``. An output that already names this
    shard's file (``-o OUT.shard0of2.h5 --shard 0/2``, as a job script often spells it) is its file:
    it was made OUT.shard0of2.shard0of2.h5, which neither merge's names nor --resume then found.
    One that names another shard's file is refused: it would hold this shard's points."""
    index, count = shard
    path = Path(path)
    if count == 1:
        return path
    given = SHARD_SUFFIX.search(path.stem)
    if given and (int(given.group(1)), int(given.group(2))) == (index, count):
        return path
    if given:
        from vrsweep.errors import UsageError

        run_output = path.with_name(path.stem[:given.start()] + path.suffix)
        raise UsageError.naming("{output} {path} names the file of shard {named}, but this is shard {this}: give "
                                "the run's output, {run_output}, and each shard adds its own .shardIofN",
                                path=path, named=f"{given.group(1)}/{given.group(2)}", this=f"{index}/{count}",
                                run_output=run_output)
    return path.with_name(f"{path.stem}.shard{index}of{count}{path.suffix}")


def _variable_specs(config):
    variables = point_variables(config.integration)
    if config.written:
        variables = written_model_words(variables, config.model)
    return [VariableSpec(name=name, dtype=dtype, extra_dims=extra, attrs=attrs) for name, dtype, extra, attrs in variables]


def _axes(grid, written=False):
    axes = []
    for name, values in zip(grid.axis_names, grid.axis_values):
        if name == "direction":
            attrs = {"units": "1", "long_name": "continuation direction (+1: up the axis, -1: down)"}
        else:
            # a written model's parameter: dimensionless as the model is written (its own units)
            attrs = {"units": AXIS_UNITS.get(name, "1"),
                     "long_name": axis_long_name(name, written)}
        axes.append((name, values, attrs))
    return axes


def _title(config):
    axes = ", ".join(config.axis_names) if config.axes else "one point"
    return f"vrsweep sweep of the {config.model} model over {axes}"  # a written model prints its name


def root_attributes(config, shard=(0, 1)):
    attrs = {
        "config": config.to_yaml(),
        **model_attributes(config.model),
        "vrsweep_version": __version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        **cf_attributes(_title(config), model=config.model),
    }
    if shard[1] > 1:
        attrs["shard"] = f"{shard[0]}/{shard[1]}"
    return attrs


def owned_mask(grid, shard):
    from vrsweep.execution.chunks import shuffled_lines

    mask = np.zeros(grid.n_points, dtype=bool)
    mask[shuffled_lines(grid, *shard).reshape(-1)] = True
    return mask.reshape(grid.shape)


# Points per call of theory.analytic_columns. Its temporaries (companion matrices, complex
# eigenvalues, stability tests) take ~0.5 kB a point: on the whole grid at once they were the
# largest thing a run held (+50 MB peak at 10^5 points, so +5 GB at 10^7). In blocks they are
# bounded; every point is computed on its own (elementwise numpy, one small eigenproblem per point),
# so the blocks change no bit of the result.
ANALYTIC_BLOCK_POINTS = 8192


def analytic_extras(config, grid):
    """The analytic side stored beside the numerical grid (issue 3): theory.analytic_columns. The
    paper's theory is of the paper's model: a written model has none ({})."""
    from vrsweep.analysis import theory

    if config.written:
        return {}
    blocks = {}
    for start in range(0, grid.n_points, ANALYTIC_BLOCK_POINTS):
        flat = np.arange(start, min(start + ANALYTIC_BLOCK_POINTS, grid.n_points))
        part = grid.parameters_at(config, flat)
        for name, (array, dims_suffix, attrs) in theory.analytic_columns(part).items():
            blocks.setdefault(name, ([], dims_suffix, attrs))[0].append(np.asarray(array))
    extras = {}
    for name, (arrays, dims_suffix, attrs) in blocks.items():
        array = np.concatenate(arrays)
        array = array.reshape(grid.shape + array.shape[1:])
        dims = tuple(grid.axis_names) + tuple(dims_suffix)
        if name == "g_res":
            array, dims = _reduce_constant_axes(array, grid.axis_names)
        extras[name] = (array, dims, attrs)
    return extras


def solver_error_attributes(config, grid, shard, writer, sample=None):
    """R_solver_err and its sample's size and tolerance (execution/solver_error.py), measured on the
    points this file holds (a shard's own); ``sample``: its tight run, if started already
    (SolverErrorSample)."""
    from vrsweep.execution import solver_error

    done, stored = _done_and_stored(writer)
    if sample is None:
        sample = solver_error.start(config, grid, done, stored)
    return solver_error.finish(sample, stored)


def _done_and_stored(writer):
    """The points this file holds done (a shard's own) and the values the solver's error is
    estimated from, flat over the grid."""
    done = writer.done_mask().reshape(-1)
    owned = writer.owned_mask()
    if owned is not None:
        done = done & owned.reshape(-1)
    stored = {name: array.reshape(-1) for name, array in writer.read_variables(("R", "period", "status", "motion")).items()}
    return done, stored


class SolverErrorSample:
    """On a GPU, the solver error's tight run (execution/solver_error.py) starts as soon as its
    sample is final, the grid's first lines being done, and the card computes it beside the rest
    of the grid: at the run's end it would be a launch of a few points alone on the card (4.9 s on
    the original model on an H100, benchmarks/README.md). On the CPU it runs at the end, as before
    (started early, it would take the run's threads)."""

    def __init__(self, config, grid, writer):
        from vrsweep.execution import solver_error

        self.config, self.grid, self.writer = config, grid, writer
        self.sample = None
        self.early = config.integration.device == "cuda"
        # (the grid's shuffled order, once: not after every chunk)
        self.candidates = solver_error.candidate_lines(grid) if self.early else None

    def check(self):
        """Start the tight run if it can start now (called before the run and after every chunk)."""
        from vrsweep.execution import solver_error

        if not self.early or self.sample is not None:
            return
        owned = self.writer.owned_mask()
        if solver_error.sample_is_final(self.candidates, self.writer.done_mask().reshape(-1),
                                        None if owned is None else owned.reshape(-1)):
            self.sample = solver_error.start(self.config, self.grid, *_done_and_stored(self.writer))


def basin_extras(config, writer):
    """The attractor labels and table of a sweep with x0 / v0 axes (vrsweep.analysis.attractors); ({}, {})
    without. Reads the finished points back from the checkpoint the writer holds."""
    from vrsweep.analysis import attractors

    if not attractors.has_initial_state_axes(config.axis_names):
        return {}, {}
    grid = Grid.from_config(config)
    axes = dict(zip(grid.axis_names, grid.axis_values))
    stored = writer.read_variables(attractors.NEEDED)
    return attractors.attractor_extras(axes, stored, config.integration.period_tolerance,
                                       config.model if config.written else None)


def _reduce_constant_axes(array, axis_names):
    """Drop the axes along which a grid array does not vary (g_res depends on Omega only)."""
    keep = []
    for axis in range(array.ndim):
        first = np.take(array, [0], axis=axis)
        if not np.allclose(array, first, rtol=0, atol=0, equal_nan=True):
            keep.append(axis)
    index = tuple(slice(None) if axis in keep else 0 for axis in range(array.ndim))
    return array[index], tuple(axis_names[axis] for axis in keep)


def run_job(config, output=None, *, threads=None, resume=False, overwrite=False, shard=(0, 1),
            progress_factory=None, executor=None, stop=None):
    """Run (or resume) a sweep into an HDF5 file. Returns a JobReport.

    progress_factory(total_points, already_done) -> callable(n) advancing a progress bar, or None.
    executor: optional callable with run_sweep's signature (e.g. the Dask backend).
    stop: optional GracefulStop; checked after each chunk is written (see GracefulStop).
    """
    from vrsweep.execution.device import check_device

    check_device(config.integration.device)  # before anything is written: no GPU, one line
    if executor is not None and config.integration.device != "cpu":
        from vrsweep.errors import UsageError

        raise UsageError("integration.device: cuda runs in this process, not on Dask's workers: on GPU nodes "
                         "run shards of the grid instead")
    grid = Grid.from_config(config)
    path = shard_output_path(config.output_path(output), shard)
    owned = owned_mask(grid, shard) if shard[1] > 1 else None
    inputs = (config.source_name,) if os.path.isfile(config.source_name) else ()  # never written over
    if resume and path.exists():
        _refuse_results_of_older_steps(path)
        writer = ResultWriter.open_for_resume(path, _expected_config_text(path, config),
                                              expected_shard=f"{shard[0]}/{shard[1]}" if shard[1] > 1 else None,
                                              inputs=inputs)
    else:
        writer = ResultWriter.create(path, _axes(grid, config.written), _variable_specs(config),
                                     root_attributes(config, shard), overwrite=overwrite or resume,
                                     owned_mask=owned, inputs=inputs)
    try:
        done = writer.done_mask().reshape(-1)
        n_owned = int(owned.sum()) if owned is not None else grid.n_points
        n_done = int(done[owned.reshape(-1)].sum()) if owned is not None else int(done.sum())
        advance = progress_factory(n_owned, n_done) if progress_factory else None
        run = executor or run_sweep
        left = [n_owned - n_done]

        motions = {}
        lyapunov_nan = [0]
        solver_sample = SolverErrorSample(config, grid, writer)
        solver_sample.check()  # (a resumed run's sample may be done already)

        def on_chunk(flat_indices, values):
            writer.write_points(flat_indices, values)
            for code, n in zip(*np.unique(values["motion"], return_counts=True)):
                motions[Motion(int(code))] = motions.get(Motion(int(code)), 0) + int(n)
            if "lyapunov" in values:
                lyapunov_nan[0] += int(np.sum((values["status"] == Status.OK) & np.isnan(values["lyapunov"])))
            left[0] -= len(flat_indices)
            solver_sample.check()
            if stop is not None and left[0] > 0:  # after the last chunk, finishing is better
                stop.check()  # a stop asked for during the chunk takes effect now it is saved

        counts = run(config, threads=threads, shard=shard, done=done, on_chunk=on_chunk,
                     progress=(lambda n, total: advance(n)) if advance else None)
        extras = analytic_extras(config, grid)
    except BaseException:
        writer.abandon()  # everything finished so far is on disk; --resume continues
        raise
    coords = {}
    if shard[1] == 1:  # a shard sees part of each slice: the merge labels the whole grid
        attractors, coords = basin_extras(config, writer)
        extras.update(attractors)
    writer.finish(extra=extras, coords=coords,
                  attributes=solver_error_attributes(config, grid, shard, writer, solver_sample.sample))
    return JobReport(path, n_owned, sum(counts.values()), counts, config.integration, motions, lyapunov_nan[0])


def points_left(config, output=None, shard=(0, 1)):
    """(path, points not done, points of the shard) for ``run --resume``, read without writing:
    None for the points not done where ``path`` does not exist (resume starts afresh).
    ResultFileError where --resume would refuse the file (another config, shard or version)."""
    from vrsweep.store.writer import ResultWriter

    grid = Grid.from_config(config)
    path = shard_output_path(config.output_path(output), shard)
    owned = owned_mask(grid, shard).reshape(-1) if shard[1] > 1 else np.ones(grid.n_points, dtype=bool)
    n_owned = int(owned.sum())
    if not path.exists():
        return path, None, n_owned
    _refuse_results_of_older_steps(path)
    done = ResultWriter.done_for_resume(path, _expected_config_text(path, config),
                                        expected_shard=f"{shard[0]}/{shard[1]}" if shard[1] > 1 else None)
    return path, n_owned - int(done.reshape(-1)[owned].sum()), n_owned


def _refuse_results_of_older_steps(path):
    """ResultFileError if the file at ``path`` was written by a version whose points differ from
    this version's (or by an unknown one); files this function cannot read are left to the writer."""
    from vrsweep.errors import ResultFileError
    from vrsweep.store.fileio import open_hdf5
    from vrsweep.store.provenance import RESULTS_CHANGE, RESULTS_SINCE_VERSION, same_results_as_now
    from vrsweep.store.sealing import unless_changed
    from vrsweep.store.writer import ARGUMENT_WORDS

    try:
        with open_hdf5(path, "r") as h5file:
            if "vrsweep_format_version" not in h5file.attrs:
                return  # not a vrsweep file: the writer says so
            written_by = h5file.attrs.get("vrsweep_version")
            if isinstance(written_by, bytes):
                written_by = written_by.decode("utf-8", errors="replace")
            if same_results_as_now(written_by):
                return
            # The version is read before the attributes' checksum: an edited or damaged one says so.
            changed = unless_changed(h5file, path)
    except Exception:  # noqa: BLE001 -- any failure here is reported by open_for_resume itself
        return
    raise ResultFileError.naming(
        "cannot resume: {path} was written by vrsweep {written_by}, whose points differ from those of "
        "vrsweep {version} ({change} since {since}), so the two "
        "cannot share a file; pass {overwrite} to compute it afresh{changed}", ARGUMENT_WORDS, path=path,
        written_by=written_by or "(unknown version)", version=__version__,
        since=RESULTS_SINCE_VERSION, change=RESULTS_CHANGE, changed=changed)


def _expected_config_text(path, config):
    """The config text the writer must find in ``path`` to resume it: the stored text itself when it
    parses to the same config (however an earlier version wrote it out), else today's text (and the
    writer's message then says where the two differ).

    The comparison is of parsed configs, not of text: a checkpoint written before a change in how
    the config is written out still resumes, and one from a different config never does.
    """
    from vrsweep.config import same_config

    stored = _stored_config_text(path)
    if stored is not None and same_config(stored, config):
        return stored
    return config.to_yaml()


def _stored_config_text(path):
    """The ``config`` attribute of the result file at ``path``, or None if it cannot be read (the
    writer then reports what is wrong with the file)."""
    from vrsweep.store.fileio import open_hdf5

    try:
        with open_hdf5(path, "r") as h5file:
            value = h5file.attrs.get("config")
    except Exception:  # noqa: BLE001 -- any failure here is reported by open_for_resume itself
        return None
    if isinstance(value, bytes):
        value = value.decode("utf-8", errors="replace")
    return value if isinstance(value, str) else None

