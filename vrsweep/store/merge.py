"""Merge the shard files of one run into the file a single run would have written, streaming.

A merge never holds a shard, or the result, in memory:

1. Each shard file is opened and only its metadata is read (root attributes, axes, the type and
   shape of each variable): every shard must have the same ``config`` and the same layout.
2. The ``done`` masks are read one at a time to decide which shard supplies each point (the first
   one, in the order given, that has it done); a point done by several shards is a duplicate.
3. Points that no shard has done are an error naming the shard each belongs to (shards own points
   in a fixed shuffled order, ``vrsweep.execution.sweep.shard_of_points``), unless ``allow_missing``.
4. The output is written variable by variable, block by block: a block is a run of whole HDF5
   chunks of a few MiB; it is read from each shard that supplies points in it, those points are
   kept, duplicates are compared bit for bit with the supplier's values, and the block is written.

Peak memory is therefore start-up, a few blocks, a few bytes per grid point (which shard supplies
it) and the largest derived variable (a theory column, stored as one chunk), whatever the number of
shards; benchmarks/bench_merge.py measures it (benchmarks/README.md, "Merge"). The output is
written under a temporary name and renamed into place (``fileio.atomic_write``), so an error or a
signal leaves no partial file.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from vrsweep.errors import ResultFileError, UsageError, VrsweepError
from vrsweep.store.fileio import KIND_WORDS, LIBVER, NAMED_KINDS, atomic_write, stored_kind, open_hdf5, output_target, prepare_output_directory, writing_hdf5
from vrsweep.store.provenance import (
    RESULTS_CHANGE, RESULTS_SINCE_VERSION, cf_attributes, results_epoch, same_results_as_now,
)
from vrsweep.store.layout import RESERVED_ROOT_ATTRS, add_extras, build_skeleton, creation_reserve
from vrsweep.store.reader import StoredLayout, corrupt_error, open_checked
from vrsweep.store.writer import ARGUMENT_WORDS as _WRITER_WORDS
from vrsweep.store.writer import first_difference

# How messages name what the caller may do; `vrsweep merge` names its flags (commands/options.py).
ARGUMENT_WORDS = {**_WRITER_WORDS, "allow_missing": "allow_missing=True", "resume_into": "a resumed run"}

# Bytes of one variable per block: large enough that HDF5 calls are few, small enough that a few
# blocks are nothing beside the start-up of Python, numpy and h5py.
BLOCK_BYTES = 4 * 1024 * 1024
# Blocks are written as whole chunks, so the output needs no chunk cache either.
_WRITE_CACHE_BYTES = 0
_EXAMPLES = 3  # points named in a message
_GROUPS = 6    # shards named in a missing-points message


class MergeWriteError(VrsweepError):
    """The merged file could not be written (a runtime failure: exit 1)."""


@dataclass
class MergeReport:
    """What a merge found; ``str()`` is a short summary for the CLI."""

    out_path: str
    n_points: int
    n_done: int
    n_missing: int
    missing_examples: list
    n_duplicated: int
    shards: list  # (path, shard label or None, points done)
    warnings: list = field(default_factory=list)

    @property
    def complete(self) -> bool:
        return self.n_missing == 0

    def __str__(self):
        lines = [f"merged {len(self.shards)} shard(s) into {self.out_path}: "
                 f"{self.n_done} of {self.n_points} points"]
        if self.n_missing:
            lines.append(f"{self.n_missing} point(s) missing, e.g. {'; '.join(self.missing_examples)}"
                         " (the file is marked incomplete)")
        if self.n_duplicated:
            lines.append(f"{self.n_duplicated} point(s) computed by more than one shard "
                         "(identical values, kept once)")
        lines.extend(f"warning: {w}" for w in self.warnings)
        return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# One shard file: its metadata in memory, its data read block by block
# --------------------------------------------------------------------------------------------


class _Shard(StoredLayout):
    """A shard file: its layout in memory (StoredLayout), its data read on demand. Any damage found
    while reading is a ResultFileError naming the file (HDF5 chunks carry checksums).

    The file is open only while a block is read: HDF5 keeps a few hundred bytes for every chunk
    read from a file until the file is closed (about a tenth of the data read), so shards held
    open for the whole merge would make its memory grow with their number.
    """

    def __init__(self, path, stop):
        stop()
        self._stop = stop
        kind = stored_kind(path)
        if kind in NAMED_KINDS:  # open_checked says only that it is no sweep's: say what merge takes
            raise ResultFileError(f"{path} is {KIND_WORDS[kind]}, not a sweep's results: merge takes the result "
                                  "files of one sweep (those vrsweep run writes, whole or in shards)")
        f = open_checked(path, "r")
        try:
            super().__init__(path, f)
            self._identity = _identity(path)
            if not self.complete:
                self._refuse_torn_chunks(f)
        except ResultFileError:
            raise
        except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
            raise corrupt_error(path, error) from None
        finally:
            f.close()

    def _refuse_torn_chunks(self, f):
        """ResultFileError for an unfinished shard holding chunks whose write a kill cut (their
        checksums fail, store/torn.py): --resume repairs them (and computes again what it cannot
        recover); the merge reads chunks whole and would fail on them, or name no cause."""
        from vrsweep.store import torn

        recovery, _ = torn.find(f)
        if recovery is not None and recovery.n_torn:
            again = f" (computing again {recovery.n_lost} point(s) it cannot recover)" if recovery.n_lost else ""
            raise ResultFileError.naming(
                "{path} holds {n} chunk(s) whose write a kill cut (their checksums fail): resume that shard "
                "with {resume}, which repairs them{again}, then merge again", ARGUMENT_WORDS,
                path=self.path, n=recovery.n_torn, again=again)

    def read(self, name, selection=()):
        """``name[selection]`` as an array (the file opened for this read, with no chunk cache:
        blocks are whole chunks, each read once)."""
        try:
            with self._open() as f:
                return np.asarray(f[name][selection])
        except ResultFileError:
            raise
        except Exception as error:  # noqa: BLE001 - a failed checksum is an OSError, others vary
            raise corrupt_error(self.path, error) from None

    def _open(self):
        """The file, opened for one read, if it is still the file whose metadata was read (and the
        merge has not been asked to stop: every read is a point where it can)."""
        self._stop()
        if _identity(self.path) != self._identity:
            raise ResultFileError(f"{self.path} was changed or replaced while it was being merged")
        return open_hdf5(self.path, "r", rdcc_nbytes=0)

    def stored_digest(self, name):
        """SHA-256 of a variable as stored on disk (chunk checksums included), one chunk at a
        time: equal digests mean equal values, without decoding either whole variable."""
        digest = hashlib.sha256()
        try:
            with self._open() as f:
                ds = f[name]
                if ds.chunks is None:  # a 0-d variable: contiguous, and small
                    digest.update(np.asarray(ds[()]).tobytes())
                    return digest.hexdigest()
                for index in range(ds.id.get_num_chunks()):
                    offset = ds.id.get_chunk_info(index).chunk_offset
                    filter_mask, data = ds.id.read_direct_chunk(offset)
                    digest.update(repr((offset, filter_mask, len(data))).encode())
                    digest.update(data)
        except ResultFileError:
            raise
        except Exception as error:  # noqa: BLE001 - as in read()
            raise corrupt_error(self.path, error) from None
        return digest.hexdigest()

    def read_mask(self, name):
        return np.asarray(self.read(name), dtype=bool).reshape(self.shape)


def _identity(path):
    """What tells that a file is still the one first opened: not replaced, not written to."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def _layout_difference(a: _Shard, b: _Shard):
    if list(a.axes) != list(b.axes):
        return f"axes {list(b.axes)} instead of {list(a.axes)}"
    for name in a.axes:
        if a.axes[name].shape != b.axes[name].shape or a.axes[name].tobytes() != b.axes[name].tobytes():
            return f"different values of axis {name!r}"
    if a.point_variables != b.point_variables:
        return f"variables {list(b.point_variables)} instead of {list(a.point_variables)}"
    for name in a.point_variables:
        if (a.dtypes[name] != b.dtypes[name] or a.shapes[name] != b.shapes[name]
                or a.dims[name] != b.dims[name]):
            return f"variable {name!r} differs in type or shape"
    return None


# --------------------------------------------------------------------------------------------
# Blocks of grid points
# --------------------------------------------------------------------------------------------


def _blocks(grid_shape, chunk_shape, max_points):
    """Hyperslabs (tuples of slices) that cover the grid in C order, each whole HDF5 chunks.

    A block fixes the axes before a split axis, takes a range of the split axis (a multiple of
    its chunk length) and all of the axes after it, so that no chunk is cut and each is read once.
    The store's chunks hold whole trailing axes, part of one axis and one row of the leading ones
    (store._chunk_shape), so the split axis is never after the first axis a chunk spans more than
    one row of; it is the first one whose chunk rows fit ``max_points``.
    """
    n_axes = len(grid_shape)
    if n_axes == 0:
        yield ()
        return
    chunk_shape = tuple(chunk_shape[:n_axes]) if chunk_shape else (1,) * n_axes
    last_allowed = next((k for k in range(n_axes) if chunk_shape[k] > 1), n_axes - 1)
    split = last_allowed
    for k in range(last_allowed + 1):
        if chunk_shape[k] * math.prod(grid_shape[k + 1:]) <= max_points:
            split = k
            break
    inner = math.prod(grid_shape[split + 1:])
    rows = chunk_shape[split]
    step = max(rows, (max_points // max(inner, 1)) // rows * rows)
    tail = tuple(slice(0, n) for n in grid_shape[split + 1:])
    for lead in np.ndindex(*grid_shape[:split]):
        head = tuple(slice(i, i + 1) for i in lead)
        for start in range(0, grid_shape[split], step):
            yield head + (slice(start, min(start + step, grid_shape[split])),) + tail


# --------------------------------------------------------------------------------------------
# The merge
# --------------------------------------------------------------------------------------------


def merge_results(shard_paths: Iterable, out_path, overwrite=False, allow_missing=False,
                  stop=None) -> MergeReport:
    """Merge shard files of one config into a file identical to a single-process run.

    Checks that every shard has the same ``config`` (else ResultFileError naming the foreign
    shard) and the same layout; a point done in two shards is fine if its values are bit-for-bit
    identical and an error otherwise; refuses to write if any point is missing (naming the shard
    that owns it) unless ``allow_missing`` (the result is then marked incomplete and can be
    resumed). Writes ``out_path`` atomically; same variables and attributes as a single run
    (``created`` is the merge time; no ``shard``/``owned``).

    ``stop``: called before every read of a shard; whatever it raises (the CLI: a KeyboardInterrupt
    after SIGINT or SIGTERM) ends the merge, and the temporary file is removed.
    """
    paths = [os.fspath(p) for p in shard_paths]
    out_path = os.fspath(out_path)
    if not paths:
        raise UsageError("merge needs at least one shard file")
    given = out_path
    out_path = output_target(out_path, overwrite=overwrite, inputs=paths, inputs_are="one of the shards being merged",
                             kind="sweep", exists_error=lambda: UsageError.naming(
        "output {path} already exists: pass {overwrite} to replace it", ARGUMENT_WORDS, path=given))

    stop = stop or (lambda: None)
    paths, repeated = _each_file_once(paths)
    return _merge([_Shard(path, stop) for path in paths], out_path, allow_missing,
                  [f"{first} given {n} times (read once)" for first, n in repeated])


def _each_file_once(paths):
    """(the paths with each file once, in the order given; [(first path, times given)] of files given
    more than once). One file given twice (a shell glob and its name, ``./a.h5`` and ``a.h5``, a link)
    is one shard: read twice, it was counted as two ("merged 3 shard(s)") and its points as
    "computed by more than one shard"."""
    first, times = {}, {}
    for path in paths:
        try:
            stat = os.stat(path)
            key = (stat.st_dev, stat.st_ino)
        except OSError:  # missing or unreadable: _Shard says so, naming this path
            key = os.path.realpath(path)
        first.setdefault(key, path)
        times[key] = times.get(key, 0) + 1
    return list(first.values()), [(first[key], n) for key, n in times.items() if n > 1]


def _merge(shards, out_path, allow_missing, warnings=()):
    ref, found = _check_one_run(shards)
    warnings = [*warnings, *found]
    # Only now that the inputs are known to be one run's: a folder made for a merge that is then
    # refused would be left behind empty.
    prepare_output_directory(out_path)

    # Which shard supplies each point: the first, in the order given, that has it done.
    shape = ref.shape
    n_points = math.prod(shape)
    supplier = np.full(shape, -1, dtype=np.int32)
    n_done_by_shard = []
    duplicates = np.zeros(len(shards), dtype=np.int64)  # points shard k has that an earlier one had
    for k, s in enumerate(shards):
        done = s.read_mask("done")
        n_done_by_shard.append(int(done.sum()))
        duplicates[k] = int((done & (supplier >= 0)).sum())
        supplier[done & (supplier < 0)] = k
        del done
    merged_done = supplier >= 0
    missing = np.flatnonzero(~merged_done.reshape(-1))
    examples = [ref.point_label(i) for i in missing[:_EXAMPLES]]
    if missing.size and not allow_missing:
        raise ResultFileError.naming(_missing_points_message(shards, ref, missing, n_done_by_shard), ARGUMENT_WORDS)
    complete = missing.size == 0

    point_dims = {d for n in ref.point_variables for d in ref.dims[n][len(ref.axes):]}
    extra_coords = {d: (ref.coords[d], ref.coord_attrs[d]) for d in ref.coords if d in point_dims}
    root_attrs = {**_root_attributes(ref), **_solver_error(shards)}
    axes = [(name, values, ref.coord_attrs[name]) for name, values in ref.axes.items()]

    specs = ref.variable_specs()
    # Attractor labels (8 bytes a point at most) come from the whole grid, not from a shard.
    derived_bytes = _derived_bytes(shards) + 8 * n_points if complete else 0

    def write(tmp):
        # As ResultWriter.create: checksummed object headers, and the file's space allocated before
        # HDF5 writes (writing_hdf5), so a full disk is one clean error, never a crash in HDF5.
        with writing_hdf5(tmp, "w", reserve=creation_reserve(axes, specs), track_order=True,
                          libver=LIBVER) as out:
            build_skeleton(out, axes, specs, root_attrs, extra_coords, None)
        for name in ref.point_variables:  # reopened for each: see _Shard on HDF5's memory per chunk
            # Space allocated at creation: point values overwrite it in place.
            with writing_hdf5(tmp, "r+", rdcc_nbytes=_WRITE_CACHE_BYTES) as out:
                _merge_variable(out[name], name, shards, supplier, duplicates > 0, ref)
        with writing_hdf5(tmp, "r+", reserve=2 * derived_bytes + 64 * 1024 + 8192 * len(specs)) as out:
            out["done"][()] = merged_done.astype(np.int8)
            if complete:
                _copy_derived_variables(out, shards, ref, warnings)
                _add_attractor_labels(out, ref)
                out.attrs.modify("vrsweep_complete", np.int32(1))  # in place: keeps attribute order

    try:
        atomic_write(out_path, write)  # on any error or signal, removes the temporary file
    except OSError as error:  # full disk, quota, a folder gone: the shards' errors are ResultFileErrors
        raise MergeWriteError(f"cannot write {out_path}: {error.strerror or error}") from None
    except (ValueError, RuntimeError) as error:  # how h5py reports some HDF5 write failures
        raise MergeWriteError(f"cannot write {out_path}: {error}") from None
    return MergeReport(
        out_path=out_path, n_points=n_points, n_done=int(merged_done.sum()),
        n_missing=int(missing.size), missing_examples=examples, n_duplicated=int(duplicates.sum()),
        shards=[(s.path, s.shard, n) for s, n in zip(shards, n_done_by_shard)], warnings=warnings)


def _solver_error(shards):
    """R_solver_err of the merged file (execution/solver_error.py): the largest of the shards' bounds,
    measured on all their samples' points together."""
    found = [s.attrs for s in shards if "R_solver_err_points" in s.attrs]
    if not found:
        return {}
    merged = {"R_solver_err_points": np.int64(sum(int(a["R_solver_err_points"]) for a in found)),
              "R_solver_err_rtol": found[0].get("R_solver_err_rtol", np.nan)}
    bounds = [float(a["R_solver_err"]) for a in found if "R_solver_err" in a]
    if bounds:  # absent where no shard measured one, as in a whole run's file
        merged = {"R_solver_err": max(bounds), **merged}
    return merged


def _root_attributes(ref):
    """The merged file's root attributes: the reference shard's, but for those the store sets
    (``created``: the merge time) and the shard label; ``history`` gains the merge's line."""
    attrs = {k: v for k, v in ref.attrs.items() if k not in RESERVED_ROOT_ATTRS and k != "shard"}
    if "history" in attrs:  # CF: the merge adds its own line to the first shard's history
        attrs.update(cf_attributes(str(attrs.get("title", "")), history=str(attrs["history"]),
                                   references=str(attrs["references"]) if "references" in attrs else None))
    return attrs


def _run_of(config_text):
    """What of a stored config decides a shard's points: the text without its output and
    continuation sections (config.same_config's rule for --resume), so that shards whose config
    only named another output file still merge; a text that does not parse stands for itself."""
    import dataclasses

    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    try:
        config = parse_config(config_text, "<the stored config>")
    except ConfigError:
        return ("unparsed", config_text)
    return dataclasses.replace(config, output=None, continuation=None).to_yaml()


def _check_one_run(shards):
    """The reference shard (for layout and attributes) and the warnings; raises if the shards are
    not of one run."""
    # One config: the largest group of identical configs is the reference (ties: the first file),
    # so the message names the odd one out, not the innocent majority.
    groups = {}
    for s in shards:
        groups.setdefault(_run_of(s.attrs.get("config", "")), []).append(s)
    reference_run = max(groups, key=lambda c: (len(groups[c]), -shards.index(groups[c][0])))
    ref = groups[reference_run][0]
    reference_config = ref.attrs.get("config", "")
    foreign = [s for s in shards if _run_of(s.attrs.get("config", "")) != reference_run]
    if foreign:
        s = foreign[0]
        raise ResultFileError(
            f"{s.path} was written from a different config than {ref.path} "
            f"({first_difference(s.attrs.get('config', ''), reference_config)}); "
            f"{len(foreign)} of {len(shards)} shard(s) do not belong to this run")
    for s in shards:
        problem = _layout_difference(ref, s) if s is not ref else None
        if problem:
            raise ResultFileError(f"{s.path} does not have the layout of {ref.path}: {problem}")

    warnings = []
    labels = [s.shard for s in shards if s.shard]
    counts = {str(label).split("/")[-1] for label in labels}
    if len(counts) > 1:
        warnings.append(f"shard labels disagree on the number of shards: {', '.join(labels)}")
    _refuse_mixed_results(shards, ref)
    _check_shard_labels(shards, ref)
    for key in ("vrsweep_version", "numba_version", "numpy_version"):
        found = sorted({str(s.attrs.get(key)) for s in shards})
        if len(found) > 1:
            warnings.append(f"shards were written with different {key}: {', '.join(found)} "
                            f"(the merged file records {ref.attrs.get(key)})")
    return ref, warnings


def _results_epoch(shard):
    """The versions whose points a shard's are: "current" for RESULTS_SINCE_VERSION or later (they
    all compute the same points), else the version it records (each earlier one its own)."""
    written_by = shard.attrs.get("vrsweep_version")
    if same_results_as_now(written_by):
        return "current"
    return results_epoch(written_by) or str(written_by or "(unknown version)")


def _refuse_mixed_results(shards, ref):
    """ResultFileError when the shards were written by versions whose points differ (as --resume
    refuses to continue such a file): one file must not mix them."""
    epochs = {}
    for s in shards:
        epochs.setdefault(_results_epoch(s), s)
    if len(epochs) < 2:
        return
    older = next(s for epoch, s in epochs.items() if epoch != "current") if "current" in epochs else \
        next(s for s in epochs.values() if s is not ref)
    other = epochs["current"] if "current" in epochs else ref
    version = lambda s: s.attrs.get("vrsweep_version") or "an unknown version"  # noqa: E731
    raise ResultFileError(
        f"{older.path} was written by vrsweep {version(older)} and {other.path} by vrsweep {version(other)}, "
        f"whose points differ ({RESULTS_CHANGE} since {RESULTS_SINCE_VERSION}): "
        "one file must not mix them; run the older shards again with this version")


def _check_shard_labels(shards, ref):
    """ResultFileError for a shard whose label I/N was changed from the shard it is: its ``owned``
    mask is the run's own assignment (config.grid.shard_of_points) for shard J of N, J != I. It would
    otherwise be merged, and named in messages, as shard I (its attributes' checksum catches an edit
    too; this holds for files written before they had one). Masks that are no shard's of this
    config (made by hand) are left to the merge's own checks."""
    if not any(s.shard and s.has_owned for s in shards):
        return
    from vrsweep.config import parse_config
    from vrsweep.config.grid import Grid, shard_of_points
    from vrsweep.errors import ConfigError

    try:
        grid = Grid.from_config(parse_config(str(ref.attrs.get("config", "")), "<the stored config>"))
    except ConfigError:
        return  # a config this version cannot read: the layout checks are all there is
    if grid.shape != ref.shape:
        return
    owners = {}
    for s in shards:
        if not s.shard or not s.has_owned:
            continue
        index, _, count = str(s.shard).partition("/")
        index, count = int(index), int(count)  # reader.check_structure: digits/digits
        if count < 1 or count > grid.n_points:
            continue
        if count not in owners:
            owners[count] = shard_of_points(grid, count)
        owned = s.read_mask("owned")
        if np.array_equal(owned, owners[count] == index):
            continue
        actual = next((j for j in range(count) if np.array_equal(owned, owners[count] == j)), None)
        if actual is not None:
            raise ResultFileError(f"{s.path} says it is shard {s.shard}, but the points it owns are those of shard "
                                  f"{actual}/{count} of this config: its shard attribute was changed")


def _merge_variable(out, name, shards, supplier, may_duplicate, ref):
    """Copy one point variable into ``out`` block by block; duplicates must agree bit for bit."""
    grid_shape = supplier.shape
    extra_shape = tuple(out.shape[len(grid_shape):])
    point_bytes = out.dtype.itemsize * math.prod(extra_shape)
    conflicts, first_conflict = 0, None
    for block in _blocks(grid_shape, out.chunks, max(1, BLOCK_BYTES // point_bytes)):
        who = supplier[block].reshape(-1)
        if (who < 0).all():
            continue  # no shard has these points: they keep the fill value, as in a run
        # Points no shard has keep the fill value's bytes exactly as HDF5 wrote them.
        merged = None if (who >= 0).all() else np.asarray(out[block]).reshape((who.size,) + extra_shape)
        for k, s in enumerate(shards):
            supplies = who == k
            # Points this shard has too, supplied by an earlier one (so already in merged).
            twice = (np.flatnonzero(s.read("done", block).reshape(-1).astype(bool) & (who >= 0) & ~supplies)
                     if may_duplicate[k] else np.empty(0, dtype=np.int64))
            if not supplies.any() and twice.size == 0:
                continue
            values = s.read(name, block).reshape((who.size,) + extra_shape)
            if merged is None:
                merged = values if supplies.all() else np.empty_like(values)
            if merged is not values:
                merged[supplies] = values[supplies]
            if twice.size:
                # Compare bytes, not values: NaN must equal NaN, and -0.0 must not equal 0.0.
                a, b = merged[twice], values[twice]
                differs = np.any(a.view(np.uint8).reshape(twice.size, -1)
                                 != b.view(np.uint8).reshape(twice.size, -1), axis=1)
                if differs.any() and first_conflict is None:
                    i = int(np.argmax(differs))
                    first_conflict = (_grid_index(block, grid_shape, twice[i]), shards[who[twice[i]]], s, a[i], b[i])
                conflicts += int(differs.sum())
        out[block] = merged.reshape(_block_shape(block) + extra_shape)
    if conflicts:
        flat, supplied_by, also_in, a, b = first_conflict
        raise ResultFileError(
            f"{ref.point_label(flat)} was computed by both {supplied_by.path} and {also_in.path} with "
            f"different values of {name} ({a} vs {b}); {conflicts} point(s) conflict: were the "
            "shards run with different software versions?")


def _grid_index(block, grid_shape, at):
    """The flat grid index of the point at flat position ``at`` of ``block``."""
    if not block:
        return 0
    where = np.unravel_index(at, _block_shape(block))
    return int(np.ravel_multi_index(tuple(i + s.start for i, s in zip(where, block)), grid_shape))


def _block_shape(block):
    return tuple(s.stop - s.start for s in block)


def _same_bytes(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(
        a.reshape(-1).view(np.uint8), b.reshape(-1).view(np.uint8))


def _derived_bytes(shards):
    """Bytes of the derived variables that the merge will copy (from their stored types and
    shapes), for reserving space before HDF5 writes them."""
    with_extras = [s for s in shards if s.derived_variables]
    if not with_extras:
        return 0
    source = with_extras[0]
    return sum(int(np.prod(source.shapes[name], dtype=np.int64)) * source.dtypes[name].itemsize
               for name in source.derived_variables)


def _add_attractor_labels(out, ref):
    """A sweep over the initial state gets its attractor labels from the whole grid, as a single
    run's finish does (a shard sees only part of each slice, so shards carry none)."""
    from vrsweep.analysis import attractors
    from vrsweep.config import parse_config

    if not attractors.has_initial_state_axes(tuple(ref.axes)):
        return
    config = parse_config(str(ref.attrs["config"]))
    add_extras(out, *attractors.attractor_extras_from_file(out, config.integration.period_tolerance,
                                                            config.model if config.written else None))


def _copy_derived_variables(out, shards, ref, warnings):
    """Derived variables (theory columns) from the first finished shard that has them, one at a
    time; the others' must agree, or a warning says whose were kept."""
    with_extras = [s for s in shards if s.derived_variables]
    if not with_extras:
        return
    source = with_extras[0]
    point_dims = set(ref.axes) | {d for n in ref.point_variables for d in ref.dims[n]}
    differing = set()
    for name in source.derived_variables:
        array = source.read(name)
        digest = source.stored_digest(name)
        for other in with_extras[1:]:
            if name not in other.dtypes or other.dtypes[name] != array.dtype or other.shapes[name] != array.shape:
                differing.add(other.path)
            elif other.stored_digest(name) != digest and not _same_bytes(other.read(name), array):
                differing.add(other.path)  # stored differently (another version?) and different
        coords = {d: (source.coords[d], source.coord_attrs[d])
                  for d in source.dims[name] if d not in point_dims}
        add_extras(out, {name: (array, source.dims[name], source.var_attrs[name])}, coords)
        del array
    for other in with_extras[1:]:
        if other.path in differing or set(other.derived_variables) != set(source.derived_variables):
            warnings.append(f"derived variables of {other.path} differ from {source.path}; "
                            f"kept those of {source.path}")


# --------------------------------------------------------------------------------------------
# Missing points: whose are they?
# --------------------------------------------------------------------------------------------


def _missing_points_message(shards, ref, missing, n_done_by_shard):
    """'N of M points are missing from the shards: n (g=..; ..) owned by shard i/N (file, not
    given); ...', from the run's own assignment of points to shards when it can be recomputed.

    A template for ResultFileError.naming: {allow_missing} and {resume} are what the caller may
    do, everything else is literal (braces doubled)."""
    n_points = math.prod(ref.shape)
    head = f"{missing.size} of {n_points} points are missing from the shards: "
    tail = ("; run or resume those shards, then merge again (or pass {allow_missing} to write an "
            "incomplete file that {resume_into} completes)")

    def examples(points):
        more = "; ..." if points.size > _EXAMPLES else ""
        return _literal("; ".join(ref.point_label(i) for i in points[:_EXAMPLES]) + more)

    def given_shard(s, n_owned):
        n_done = n_done_by_shard[shards.index(s)]
        return f"{_literal(s.path)}, which finished {n_done} of its {n_owned} points: resume it with {{resume}}"

    ownership = _run_ownership(shards, ref)
    groups = []
    if ownership is not None:
        owner, count = ownership
        missing_owner = owner[missing]
        by_index = {_shard_index(s): s for s in reversed(shards) if _shard_index(s) is not None}
        for index in np.unique(missing_owner):
            points = missing[missing_owner == index]
            s = by_index.get(int(index))
            where = (given_shard(s, int((owner == index).sum())) if s is not None
                     else f"{_literal(_sibling_path(shards, int(index), count) or 'its file')}, not given")
            groups.append((points.size, f"{points.size} ({examples(points)}) owned by shard "
                                        f"{index}/{count} ({where})"))
    else:  # the files do not say how the run assigned points: what their 'owned' masks say
        claimed = np.zeros(missing.size, dtype=bool)
        for s in shards:
            if not s.has_owned:
                continue
            owned = s.read_mask("owned").reshape(-1)
            mine = owned[missing] & ~claimed
            claimed |= mine
            if mine.any():
                points = missing[mine]
                groups.append((points.size, f"{points.size} ({examples(points)}) owned by shard "
                                            f"{_literal(s.shard)} ({given_shard(s, int(owned.sum()))})"))
        if not claimed.all():
            points = missing[~claimed]
            if any(s.has_owned for s in shards):
                labels = _literal(", ".join(str(s.shard) for s in shards if s.shard) or "none")
                whose = (f"belong to no shard given (shards given: {labels}); is a shard file "
                         "missing from the list?")
            else:
                whose = "were computed by none of the files given"
            groups.append((points.size, f"{points.size} ({examples(points)}) {whose}"))
    shown = [text for _, text in groups[:_GROUPS]]
    if len(groups) > _GROUPS:
        rest = sum(n for n, _ in groups[_GROUPS:])
        shown.append(f"{rest} more in {len(groups) - _GROUPS} more shard(s)")
    return head + "; ".join(shown) + tail


def _literal(text):
    """``text`` as literal text of a message template (ResultFileError.naming)."""
    return str(text).replace("{", "{{").replace("}", "}}")


def _shard_index(s):
    """I of the label "I/N", or None."""
    try:
        return int(str(s.shard).split("/")[0]) if s.shard else None
    except ValueError:
        return None


def _run_ownership(shards, ref):
    """(the shard of every point, flat; the number of shards) as the run assigned them, or None.

    Recomputed from the config (the shuffled order of vrsweep.execution.sweep.shard_of_points), so that
    points of a shard that is not given can be attributed too; trusted only if it agrees with the
    ``owned`` mask of every shard given.
    """
    labels = [str(s.shard) for s in shards if s.shard]
    counts = {label.split("/")[-1] for label in labels}
    if not labels or len(counts) != 1 or len(labels) != len(shards):
        return None
    try:
        count = int(counts.pop())
        from vrsweep.config import parse_config
        from vrsweep.config.grid import Grid, shard_of_points

        grid = Grid.from_config(parse_config(ref.attrs.get("config", "")))
        if grid.shape != ref.shape:
            return None
        owner = shard_of_points(grid, count).reshape(-1)
    except Exception:  # noqa: BLE001 - only a hint for a message: a config this version cannot parse
        return None
    for s in shards:
        index = _shard_index(s)
        if index is None or not 0 <= index < count or not s.has_owned:
            return None
        if not np.array_equal(s.read_mask("owned").reshape(-1), owner == index):
            return None
    return owner, count


def _sibling_path(shards, index, count):
    """The file name shard ``index`` of ``count`` has beside the given ones (run --shard names
    them OUT.shardIofN.h5), or None if the given files are not named that way."""
    for s in shards:
        directory, base = os.path.split(s.path)
        match = re.fullmatch(r"(.*)\.shard[0-9]+of([0-9]+)(\.[^.]*)?", base)
        if match and int(match.group(2)) == count:
            return os.path.join(directory, f"{match.group(1)}.shard{index}of{count}{match.group(3) or ''}")
    return None


__all__ = ["merge_results", "MergeReport", "MergeWriteError", "BLOCK_BYTES"]
