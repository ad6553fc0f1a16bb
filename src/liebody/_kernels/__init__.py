"""Private numba kernels.

Everything here is ``@njit(cache=True)`` on plain float64 arrays and scalars: no
Python objects, no allocation inside hot loops. Kernels compile on first use,
never at import of :mod:`liebody`. The public API validates input before calling
them; kernels themselves trust their arguments.
"""
