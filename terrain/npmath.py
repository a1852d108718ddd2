"""numpy's own float64 ``pow``, ``exp``, ``log`` and ``log1p`` for numba kernels, so that a kernel
rounds exactly as the numpy code it replaces.

On x86-64 with AVX-512 (``AVX512_SKX``) numpy evaluates these ufuncs with Intel's SVML, linked into
its ``_multiarray_umath`` extension (the ``__svml_*8_ha`` entries, 8 lanes at a time, whatever the
array's length).  SVML and the C library round differently in a few per cent of cases (even
``pow(x, 2.0)`` and ``x * x`` differ), so a kernel calling ``math.pow`` -- the C library, which
numba uses -- would drift from the numpy code by an ulp here and there.  Here each function is a
numba intrinsic that calls numpy's SVML entry on a vector holding the argument in lane 0: the same
machine code numpy runs, bit for bit (``tests/test_threats.py`` checks it on a million values).

Where numpy does not use SVML (another CPU or platform, or ``NPY_DISABLE_CPU_FEATURES``), or its
extension does not export the entries, the functions are the C library's (``math.pow``...),
which may differ from numpy's by an ulp: :data:`NUMPY_SVML` says which is in use.  The choice is
made when a kernel compiles and numba's cache keeps it: clear the cache (``NUMBA_CACHE_DIR``)
after changing ``NPY_DISABLE_CPU_FEATURES``.

numpy also takes shortcuts for ``array ** scalar`` (``x ** 2`` is ``x * x``, ``x ** 0.5`` is
``sqrt(x)``, ``x ** -1`` is ``1 / x``): :func:`scalar_pow` does the same; an array exponent always
goes through ``pow`` (:func:`pow_`).
"""

from __future__ import annotations

import ctypes
import importlib
import math
from collections.abc import Callable
from typing import Any

import llvmlite.binding as llb
import numba as nb
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

_ENTRIES = {"pow": "__svml_pow8_ha", "exp": "__svml_exp8_ha", "log": "__svml_log8_ha"}
_ENTRIES["log1p"] = "__svml_log1p8_ha"


def _find_svml() -> bool:
    """True when numpy dispatches to SVML here and its extension exports the entries.  Exported
    entries are registered with LLVM even when numpy does not use them (``NPY_DISABLE_CPU_FEATURES``),
    so that kernels compiled another time and loaded from numba's cache still link."""
    try:
        umath = importlib.import_module("numpy._core._multiarray_umath")
        lib = ctypes.CDLL(umath.__file__)
        addresses = {
            name: ctypes.cast(getattr(lib, name), ctypes.c_void_p).value
            for name in _ENTRIES.values()
        }
    except (ImportError, OSError, AttributeError):
        return False
    for name, address in addresses.items():
        llb.add_symbol(name, address)
    return bool(umath.__cpu_features__.get("AVX512_SKX", False))


NUMPY_SVML = _find_svml()


def _lane0(entry: str, arity: int, fallback: Callable[..., float]) -> Any:
    """An intrinsic computing ``entry`` on (float64, ...) scalars: numpy's SVML vector entry on
    lane 0 (the other lanes hold 1.0 and are dropped), or ``fallback`` compiled by numba."""
    args = (types.float64,) * arity

    def typer(typingctx: Any, *xs: Any) -> Any:
        sig = types.float64(*args)

        def codegen(context: Any, builder: Any, signature: Any, values: Any) -> Any:
            if not NUMPY_SVML:
                return context.compile_internal(builder, fallback, signature, values)
            vec = ir.VectorType(ir.DoubleType(), 8)
            fnty = ir.FunctionType(vec, [vec] * arity)
            fn = cgutils.get_or_insert_function(builder.module, fnty, entry)
            lane = ir.Constant(ir.IntType(32), 0)
            ones = ir.Constant(vec, [1.0] * 8)
            vs = [builder.insert_element(ones, v, lane) for v in values]
            return builder.extract_element(builder.call(fn, vs), lane)

        return sig, codegen

    if arity == 1:

        def one(typingctx: Any, x: Any) -> Any:
            return typer(typingctx, x)

        return intrinsic(one)

    def two(typingctx: Any, x: Any, y: Any) -> Any:
        return typer(typingctx, x, y)

    return intrinsic(two)


def _pow(x: float, y: float) -> float:
    return math.pow(x, y)


def _exp(x: float) -> float:
    return math.exp(x)


def _log(x: float) -> float:
    return math.log(x)


def _log1p(x: float) -> float:
    return math.log1p(x)


pow_ = _lane0(_ENTRIES["pow"], 2, _pow)
exp_ = _lane0(_ENTRIES["exp"], 1, _exp)
log_ = _lane0(_ENTRIES["log"], 1, _log)
log1p_ = _lane0(_ENTRIES["log1p"], 1, _log1p)


LANES = 8


def _pow_lanes_fallback(x: Any, y: Any, out: Any) -> None:
    for i in range(LANES):
        out[i] = math.pow(x[i], y[i])


def _pow_lanes(typingctx: Any, x: Any, y: Any, out: Any) -> Any:
    """``out[:8] = x[:8] ** y[:8]`` for C-contiguous float64 arrays of at least 8 values: one call
    of numpy's 8-lane entry (or 8 of the fallback), for kernels that can advance 8 independent
    searches together (a single-value :func:`pow_` costs nearly as much as 8 lanes)."""
    want = types.Array(types.float64, 1, "C")
    if not (x == want and y == want and out == want):
        return None
    sig = types.void(x, y, out)

    def codegen(context: Any, builder: Any, signature: Any, values: Any) -> Any:
        if not NUMPY_SVML:
            context.compile_internal(builder, _pow_lanes_fallback, signature, values)
            return context.get_dummy_value()
        vec = ir.VectorType(ir.DoubleType(), LANES)
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(vec, [vec, vec]), _ENTRIES["pow"]
        )
        ptrs = [
            builder.bitcast(context.make_array(ty)(context, builder, v).data, vec.as_pointer())
            for ty, v in zip(signature.args, values, strict=True)
        ]
        xv = builder.load(ptrs[0], align=8, typ=vec)
        yv = builder.load(ptrs[1], align=8, typ=vec)
        builder.store(builder.call(fn, [xv, yv]), ptrs[2], align=8)
        return context.get_dummy_value()

    return sig, codegen


pow_lanes: Any = intrinsic(_pow_lanes)


@nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def scalar_pow(x: float, e: float) -> float:  # pragma: no cover - jit
    """numpy's ``x ** e`` for an array x and a Python scalar e (its shortcuts for 2, 0.5, -1)."""
    if e == 2.0:
        return x * x
    if e == 0.5:
        return math.sqrt(x)
    if e == -1.0:
        return 1.0 / x
    return pow_(x, e)
