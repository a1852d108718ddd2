"""terrain/npmath.py: numba intrinsics that round as numpy's float64 ``pow``, ``exp``, ``log`` and
``log1p`` do (its SVML entries where numpy uses them), and numpy's ``array ** scalar`` shortcuts."""

from __future__ import annotations

import numba as nb
import numpy as np

from terrain.npmath import LANES, NUMPY_SVML, exp_, log1p_, log_, pow_, pow_lanes, scalar_pow


@nb.njit(cache=True, error_model="numpy")
def _evaluate(x, k, y, z, w, e):  # type: ignore[no-untyped-def]  # pragma: no cover - jit
    out = np.empty((6, x.size))
    a, b, r = np.empty(LANES), np.empty(LANES), np.empty(LANES)
    for i in range(x.size):
        out[0, i] = pow_(x[i], k[i])
        out[1, i] = exp_(y[i])
        out[2, i] = log_(z[i])
        out[3, i] = log1p_(w[i])
        out[4, i] = scalar_pow(x[i], e)
    for first in range(0, x.size - LANES + 1, LANES):
        a[:] = x[first : first + LANES]
        b[:] = k[first : first + LANES]
        pow_lanes(a, b, r)
        out[5, first : first + LANES] = r
    return out


def test_the_intrinsics_round_as_numpy() -> None:
    rng = np.random.default_rng(7)
    n = 100_000  # a multiple of LANES
    x = rng.uniform(0.0, 2.0, n)
    x[:4] = [0.0, 1.0, 0.5, 2.0]
    k = np.exp(rng.uniform(np.log(0.01), np.log(200.0), n))
    k[4:8] = [1.0, 2.0, 0.5, 100.0]
    y = rng.uniform(-745.0, 709.0, n)
    z = np.exp(rng.uniform(-700.0, 700.0, n))
    w = rng.uniform(-0.999, 10.0, n)
    with np.errstate(all="ignore"):
        want = [x**k, np.exp(y), np.log(z), np.log1p(w)]
    for e in (2.0, 0.5, -1.0, 1.0, 3.7, 8.0):
        got = _evaluate(x, k, y, z, w, e)
        with np.errstate(all="ignore"):
            expect = np.vstack([*want, x**e, want[0]])
        if NUMPY_SVML:  # numpy's own machine code: the same bits
            assert np.array_equal(got, expect), e
        else:  # the C library's: within an ulp or so
            np.testing.assert_allclose(got, expect, rtol=4e-16, atol=0)
