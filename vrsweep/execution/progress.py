"""Progress of a sweep as lines in a log, for batch jobs (stderr not a terminal).

A terminal gets tqdm's bar; a batch log would fill with its redraws, so there ``vrsweep run``
writes one line every ``interval`` seconds instead::

    2026-11-23 09:41:07 vrsweep: 1200 of 9801 points (12.2%), 41.3 points/s, ETA 3.5 min

Fed by the chunk loop (run_sweep's or Dask's ``progress`` callback), so a line can only come
when a chunk finishes: at the first chunk end after each interval. The kernel knows nothing of it.
"""

import sys
import time

from vrsweep.execution.estimate import format_duration


class ProgressLog:
    """``update(n)`` after each chunk; writes a line when ``interval`` seconds have passed.

    The rate counts only the points computed by this process after its first chunk: the first
    chunk carries the kernel's compilation (or loading) and, when resuming, the points already
    done are not this run's work.
    """

    def __init__(self, total, already_done=0, interval=60.0, stream=None, clock=time.monotonic,
                 now=time.localtime):
        self.total = int(total)
        self.done = int(already_done)
        self.already_done = self.done
        self.interval = float(interval)
        self.stream = stream
        self.clock = clock
        self.now = now
        self.started = clock()
        self.last_line = self.started
        self.first_chunk = None  # (time, points done) at the end of the first chunk

    def update(self, n):
        self.done += int(n)
        at = self.clock()
        if self.first_chunk is None:
            self.first_chunk = (at, self.done)
        if at - self.last_line >= self.interval:
            self.last_line = at
            stream = self.stream or sys.stderr
            stream.write(self.line(at) + "\n")
            stream.flush()

    def rate(self, at):
        """Points per second, or None before there is anything to go by."""
        first_at, first_done = self.first_chunk
        if self.done > first_done and at > first_at:
            return (self.done - first_done) / (at - first_at)
        if self.done > self.already_done and at > self.started:  # one chunk so far: all we have
            return (self.done - self.already_done) / (at - self.started)
        return None

    def line(self, at):
        percent = 100.0 * self.done / self.total if self.total else 100.0
        text = (f"{time.strftime('%Y-%m-%d %H:%M:%S', self.now())} vrsweep: {self.done} of "
                f"{self.total} points ({percent:.1f}%)")
        rate = self.rate(at)
        if rate is not None:
            text += f", {format_rate(rate)} points/s"
            if self.done < self.total:
                text += f", ETA {format_duration((self.total - self.done) / rate)}"
        return text


def format_rate(rate):
    """Three significant digits, whole numbers from 100 up: 0.0123, 1.23, 12.3, 123, 12345."""
    return f"{rate:.0f}" if rate >= 100 else f"{rate:.3g}"
