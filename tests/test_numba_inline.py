"""numerics/numba_inline.py: numba's inliner copies an inlined function's scope once per IR, not
once per block, and inlines the same code as before."""

import copy

import numpy as np
import pytest
from numba import njit
from numba.core import inline_closurecall
from numba.extending import overload

from vrsweep.numerics import jit, numba_inline  # noqa: F401 - jit applies the change on import


def _many_blocks(x, n):
    # a callee with a few dozen blocks and variables: branches and a loop
    total = 0.0
    for k in range(n):
        if x > k:
            total += x * k
        elif x < -k:
            total -= x / (k + 1)
        else:
            total += 1.0
        if total > 1e6:
            total = 1e6
    y = total if x > 0 else -total
    z = y * 2.0 if n > 3 else y
    return z + (1.0 if n % 2 else 0.0)


_many_blocks_inlined = njit(inline="always")(_many_blocks)


def _caller(x, n):
    return _many_blocks_inlined(x, n) - 2.0 * _many_blocks_inlined(-x, n + 1)  # two inlined sites


def _compile_with(inline_ir, monkeypatch):
    """Compile a caller of the inlined callee with ``inline_ir`` as numba's inliner. Returns the
    caller's values and, for each inlined call, the number of blocks of the callee's copy and of
    distinct scope objects among them (each a copy of the whole scope)."""
    copies = []

    def spying(self, *args, **kwargs):
        result = inline_ir(self, *args, **kwargs)
        blocks = result[0].blocks.values()  # the unmutated copy of the callee's IR
        copies.append((len(blocks), len({id(block.scope) for block in blocks})))
        return result

    monkeypatch.setattr(inline_closurecall.InlineWorker, "inline_ir", spying)
    caller = njit(_caller)  # a dispatcher of its own: compiled afresh
    values = [caller(x, n) for x in (-3.5, 0.0, 2.25, 40.0) for n in (0, 3, 8)]
    return values, copies


def test_the_inliner_copies_each_scope_once_and_computes_the_same(monkeypatch):
    """numba's own inliner deep-copies the callee's scope once per block; with the change, once per
    copy of the IR. The caller computes the same values bit for bit."""
    shared = inline_closurecall.InlineWorker.inline_ir
    if not getattr(shared, "shares_scope_copies", False):
        pytest.skip("this numba's inliner does not copy block by block (numba_inline left it alone)")
    before, copies_before = _compile_with(shared.__wrapped__, monkeypatch)
    after, copies_after = _compile_with(shared, monkeypatch)
    assert before == [_many_blocks(x, n) - 2.0 * _many_blocks(-x, n + 1)
                      for x in (-3.5, 0.0, 2.25, 40.0) for n in (0, 3, 8)]
    assert np.array_equal(before, after)
    assert len(copies_before) == len(copies_after) == 2  # two call sites
    for (blocks, scopes_before), (blocks_after, scopes_after) in zip(copies_before, copies_after):
        assert blocks == blocks_after > 10
        assert scopes_before == blocks  # one copy of the scope per block
        assert scopes_after == 1


def _twice(x):
    return 2.0 * x


@overload(_twice, inline="always")
def _twice_inlined(x):
    # an overload inlined with its IR cached: the same IR copied at each call site
    def implementation(x):
        if x > 0:
            return 2.0 * x
        return x + x
    return implementation


def test_an_overloads_cached_ir_inlined_at_several_sites_stays_apart():
    """The copies of one inline_ir call share a memo, those of two calls do not: an overload's IR,
    cached once and inlined at three sites, gives three independent copies."""
    @njit
    def three_sites(a, b, c):
        return _twice(a) + 10.0 * _twice(b) + 100.0 * _twice(c)

    assert three_sites(1.0, -2.0, 3.0) == 2.0 - 40.0 + 600.0
    assert three_sites(-1.0, 2.0, -3.0) == -2.0 + 40.0 - 600.0


def test_an_inliner_that_does_not_copy_block_by_block_is_left_alone():
    """A numba whose inliner copies otherwise (or whose module is not the one expected) is not
    changed: share_scope_copies says so and replaces nothing."""
    class Worker:
        def inline_ir(self, caller_ir, block, i, callee_ir, callee_freevars, arg_typs=None):
            return callee_ir.copy()

    class Module:
        InlineWorker = Worker

    Module.copy = copy
    assert numba_inline.share_scope_copies(Module) is False
    assert Module.InlineWorker.inline_ir is Worker.inline_ir
    assert numba_inline.share_scope_copies(object()) is False


def test_numbas_and_numba_cudas_inliners_share_scope_copies_where_they_copy_block_by_block():
    """Applied on import (jit.py; cuda.py for numba-cuda's own copy of the inliner), and applied
    again harmlessly."""
    assert numba_inline.share_scope_copies(inline_closurecall) == getattr(
        inline_closurecall.InlineWorker.inline_ir, "shares_scope_copies", False)
    wrapped = inline_closurecall.InlineWorker.inline_ir
    numba_inline.share_scope_copies(inline_closurecall)
    assert inline_closurecall.InlineWorker.inline_ir is wrapped  # not wrapped twice
    # Outside an inline_ir call the module's copy is the copy module's, memo and all.
    nested = [1.0, [2.0]]
    copied = inline_closurecall.copy.deepcopy(nested)
    assert copied == nested and copied[1] is not nested[1]
    assert inline_closurecall.copy.copy is copy.copy
    cuda_inliner = pytest.importorskip("numba.cuda.core.inline_closurecall")
    from vrsweep.numerics import cuda  # noqa: F401 - applies it to numba-cuda's

    assert numba_inline.share_scope_copies(cuda_inliner) == getattr(
        cuda_inliner.InlineWorker.inline_ir, "shares_scope_copies", False)
