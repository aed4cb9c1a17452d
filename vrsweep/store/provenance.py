"""Where a result file comes from: the CF-1.10 global attributes every vrsweep file carries.

``Conventions``, ``title``, ``history``, ``source``, ``references`` and ``date_created`` are the
attributes CF and ACDD readers look for (they sit beside vrsweep's own ``config``,
``vrsweep_version``... which stay as they were). ``history`` is the UTC time and the exact
command line that wrote the file; a merge appends its own line, as CF asks.

The command line is what the ``vrsweep`` program was given (:func:`record_command_line`, called
by the CLI before a command runs); a file written from Python says so instead.
"""

from __future__ import annotations

import datetime
import shlex
import sys

CONVENTIONS = "CF-1.10"
REFERENCES = ("S. Roy and S. Gupta, \"Vibrational resonance in vibro-impact oscillator through "
              "fast harmonic excitation\", International Journal of Non-Linear Mechanics "
              "(arXiv:2407.17849); "
              "corrections in vrsweep's docs/errata.md")
WRITTEN_REFERENCES = ("a model written in the config (the model_definition attribute), integrated by vrsweep's "
                      "Dormand-Prince kernels with impact location (vrsweep's docs/models.md)")

_command_line: str | None = None


def record_command_line(args) -> None:
    """Remember the arguments of this ``vrsweep`` invocation, for ``history``."""
    global _command_line
    _command_line = shlex.join(["vrsweep", *[_utf8_text(a) for a in args]])


def _utf8_text(argument) -> str:
    """An argument as text HDF5 can store (UTF-8). Under LC_ALL=C, or for a file name that is not
    UTF-8, Python holds its bytes as lone surrogates, which no UTF-8 attribute can take: the bytes
    are read again as UTF-8 (a UTF-8 name under LC_ALL=C comes out as typed), and any that are not
    are written as \\xNN escapes."""
    return str(argument).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def command_line() -> str:
    """The recorded ``vrsweep ...`` command, or the Python program that called the library."""
    if _command_line is not None:
        return _command_line
    return "python " + shlex.join(_utf8_text(a) for a in sys.argv) + " (vrsweep library)"


def utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def source() -> str:
    import numpy

    from vrsweep import __version__

    return f"vrsweep {__version__} (numba {numba_version()}, numpy {numpy.__version__})"


def numba_version() -> str:
    """numba's version, without importing numba where nothing else has: a merge (or any command
    that computes nothing) needs its version for the ``source`` attribute, and importing it cost
    the merge 45 MiB of its peak. The installed distribution's version is the one numba reports."""
    numba = sys.modules.get("numba")
    if numba is not None:
        return numba.__version__
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("numba")
    except PackageNotFoundError:  # not installed as a distribution (a source tree on the path)
        import numba

        return numba.__version__


def cf_attributes(title: str, history: str | None = None, model="original", references: str | None = None) -> dict:
    """The CF global attributes of a new file; ``history`` continues an earlier one (merge), whose
    ``references`` it keeps. A written model's file does not cite the paper, whose system it is not."""
    now = utc_now()
    line = f"{now} {command_line()}"
    return {
        "Conventions": CONVENTIONS,
        "title": title,
        "history": f"{history}\n{line}" if history else line,
        "source": source(),
        "references": references or (REFERENCES if isinstance(model, str) else WRITTEN_REFERENCES),
        "date_created": now,
    }


WRITTEN = "written"  # the ``model`` attribute and trajectory group of a model written in the config


def model_key(model) -> str:
    """What files call a model: ``original``, ``effective``, or ``written`` (whose equations are in
    the ``model_definition`` attribute and in the stored config)."""
    return model if isinstance(model, str) else WRITTEN


def model_attributes(model) -> dict:
    """The file attributes that say which model ran: ``model`` (model_key) and, for a written one,
    ``model_name`` and ``model_definition`` (the model as the config writes it, JSON)."""
    if isinstance(model, str):
        return {"model": model}
    import json

    return {"model": WRITTEN, "model_name": model.title,
            "model_definition": json.dumps(model.as_data(), sort_keys=False)}


RESULT_EPOCHS = (
    ("0.2.0", "impacts are decided on each step's interpolant"),
    ("0.6.0", "R of a quasi-periodic point is a weighted Birkhoff average"),
    ("0.7.0", "a periodic point's impacts_per_period and lyapunov are its orbit's, over its last whole cycles"),
    ("0.7.1", "a periodic point's R spans whole cycles of its response frequency too, 0 at no harmonic of it, and "
              "the lyapunov of an orbit with complex multipliers is log|mu|/(pT) from its log areas"),
    ("0.7.2", "R_err is the spread of |Q| divided by c once (its last digits), and a written model's stuck mass "
              "is released on a scan of its fastest force"),
    ("0.7.3", "a rebound whose flight rises less than 16 ulps of the stop's position sticks, and a written model's "
              "force counts the frequencies of its products and powers"),
    ("0.7.4", "a written model's kinks (abs, min, max of the state) are located as events"),
    ("0.7.5", "a written model's jumps (sign) are located as events too, and the steps around a kink or jump hold "
              "its side (a frozen mode)"),
    ("0.7.6", "a written model's tangent vectors jump by the saltation matrix where its force jumps (sign): the "
              "lyapunov of such models changes"),
    ("0.7.7", "a written model's mass slides on a jump of its force at v = c (stick-slip, Filippov) where it ended "
              "`sliding`, a step rejected beside a surface is retried on its side, and a complex-pair orbit's "
              "lyapunov_err is its stored exponent's band"),
    ("0.7.8", "a written model's mass that leaves a slide on a short step goes on where it ended `sliding`"),
    ("0.7.9", "a written model's mass that arrives where both fields point into a sliding surface slides from its "
              "arrival, and its slide's exit scan shortens where the sliding margin falls: short sticks and short "
              "pulls were stepped over"),
    ("0.7.10", "a sliding model's n_rhs counts the two fields evaluated at each slide's start"),
    ("0.7.14", "a written model's fractional power of a kinked quantity (Hertz's max(x - d, 0)**1.5, "
               "sqrt(abs(x))) is 0 beyond its surface in the steps that hold a side, where it was NaN, and "
               "constant multiples of a switching function are one surface (v and -2*v flipped as two)"),
    ("0.7.18", "a stuck mass is let go where the force at rest on its stop pulls it away, not where that force "
               "only touches zero (the bouncing ball at Gamma = 1 was let go at each period's end), a mass laid on a "
               "stop under no force is stuck, and a slide ends where a field leads away from its surface, not where "
               "one only turns tangent"),
)
"""The versions from which points changed, and why: 0.2.0 decides impacts on each step's dense
output (Bernstein form) and takes longer steps on the effective model, so a point of an earlier
version differs at the tolerance's level; 0.6.0 measures R (and R_err) of quasi-periodic points
by weighted Birkhoff averages (analysis/motion.py) and adds ``motion``; 0.7.0 takes a periodic
point's impacts_per_period and lyapunov over its last whole cycles, as R, a written model's R as
|Q| / |scale|, and a written model's forcing period from every frequency of its forces; 0.7.1
reads a written model's R at a periodic point over whole cycles of both its motion and its
response frequency w (0 where w is no harmonic of the orbit), on branches too, and the lyapunov of
a periodic orbit whose multipliers are a complex pair as log|mu|/(pT) from its exact log areas
(the paper's models too); 0.7.2 takes R_err from the spread of |Q| and divides by |c| once (R's
own squared deviations overflowed at c = 1e-300; every R_err may differ in its last digits, 2.6e-15
at most on a 400-point map), and releases a written model's stuck mass on a scan of 1/64 of its
fastest force's period (max_step/8 stepped over short pulls); 0.7.3 sticks a rebound whose flight
v^2/2a rises less than 16 ulps of max(1, |position|) (kernel.STICK_HEIGHT: a stiff chatter's tail
was decided by rounding, 178 against 181-186 impacts a period for one orbit), in every model, and
finds a written force's frequencies in its products and powers (cos(omega t)**9 holds 9 omega: the
release scan and the forcing's period q follow); 0.7.4 ends a step on each kink of a written
acceleration (abs, min, max of x, v or t: codegen.switching_functions), where it stepped over them
(a bilinear spring's R 1.5e-6 off at rtol 1e-6; the paper's models have none and are unchanged
bit for bit); 0.7.5 locates the jumps of sign too, holds each switch's side for all the stages of
the steps that end on a surface and leave it (the frozen mode: a stage a rounding across it was an
error of the jump times the step, in friction's force and in the tangents' Jacobian at a kink, so
lambda_1 of a bilinear spring scattered by 1e-6), and ends a sliding motion with the status
sliding; the paper's models have no switches and are unchanged bit for bit; 0.7.6 jumps the
tangent vectors by the saltation matrix where a written force jumps (friction's lambda_1 was the
damping's -zeta alone, 1.5e-2 off; kinks and the paper's models unchanged bit for bit); 0.7.7 follows a written model's sliding
motion on a jump at v = c (friction on a floor or a belt: the point ended `sliding` at its first
stick) and retries a step rejected beside a surface frozen on its side (the steps crept up to a
stick for millions of steps; models that never reach one are unchanged bit for bit, the paper's
too), and takes a periodic orbit's lyapunov_err, where its multipliers are a complex pair, from
the batches of the exponent it stores (half the log area), not of one vector's stretch (0.026
about an exact -0.03 on a bilinear spring; the paper's models too); 0.7.8 lets a mass that leaves a
slide on a short step, its end on the surface to rounding, go on to the side whose force leads away
(such a point ended `sliding` a few sticks in: 29 of 992 belt runs at rtol 1e-6 to 1e-10; the
paper's models unchanged bit for bit); 0.7.9 makes Filippov's test at a mass's arrival on a sliding
surface, where both fields are known: near the sliding region's edge the field of the side crossed
to turns within the next step, which ended on the side it started, and the stick was stepped over
with status ok (belt friction at omega 1.5, mu 0.72: dop853 logged 27 to 38 sticks of 52, x off by
2e-3), and shortens the scan for a slide's exit where the margin of the sliding condition falls (on a
fast belt a double-well spring's short pull past mu was stepped over: the exit at t = 0.46 for
0.207); every sliding model's step counts change; the paper's models unchanged bit for bit; 0.7.10 counts in
n_rhs the two fields a slide's exit scan evaluates at the slide's start (a sliding model's n_rhs
was 2 short per slide; every other result unchanged bit for bit); 0.7.14 takes a written model's
fractional power b**p of a kinked quantity as 0 where b < 0 in the steps that hold a side (the
stages a rounding beyond its surface computed NaN: every point of a Hertzian contact
max(x - d, 0)**1.5 ended non_finite at its first contact; codegen.held_in_domain), and every
model without such a power is unchanged bit for bit, its generated code the same text; it also takes
constant multiples of a switching function as one surface (a nested max of x + k*v had the surfaces
-v, -2*v, ..., each a bit of the frozen mode, flipping together as a corner; only models with two such
switches change); 0.7.18 lets a stuck mass go where the force at rest on its stop is negative, not
where it is zero (impact.release_time: the bouncing ball's 1 - cos t at Gamma = 1 is 0 at the
double nearest 2 pi, where each period's scan ends, so the ball lying on the table was let go
there and met it again at speed 0, 1.28 impacts a period; a start at rest on a stop under no force
is stuck from t = 0, where it flew and met the stop at speed 0), and ends a slide where a side's field
leads away from the surface, not where it is tangent (kernel._sliding_exit: dry friction mu sign(v)
against F cos t at F = mu let the resting mass go at each period's end); the paper's models, and
every force that changes sign where no scan lands on its zero, unchanged bit for bit. Versions of one epoch
compute the same points; one file must not mix epochs (a resume, a merge). Add an epoch whenever
a change of the numerics or of the estimators changes results."""
RESULTS_SINCE_VERSION, RESULTS_CHANGE = RESULT_EPOCHS[-1]
"""The first version whose points this one reproduces, and what changed then."""


def version_tuple(text):
    """'0.4.0' -> (0, 4, 0); None for anything that is not a version."""
    try:
        return tuple(int(part) for part in str(text).split(".")[:3])
    except ValueError:
        return None


def results_epoch(written_by):
    """The first version of the epoch (RESULT_EPOCHS) whose points vrsweep ``written_by`` (a
    version, as text) computes; None for an unknown version or one before the first epoch."""
    found = version_tuple(written_by) if written_by is not None else None
    if found is None:
        return None
    epoch = None
    for since, _ in RESULT_EPOCHS:
        if found >= version_tuple(since):
            epoch = since
    return epoch


def same_results_as_now(written_by) -> bool:
    """Whether points written by vrsweep ``written_by`` (a version, as text; None: unknown) are
    those this version computes (RESULTS_SINCE_VERSION or later)."""
    return results_epoch(written_by) == RESULTS_SINCE_VERSION


