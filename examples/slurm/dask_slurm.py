"""Run a sweep on Dask workers that are SLURM jobs (dask-jobqueue), with `vrsweep run --dask`.

    sbatch examples/slurm/dask_slurm.sbatch CONFIG.yaml [N_JOBS]     # the client as a small job
    python examples/slurm/dask_slurm.py CONFIG.yaml [N_JOBS]         # or from a login node

Starts a Dask scheduler here, asks SLURM for N_JOBS worker jobs (one Dask worker per job, one
numba thread per CPU of the job: $CPUS_PER_WORKER, default 8), and runs
`vrsweep run CONFIG --dask <scheduler address>`. The client (this job) is the only process that
writes the result file, chunk by chunk as results come back; if anything stops it, running the
same command again resumes (the run uses --resume).

Needs the slurm extra (dask.distributed and dask-jobqueue): `pip install "vrsweep[slurm]"`, or in
a clone of vrsweep `pip install -e ".[slurm]"`; and the same vrsweep installation on
the worker nodes (a shared venv or module). Compared with the job array (array.sbatch), Dask
balances the load dynamically and needs no merge step, but the client must outlive the sweep.
"""

import os
import shlex
import signal
import sys

# SIGTERM (scancel) before or after vrsweep's own handling (while the cluster starts or closes):
# exit through Python, so that the cluster is closed (finally below, or distributed's atexit) and
# the worker jobs are cancelled; the default action ended the process and left them queued.
signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))

# Before vrsweep is imported: importing it sets NUMBA_CACHE_DIR (to its per-user folder when unset),
# and this default, the folder the worker jobs are told to share, was then never used.
cache = os.environ.setdefault("NUMBA_CACHE_DIR", os.path.expanduser("~/.cache/vrsweep-numba"))

try:
    from dask_jobqueue import SLURMCluster
except ModuleNotFoundError:
    sys.exit('dask_slurm.py needs dask-jobqueue: pip install "vrsweep[slurm]", or in a clone of vrsweep: '
             'pip install -e ".[slurm]"')

from vrsweep.cli import main as vrsweep

CPUS_PER_WORKER = int(os.environ.get("CPUS_PER_WORKER", 8))  # each worker job's CPUs

config = sys.argv[1]
n_jobs = int(sys.argv[2]) if len(sys.argv) > 2 else 4
output = os.environ.get("OUT", f"results/{os.path.splitext(os.path.basename(config))[0]}.h5")

cluster = SLURMCluster(
    cores=CPUS_PER_WORKER,   # -> --cpus-per-task of each worker job, and the worker's nthreads
    processes=1,             # one worker process per job: numba threads, not Dask processes, fill it
    memory="8GB",
    walltime="04:00:00",
    # account="myproject", queue="compute",            # site specific
    job_script_prologue=[
        f"export NUMBA_CACHE_DIR={cache}",           # shared and writable: compiled once (warm-up)
        f"export NUMBA_NUM_THREADS={CPUS_PER_WORKER}",
        # "export HDF5_USE_FILE_LOCKING=FALSE",      # only the client writes; harmless either way
    ],
    log_directory="logs",
)
cluster.scale(jobs=n_jobs)
print(cluster.job_script(), flush=True)

# Workers may still be queued: vrsweep submits every chunk now and Dask hands them out as workers
# arrive. Each chunk runs with the worker's 8 threads (vrsweep's default when --threads is not
# given to a remote cluster). Run in this process rather than as a subprocess, so that SIGTERM
# (time limit, scancel) reaches vrsweep directly: it saves the chunk in hand and exits 143.
arguments = ["run", config, "-o", output, "--dask", cluster.scheduler_address, "--resume"]
print("vrsweep", " ".join(arguments), flush=True)
try:
    vrsweep(arguments)  # exits with vrsweep's exit code
except SystemExit as end:
    if end.code in (128 + signal.SIGINT, 128 + signal.SIGTERM):
        # vrsweep's resume command names this scheduler, which closes with this script.
        again = (f"sbatch examples/slurm/dask_slurm.sbatch {shlex.join(sys.argv[1:])}" if "SLURM_JOB_ID" in os.environ
                 else f"python {shlex.join(sys.argv)}")
        print(f"The scheduler closes with this client: to resume, run it again: {again}", file=sys.stderr,
              flush=True)
    raise
finally:
    cluster.close()  # cancels the worker jobs
