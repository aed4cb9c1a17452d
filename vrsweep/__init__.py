"""vrsweep: vibrational resonance sweeps of a vibro-impact Van der Pol-Duffing oscillator.

Implements Roy & Gupta, "Vibrational resonance in vibro-impact oscillator through fast
harmonic excitation", with the corrections listed in docs/errata.md.

Computing and reading in Python (docs/python-api.md)::

    import vrsweep
    ds = vrsweep.sweep({"sweep": {"g": [5.0, 10.0]}}, measure_periods=20)  # an xarray.Dataset
    traj = vrsweep.simulate("configs/fig3.yaml")                           # one trajectory
    rows = vrsweep.theory("configs/fig1.yaml")                             # g_res, peak, ...
    ds = vrsweep.open_results("results/quickstart.h5")   # a file written before, read lazily

``sweep``, ``simulate`` and ``theory`` live in :mod:`vrsweep.execution.api` and are imported on
first use, so that the command line starts without numba, xarray or tqdm.
"""

import os as _os
import sys as _sys

if _os.path.basename(_sys.argv[0]) in ("vrsweep", "-m"):  # the command line (`vrsweep`, `python -m vrsweep`)
    # First of all: Ctrl-C during the imports below exits 130 with one line, not a traceback.
    from vrsweep.execution import signals as _signals

    _signals.exit_at_once_on_sigint()

from vrsweep._version import __version__  # noqa: E402
from vrsweep.numerics import numba_cache as _numba_cache  # noqa: E402
from vrsweep.execution import threads as _threads  # noqa: E402
from vrsweep import mpl_folder as _mpl_folder  # noqa: E402

_numba_cache.configure()  # before anything imports numba: kernels never go into site-packages
_mpl_folder.configure()  # before anything imports matplotlib: a writable folder, not its warnings
_threads.drop_unreadable_setting()
_threads.word_numba_setting_warnings()


def open_results(path, **kwargs):
    """Open a vrsweep sweep, shard, trajectory, branch or curves file as a lazily read ``xarray.Dataset``.

    See :func:`vrsweep.store.reading.open_results`; xarray is imported only when this is called, so the
    command line starts as fast as before.
    """
    from vrsweep.store.reading import open_results as _open_results

    return _open_results(path, **kwargs)


_COMPUTING = ("sweep", "simulate", "theory")  # vrsweep.execution.api, imported on first use


def __getattr__(name):
    if name in _COMPUTING:
        from vrsweep.execution import api

        return getattr(api, name)
    raise AttributeError(f"module 'vrsweep' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_COMPUTING))


__all__ = ["__version__", "open_results", "sweep", "simulate", "theory"]
