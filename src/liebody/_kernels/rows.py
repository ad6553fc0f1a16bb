"""Row permutations in place: an ensemble's groups of bodies run on contiguous rows of its
sample arrays (no copy of the samples per group), which are put back in body order."""

from __future__ import annotations

import numpy as np

from liebody._kernels._jit import jit


@jit
def unpermute_rows(a, order, seen):
    """Move row ``k`` of the 2-d array ``a`` to row ``order[k]`` for every ``k``, in place
    (``order`` a permutation of ``0 .. n - 1``), cycle by cycle with one spare row;
    ``seen`` (``n`` booleans, all false) is scratch."""
    n, w = a.shape
    spare = np.empty(w)
    for s in range(n):
        if seen[s]:
            continue
        seen[s] = True
        d = order[s]
        if d == s:
            continue
        for c in range(w):  # the row that belongs at d
            spare[c] = a[s, c]
        while True:
            for c in range(w):  # put it there, take out the row that belongs at order[d]
                x = a[d, c]
                a[d, c] = spare[c]
                spare[c] = x
            seen[d] = True
            d = order[d]
            if d == s:
                for c in range(w):
                    a[s, c] = spare[c]
                break
