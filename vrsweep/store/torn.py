"""Chunks whose write a kill cut: finding them in an unfinished file, and what can be recovered.

Why this exists
---------------
Point variables are allocated whole when a file is created and each HDF5 chunk (a few kB, with a
fletcher32 checksum at its end) is rewritten in place whenever a point in it is written. The
system writes a chunk page by page, so a ``kill -9`` (or a node failure) in the middle of that
write can leave a chunk part new and part old: a *torn* chunk, whose checksum fails, so HDF5
refuses to read any of it, the points finished before among them. ``--resume`` refused the whole
file ("filter returned failure during read").

What a torn chunk still holds
-----------------------------
The writer rewrites a chunk as read-modify-write: every point already in it is written back with
the very bytes it had, and the points being written are marked ``done`` only after their values
were flushed and fsynced (``writer.write_points``). So in a torn chunk of a point variable the
points marked done hold their own values, whichever half of the write reached them; only the
points not done (the write in flight) may be half new. The chunk as it was before the cut write is
therefore the torn bytes with the points not done set back to their fill value; when the checksum
stored at the chunk's end (the old one: the write goes from the chunk's start to its end) is that
chunk's, the recovery is exact and verified, and nothing is lost. When it is not (the points not
done held values of an earlier write cut by a kill, or the damage is something else), the points
of the chunk are not trusted: their ``done`` flags are cleared and they are computed again.

A torn chunk of ``done`` is not read from its bytes: they cannot be checked (the points whose
flags were in flight are unknown, so the chunk as it was cannot be rebuilt to test its checksum),
and a flipped bit would be taken as a flag (a point marked done over values half written, with
status -1, finished so). Its flags are made again from another record: ``status``, which the writer
writes last of a point's values, after the others were flushed (``writer.write_points``), and
whose fill value -1 no computed point has. A point of a torn ``done`` chunk is done where its
``status`` reads back through its checksum and is not -1: then every value of it was written
before, whether its flag was (a kill between a point's values and its flag leaves such points,
computed whole). Where ``status`` cannot be read either (its chunk fails too: two records cut at
once are damage, not a kill), the points are computed again. A file without ``status`` (a writer's
own variables, no sweep's) has no such record, and the points of a torn ``done`` chunk are
computed again.

Only an unfinished file is read this way: a finished file must read back whole through every
checksum (reader.check_structure), and a failing chunk there is damage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import h5py
import numpy as np

from vrsweep.store.layout import point_label, point_variables_of, scale_names

CHECKSUM_BYTES = 4  # fletcher32, after the chunk's data
# The variable written last of a point's values, after the others were flushed: a value other than
# its fill says the point's values are all on disk (writer.write_points); it vouches for the
# points of a torn chunk of done.
COMPLETION = "status"
# Bytes read at a time while looking for failing chunks (reader.CHECK_BLOCK_BYTES's reason).
SCAN_BLOCK_BYTES = 4 * 2 ** 20


def _offset(selection, chunks):
    """The offset of the chunk that holds the start of ``selection`` (a tuple of slices)."""
    return tuple(s.start // c * c for s, c in zip(selection, chunks))


def _chunk_slices(ds, offset):
    """The part of the chunk at ``offset`` that lies inside the dataset."""
    return tuple(slice(o, min(o + c, n)) for o, c, n in zip(offset, ds.chunks, ds.shape))


def failing_chunks(ds, keep=False, seen=None):
    """The offsets of the chunks of ``ds`` that fail their checksum, in file order; with ``keep``,
    also the dataset's values (its fill value in those chunks). One read of the dataset, a few MiB
    at a time; only a block that fails is read again chunk by chunk. ``seen(selection, values)`` is
    called with every part that reads."""
    values = np.full(ds.shape, ds.fillvalue, dtype=ds.dtype) if keep else None
    if ds.chunks is None or not ds.fletcher32:
        data = ds[()]
        if keep:
            values[...] = data
        if seen is not None:
            seen(tuple(slice(0, n) for n in ds.shape), np.asarray(data))
        return [], values
    row_bytes = max(1, ds.dtype.itemsize * math.prod(ds.shape[1:]))
    step = max(ds.chunks[0], SCAN_BLOCK_BYTES // row_bytes // ds.chunks[0] * ds.chunks[0])
    failing = []
    for start in range(0, ds.shape[0], step):
        block = (slice(start, min(start + step, ds.shape[0])),) + tuple(slice(0, n) for n in ds.shape[1:])
        try:
            data = ds[block]
        except OSError:
            for piece in ds.iter_chunks(block):
                try:
                    data = ds[piece]
                except OSError:
                    failing.append(_offset(piece, ds.chunks))
                    continue
                if keep:
                    values[piece] = data
                if seen is not None:
                    seen(piece, data)
            continue
        if keep:
            values[block] = data
        if seen is not None:
            seen(block, data)
    return failing, values


def _raw_chunk(ds, offset):
    """The chunk's stored values (the whole chunk, edges included) and its stored checksum."""
    _, raw = ds.id.read_direct_chunk(offset)
    data = np.frombuffer(raw[:-CHECKSUM_BYTES], dtype=ds.dtype)
    if data.size != math.prod(ds.chunks):  # not a chunk as vrsweep stores them (compressed?)
        return None, None
    return data.reshape(ds.chunks).copy(), raw[-CHECKSUM_BYTES:]


def chunk_bytes(ds, array):
    """The bytes HDF5 stores for a chunk of ``ds`` holding ``array`` (the whole chunk), checksum
    included: made by HDF5 itself, in a file in memory with the same chunk layout."""
    with h5py.File(f"vrsweep-chunk-{id(array)}", "w", driver="core", backing_store=False) as scratch:
        copy = scratch.create_dataset("chunk", shape=ds.chunks, dtype=ds.dtype, chunks=ds.chunks, fletcher32=True)
        copy[()] = array
        return copy.id.read_direct_chunk((0,) * len(ds.chunks))[1]


def _is_fill(values, fill):
    if isinstance(fill, float) or np.issubdtype(np.asarray(fill).dtype, np.floating):
        if np.isnan(fill):
            return np.isnan(values)
    return values == fill


@dataclass
class Recovery:
    """What an unfinished file holds where a kill cut a chunk's write.

    torn: {variable: [chunk offsets]} of the chunks that fail their checksum; done: the ``done``
    flags to trust (a torn chunk of ``done`` made again from ``status``, the points of a chunk that could
    not be recovered cleared); chunks: {variable: {offset: the whole chunk to store}}; lost: the
    points that were marked done but whose values (or flag) cannot be trusted: computed again.
    """

    torn: dict
    done: np.ndarray
    chunks: dict = field(default_factory=dict)
    lost: np.ndarray = None
    recovered: int = 0  # done points of torn chunks whose values were recovered, verified
    stale: np.ndarray = None  # points not done that hold values (a write its kill stopped before its flags)
    examples: list = field(default_factory=list)  # labels of the first points lost (g=1.5, Omega=4)

    def __post_init__(self):
        if self.lost is None:
            self.lost = np.zeros(self.done.shape, dtype=bool)
        if not self.chunks:
            self.chunks = {name: {} for name in self.torn}

    @property
    def n_torn(self):
        return sum(len(offsets) for offsets in self.torn.values())

    @property
    def n_lost(self):
        return int(np.count_nonzero(self.lost))

    def describe(self, path, reading=False):
        """One line: what was cut, and what is computed again (``reading``: what a reader shows)."""
        # A reader may open a file a live run is writing (HDF5_USE_FILE_LOCKING=FALSE) and catch a
        # chunk mid-write: it cannot tell that from a kill, so it names both.
        cause = "a kill, or the run still writing the file," if reading else "a kill"
        what = (f"{path}: {cause} cut the write of {self.n_torn} chunk(s) of "
                f"{', '.join(name for name, offsets in self.torn.items() if offsets)} (their checksums fail)")
        checked = f"{self.recovered} point(s) done before recovered, checked against the chunks' checksums"
        if not self.n_lost:
            return f"{what}: every point done before is recovered, checked against the chunks' checksums"
        more = ", ..." if self.n_lost > len(self.examples) else ""
        unreadable = (f"{self.n_lost} point(s) that may have been done cannot be read back "
                      f"({'; '.join(self.examples)}{more})")
        then = ("they read as not computed (resuming the run computes them again)" if reading
                else "they are computed again")
        return f"{what}: {unreadable}, {then}" + (f"; {checked}" if self.recovered else "")


def find(f, keep=False):
    """(Recovery or None if every chunk reads, {variable: values} with ``keep``) of the open file ``f``.

    With ``keep`` every point variable and ``done`` is read whole (a reader of an unfinished file),
    recovered chunks in place; without, only failing chunks are remembered (the writer's resume).
    """
    names = ("done",) + point_variables_of(f)
    done_ds = f["done"]
    grid_ndim = done_ds.ndim
    torn, values = {}, {}
    torn["done"], values["done"] = failing_chunks(done_ds, keep=True)
    written = np.asarray(values["done"]) == 1  # as read: a torn chunk of done reads as not done
    # Values of points not done: a write that a kill stopped before its flags. Put back to their
    # fill value on resume, so that the chunk as it was is always "points done, and fill".
    stale = np.zeros(done_ds.shape, dtype=bool)

    def seen(selection, data):
        grid = selection[:grid_ndim]
        blank = _is_fill(np.asarray(data), ds.fillvalue)
        if blank.ndim > grid_ndim:
            blank = blank.reshape(blank.shape[:grid_ndim] + (-1,)).all(axis=-1)
        stale[grid] |= ~blank & ~written[grid]

    for name in names[1:]:
        ds = f[name]
        # status is kept whole (1 byte a point, as done): it rebuilds a torn chunk of done
        torn[name], values[name] = failing_chunks(ds, keep or name == COMPLETION, seen=None if keep else seen)
    if not any(torn.values()):
        return (Recovery(torn=torn, done=written, stale=stale) if stale.any() else None), values
    done = np.asarray(values["done"], dtype=np.int8)
    lost = np.zeros(done.shape, dtype=bool)
    chunks = {name: {} for name in names}
    if torn["done"]:
        if COMPLETION in names:
            status_ds = f[COMPLETION]
            # status as read (a failing chunk holds its fill value), and which points it could not tell
            complete = ~_is_fill(np.asarray(values[COMPLETION]), status_ds.fillvalue)
            unknown = _in_chunks(status_ds, torn[COMPLETION])
        for offset in torn["done"]:
            where = _chunk_slices(done_ds, offset)
            if COMPLETION in names:
                done[where] = complete[where] & ~unknown[where]
                lost[where] = unknown[where]
            else:
                lost[where] = True
                done[where] = 0
            chunks["done"][offset] = None  # written from the final flags below
    kept = np.zeros(done.shape, dtype=bool)  # done points of chunks recovered exactly
    for name in names[1:]:
        ds = f[name]
        for offset in torn[name]:
            where = _chunk_slices(ds, offset)
            grid = where[:grid_ndim]
            inside = tuple(slice(0, s.stop - s.start) for s in where)
            stored, checksum = _raw_chunk(ds, offset)
            flags = done[grid].astype(bool)
            if stored is not None:
                candidate = stored.copy()
                part = candidate[inside]
                part[~flags] = ds.fillvalue  # the points in flight, back to what they were
                candidate[inside] = part
                if chunk_bytes(ds, candidate)[-CHECKSUM_BYTES:] == checksum:
                    chunks[name][offset] = candidate
                    kept[grid] |= flags
                    if keep:
                        values[name][where] = part
                    continue
            # Not the chunk as it was: none of its points is trusted.
            lost[grid] |= flags
            done[grid] = 0
            chunks[name][offset] = np.full(ds.chunks, ds.fillvalue, dtype=ds.dtype)
            if keep:
                values[name][where] = ds.fillvalue
    recovered = int(np.count_nonzero(kept & (done == 1)))
    for offset in chunks["done"]:
        array = np.zeros(done_ds.chunks, dtype=np.int8)
        where = _chunk_slices(done_ds, offset)
        array[tuple(slice(0, s.stop - s.start) for s in where)] = done[where]
        chunks["done"][offset] = array
    if keep:
        values["done"] = done
    done = done.astype(bool)
    axes = {name: f[name][()] for name in (scale_names(done_ds) if grid_ndim else ())}
    examples = [point_label(axes, index) for index in np.flatnonzero(lost.reshape(-1))[:3]]
    return Recovery(torn=torn, done=done, chunks=chunks, lost=lost, recovered=recovered, examples=examples,
                    stale=(stale | lost) & ~done), values


def _readable(ds, failing):
    """``ds`` whole, its failing chunks read as its fill value."""
    values = np.full(ds.shape, ds.fillvalue, dtype=ds.dtype)
    failing = set(failing)
    for piece in ds.iter_chunks():
        if _offset(piece, ds.chunks) not in failing:
            values[piece] = ds[piece]
    return values


def repair(f, recovery, fsync):
    """Store the recovered chunks in the open file ``f`` (``done`` first: a point is never left
    marked done over values not yet put back), each flushed and fsynced. A kill during the repair
    leaves chunks that the next resume recovers the same way. ``fsync(f)`` pushes the file to disk."""
    done_ds = f["done"]
    for offset, array in recovery.chunks["done"].items():
        done_ds.id.write_direct_chunk(offset, chunk_bytes(done_ds, array))
    # Points of a recovered data chunk that could not be trusted, in chunks of done that read.
    cleared = recovery.lost & ~_in_chunks(done_ds, recovery.chunks["done"])
    if cleared.any():
        done_ds[...] = np.where(cleared, 0, done_ds[()]).astype(np.int8)
    f.flush()
    fsync(f)
    # status first: a point's status other than -1 must always mean its values are all there,
    # also after a kill in the middle of clearing the values of points not done
    for name in sorted(recovery.chunks, key=lambda name: name != COMPLETION):
        chunks = recovery.chunks[name]
        if name == "done":
            continue
        ds = f[name]
        for offset, array in chunks.items():
            ds.id.write_direct_chunk(offset, chunk_bytes(ds, array))
        if recovery.stale is not None and recovery.stale.any():
            _clear(ds, recovery.stale, set(chunks))
    f.flush()
    fsync(f)


def _clear(ds, points, skip):
    """Set ``points`` (a mask over the grid) of ``ds`` to its fill value, chunk by chunk (but the
    chunks in ``skip``, stored whole already)."""
    grid_ndim = points.ndim
    if grid_ndim == 0 or ds.chunks is None:
        ds[...] = ds.fillvalue
        return
    corners = {tuple(int(i) // c * c for i, c in zip(where, ds.chunks)) for where in zip(*np.nonzero(points))}
    for corner in sorted(corners):
        offset = corner + (0,) * (ds.ndim - grid_ndim)
        if offset in skip:
            continue
        where = _chunk_slices(ds, offset)
        data = ds[where]
        data[points[where[:grid_ndim]]] = ds.fillvalue
        ds[where] = data


def _in_chunks(ds, offsets):
    mask = np.zeros(ds.shape, dtype=bool)
    for offset in offsets:
        mask[_chunk_slices(ds, offset)] = True
    return mask
