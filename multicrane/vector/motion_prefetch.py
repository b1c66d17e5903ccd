"""Software prefetch for the motion step: the next copy's scattered lines fetched ahead.

At thousands of copies a copy's observations (``[N, D]``) and occupancy are out of cache, and
a step touches them in scattered places: each crane's vector, and the table rows and plan
columns of the components the cranes hold (what their moves and arrivals repaint). Those
places are known before the copy steps, so ``prefetch_copy`` asks for them (LLVM's
``llvm.prefetch``, for writing) while the copy before it steps: the fetches then overlap with
that work instead of stalling the store buffer one line after another. A prefetch changes no
value; a wrong guess costs one wasted fetch.
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

from multicrane.core.codes import Move
from multicrane.envs.observation import COMPONENT_FEATURES, N_OWN, N_SHARED
from multicrane.vector.compiled import inlined

_X_MOVES = (int(Move.X_MINUS), int(Move.X_PLUS))  # the neighbours on other cache lines
_I8P = ir.IntType(8).as_pointer()
_I32 = ir.IntType(32)


@intrinsic
def prefetch(typingctx, row, index):
    """Ask for the cache line holding ``row[index]`` (a 1-D array), to be written soon."""

    def codegen(context, builder, signature, args):
        row_type = signature.args[0]
        array = context.make_array(row_type)(context, builder, args[0])
        at = context.cast(builder, args[1], signature.args[1], types.intp)
        pointer = cgutils.get_item_pointer(context, builder, row_type, array, [at])
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [_I8P, _I32, _I32, _I32]),
            "llvm.prefetch.p0i8",
        )  # fmt: skip
        # write, keep in every cache level, data
        flags = [ir.Constant(_I32, 1), ir.Constant(_I32, 3), ir.Constant(_I32, 1)]
        builder.call(fn, [builder.bitcast(pointer, _I8P), *flags])
        return context.get_dummy_value()

    return types.none(row, index), codegen


@inlined
def _prefetch_held(site, st, buf, b, crane, comp):
    """The lines a move of ``comp`` (held by ``crane``) reads or writes: its cells and their
    neighbours along x in the occupancy, its plan columns in the crane's own planes and in
    every crane's shared planes, and its table row."""
    occ, obs = st.occ[b], buf.obs
    for i in range(site.length[comp]):
        j = st.cells[b, comp, i]
        prefetch(occ, j)
        for m in _X_MOVES:
            prefetch(occ, j + site.move_delta[m])
        prefetch(obs[b, crane], site.own_start + site.column_of[j] * N_OWN)
    row = site.rows_start + comp * COMPONENT_FEATURES
    for u in range(site.n_cranes):
        line = obs[b, u]
        prefetch(line, row)
        prefetch(line, row + COMPONENT_FEATURES - 1)
        for i in range(site.length[comp]):
            prefetch(line, site.column_of[st.cells[b, comp, i]] * N_SHARED)


@inlined
def prefetch_copy(site, st, buf, b):
    """Prefetch what copy ``b``'s step will most likely touch: every crane's vector and
    what the moves of the components held will (``_prefetch_held``)."""
    for k in range(site.n_cranes):
        prefetch(buf.obs[b, k], site.crane_start)
    for k in range(site.n_cranes):
        comp = st.held[b, k]
        if comp >= 0:
            _prefetch_held(site, st, buf, b, k, comp)
