"""The numba decorator of the numerical kernel: cached (where vrsweep can key the cache by its
sources), with numpy's floating-point error model.

``error_model="numpy"``: a float division by zero gives inf or nan, as in numpy, instead of
raising ZeroDivisionError. Inside the parallel loop of 0.7.16 and before such an exception could
not be raised cleanly (it surfaced as "SystemError: ... returned a result with an exception set"
for g = 1e200), and
every non-finite value is already turned into a point status (``non_finite``, ``step_too_small``)
by the kernel. It also drops the zero test before every division from the hot loop.

One compile per argument type: numba compiles a jitted function called from another with a
constant argument once per constant (``rhs(t, h, 4, ...)`` is typed ``Literal[int](4)``), so
dop853's step, which names its stages 1 to 15, compiled the model's right-hand side 15 times, and
a dozen helpers called with constant flags were compiled two to five times. No function of the
kernel needs the constant's value to be typed (none calls ``numba.literally`` or relies on a
branch pruned by a constant argument), so ``kernel_jit``'s functions are compiled for the
argument's type alone, and LLVM folds the constant where it inlines the call. A cold dop853 sweep
compiles in three quarters of the time, with the same results bit for bit and the same speed
(benchmarks/README.md, "One compile per argument type"). The GPU's kernel is compiled from
numba-cuda's own device copies of these functions, which keep numba-cuda's rule (the same section
says why).
"""

from numba import njit, types

from numba.core import inline_closurecall
from numba.core.registry import CPUDispatcher

from vrsweep.numerics import numba_cache, numba_inline

numba_cache.keep_going_when_a_save_fails()  # before any kernel is compiled (and saved)
numba_inline.share_scope_copies(inline_closurecall)  # a fifth of each kernel's compile


def kernel_jit(function=None, **options):
    """``njit(cache=True, error_model="numpy", **options)``, compiled once per argument type
    (_PerTypeDispatcher), usable with or without arguments.

    ``cache`` is False when vrsweep found no cache folder it can key by its sources
    (``numba_cache.enabled``): numba's own fallback, the package's ``__pycache__``, could load a
    kernel older than the installed code.
    """
    options = {"cache": numba_cache.enabled(), "error_model": "numpy", **options}

    def compiled(function):
        return _compiled_per_type(njit(**options)(function))

    return compiled if function is None else compiled(function)


class _PerTypeDispatcher(CPUDispatcher):
    """numba's CPU dispatcher, typing a call from jitted code by its arguments' types, not their
    constant values (the module's docstring says why)."""

    def get_call_template(self, args, kws):
        return super().get_call_template(tuple(types.unliteral(arg) for arg in args),
                                         {name: types.unliteral(arg) for name, arg in kws.items()})


def _compiled_per_type(dispatcher):
    # (NUMBA_DISABLE_JIT gives the Python function back; a subclass of numba's has its own reasons)
    if type(dispatcher) is CPUDispatcher:
        dispatcher.__class__ = _PerTypeDispatcher
    return dispatcher
