"""Compiled (numba) pieces shared by the fixed-wing and multirotor kernels.

- :func:`attitude`: the trigonometry of the Euler angles (3-2-1: yaw psi, pitch theta, roll phi)
  and the body -> NED rotation matrix, the same arithmetic as
  :func:`replay.frames.rotation_body_to_ned`;
- :func:`body_to_ned` / :func:`ned_to_body`: a vector turned by that matrix or its transpose;
- :func:`record`: one row of the flight log the ``fly`` kernels fill (state, controls, the
  controller's logged signals).

The rotation comes as a flat 9-tuple, row-major: ``r[3 * i + j]`` is row i, column j. numba's
disk cache does not see changes to these functions from the kernels that call them: after editing
this module, delete ``NUMBA_CACHE_DIR`` (``make clean``).
"""

from __future__ import annotations

import math

import numba as nb


@nb.njit(cache=True, nogil=True)
def attitude(phi, theta, psi):  # pragma: no cover - jit
    """``(sin phi, cos phi, sin theta, cos theta, sin psi, cos psi, r)`` with ``r`` the body -> NED
    rotation (row-major 9-tuple)."""
    sf = math.sin(phi)
    cf = math.cos(phi)
    st = math.sin(theta)
    ct = math.cos(theta)
    sp = math.sin(psi)
    cp = math.cos(psi)
    r = (
        ct * cp,
        sf * st * cp - cf * sp,
        cf * st * cp + sf * sp,
        ct * sp,
        sf * st * sp + cf * cp,
        cf * st * sp - sf * cp,
        -st,
        sf * ct,
        cf * ct,
    )
    return sf, cf, st, ct, sp, cp, r


@nb.njit(cache=True, nogil=True)
def body_to_ned(r, x, y, z):  # pragma: no cover - jit
    """``r @ (x, y, z)``: a body-axes vector in NED."""
    return (
        r[0] * x + r[1] * y + r[2] * z,
        r[3] * x + r[4] * y + r[5] * z,
        r[6] * x + r[7] * y + r[8] * z,
    )


@nb.njit(cache=True, nogil=True)
def ned_to_body(r, n, e, d):  # pragma: no cover - jit
    """``r.T @ (n, e, d)``: a NED vector in body axes."""
    return (
        r[0] * n + r[3] * e + r[6] * d,
        r[1] * n + r[4] * e + r[7] * d,
        r[2] * n + r[5] * e + r[8] * d,
    )


@nb.njit(cache=True, nogil=True)
def record(x, u, log, first, n_log, rec_x, rec_u, rec_g, nrec):  # pragma: no cover - jit
    """Row ``nrec`` of the flight log, if the buffers have room: the 12 states of ``x``, the 4
    controls ``u`` and ``log[first : first + n_log]``; returns the new number of rows."""
    if nrec >= rec_x.shape[0]:
        return nrec
    for j in range(12):
        rec_x[nrec, j] = x[j]
    for j in range(4):
        rec_u[nrec, j] = u[j]
    for j in range(n_log):
        rec_g[nrec, j] = log[first + j]
    return nrec + 1
