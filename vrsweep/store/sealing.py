"""One checksum over every attribute of a file (SHA-256), for each kind of file vrsweep writes.

HDF5 checksums the data of a dataset (Fletcher-32 on its chunks) and the object headers of files
written as libver v108+ does, but not what a reader takes from the attributes: one flipped bit in
the stored config (``gamma: 0.05`` -> ``0.07``) or in an axis's units went unnoticed, and ``info``,
a figure's caption, ``continue --point`` and ``--resume`` used it. So the root holds
``vrsweep_attributes_sha256``: the digest of every attribute of the root, each group and each
dataset (names and values, in path order), checked where the file is opened.

Branch and curves files cover every attribute. Sweep and trajectory files leave out when and by
which command they were written (``created``, ``date_created``, ``history``: two runs that are
otherwise bit for bit the same differ there) and a sweep file's ``vrsweep_complete`` (a checkpoint
is finished in place; the ``done`` mask, not the flag, says which points are there). A file written
before attributes had a checksum opens as it did, with one note that they are unprotected.
"""

from __future__ import annotations

import h5py
import numpy as np

from vrsweep.errors import ResultFileError

ATTRIBUTES_CHECKSUM = "vrsweep_attributes_sha256"
# HDF5's dimension-scale bookkeeping: references, i.e. addresses in the file, not content.
_REFERENCES = ("DIMENSION_LIST", "REFERENCE_LIST")
# What a sweep or trajectory file's checksum leaves out (module docstring).
WHEN_AND_HOW = ("created", "date_created", "history")
SWEEP_UNSEALED = WHEN_AND_HOW + ("vrsweep_complete",)
_unprotected_said = set()


def _canonical(value) -> bytes:
    """``value`` as h5py reads an attribute back (str, bytes, numpy scalar or array), as bytes that
    say its type and content: equal for equal attributes, whatever damage they hold."""
    if isinstance(value, str):
        return b"s" + value.encode("utf-8", "surrogateescape")
    if isinstance(value, bytes):
        return b"b" + value
    value = np.asarray(value)
    if value.dtype.kind == "O":
        return b"o" + b"\0".join(_canonical(item) for item in value.reshape(-1))
    return b"n" + value.dtype.str.encode() + repr(value.shape).encode() + value.tobytes()


def _owners(f):
    """("", the root), then every group and dataset below it as (its path without the leading /,
    the object), in path order: for a flat file, the root's datasets in name order."""
    found = []

    def visit(name, obj):
        if isinstance(obj, (h5py.Group, h5py.Dataset)):
            found.append(name)

    f.visititems(visit)
    return [("", f)] + [(name, f[name]) for name in sorted(found)]


def attributes_digest(f, skip_root=()) -> str:
    """SHA-256 (hex) of every attribute of the open file ``f``: its root's (but ATTRIBUTES_CHECKSUM
    and the root attributes ``skip_root``) and those of every group and dataset (but _REFERENCES):
    names and values, in path order."""
    import hashlib

    digest = hashlib.sha256()
    for owner, obj in _owners(f):
        for name in sorted(obj.attrs):
            if name in _REFERENCES or (owner == "" and (name == ATTRIBUTES_CHECKSUM or name in skip_root)):
                continue
            digest.update(f"{owner}/{name}".encode("utf-8", "surrogateescape") + b"\0"
                          + _canonical(obj.attrs[name]) + b"\0")
    return digest.hexdigest()


def seal_attributes(f, skip_root=()) -> None:
    """Store the checksum of the attributes of ``f`` once all are written (again after any change)."""
    f.attrs[ATTRIBUTES_CHECKSUM] = attributes_digest(f, skip_root)


# Not "is corrupt" alone: a file re-saved by xarray's to_netcdf gains attributes of its own
# (_Netcdf4Dimid, _FillValue) and fails the check as a damaged one does.
CHANGED = ("is corrupt or was changed after vrsweep wrote it (edited, or re-saved by another tool such as xarray's "
           "to_netcdf: open the file vrsweep wrote): its attributes (config, model, parameters, labels) do not "
           "match their checksum")


def check_attributes(f, path, skip_root=()) -> bool:
    """ResultFileError when the attributes of ``f`` fail their checksum. Returns whether the file
    has one: a file written before (no ATTRIBUTES_CHECKSUM) passes unprotected
    (note_if_unprotected says so, once it is found sound)."""
    if ATTRIBUTES_CHECKSUM not in f.attrs:
        return False
    stored = f.attrs[ATTRIBUTES_CHECKSUM]
    if isinstance(stored, bytes):
        stored = stored.decode("utf-8", "replace")
    if not isinstance(stored, str) or stored != attributes_digest(f, skip_root):
        raise ResultFileError(f"{path} {CHANGED}")
    return True


def check_attributes_of_any_kind(f, path) -> None:
    """ResultFileError when ``f`` has a checksum that its attributes match as no kind of file would
    seal them: for a file whose kind is not known (its vrsweep_file changed, one bit of it maybe)."""
    if ATTRIBUTES_CHECKSUM not in f.attrs:
        return
    for skip in ((), WHEN_AND_HOW, SWEEP_UNSEALED):
        try:
            check_attributes(f, path, skip)
            return
        except ResultFileError:
            continue
    raise ResultFileError(f"{path} {CHANGED}")


def unless_changed(f, path) -> str:
    """What a refusal that read the file's kind or format adds where the file's attributes match
    their checksum under no kind's sealing: the attribute it read may be the one that was changed
    (a bit flipped, an edit), so the file may be corrupt rather than what the attribute says.
    "" where the attributes match (or the file has no checksum)."""
    try:
        check_attributes_of_any_kind(f, path)
    except ResultFileError:
        return f"; or it {CHANGED}"
    return ""


def note_if_unprotected(path, protected) -> None:
    """The note, once per file and process, that a sound file's attributes have no checksum (written
    before they had one): after every check, so that a refused file is one line."""
    if not protected and path not in _unprotected_said:
        _unprotected_said.add(path)
        from vrsweep.store.fileio import notice

        notice(f"Note: {path} was written before attributes had checksums: its config and parameters are read "
               "as they are, unprotected against damage")
