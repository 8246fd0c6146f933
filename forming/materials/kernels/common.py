"""Compilation switch and status codes shared by the point-kernel modules.

Every inner kernel function is compiled with :data:`_inner` (numba, cached, without
the numba runtime); the status codes are what a stress update reports for a point.
"""

from __future__ import annotations

import numba

STATUS_OK = 0
STATUS_INVERTED = 1  # C not positive definite (det F <= 0 is checked by the caller)
STATUS_RETURN_MAP = 2  # local Newton of the return mapping did not converge

# The inner functions allocate nothing, so they are compiled without the numba
# runtime (NRT; ``_nrt`` is numba's switch for it): the arrays they pass around are
# then not reference-counted. With the runtime, every call that passes arrays
# increments and decrements their counts with atomic operations (numba issue
# #2345), which cost more than the arithmetic of these kernels. Allocating in such a
# function is a compile error ("NRT required but not enabled").
_inner = numba.njit(cache=True, _nrt=False)
# Small helpers on the hot path of every point are inlined into their callers (numba
# IR inlining): a call passing several arrays cost about as much as their work.
_inlined = numba.njit(cache=True, _nrt=False, inline="always")
