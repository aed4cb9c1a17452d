"""Run a sweep's chunks on dask.distributed workers; the client stays the only writer.

``vrsweep run CONFIG --dask ADDRESS`` (or ``--dask local:N``) swaps run_sweep's local loop for
:class:`DaskExecutor`, which has run_sweep's signature: the same shuffled, not-yet-done lines are
cut into chunks, each chunk is one Dask task (:func:`run_chunk`) running the numba kernel on a
worker, and results are handed to ``on_chunk`` as they arrive. ``on_chunk`` is the job's
``ResultWriter.write_points``, so the HDF5 file is written by this one process exactly as in a
local run: checkpointed chunk by chunk, resumable with ``--resume`` (with or without Dask), and
bit for bit the same values (a chunk runs the same code on the same coefficients; see sweep.py).

Dask is an optional extra (``pip install "vrsweep[dask]"``, from a clone ``pip install -e ".[dask]"``;
``[slurm]`` adds dask-jobqueue for examples/slurm/dask_slurm.py): nothing here imports it at module
level, so ``vrsweep run`` without ``--dask`` never loads it.

Threads: a task runs the kernel's lines on ``--threads`` threads, or on as many as its worker
has (``--nthreads``) when not given. Tasks in one worker process take a lock around the kernel,
so a worker with several Dask threads still runs one chunk's lines at a time: each chunk already
spreads over the worker's threads, and two at once would oversubscribe its cores.
"""

import contextlib
import functools
import logging
import signal
import threading
import time

import numpy as np

from vrsweep.numbertext import read_int
from vrsweep.errors import InvalidArgument, RunFailed, VrsweepError
from vrsweep.execution.signals import Interrupted
from vrsweep.execution.chunks import count_statuses, default_chunk_lines, max_chunk_lines, plan_lines
from vrsweep.config.grid import Grid
from vrsweep.execution.threads import machine_cpus

LOCAL_PREFIX = "local:"
CONNECT_TIMEOUT = "10s"  # a scheduler answers in milliseconds; a port that is none may never
POLL_SECONDS = 0.2  # how often a client waiting for workers or chunks looks for a stop
INSTALL_HINT = ('pip install "vrsweep[dask]", or in a clone of vrsweep: pip install -e ".[dask]" '
                '(or just pip install "dask[distributed]")')


def dask_executor(address, threads=None, stop=None):
    """A callable with run_sweep's signature that runs the chunks on dask.distributed.

    address: a scheduler address (``tcp://host:8786``, a scheduler file is not supported) or
    ``local:N`` for a LocalCluster of N worker processes with ``threads`` (default 1) threads each.
    Checks the address and that dask.distributed is installed now, so a bad address fails
    before any file is created (InvalidArgument; the run command words it as ``--dask ADDRESS``),
    and that a remote scheduler answers (VrsweepError, one line); connects again when called.
    stop: the run's GracefulStop, if any: a stop asked for while no worker is connected (SLURM
    worker jobs still queued, or all gone) takes effect at once, as no chunk is being computed.
    """
    n_local = parse_local(address)
    try:
        import dask.distributed  # noqa: F401
    except ModuleNotFoundError:
        raise InvalidArgument("Dask address", address,
                              f"needs dask.distributed, which is not installed: {INSTALL_HINT}") from None
    executor = DaskExecutor(address, threads, n_local, stop)
    if n_local is None:
        with executor._client():  # a scheduler that cannot be reached is known before any file is made
            pass
    return executor


def parse_local(address):
    """``local:N`` -> N; any other address -> None."""
    if not address.startswith(LOCAL_PREFIX):
        return None
    text = address[len(LOCAL_PREFIX):]
    try:
        n = read_int(text)  # the one rule of numbers as text: local:١٢ is no address
    except ValueError:  # NumberTextError is one
        n = 0
    if n < 1:
        raise InvalidArgument("Dask address", address, "expected local:N with N >= 1 workers (e.g. local:4)")
    most = machine_cpus()
    if n > most:  # each worker is a process with its own kernel threads: more is only slower
        raise InvalidArgument("Dask address", address,
                              f"local:N starts N worker processes; this machine has {most} CPUs, so N <= {most}")
    return n


# ---------------------------------------------------------------------------------------------
# Worker side
# ---------------------------------------------------------------------------------------------

_KERNEL_LOCK = threading.Lock()


@functools.lru_cache(maxsize=2)
def _runner(config_text):
    # Parsed and tabulated once per worker process and config, not once per chunk.
    from vrsweep.config import parse_config
    from vrsweep.execution.sweep import LineRunner

    return LineRunner(parse_config(config_text, "<config sent by the vrsweep client>"))


def run_chunk(config_text, lines, threads=None):
    """The Dask task: run ``lines`` of the config's grid; return (flat indices, values)."""
    if threads is None:
        threads = _worker_threads()
    with _KERNEL_LOCK:
        return _runner(config_text).run(lines, threads)


def dask_setup(worker):
    """Preload hook of the LocalCluster's workers (``preload=["vrsweep.execution.distributed"]``).

    Ctrl-C in a terminal sends SIGINT to the whole process group, local workers included; a
    worker killed by it would leave its chunk unfinished and the client waiting for a worker that
    never returns. Ignoring SIGINT there leaves it to the client, which stops after the next chunk
    is saved and shuts the cluster down. (Runs in the worker's main thread, where the event loop of
    a nanny-started worker lives; elsewhere it does nothing.)
    """
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    # Shutting the cluster down is expected to cancel the chunks still running after a stop, and
    # on a loaded machine a worker's last heartbeat can race the scheduler's exit (the scheduler
    # is in the client's process, so it is never lost otherwise): no warning per worker for these.
    _drop_messages("distributed.worker.state_machine", "ended with CancelledError")
    _drop_messages("distributed.worker", "Failed to communicate with scheduler during heartbeat")
    _no_tracebacks_below_warning()


def _drop_messages(logger, text):
    logging.getLogger(logger).addFilter(lambda record: text not in record.getMessage())


def _no_tracebacks_below_warning():
    """distributed's own lines (its handler on the "distributed" logger, stderr) keep their
    tracebacks to warnings and errors. Its INFO lines carry one where a connection closed while
    it was sending: a scheduler closed with its workers still connected, after every stop, logged
    "Batched Comm Closed" with a CommClosedError traceback beneath vrsweep's "Interrupted" line (the
    Dask-on-SLURM client, on a loaded machine). That is the expected end of a cluster, not a fault:
    the line stays, its traceback goes. Idempotent."""
    import distributed  # noqa: F401 - its import installs the handler

    for handler in logging.getLogger("distributed").handlers:
        if not any(getattr(f, "vrsweep_info_without_traceback", False) for f in handler.filters):
            handler.addFilter(_info_without_traceback)


def _info_without_traceback(record):
    if record.levelno < logging.WARNING and record.exc_info:
        record.exc_info = None
        record.exc_text = None
    return True


_info_without_traceback.vrsweep_info_without_traceback = True


def _worker_threads():
    try:
        from distributed import get_worker

        return int(get_worker().state.nthreads)
    except (ImportError, ValueError, AttributeError):
        return None  # not in a worker (or an old distributed): numba's default


# ---------------------------------------------------------------------------------------------
# Client side
# ---------------------------------------------------------------------------------------------


class DaskExecutor:
    """run_sweep's signature, run on Dask. Connects (or starts a LocalCluster) per call."""

    def __init__(self, address, threads=None, n_local=None, stop=None):
        self.address = address
        self.threads = threads
        self.n_local = n_local
        self.stop = stop

    def __call__(self, config, *, threads=None, shard=(0, 1), done=None, on_chunk=None,
                 progress=None, chunk_lines=None):
        threads = threads or self.threads
        plan = plan_lines(Grid.from_config(config), shard, done)
        lines = plan.lines
        counts = {}
        if len(lines) == 0:
            return counts
        config_text = config.to_yaml()
        with self._client() as client:
            from dask.distributed import as_completed

            if chunk_lines is None:
                if not threads:  # chunks sized for the workers' threads: wait for one to know them
                    self._wait_for_a_worker(client)
                chunk_lines = min(default_chunk_lines(threads or _largest_worker(client), plan.line_length),
                                  max_chunk_lines(config.integration, plan.line_length))
            # All chunks are submitted at once and Dask balances them over the workers. Each result
            # is fetched and written as soon as it is ready, then dropped (the future is no longer
            # referenced), so results do not pile up on either side.
            pending = {}
            for start in range(0, len(lines), chunk_lines):
                chunk = np.ascontiguousarray(lines[start:start + chunk_lines])
                future = client.submit(run_chunk, config_text, chunk, threads, pure=False)
                pending[future.key] = future
            try:
                for future in self._as_completed(client, as_completed(list(pending.values()))):
                    pending.pop(future.key)
                    try:
                        flat, values = future.result()
                    except Exception as error:
                        raise RunFailed(f"a Dask task failed: {type(error).__name__}: {error}") from error
                    if on_chunk is not None:
                        on_chunk(flat, values)
                    count_statuses(counts, values["status"])
                    if progress is not None:
                        progress(plan.newly_done(flat), plan.total)
            finally:
                # Interrupted or failed: do not leave a shared cluster computing for nobody (a
                # LocalCluster is about to be shut down anyway).
                if pending and self.n_local is None:
                    client.cancel(list(pending.values()))
        return counts

    # A stop (SIGINT, SIGTERM) only sets a flag, and run_job acts on it once the next chunk is saved.
    # Blocked on Dask, this process would wait for that chunk forever when no worker is connected:
    # a SLURM client scancelled while its worker jobs were queued stayed until SIGKILL, and never
    # cancelled them. So the waits below look for a stop, and with no worker there is nothing in
    # progress to save: the stop takes effect at once.

    def _stop_now(self, client):
        if self.stop is None or self.stop.signum is None:
            return False
        return not client.nthreads()  # asks the scheduler: the workers connected now

    def _wait_for_a_worker(self, client):
        while True:
            try:
                client.wait_for_workers(1, timeout=POLL_SECONDS)
                return
            except TimeoutError:
                if self._stop_now(client):
                    raise Interrupted(self.stop.signum) from None

    def _as_completed(self, client, completed):
        while not completed.is_empty():
            if completed.has_ready():
                yield next(completed)
            elif self._stop_now(client):
                raise Interrupted(self.stop.signum)
            else:
                time.sleep(POLL_SECONDS / 4)

    @contextlib.contextmanager
    def _client(self):
        from dask.distributed import Client, LocalCluster

        _no_tracebacks_below_warning()  # this process may hold the scheduler (LocalCluster, dask_slurm.py)
        if self.n_local is not None:
            # Worker processes (not threads): each has its own numba thread pool. No dashboard, and
            # the scheduler's small HTTP server on any free local port, not on 8787 (which a
            # second run on the machine would find taken, and warn).
            # The workers ignore SIGINT (dask_setup, preloaded), so Ctrl-C reaches only this client.
            # After a stop (SIGINT, SIGTERM) a worker busy in the kernel is killed at shutdown, as
            # intended (its chunk is not saved and --resume computes it): no warning line for that.
            _drop_messages("distributed.nanny", "Worker process still alive after")
            with LocalCluster(n_workers=self.n_local, threads_per_worker=self.threads or 1,
                              processes=True, dashboard_address=None,
                              scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                              preload=[__name__]) as cluster, \
                    Client(cluster) as client:
                yield client
            return
        try:
            client = Client(self.address, timeout=CONNECT_TIMEOUT)
        except Exception as error:  # noqa: BLE001 - whatever the other end does, one line
            # A port that is no Dask scheduler answers with bytes Dask reads as a frame length
            # (a 3 EiB "message": MemoryError), or with nothing (a timeout), or closes (OSError).
            reason = f"{type(error).__name__}: {error}" if not isinstance(error, (OSError, TimeoutError)) else str(error)
            raise VrsweepError(f"cannot connect to a Dask scheduler at {self.address} ({reason.strip() or 'no answer'}); "
                               "is it a scheduler's address, e.g. tcp://host:8786?") from None
        with client:
            yield client


def _largest_worker(client):
    workers = client.scheduler_info().get("workers", {})
    return max((int(w.get("nthreads", 1)) for w in workers.values()), default=1)
