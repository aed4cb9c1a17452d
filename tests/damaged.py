"""What the damaged-file tests (test_damaged_*.py) share: a copy of a good file with one change,
a bit flipped behind HDF5's back, and the answer every command must give to a damaged file: one
"Error: " line and exit 2, never a traceback or a figure."""

import shutil

import h5py


def damaged_copy(good, folder, change, name="damaged.h5"):
    """The path of a copy of the file ``good`` in ``folder``, changed by ``change(f)`` (f: the
    copy, open for writing through h5py); change None: a plain copy, not opened."""
    path = folder / name
    shutil.copy(good, path)
    if change is not None:
        with h5py.File(path, "r+") as f:
            change(f)
    return path


def flip_bit(path, name, bit=None) -> bool:
    """Flip one bit of the stored bytes of dataset ``name`` (its first chunk if it is chunked):
    bit number ``bit`` modulo their size, or by default one in the middle. Returns whether the
    dataset carries a checksum (Fletcher-32) that should catch it."""
    with h5py.File(path, "r") as f:
        ds = f[name]
        checksummed = ds.fletcher32
        offset = ds.id.get_chunk_info(0).byte_offset if ds.chunks else ds.id.get_offset()
        size = ds.id.get_chunk_info(0).size if ds.chunks else ds.id.get_storage_size()
    if bit is None:
        bit = 8 * (size // 2) + 4
    byte, within = divmod(bit % (8 * size), 8)
    with open(path, "r+b") as handle:
        handle.seek(offset + byte)
        original = handle.read(1)[0]
        handle.seek(offset + byte)
        handle.write(bytes([original ^ (1 << within)]))
    return checksummed


def one_line_error(result):
    """The one line of a refusal (click's Result): exit 2, a single "Error: " line, no traceback."""
    lines = [line for line in result.output.strip().splitlines() if line.strip()]
    assert "Traceback" not in result.output, result.output
    assert result.exit_code == 2, result.output
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    return lines[0]


def refused_by_plot_and_info(invoke, path, folder, words):
    """plot and info each refuse the file at ``path`` in one line containing ``words``; plot
    draws no figure (in ``folder``)."""
    for args in (("plot", path, "-o", folder / "figure.png"), ("info", path)):
        assert words in one_line_error(invoke(*args)), args
    assert not (folder / "figure.png").exists()


def reseal(path):
    """Seal the attributes of the vrsweep file ``path`` again after a test changed them by hand, as
    its writer would have sealed them (store/sealing.py): a file as another run, shard or version
    would have written it, not a damaged one."""
    from vrsweep.store.sealing import SWEEP_UNSEALED, WHEN_AND_HOW, seal_attributes

    with h5py.File(path, "r+") as f:
        kind = f.attrs.get("vrsweep_file", "sweep")
        kind = kind.decode() if isinstance(kind, bytes) else kind
        skip = {"sweep": SWEEP_UNSEALED, "shard": SWEEP_UNSEALED, "trajectory": WHEN_AND_HOW}.get(kind, ())
        seal_attributes(f, skip)

