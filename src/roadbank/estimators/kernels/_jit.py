"""The numba options of the kernels (see the compile-time rules in :mod:`roadbank.estimators.kernels`)
and the freshness of their disk cache.

``ENTRY``: a function Python calls (a ``*_run`` or ``*_step``); ``HELPER``: a function only
compiled code calls (no Python or C wrapper); ``INLINE``: a small helper LLVM inlines into
its callers; :func:`optimise_for_size`, called first in a kernel, has LLVM optimise it for size.
None allocates or counts references (``_nrt=False``); division by zero gives inf/NaN as in numpy
(``error_model="numpy"``); every compiled function is cached on disk.

numba checks a cached function against its own source file only, while a kernel here also
holds code of the package's other modules and of :mod:`roadbank.estimators.layout` (inlined
helpers, frozen offsets). So the kernels' cache entries carry one stamp of all those files
(:func:`sources_stamp`): editing any of them recompiles every kernel instead of loading stale
machine code.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba import types
from numba.core import caching
from numba.extending import intrinsic

ENTRY = dict(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
HELPER = dict(ENTRY, no_cpython_wrapper=True)
INLINE = dict(HELPER, forceinline=True)


@intrinsic
def optimise_for_size(typingctx):
    """Called first in a kernel: LLVM optimises the compiled function for size (``optsize``), whatever inlines
    into it included.

    No arithmetic changes (no fast-math: the same IEEE operations in the same order), but no loop vectorised or
    unrolled at the cost of code (runtime checks, epilogues), which for the loops over a few states only costs
    compile time: this halves LLVM's share of a family's cold compile, and the general path (trapezoidal rule, LU)
    runs faster than with the vectorised loops. Not in the fixed-rate batch loop (:func:`.lpv.lpv3_fixed_run`,
    :func:`.sample.angles`), whose loops over samples vectorise. numba has no option for it, hence a call.
    """
    def codegen(context, builder, signature, args):
        builder.function.attributes.add("optsize")
        return context.get_dummy_value()
    return types.none(), codegen

_HERE = Path(__file__).resolve().parent
#: the files whose code the compiled kernels contain
SOURCES = tuple(sorted(_HERE.glob("*.py"))) + (_HERE.parent / "layout.py",)


def sources_stamp(paths) -> str:
    """SHA-256 (hex) of the contents of ``paths``, in order."""
    h = hashlib.sha256()
    for p in paths:
        h.update(Path(p).read_bytes())
    return h.hexdigest()


_STAMP = sources_stamp(SOURCES)


class KernelCacheLocator:
    """numba cache locator of the functions defined in this package: numba's own locator for the
    file (where the cache lives), with a source stamp that also covers :data:`SOURCES`."""

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def get_source_stamp(self):
        return self._inner.get_source_stamp(), _STAMP

    @classmethod
    def from_function(cls, py_func, py_file):
        if Path(py_file).resolve().parent != _HERE:
            return None
        for other in _cache_impl()._locator_classes:
            if other is not cls:
                inner = other.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner)
        return None


def _cache_impl():
    """numba's class that picks a cache locator (``CacheImpl``; ``_CacheImpl`` before numba 0.61)."""
    return getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)


def _register() -> None:
    impl = _cache_impl()
    locators = getattr(impl, "_locator_classes", None)
    if isinstance(locators, list) and KernelCacheLocator not in locators:
        locators.insert(0, KernelCacheLocator)     # else numba's internals changed: its own check remains


_register()
