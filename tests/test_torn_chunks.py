"""A kill in the middle of a chunk's write (store/torn.py): nothing done before is lost.

A point variable's chunk is rewritten in place whenever a point in it is written; the system
writes it page by page, so a kill -9 mid-write leaves it part new, part old, and its checksum
fails. ``test_store``'s kill -9 test met it once under load ("filter returned failure during
read"): ``--resume`` refused the whole file, and every point done before in that chunk was lost.
Here the cut is made on purpose, byte for byte as the system leaves it: the chunk's new bytes, as
the writer would have stored them, written up to a given length over the old ones.
"""

import shutil

import h5py
import numpy as np
import pytest

from test_store import ATTRS, CONFIG, GRID, owned_masks, specs, values_for
from damaged import reseal
from vrsweep.errors import ResultFileError
from vrsweep.store import ResultWriter, merge_results
from vrsweep.store.reading import load_results

N = 3000  # GRID's points
FIRST = np.arange(0, N, 7)          # done before the cut
SECOND = np.array([1, 2, 3, 2995])  # the write that the kill cuts: in the first chunk of each variable


def _chunk_of(ds, flat):
    where = np.unravel_index(int(flat), ds.shape[:2])
    return tuple(int(i) // c * c for i, c in zip(where, ds.chunks)) + (0,) * (ds.ndim - 2)


def cut(tmp_path, name, where, first=FIRST, second=SECOND, **create):
    """A checkpoint holding ``first``, killed while writing ``second``: the variables before ``name``
    written whole, ``name``'s chunk holding second[0] cut (``done``: after every variable), the rest
    not written; the cut ``where``: just after the first byte the write changes, half way from there
    to the end, or all but the checksum. Returns the path."""
    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS, **create)
    writer.write_points(first, values_for(first))
    writer.close()
    return cut_write(tmp_path, path, name, where, second)


def cut_write(tmp_path, path, name, where, second):
    """``cut``'s kill, in the checkpoint at ``path`` as it is."""
    after = tmp_path / "after.h5"
    shutil.copy(path, after)
    writer = ResultWriter.open_for_resume(after, CONFIG)
    writer.write_points(second, values_for(second))
    writer.close()
    order = [spec.name for spec in specs()] + ["done"]
    with h5py.File(after, "r") as new, h5py.File(path, "r+") as old:
        for variable in order[:order.index(name)]:
            for index in range(new[variable].id.get_num_chunks()):
                offset = new[variable].id.get_chunk_info(index).chunk_offset
                old[variable].id.write_direct_chunk(offset, new[variable].id.read_direct_chunk(offset)[1])
        offset = _chunk_of(new[name], second[0])
        data = new[name].id.read_direct_chunk(offset)[1]
        before = old[name].id.read_direct_chunk(offset)[1]
        at = old[name].id.get_chunk_info_by_coord(offset).byte_offset
    changed = int(np.flatnonzero(np.frombuffer(data, np.uint8) != np.frombuffer(before, np.uint8))[0])
    length = {"first byte": changed + 1, "half": (changed + len(data)) // 2, "all but checksum": len(data) - 4}[where]
    with open(path, "r+b") as handle:  # past HDF5: the bytes the system wrote before the kill
        handle.seek(at)
        handle.write(data[:length])
    with h5py.File(path, "r") as f:  # the cut is real: HDF5 refuses the chunk
        with pytest.raises(OSError, match="filter"):
            f[name][()]
    return path


def finish_and_compare(path, tmp_path, assert_same_result):
    writer = ResultWriter.open_for_resume(path, CONFIG)
    todo = np.flatnonzero(~writer.done_mask())
    writer.write_points(todo, values_for(todo))
    writer.finish()
    reference = ResultWriter.create(tmp_path / "ref.h5", GRID, specs(), ATTRS)
    reference.write_points(np.arange(N), values_for(np.arange(N)))
    reference.finish()
    assert_same_result(path, tmp_path / "ref.h5")


def stored_values_are(path, points):
    result = load_results(path)
    for name, values in values_for(points).items():
        stored = result[name].values.reshape((N,) + values.shape[1:])
        np.testing.assert_array_equal(stored[points], values)
    return result


@pytest.mark.parametrize("name", ["R", "roots", "n_steps", "status", "done"])
@pytest.mark.parametrize("where", ["first byte", "half", "all but checksum"])
def test_a_cut_chunk_loses_no_point_done_before(tmp_path, capfd, assert_same_result, name, where):
    """--resume recovers every point of the cut chunk done before, bit for bit, checked against
    the chunk's own checksum (the old one: the write had not reached the chunk's end), and says so
    in one line; the run then finishes to the file an uninterrupted run writes."""
    path = cut(tmp_path, name, where)
    writer = ResultWriter.open_for_resume(path, CONFIG)
    done = writer.done_mask().reshape(-1)
    writer.close()
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and f"a kill cut the write of 1 chunk(s) of {name}" in err
    assert "every point done before is recovered, checked against the chunks' checksums" in err
    assert done[FIRST].all()
    if name == "done":
        # Every value was on disk before the flags: the flags, made again from status, are all true,
        # the ones the cut did not reach too.
        assert np.array_equal(np.flatnonzero(done), np.sort(np.concatenate([FIRST, SECOND])))
    else:
        assert np.array_equal(np.flatnonzero(done), np.sort(FIRST))
    result = stored_values_are(path, np.flatnonzero(done))
    assert np.isnan(result["R"].values.reshape(-1)[~done]).all()
    finish_and_compare(path, tmp_path, assert_same_result)


def test_a_second_kill_after_a_first_loses_nothing_either(tmp_path, capfd, assert_same_result):
    """A kill between a write's values and its flags leaves values of points not done; a later cut
    of their chunk could then not be told from damage (the chunk as it was held those values, not
    fill), and its points done were computed again. --resume puts such values back to their fill
    value, so the cut chunk is recovered, every point done before kept."""
    from vrsweep.store.writer import _write_selection

    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS)
    writer.write_points(FIRST, values_for(FIRST))
    left = SECOND[:2]
    for name, values in values_for(left).items():  # the first kill: values on disk, no flags
        _write_selection(writer._file[name], writer.grid_shape, left, values)
    writer._file.flush()
    writer.close()
    ResultWriter.open_for_resume(path, CONFIG).close()
    with h5py.File(path, "r") as f:
        assert np.isnan(f["R"][()].reshape(-1)[left]).all() and (f["status"][()].reshape(-1)[left] == -1).all()
        assert np.isnan(f["roots"][()].reshape(N, -1)[left]).all()
    assert capfd.readouterr().err == ""  # nothing was cut: nothing to say
    cut_write(tmp_path, path, "R", "half", SECOND)  # the second kill, while the resume writes them and more
    writer = ResultWriter.open_for_resume(path, CONFIG)
    assert np.array_equal(np.flatnonzero(writer.done_mask()), np.sort(FIRST))
    writer.close()
    assert "every point done before is recovered" in capfd.readouterr().err
    finish_and_compare(path, tmp_path, assert_same_result)


def test_a_cut_chunk_reads_as_recovered_before_the_resume(tmp_path, capfd):
    """open_results (and so info and plot) of a file with a cut chunk: what --resume will recover,
    with one line (it was "truncated or corrupt", a refusal of the whole file)."""
    path = cut(tmp_path, "R", "half")
    stored_values_are(path, FIRST)
    err = capfd.readouterr().err
    assert "every point done before is recovered" in err
    # A reader cannot tell a kill from a run still writing the file (read with locking off).
    assert "a kill, or the run still writing the file, cut the write of 1 chunk(s) of R" in err


def spoil(path, name, flat, value=None, at_byte=100):
    """Bytes of ``name``'s chunk holding point ``flat`` that are no write's: damage, or a chunk
    holding leftovers of a write cut before (then the chunk as it was cannot be told)."""
    with h5py.File(path, "r") as f:
        ds = f[name]
        offset = _chunk_of(ds, flat)
        at = ds.id.get_chunk_info_by_coord(offset).byte_offset
        footprint = np.zeros(ds.shape[:2], dtype=bool)
        footprint[tuple(slice(o, o + c) for o, c in zip(offset[:2], ds.chunks[:2]))] = True
    with open(path, "r+b") as handle:
        handle.seek(at + at_byte)
        handle.write(bytes([value if value is not None else 0x5A]) * 8)
    return footprint.reshape(-1)


def test_a_chunk_that_cannot_be_told_is_computed_again(tmp_path, capfd, assert_same_result):
    """A chunk whose bytes are not those of a write (its checksum fails however the points in
    flight are reset): its points done before cannot be trusted; only they are computed again, with
    one line saying how many, and the run still ends bit for bit as an uninterrupted one."""
    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS)
    writer.write_points(FIRST, values_for(FIRST))
    writer.close()
    footprint = spoil(path, "R", 0, at_byte=8 * 14)  # point 14's value, done
    lost = footprint & np.isin(np.arange(N), FIRST)
    assert lost.sum() == 72  # a chunk of R: 10 x 50 points, one in 7 done

    from vrsweep.commands.info import describe, format_summary

    summary = describe(path)  # info: the points that cannot be read back, counted
    assert summary["points_done"] == FIRST.size - lost.sum() and summary["points_unreadable"] == lost.sum()
    assert f"{lost.sum()} more unreadable (a kill cut the write of their chunk" in format_summary(summary)
    result = stored_values_are(path, np.flatnonzero(np.isin(np.arange(N), FIRST) & ~lost))
    assert np.isnan(result["R"].values.reshape(-1)[lost]).all()
    assert (result["status"].values.reshape(-1)[lost] == -1).all()
    capfd.readouterr()

    writer = ResultWriter.open_for_resume(path, CONFIG)
    done = writer.done_mask().reshape(-1)
    writer.close()
    assert np.array_equal(done, np.isin(np.arange(N), FIRST) & ~lost)
    err = capfd.readouterr().err
    # named by their parameters: the first three points of the chunk done before (0, 7, 14: g = 0)
    assert err.count("\n") == 1 and (f"{lost.sum()} point(s) that may have been done cannot be read back "
                                     "(g=0, Omega=3; g=0, Omega=3.42857; g=0, Omega=3.85714, ...), "
                                     "they are computed again") in err
    finish_and_compare(path, tmp_path, assert_same_result)


def test_done_flags_that_are_not_flags_are_made_again_from_status(tmp_path, capfd, assert_same_result):
    """A chunk of done whose bytes are no flags at all: its flags are made again from status (the
    record written last of a point's values), so no point done before is computed again."""
    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS)
    writer.write_points(FIRST, values_for(FIRST))
    writer.close()
    spoil(path, "done", 0, value=7)  # int8 done: one chunk over the whole grid
    writer = ResultWriter.open_for_resume(path, CONFIG)
    assert np.array_equal(np.flatnonzero(writer.done_mask()), np.sort(FIRST))
    writer.close()
    assert "every point done before is recovered" in capfd.readouterr().err
    finish_and_compare(path, tmp_path, assert_same_result)


def test_a_flag_flipped_over_half_written_values_is_not_taken(tmp_path, capfd, assert_same_result):
    """A kill in the middle of a write's values leaves some variables of its points written and
    the rest not (status, written last, not yet); a bit of done flipped to 1 over such a point, in
    a chunk that then fails its checksum, was taken as a flag (its bytes are all 0 or 1, and the
    point's values are not all fill): the point was done with status -1 and n_steps -1, and the
    finished file held it so. Torn flags are made from status now, which says not written."""
    from vrsweep.store.writer import _write_selection

    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS)
    writer.write_points(FIRST, values_for(FIRST))
    half = np.arange(100, 108)  # none of them in FIRST but 105
    values = values_for(half)
    for name in ("R", "Qs"):  # the kill: R and Qs written, the rest not
        _write_selection(writer._file[name], writer.grid_shape, half, values[name])
    writer._file.flush()
    writer.close()
    spoil(path, "done", 100, value=1, at_byte=100)  # done's bytes 100..107 flipped to 1
    writer = ResultWriter.open_for_resume(path, CONFIG)
    done = writer.done_mask().reshape(-1)
    writer.close()
    assert np.array_equal(np.flatnonzero(done), np.sort(FIRST))
    capfd.readouterr()
    finish_and_compare(path, tmp_path, assert_same_result)


def test_a_chunk_of_done_and_one_of_status_cut_at_once_are_computed_again(tmp_path, capfd, assert_same_result):
    """Both records of a point failing (damage: a kill cuts one write at a time, and done's after
    an fsync of every value) leave nothing to rebuild the flags from: those points are computed
    again, and the run still ends as an uninterrupted one."""
    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS)
    writer.write_points(FIRST, values_for(FIRST))
    writer.close()
    spoil(path, "done", 0, value=7)
    footprint = spoil(path, "status", 0, value=9, at_byte=0)
    writer = ResultWriter.open_for_resume(path, CONFIG)
    done = writer.done_mask().reshape(-1)
    writer.close()
    assert np.array_equal(done, np.isin(np.arange(N), FIRST) & ~footprint)
    assert "cannot be read back" in capfd.readouterr().err
    finish_and_compare(path, tmp_path, assert_same_result)


def test_a_file_read_while_it_is_written_shows_no_value_before_its_done_flag(tmp_path):
    """The writer flushes a chunk's values before it marks them done: a file read in between (with
    HDF5_USE_FILE_LOCKING=FALSE, or left so by a kill) showed R, status... of points not done.
    Points not done read as not computed, whatever their bytes."""
    from vrsweep.store.writer import _write_selection

    path = tmp_path / "ckpt.h5"
    writer = ResultWriter.create(path, GRID, specs(), ATTRS)
    writer.write_points(FIRST, values_for(FIRST))
    in_flight = np.array([1, 2, 1500])
    for name, values in values_for(in_flight).items():  # the values, flushed; done not yet
        _write_selection(writer._file[name], writer.grid_shape, in_flight, values)
    writer._file.flush()
    result = load_results(path)
    writer.close()
    assert not result["done"].values.reshape(-1)[in_flight].any()
    assert np.isnan(result["R"].values.reshape(-1)[in_flight]).all()
    assert np.isnan(result["roots"].values.reshape(N, -1)[in_flight]).all()
    assert (result["status"].values.reshape(-1)[in_flight] == -1).all()
    assert (result["n_steps"].values.reshape(-1)[in_flight] == -1).all()
    assert result["R"].dtype == np.float64 and result["status"].dtype == np.int8
    stored_values_are(path, FIRST)


def test_merge_of_a_shard_with_a_cut_chunk_says_to_resume_it(tmp_path):
    owned = owned_masks(2, (60, 50))
    first = np.flatnonzero(owned[0])[::2]
    path = cut(tmp_path, "R", "half", first=first, second=np.flatnonzero(owned[0])[1::2][:3], owned_mask=owned[0])
    with h5py.File(path, "r+") as f:
        f.attrs["shard"] = "0/2"
    reseal(path)
    with pytest.raises(ResultFileError, match=r"holds 1 chunk\(s\) whose write a kill cut \(their checksums "
                                              r"fail\): resume that shard with ResultWriter.open_for_resume, "
                                              r"which repairs them"):
        merge_results([path], tmp_path / "merged.h5", allow_missing=True)
    assert not (tmp_path / "merged.h5").exists()
