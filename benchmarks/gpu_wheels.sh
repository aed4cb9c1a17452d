#!/usr/bin/env bash
# The wheels a lent GPU machine lacks, downloaded here into .whl/ (excluded from git), for the
# device tool's calls to carry: carry [".whl"] and begin the command with
#
#   python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site PYTHONUNBUFFERED=1 PYTHONWARNINGS=ignore || exit 1
#
# The machine's image (the device tool's KINDS.md lists it) has numba, numba-cuda, h5py, xarray,
# click, tqdm, sympy and scipy, with Python 3.12 and numpy 2.5; vrsweep also needs the packages
# below, and numpy < 2.5 (pyproject.toml's cuda extra says why). About 19 MB: the checkout's
# working tree travels with it, within the tool's 64 MiB a call.
#
#   bash benchmarks/gpu_wheels.sh          (from the repository root, where pip reaches PyPI)
set -euo pipefail
cd "$(dirname "$0")/.."
grep -qx '/.whl/' .git/info/exclude 2>/dev/null || echo '/.whl/' >> .git/info/exclude
rm -rf .whl
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
    --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64 \
    --platform manylinux2014_x86_64 --platform manylinux1_x86_64 -d .whl \
    numpy==2.4.6 ruamel.yaml==0.19.1 pydantic==2.13.4 pydantic-core==2.46.4 annotated-types==0.7.0 \
    typing-inspection==0.4.2 typing-extensions==4.15.0 platformdirs==4.14.8 h5netcdf==1.8.2
du -sh .whl
ls .whl
