"""The numba decorator of the numerical kernel: cached (where vrsweep can key the cache by its
sources), with numpy's floating-point error model.

``error_model="numpy"``: a float division by zero gives inf or nan, as in numpy, instead of
raising ZeroDivisionError. Inside a ``prange`` loop such an exception cannot be raised cleanly
(it surfaced as "SystemError: ... returned a result with an exception set" for g = 1e200), and
every non-finite value is already turned into a point status (``non_finite``, ``step_too_small``)
by the kernel. It also drops the zero test before every division from the hot loop.
"""

from numba import njit

from numba.core import inline_closurecall

from vrsweep.numerics import numba_cache, numba_inline

numba_cache.keep_going_when_a_save_fails()  # before any kernel is compiled (and saved)
numba_inline.share_scope_copies(inline_closurecall)  # a fifth of each kernel's compile


def kernel_jit(function=None, **options):
    """``njit(cache=True, error_model="numpy", **options)``, usable with or without arguments.

    ``cache`` is False when vrsweep found no cache folder it can key by its sources
    (``numba_cache.enabled``): numba's own fallback, the package's ``__pycache__``, could load a
    kernel older than the installed code.
    """
    options = {"cache": numba_cache.enabled(), "error_model": "numpy", **options}
    if function is None:
        return njit(**options)
    return njit(**options)(function)
