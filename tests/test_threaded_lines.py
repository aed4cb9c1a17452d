"""The sweep's lines on Python's threads (numerics/lines.py): every line run exactly once, whatever
the thread count; a failure in any thread reaches the caller after every thread is done; the
compiled lines give the same bits on one thread and on several."""

import threading
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrsweep.numerics import kernel, lines
from vrsweep.numerics.lines import GuidedSchedule, ThreadedLines


@settings(max_examples=200, deadline=None)
@given(n_lines=st.integers(0, 5000), threads=st.integers(1, 64))
def test_the_schedule_hands_out_every_line_once_in_shrinking_ranges(n_lines, threads):
    schedule = GuidedSchedule(n_lines, threads)
    ranges = list(iter(schedule.take, None))
    assert [first for first, _ in ranges] == [0, *[stop for _, stop in ranges[:-1]]][:len(ranges)]  # contiguous
    assert (ranges[-1][1] if ranges else 0) == n_lines
    sizes = [stop - first for first, stop in ranges]
    assert all(size >= 1 for size in sizes)
    assert sizes == sorted(sizes, reverse=True)
    # The first range is a quarter of one thread's share; the last threads' ranges are single lines.
    if n_lines:
        assert sizes[0] == max(1, n_lines // (GuidedSchedule.SHARE * threads))
        assert sizes[-min(len(sizes), threads):] == [1] * min(len(sizes), threads)


def test_a_stopped_schedule_hands_out_nothing_more():
    schedule = GuidedSchedule(100, 2)
    assert schedule.take() == (0, 12)
    schedule.stop()
    assert schedule.take() is None


def _arrays(n_lines):
    """ThreadedLines' seven arrays, with the outputs a fake kernel writes into."""
    statuses = np.zeros((n_lines, 1), dtype=np.int8)
    return (np.zeros((n_lines, 1)), np.zeros((n_lines, 2)), np.zeros(1), np.arange(n_lines).reshape(n_lines, 1),
            np.zeros((n_lines, 1, 1, 1)), np.zeros((n_lines, 1, 1)), statuses)


class Recording:
    """A fake line kernel: counts the runs of each line and the threads that ran them."""

    def __init__(self, fail_at=None, error=RuntimeError, only_in=None):
        self.fail_at, self.error, self.only_in = fail_at, error, only_in
        self.names = set()
        self.lock = threading.Lock()

    def __call__(self, *arrays_and_range):
        *arrays, first, stop = arrays_and_range
        statuses = arrays[-1]
        with self.lock:
            self.names.add(threading.current_thread().name)
        for line in range(first, stop):
            time.sleep(0.001)  # long enough that the threads overlap
            statuses[line, 0] += 1
            if self.only_in is not None:
                if threading.current_thread() is self.only_in:  # at its first line
                    raise self.error(f"line {line}")
            elif line == self.fail_at:
                raise self.error(f"line {line}")


@pytest.mark.parametrize("threads", [1, 2, 3, 8])
def test_every_line_runs_once_and_the_caller_takes_part(threads):
    arrays = _arrays(200)
    fake = Recording()
    ThreadedLines(fake)(*arrays, threads=threads)
    assert arrays[-1].ravel().tolist() == [1] * 200
    assert threading.current_thread().name in fake.names
    assert len(fake.names) <= threads
    assert not [thread for thread in threading.enumerate() if thread.name.startswith("vrsweep-lines")]


def test_a_thread_count_beyond_the_lines_starts_no_idle_thread():
    arrays = _arrays(2)
    fake = Recording()
    ThreadedLines(fake)(*arrays, threads=8)
    assert arrays[-1].ravel().tolist() == [1, 1] and len(fake.names) <= 2


def test_an_error_in_a_thread_reaches_the_caller_once_every_thread_is_done():
    arrays = _arrays(400)
    with pytest.raises(RuntimeError, match="^line 37$"):
        ThreadedLines(Recording(fail_at=37))(*arrays, threads=3)
    assert not [thread for thread in threading.enumerate() if thread.name.startswith("vrsweep-lines")]
    runs = arrays[-1].ravel()
    assert runs.max() == 1  # no line twice
    assert runs.sum() < 400  # the schedule stopped: the lines not yet handed out never started


def test_an_interrupt_in_the_calling_thread_stops_the_others_after_their_range():
    arrays = _arrays(400)
    fake = Recording(error=KeyboardInterrupt, only_in=threading.current_thread())  # at the caller's first line
    with pytest.raises(KeyboardInterrupt):
        ThreadedLines(fake)(*arrays, threads=3)
    assert not [thread for thread in threading.enumerate() if thread.name.startswith("vrsweep-lines")]
    runs = arrays[-1].ravel()
    assert runs.max() == 1 and runs.sum() < 400


@pytest.mark.parametrize("method", ["rk45", "dop853"])
def test_the_compiled_lines_give_the_same_bits_on_one_thread_and_on_three(method):
    """Lines of three points each (continuation: each point starts from the one before), on the
    original model at g from 5 to 35: the outputs are the same bytes on 1 and on 3 threads, and the
    lines' own points (one line run alone) are the same as the line's among the others."""
    from vrsweep.numerics.model import DEFAULT_PARAMETERS, kernel_coefficients
    from vrsweep.numerics.trajectory import settings_vector
    from vrsweep.results import Status

    g = np.linspace(5, 35, 18)
    coefficients = np.ascontiguousarray(kernel_coefficients({**DEFAULT_PARAMETERS, "g": g}, "original"))
    settings = settings_vector(transient_periods=6, measure_periods=4)
    line_points = np.arange(18, dtype=np.int64).reshape(6, 3)
    initial_states = np.tile([0.1, 0.0], (6, 1))

    def run(threads, which=slice(None)):
        chosen = line_points[which]
        records = np.full((len(chosen), 3, 4, kernel.N_RECORD), np.nan)
        summaries = np.full((len(chosen), 3, kernel.N_SUMMARY), np.nan)
        statuses = np.full((len(chosen), 3), Status.NOT_COMPUTED, np.int8)
        lines.RUN_LINES[method, False](coefficients, initial_states[which], settings, chosen, records, summaries,
                                       statuses, threads=threads)
        return records, summaries, statuses

    one, three = run(1), run(3)
    assert (one[2] == Status.OK).all()
    for a, b in zip(one, three):
        assert a.tobytes() == b.tobytes()
    alone = run(1, slice(4, 5))
    for a, b in zip(alone, one):
        assert a.tobytes() == b[4:5].tobytes()
