"""Named tuples of floats read from arrays: field ``k`` of the tuple from row ``k`` of an array,
one load each when compiled (:func:`record`; :mod:`rigid_env.core.layout` reads its parameters and
model columns the same way).

A module of its own, below :mod:`rigid_env.core.layout`: the modules that read records with it
(:mod:`rigid_env.core.geomagnetic`) are imported while the layout loads the effects' declarations
(whose kernels use the orbit's and the Sun's constants), so they must not import the layout.
"""

from __future__ import annotations

import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@intrinsic
def _read(typingctx, array, i, like):
    """The named tuple of ``like``'s type read from ``array``: field ``k`` from ``array[k, i]``
    (a column of a 2-D array) or ``array[i + k]`` (1-D), one load each, no copies."""

    def codegen(context, builder, sig, args):
        array_type, index_type, tuple_type = sig.args
        ary = context.make_array(array_type)(context, builder, args[0])
        col = context.cast(builder, args[1], index_type, types.intp)
        out = context.get_constant_undef(tuple_type)
        for k in range(tuple_type.count):
            row = context.get_constant(types.intp, k)
            at = [row, col] if array_type.ndim == 2 else [builder.add(row, col)]
            ptr = cgutils.get_item_pointer(
                context, builder, array_type, ary, at, wraparound=False, boundscheck=False
            )
            out = builder.insert_value(out, builder.load(ptr), k)
        return out

    return like(array, i, like), codegen


def record(numbers: FloatArray, like: tuple) -> tuple:
    """The named tuple of ``like``'s type (a NamedTuple of floats) from the head of the 1-D
    ``numbers``, field by field in order; compiled, one load per field (an array crosses into
    compiled code far faster than a tuple of numbers)."""
    return type(like)(*numbers[: len(like)].tolist())


@overload(record, inline="always")
def _record(numbers, like):
    return lambda numbers, like: _read(numbers, 0, like)
