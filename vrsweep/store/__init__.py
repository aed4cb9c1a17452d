"""HDF5 result files: their layout, writing them, reading their layout, and merging shards.

The store knows nothing of numerics: it writes what it is given, where it is told. One module per
concern:

- ``layout``: what a result file holds (variables, dimensions, attributes, chunks, fill values)
  and the bytes it takes; the only module that decides where anything is in the file.
- ``writer``: :class:`ResultWriter`, the checkpoint of a sweep (create, write points, resume,
  finish), crash-safe and locked.
- ``reader``: opening an existing file with its checks and one-line errors, and
  :class:`StoredLayout`, its metadata without its values. Values are read lazily through xarray
  (``vrsweep.open_results``, ``vrsweep/store/reading.py``), which follows the same layout.
- ``merge``: :func:`merge_results`, the shards of one run streamed into one file.
- ``torn``: chunks whose write a kill cut, in an unfinished file: found and recovered.

Every HDF5 file is opened through ``fileio.open_hdf5`` (the locking policy).

Life of a result file
---------------------
1. :meth:`ResultWriter.create` writes the whole layout up front: one coordinate per sweep axis,
   every variable pre-allocated and filled with its fill value, a per-point ``done`` mask, and the
   root attributes with ``vrsweep_complete = 0``. The skeleton is written under a temporary name
   and renamed into place, so whatever exists at ``path`` is always a readable vrsweep file. The
   writer keeps that very file open (and locked) until ``finish``: it never reopens the path,
   and checks before each write that the path still names its file (a run with ``--overwrite``
   or a scratch purge may have replaced or removed it; see ``fileio``).
2. :meth:`ResultWriter.write_points` fills finished points chunk by chunk and flushes: this file
   *is* the checkpoint. A ``kill -9`` at any moment loses at most the chunk in flight. A kill in the
   middle of a chunk's write leaves that chunk failing its checksum; ``torn`` recovers what it held
   (on resume, and for every reader of an unfinished file).
3. :meth:`ResultWriter.finish` copies the file it holds, adds derived variables (theory
   columns) to the copy, sets ``vrsweep_complete = 1`` and renames the copy into place.

A full disk at any of these steps ends in one line (``OutputError``, exit 1) saying how much
space the file needs, with HDF5 closed cleanly and no temporary file left (``fileio``).
"""

from vrsweep.store.fileio import atomic_write
from vrsweep.store.layout import (
    CHUNK_TARGET_BYTES, FORMAT_VERSION, VariableSpec, creation_reserve, finish_reserve, layout_bytes, point_label,
)
from vrsweep.store.reader import StoredLayout, corrupt_error, open_checked
from vrsweep.store.writer import ResultWriter


def __getattr__(name):
    # The merge (and what it imports) loads only when asked for: `vrsweep run` never merges.
    if name in ("merge_results", "MergeReport", "MergeWriteError"):
        from vrsweep.store import merge

        return getattr(merge, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "FORMAT_VERSION", "CHUNK_TARGET_BYTES", "VariableSpec", "ResultWriter", "StoredLayout", "open_checked",
    "corrupt_error", "layout_bytes", "creation_reserve", "finish_reserve", "point_label", "atomic_write",
    "merge_results", "MergeReport", "MergeWriteError",
]
