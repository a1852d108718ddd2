"""Compiled hot loops of the planner (numba), each with a pure-Python twin in the module that
uses it; the tests compare the two.  Kernels take plain arrays only, so they compile once and
cache on disk (``NUMBA_CACHE_DIR``)."""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def along(pred: np.ndarray, top: np.ndarray, flag: np.ndarray) -> np.ndarray:  # pragma: no cover
    """``planner.explore._along``: flagged nodes on every node's tree path from the root."""
    out = np.zeros(pred.shape[0])
    for v in top:
        p = pred[v]
        out[v] = (1.0 if flag[v] else 0.0) + (out[p] if p >= 0 else 0.0)
    return out
