"""The numba options of the kernels (see the compile-time rules in :mod:`roadbank.estimators.kernels`).

``ENTRY``: a function Python calls (a ``*_run`` or ``*_step``); ``HELPER``: a function only
compiled code calls (no Python or C wrapper); ``INLINE``: a small helper LLVM inlines into
its callers. None allocates or counts references (``_nrt=False``); division by zero gives
inf/NaN as in numpy (``error_model="numpy"``); every compiled function is cached on disk.
"""

from __future__ import annotations

ENTRY = dict(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
HELPER = dict(ENTRY, no_cpython_wrapper=True)
INLINE = dict(HELPER, forceinline=True)
