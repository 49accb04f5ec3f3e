"""Reference-count-free views of kernel arguments (numba internals; used only by the kernels).

numba keeps every array it binds (an argument passed to an inlined helper, a row view
``S[i]``) alive with an atomic reference-count update. In the identifier kernels those
updates took ≈ 25 % of a step (measured with ``perf``: the two hottest instructions of a
batched step were the atomic adds). :func:`raw` re-creates an argument array as a view
with no owner (``numba.carray`` on its data pointer), so the bindings below it cost nothing.

Safe only while the original array is alive: the kernels apply it to their own arguments,
which the caller holds for the whole call, and never return or store the views.
"""

from __future__ import annotations

from numba import carray, njit, types
from numba.extending import intrinsic


@intrinsic
def _as_pointer(typingctx, addr, like):  # pragma: no cover - compile-time
    """``addr`` (an integer address) as a pointer to the dtype of the array ``like``."""
    dtype = like.dtype

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(dtype).as_pointer())
    return types.CPointer(dtype)(types.uintp, like), codegen


@njit(cache=True, inline="always")
def raw(a):  # pragma: no cover - compiled
    """The C-contiguous array ``a`` (1-, 2- or 3-D) as an owner-less view of its data."""
    return carray(_as_pointer(a.ctypes.data, a), a.shape)

