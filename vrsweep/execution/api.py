"""The Python API: ``vrsweep.sweep``, ``vrsweep.simulate`` and ``vrsweep.theory``.

Each takes a config as a path, as YAML text, as a dict nested as the YAML is, or as a
:class:`vrsweep.config.Config`, and settings as keyword arguments (``g=5``, ``method="dop853"``)
that go through the same mechanism as the command line's ``--set NAME=VALUE``. Each computes
exactly as its command does, through the same code:

- :func:`sweep` runs :func:`vrsweep.execution.job.run_job`, the path of ``vrsweep run``, into a
  file (a temporary one when no ``output`` is given) and reads it back whole with
  :func:`vrsweep.store.reading.load_results`, so that the Dataset is the file, variable for
  variable and bit for bit: one code path for the layout;
- :func:`simulate` runs :func:`vrsweep.execution.simulate.simulate_point` and
  :func:`vrsweep.store.trajectory_file.write_trajectory`, as ``vrsweep simulate`` does, and reads
  the groups back the same way;
- :func:`theory` returns :func:`vrsweep.analysis.theory.theory_rows`, what ``vrsweep theory
  --json`` prints.

Bad input raises the library's exceptions (:class:`vrsweep.errors.ConfigError`, ``UsageError``...)
with the command line's messages; where a message names something the caller can change, it
names the keyword argument (``overwrite=True``) instead of the flag.
"""

from __future__ import annotations

import math
import numbers
import os
import warnings
from contextlib import contextmanager
from pathlib import Path

from vrsweep.errors import ConfigError, FlagTypeError, PathTypeError, UsageError, VrsweepError

__all__ = ["sweep", "simulate", "theory", "resolve_config", "setting_text"]

# How the library's messages name what a caller of these functions can change.
ARGUMENT_WORDS = {
    "overwrite": "overwrite=True", "resume": "resume=True", "start_afresh": "run without resume=True",
    "output": "output", "samples_per_period": "samples_per_period",
    "compare_effective": "compare='effective'", "compare": "compare", "model_original": "model='original'",
    "set": "",
}

COMPARE_CHOICES = ("effective",)


@contextmanager
def _python_wording():
    """The library's errors raised in the block, worded for a caller of this module."""
    try:
        yield
    except VrsweepError as error:
        raise error.reworded(ARGUMENT_WORDS) from None


# -- the config ------------------------------------------------------------------------------


def setting_text(name: str, value) -> str:
    """One keyword override as the ``NAME=VALUE`` text ``--set`` takes.

    A string goes in as written, exactly as on the command line (``method="dop853"``, and
    ``g="5"`` is ``--set g=5``); a number in the YAML spelling that reads back to the same float
    bit for bit (``repr``; ``.inf`` and ``.nan`` for the non-finite ones, which are then refused
    as the command line refuses them); True/False as ``true``/``false``; None as ``null``.
    """
    import numpy as np

    if isinstance(value, str):
        text = value
    elif isinstance(value, (bool, np.bool_)):  # numpy's too: g=np.bool_(True) is no number 1.0
        text = "true" if value else "false"
    elif value is None:
        text = "null"
    elif isinstance(value, int) or (hasattr(value, "dtype") and getattr(value.dtype, "kind", "") in "iu"):
        text = str(int(value))
    else:
        try:
            number = float(value)
        except (TypeError, ValueError):
            text = repr(value)  # refused by the validation as "not a YAML scalar" or a wrong type
        else:
            if math.isnan(number):
                text = ".nan"
            elif (number == 0.0 and value != 0 or math.isinf(number)) and _exact_text(value):
                # a Decimal or Fraction no double holds (Decimal("1e-400") is 0.0 to float()): as
                # written, so that it is refused as the same number in a config is
                text = _exact_text(value)
            elif math.isinf(number):
                text = ".inf" if number > 0 else "-.inf"
            else:
                text = repr(number)
    return f"{name}={text}"


def _exact_text(value) -> str | None:
    """A Decimal or a Fraction (numbers.Rational) in decimal notation, 17 digits; None for others."""
    import decimal
    import numbers

    try:
        if isinstance(value, decimal.Decimal) and value.is_finite():
            return f"{value:.16e}"
        if isinstance(value, numbers.Rational):
            with decimal.localcontext() as context:
                context.prec, context.Emin, context.Emax = 17, decimal.MIN_EMIN, decimal.MAX_EMAX
                return f"{decimal.Decimal(value.numerator) / decimal.Decimal(value.denominator):.16e}"
    except (ArithmeticError, ValueError):
        return None
    return None


def _looks_like_path(text: str) -> bool:
    """One line that ends in .yaml/.yml, names a file, or cannot be a YAML mapping (no ``:``):
    a path, so that a misspelt one is reported as a missing file, not as odd YAML."""
    if "\n" in text or not text.strip():
        return False
    return (text.endswith((".yaml", ".yml")) or os.path.isfile(text)
            or (":" not in text and not text.lstrip().startswith("{")))


def resolve_config(config, overrides=None, *, keywords=()):
    """``config`` (a path, YAML text, a dict nested as the YAML, or a Config) with ``overrides``
    ({name: value}, as keyword arguments give them) applied, validated: a
    :class:`vrsweep.config.Config`.

    A ``str`` is a path when it is one line that ends in ``.yaml``/``.yml``, names an existing
    file or holds no ``:`` (so cannot be a YAML mapping), and YAML text otherwise. Problems raise :class:`vrsweep.errors.ConfigError` with the
    messages the command line prints: ``FILE:LINE: field: ...`` for a file, ``<string>:LINE:
    ...`` for YAML text, ``<dict>: field: ...`` for a dict, ``keyword argument NAME=VALUE: field:
    ...`` for an override.
    """
    from vrsweep.config import Config, config_from_dict, load_config, parse_config, with_overrides
    from vrsweep.errors import clip

    overrides = overrides or {}
    for name, value in overrides.items():
        # g=[5, 6] reads as "sweep g over 5 and 6" to a caller, and was refused as a --set VALUE
        # ("VALUE must be a single number or word"), words this caller never typed.
        if _several(value) and str(name).rpartition(".")[2] != "to":
            raise ConfigError([f"keyword argument {clip(f'{name}={value!r}')}: {_several_words(str(name), value)}"],
                              source="keyword arguments")
    settings = tuple(setting_text(name, value) for name, value in overrides.items())
    # A problem names the keyword argument as the caller wrote it: this user never typed --set.
    # ``keywords``: the calling function's own (progress, overwrite...): a misspelt one (progres=False)
    # arrives here as a setting, and its near miss is named beside the config's own names.
    words = {text: f"keyword argument {clip(f'{name}={value!r}')}{_near_keyword(name, keywords)}"
             for text, (name, value) in zip(settings, overrides.items())}
    if isinstance(config, Config):
        # Validated again, settings or none: a Config is a dataclass, and one changed with
        # dataclasses.replace (e = 1.5, rtol = 5, g = "abc") ran as given, outside the model's domain
        # and the tolerances' bounds, or ended in a traceback.
        try:
            return with_overrides(config, settings, override_words=words)
        except ConfigError:
            raise
        except Exception as error:  # noqa: BLE001 - a field of a type no config holds: its YAML cannot be written
            raise ConfigError([f"{config.source_name}: this Config cannot be read back as a config "
                               f"({type(error).__name__}: {error}); make it with vrsweep.config.load_config or "
                               "parse_config, and change it with keyword settings"], source=config.source_name) from None
    if isinstance(config, os.PathLike):
        return load_config(os.fspath(config), settings, override_words=words)
    if isinstance(config, str):
        if _looks_like_path(config):
            return load_config(config, settings, override_words=words)
        return parse_config(config, "<string>", settings, override_words=words)
    if isinstance(config, dict):
        return config_from_dict(config, "<dict>", settings, override_words=words)
    raise UsageError.naming("{config} must be a path, YAML text, a dict or a vrsweep Config, got {kind}",
                            kind=type(config).__name__)


def _several_words(name, value) -> str:
    """Why a keyword holding several values is refused, and what to write instead: a parameter's
    or the initial state's axis in the config, under the axis's own name (g, not parameters.g;
    x0, not initial.x); a setting (rtol, method, continuation.KEY) takes one value, a written model
    (a dict) is the config's model section. Every keyword was told to sweep itself: rtol=[...] and
    model={...} to write sweep: {model: [5.0, 6.0]}, parameters.g=[...] sweep: {parameters.g: ...}."""
    from vrsweep.config.schema import INTEGRATION_DEFAULTS

    section, _, key = name.rpartition(".")
    if key == "model" and not section:
        if isinstance(value, dict):
            return ("a written model is the config's model section, not a keyword: give it in the config "
                    '({"model": {"acceleration": ..., ...}}, a dict config); model= takes the name of one of the '
                    "paper's models (original, effective)")
        return "model= takes one model's name (original, effective); to compare models, run each"
    if section == "continuation" or (key in INTEGRATION_DEFAULTS and section in ("", "integration")):
        setting = name if section else f"integration.{key}"
        return (f"a keyword sets one value, and {setting} is a setting, not a sweep axis (a parameter, x0 or v0 "
                f"is one): run once for each value")
    axis = {"initial.x": "x0", "initial.v": "v0"}.get(name, key if section == "parameters" else name)
    return (f"a keyword sets one value ({axis}=5 fixes {axis}); to sweep {axis} over values, give its axis in the "
            f'config, e.g. {{"sweep": {{"{axis}": [5.0, 6.0]}}}} (a dict config) or sweep: {{{axis}: [5.0, 6.0]}}')


def _several(value) -> bool:
    """Whether a keyword's value holds several values (a list, a tuple, an array of any size but a
    0-d one, a range): not one number or word."""
    import numpy as np

    if isinstance(value, (str, bytes)):
        return False
    if isinstance(value, np.ndarray):
        return value.ndim > 0
    return isinstance(value, (list, tuple, range, set, frozenset, dict))


def _near_keyword(name, keywords) -> str:
    """`` (did you mean the keyword progress?)`` where ``name`` is a near miss of one of ``keywords``;
    `` (a keyword of vrsweep.sweep, not of this function: its own are ...)`` where it is another API
    function's (simulate(progress=False), as sweep takes it, was refused among the config's names
    alone)."""
    import difflib

    close = difflib.get_close_matches(name, [word for word in keywords if word != name], n=1, cutoff=0.75)
    if close:
        return f" (did you mean the keyword {close[0]}?)"
    others = [function.__name__ for function in (sweep, simulate, theory)
              if name in _keywords(function) and name not in keywords]
    if others:
        own = ", ".join(keywords) if keywords else "none"
        return f" (a keyword of vrsweep.{others[0]}, not of this function: its own are {own})"
    return ""


def _keywords(function):
    """A function's own keyword-only arguments: what is not a setting."""
    import inspect

    return tuple(name for name, parameter in inspect.signature(function).parameters.items()
                 if parameter.kind is inspect.Parameter.KEYWORD_ONLY)


# -- sweep -----------------------------------------------------------------------------------


def sweep(config, *, output=None, threads=None, progress=True, overwrite=False, resume=False,
          allow_large=False, **overrides):
    """Sweep the response over the config's grid, as ``vrsweep run`` does; an ``xarray.Dataset``.

    Parameters
    ----------
    config : str, os.PathLike, dict or vrsweep.config.Config
        A config file, YAML text, or a dict nested as the YAML is
        (``{"sweep": {"g": {"start": 0, "stop": 40, "num": 81}}}``).
    output : str or os.PathLike, optional
        Also keep the result in this HDF5 file (the file ``vrsweep run -o`` writes). Without it
        nothing is left on disk: the run goes through a temporary file that is read back whole
        and removed, and the config's own ``output`` key is not used.
    threads : int, optional
        Numba threads (default: all that numba may use here; more than that is lowered to it,
        with a warning).
    progress : bool
        A progress bar (tqdm's notebook widget in Jupyter, text elsewhere, on stderr).
    overwrite : bool
        Replace an existing ``output``.
    resume : bool
        Continue an interrupted run into ``output`` (the file of ``vrsweep run``, written chunk
        by chunk): compute only the points it lacks, as ``vrsweep run --resume``.
    allow_large : bool
        Run a grid whose estimated size or time is out of proportion (> 2 GB or > 24 h).
    **overrides
        Settings as ``--set NAME=VALUE`` takes them: a parameter (``g=5`` fixes a swept g and
        removes its axis), an integration key (``rtol=1e-10``, ``method="dop853"``,
        ``lyapunov=True``), ``x0``/``v0`` or ``model``.

    Returns
    -------
    xarray.Dataset
        Loaded into memory (no file left open): the variables, coordinates and attributes of the
        result file, one dimension per sweep axis in the config's order (``R``: shape
        ``config.shape``), and a last one, ``direction``, of 2 for a ``continuation: both`` sweep.
        Attributes as the file's: ``config`` (the resolved YAML), versions, provenance.
        ``vrsweep.plot.plot(dataset)`` draws it as ``vrsweep plot`` draws the file.

    Raises
    ------
    vrsweep.errors.ConfigError
        An invalid config or override, or a grid out of proportion without ``allow_large``.
    vrsweep.errors.UsageError
        ``output`` exists and ``overwrite`` is False, and the like.
    """
    from vrsweep.execution.estimate import check_size
    from vrsweep.execution.job import run_job
    from vrsweep.execution.threads import available_threads
    from vrsweep.store.reading import load_results

    _check_flags(progress=progress, overwrite=overwrite, resume=resume, allow_large=allow_large)
    _check_path("output", output)
    resolved = resolve_config(config, overrides, keywords=_keywords(sweep))
    if resume and overwrite:
        raise UsageError.naming("{resume} and {overwrite} exclude each other", ARGUMENT_WORDS)
    if resume and output is None:
        raise UsageError.naming("{resume} continues the run in a file: give its {output}", ARGUMENT_WORDS)
    threads = _capped_threads(threads)
    check_size(resolved, threads or available_threads(), allow_large)  # its message says allow_large=True
    bars = []
    factory = _progress_factory(resolved, bars) if progress else None
    try:
        with _python_wording():
            if output is None:
                from vrsweep.store.fileio import scratch_folder

                with scratch_folder() as folder:
                    report = run_job(resolved, Path(folder) / "sweep.h5", threads=threads,
                                     progress_factory=factory)
                    dataset = load_results(report.output)
                dataset.encoding.pop("source", None)  # the temporary file is gone
            else:
                report = run_job(resolved, output, threads=threads, overwrite=overwrite, resume=resume,
                                 progress_factory=factory)
                dataset = load_results(report.output)
    finally:
        for bar in bars:
            bar.close()
    for item in report.advice():
        example = f", e.g. {item.setting}" if item.setting else ""
        warnings.warn(f"{item.n} of {item.n_run} points ({item.n / item.n_run:.0%}) ended with "
                      f"{item.status.name.lower()}: {item.remedy}{example}", RuntimeWarning, stacklevel=2)
    return dataset


def _check_path(name, value):
    """PathTypeError unless ``value`` is None or a path as str or os.PathLike giving str: before
    anything is computed, as output=123 or output=b"o.h5" failed in pathlib, after the run; a
    UsageError for a str that ends in a slash (a folder's name)."""
    from vrsweep.store.fileio import refuse_a_folder_name

    if value is None:
        return
    if isinstance(value, str) or (isinstance(value, os.PathLike) and isinstance(os.fspath(value), str)):
        refuse_a_folder_name(value, name)  # "o.h5/": a folder, which pathlib would make o.h5 of
        return
    raise PathTypeError(name, value)


def _check_flags(**flags):
    """FlagTypeError for the first flag that is not a bool (numpy's included): before anything is
    read or written, as ``overwrite="no"`` would otherwise replace a file."""
    import numpy as np

    for name, value in flags.items():
        if not isinstance(value, (bool, np.bool_)):
            raise FlagTypeError(name, value)


def _capped_threads(threads):
    import numpy as np

    from vrsweep.execution.threads import available_threads

    if threads is None:
        return None
    # numpy's integers are whole numbers too (threads=np.int64(4) was refused as not one); its
    # booleans, like Python's, are not.
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, numbers.Integral) or threads < 1:
        raise UsageError.naming("{threads} must be a whole number of at least 1, got {value!r}", value=threads)
    threads = int(threads)
    available = available_threads()
    if threads > available:
        warnings.warn(f"threads={threads}: numba can run {available} thread{'s' if available != 1 else ''} here "
                      f"(NUMBA_NUM_THREADS or the CPUs this process may use); using {available}",
                      RuntimeWarning, stacklevel=3)
        return available
    return threads


# What a first run's notice says compiling takes (`vrsweep run` and the API's bar alike). The CPU's:
# a first sweep with an empty cache on 2 idle cores, 0.7.12 (benchmarks/compile_versions.py): 16 s
# rk45, 20 s with the tangent vectors, 28 s dop853; a loaded machine takes longer. The CUDA
# kernel's: 20 to 65 s on an H100's host (benchmarks/README.md, "GPU"; before 0.7.12's shorter
# inlining, which took its PTX 18 -> 13 s here).
COMPILE_SECONDS = "about 30 s"
GPU_COMPILE_SECONDS = "20 to 65 s"


def _progress_factory(config, bars):
    """run_job's progress_factory: a tqdm.auto bar (a widget in Jupyter, text on stderr elsewhere),
    whose label says when the kernel is being compiled first."""

    def factory(total, already_done):
        from tqdm.auto import tqdm

        from vrsweep.numerics.models import kernels_for

        label = "vrsweep"
        integration = config.integration
        if already_done < total and not kernels_for(config.model).is_cached(integration.method, integration.lyapunov,
                                                                              integration.device):
            label = (f"vrsweep (compiling the CUDA kernel first, {GPU_COMPILE_SECONDS})" if integration.device == "cuda"
                     else f"vrsweep (compiling the numba kernel first, {COMPILE_SECONDS})")
        bar = tqdm(total=total, initial=already_done, unit="pt", desc=label, dynamic_ncols=True)
        bars.append(bar)
        return bar.update

    return factory


# -- simulate --------------------------------------------------------------------------------


def simulate(config, *, output=None, samples_per_period=None, compare=None,
             overwrite=False, **overrides):
    """Integrate the config's single point densely, as ``vrsweep simulate`` does.

    Parameters
    ----------
    config : str, os.PathLike, dict or vrsweep.config.Config
        As for :func:`sweep`; it must describe one point: fix swept parameters with overrides
        (``g=5``).
    output : str or os.PathLike, optional
        Also keep the trajectory file (``vrsweep simulate -o``) here; without it nothing is
        written.
    samples_per_period : int, optional
        Samples of x and v per slow period 2 pi/omega (from the solver's dense output). Default:
        200, or 20 per cycle of the fastest force when that is more (as ``vrsweep simulate``).
    compare : None or "effective"
        ``"effective"``: also integrate the effective system (eq2.10) from the same initial state
        and reconstruct it from the slow flow (eq2.21, eq2.24), as ``--compare effective``.
    overwrite : bool
        Replace an existing ``output``.
    **overrides
        As for :func:`sweep`.

    Returns
    -------
    xarray.Dataset or dict of xarray.Dataset
        Without ``compare``: the Dataset of the config's model (the group ``open_results``
        opens by default): ``x``, ``v`` over ``time``; ``impact_t``, ``impact_v_before``,
        ``impact_v_after`` over ``impact``; ``stick_start``, ``stick_end`` over ``stick``;
        ``impacts_per_period``, ``strobe_x``, ``strobe_v`` over ``period``; the file's
        attributes and the run's ``status``/``status_name``.
        With ``compare="effective"``: a dict of every group of the file, ``{"original": ...,
        "effective": ..., "slow_flow/state": ..., "slow_flow/paper": ...,
        "slow_flow/paper_literal": ...}``, each a Dataset as above (a slow-flow group holds
        ``x``, ``v``, ``R``, ``theta`` over ``time``). All loaded into memory.
        ``vrsweep.plot.plot`` draws either as ``vrsweep plot`` draws the trajectory file.
    """
    from vrsweep.execution.simulate import check_single_point, simulate_point
    from vrsweep.store.fileio import output_target, prepare_output_directory
    from vrsweep.store.trajectory_file import write_trajectory

    _check_flags(overwrite=overwrite)
    if samples_per_period is not None:
        if isinstance(samples_per_period, bool) or not isinstance(samples_per_period, numbers.Integral):
            raise UsageError.naming("{samples_per_period} must be a whole number of at least 1, got {value!r}",
                                    value=samples_per_period)
        samples_per_period = int(samples_per_period)
    _check_path("output", output)
    resolved = resolve_config(config, overrides, keywords=_keywords(simulate))
    if compare is not None and compare not in COMPARE_CHOICES:
        raise UsageError.naming("{compare} {value}: must be None or one of {choices}",
                                value=repr(compare), choices=", ".join(map(repr, COMPARE_CHOICES)))
    with _python_wording():
        check_single_point(resolved)  # before compiling anything
        if output is not None:  # fileio's one rule, as vrsweep simulate: say so before integrating, not after
            inputs = (resolved.source_name,) if os.path.isfile(resolved.source_name) else ()  # never written over
            path = Path(output_target(output, overwrite=overwrite, inputs=inputs, inputs_are="the config being run",
                                      kind="trajectory"))
            prepare_output_directory(path)
        data = simulate_point(resolved, samples_per_period, compare_effective=compare == "effective")
        if output is not None:
            write_trajectory(path, data, resolved, overwrite=overwrite)
            return _trajectory_datasets(path, every_group=compare is not None)
        from vrsweep.store.fileio import scratch_folder

        with scratch_folder() as folder:
            path = Path(folder) / "trajectory.h5"
            write_trajectory(path, data, resolved)
            datasets = _trajectory_datasets(path, every_group=compare is not None)
    for dataset in (datasets.values() if isinstance(datasets, dict) else [datasets]):
        dataset.encoding.pop("source", None)
    return datasets


def _trajectory_datasets(path, every_group):
    from vrsweep.store.reading import _trajectory_groups, load_results

    if not every_group:
        return load_results(path)
    runs, slow, _ = _trajectory_groups(path)
    return {group: load_results(path, group) for group in runs + slow}


# -- theory ----------------------------------------------------------------------------------


def theory(config, **overrides) -> list[dict]:
    """The paper's analytic predictions for a config: what ``vrsweep theory --json`` prints.

    One dict per Omega of the config (and per value of any other swept parameter that enters the
    theory), with ``Omega``, ``g_res`` (eq3.4), ``wt2_range`` and ``K_range`` (eq2.11, eq2.12)
    over the config's g or g axis, ``peak_g``, ``peak_amplitude``, ``peak_gain`` (the largest
    stable amplitude of X and its gain A/c, ERRATA 6), ``notes`` and more: see
    :func:`vrsweep.analysis.theory.theory_rows`. A value that does not exist (g_res when
    alpha <= 0) is None. ``pandas.DataFrame(rows)`` makes a table of it.

    ``config`` and ``overrides`` as for :func:`sweep`.
    """
    from vrsweep.analysis.theory import theory_rows

    return theory_rows(resolve_config(config, overrides))
