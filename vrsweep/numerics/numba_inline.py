"""numba's inliner, copying an inlined function's IR once instead of once per block.

numba inlines a function (``inline="always"``) by deep-copying its IR block by block, twice per
inlined call (``InlineWorker.inline_ir``'s ``copy_ir``, numba 0.58 to 0.68 and numba-cuda 0.30).
Every block refers to the function's one scope, which holds all of its variables, so each
block's copy copies the whole scope again: the work grows as blocks times variables. The
integration loop (kernel._integrate, inlined into every kernel) has about 400 blocks and 3,800
variables, and copying it took 5 s of the 23 s a first rk45 sweep waits for
(benchmarks/README.md, "The inliner's copies"). Copying one IR's blocks with one memo, as
``copy.deepcopy`` of the whole block dictionary would, copies the scope once, and the copied
blocks share it as the originals did. The inlined code is the same: numba replaces every
variable of the copy by one of the caller's and points every block at the caller's scope
before anything else reads it (numba issue 8989 and numba-cuda pull request 689 report the
same cost).

``share_scope_copies`` changes the inliner only where its source has the per-block copy this
module expects; a numba that copies differently is left as it is (and compiles as fast as it
does).
"""

import copy
import functools
import inspect
import threading

# What the inliner's source says where it copies block by block (numba and numba-cuda alike).
_PER_BLOCK_COPY = "copy.deepcopy(block)", "copy.deepcopy(the_ir.blocks[block_label])"


class _OneMemoPerScope(threading.local):
    """The copy module as the inliner's module sees it. Inside an ``inline_ir`` call (``memos`` set,
    per thread) the blocks of one IR, which share one scope, are copied with one memo, so the
    scope and its variables are copied once; outside, and for everything else, it is the copy
    module."""

    memos = None  # id(scope) -> (scope, memo): the scope kept, so its id stays its own

    def deepcopy(self, x, memo=None):
        scope = getattr(x, "scope", None)
        if memo is None and self.memos is not None and scope is not None and hasattr(x, "body"):
            entry = self.memos.get(id(scope))
            if entry is None:
                entry = self.memos[id(scope)] = (scope, {})
            memo = entry[1]
        return copy.deepcopy(x, memo)

    def __getattr__(self, name):
        return getattr(copy, name)


def _copies_block_by_block(module) -> bool:
    worker = getattr(module, "InlineWorker", None)
    if worker is None or getattr(module, "copy", None) is not copy:
        return False
    try:
        source = inspect.getsource(worker.inline_ir)
    except (OSError, TypeError, AttributeError):
        return False
    return any(text in source for text in _PER_BLOCK_COPY)


def share_scope_copies(module) -> bool:
    """Make ``module``'s inliner (numba.core.inline_closurecall or numba-cuda's copy of it) copy
    each IR's blocks with one memo. Idempotent; False where the module is not the one expected."""
    worker = getattr(module, "InlineWorker", None)
    if worker is not None and getattr(worker.inline_ir, "shares_scope_copies", False):
        return True
    if not _copies_block_by_block(module):
        return False
    inline_ir = worker.inline_ir
    copies = _OneMemoPerScope()

    @functools.wraps(inline_ir)
    def inline_ir_sharing_scope_copies(self, *args, **kwargs):
        # One memo table per call: two calls may inline the same IR (an overload's cached IR),
        # and their copies must not share anything.
        found, copies.memos = copies.memos, {}
        try:
            return inline_ir(self, *args, **kwargs)
        finally:
            copies.memos = found

    inline_ir_sharing_scope_copies.shares_scope_copies = True
    module.copy = copies  # the module's name ``copy`` is read by copy_ir only
    worker.inline_ir = inline_ir_sharing_scope_copies
    return True
