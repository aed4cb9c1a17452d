#!/bin/bash
# Submit a sweep as a SLURM job array: compile warm-up -> N shards -> merge.
#
#   examples/slurm/submit.sh CONFIG.yaml [N_SHARDS]      (from the directory the paths are relative to)
#
# Prints the three job ids. Run it again with the same arguments after a failure or a time limit:
# every shard resumes from its own file (--resume), finished shards return at once.
set -euo pipefail

CONFIG="${1:?usage: submit.sh CONFIG.yaml [N_SHARDS]}"
SHARDS="${2:-16}"
OUT="${OUT:-results/$(basename "${CONFIG%.*}").h5}"
HERE="$(dirname "$0")"

# The numba cache on a file system every node sees, and that is writable (the default, next to
# the installed package, is often read-only or not shared). Per user: cache files are not made
# to be shared between users.
export NUMBA_CACHE_DIR="${NUMBA_CACHE_DIR:-$HOME/.cache/vrsweep-numba}"
# HDF5 file locks are unsupported on some NFS/Lustre mounts. vrsweep locks "best effort" unless
# this variable is set; FALSE is the usual advice there (each file has one writer anyway).
# export HDF5_USE_FILE_LOCKING=FALSE

mkdir -p logs "$(dirname "$OUT")" "$NUMBA_CACHE_DIR"
vrsweep validate "$CONFIG"   # a broken config fails here, not in N queued jobs

warmup=$(sbatch --parsable --export="ALL,CONFIG=$CONFIG" "$HERE/warmup.sbatch")  # compiles the kernel of CONFIG
array=$(sbatch --parsable --array="1-$SHARDS" --dependency="afterok:$warmup" \
        --export="ALL,CONFIG=$CONFIG,OUT=$OUT" "$HERE/array.sbatch")
merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
        --export="ALL,OUT=$OUT,SHARDS=$SHARDS" "$HERE/merge.sbatch")

echo "warm-up job $warmup -> array job $array (shards 0..$((SHARDS - 1)) of $SHARDS) -> merge job $merge"
echo "result: $OUT   (progress: squeue -u \$USER; logs in logs/)"
