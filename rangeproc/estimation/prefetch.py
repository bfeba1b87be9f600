"""A software prefetch for compiled loops that walk large arrays backwards (``llvm.prefetch``).

Kim's IMM smoother (``estimation.imm_smoother``) reads the forward filter's model-conditioned
history, about 1.3 kB an epoch for three models (``xm`` (E, r, n), ``Pm`` (E, r, n(n+1)/2)),
from the last epoch back to the first, skipping the rows of pruned models, and writes its
output the same way. On a 20,000-epoch run (26 MB of history, far beyond the caches) the
hardware prefetchers did not keep up with that pattern: the same smoother ran 0.75 us an
epoch faster on a history that fits the caches. :func:`prefetch` asks for the cache lines of
an epoch a few steps ahead; it changes no value (a hint: LLVM's ``llvm.prefetch``, read,
highest locality, data cache), and an architecture without the instruction ignores it.
"""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

#: Bytes per cache line the callers step by (64 on x86-64 and most AArch64 cores); float64
#: elements per line: :data:`LINE_DOUBLES`.
LINE_BYTES = 64
LINE_DOUBLES = LINE_BYTES // 8


@intrinsic
def prefetch(typingctx, arr, index):
    """Hint the cache line holding flat element ``index`` (int) of the C-contiguous array
    ``arr`` into the data cache (compiled code only). ``index`` must lie inside the array
    (a prefetch never faults, but the address is only meaningful there)."""
    if not isinstance(arr, types.Array) or not isinstance(index, types.Integer):
        return None
    sig = types.void(arr, index)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        idx = context.cast(builder, args[1], signature.args[1], types.intp)
        ptr = builder.bitcast(builder.gep(ary.data, [idx]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0")
        # (address, read = 0, locality = 3 (keep in all levels), data cache = 1)
        builder.call(fn, [ptr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen
