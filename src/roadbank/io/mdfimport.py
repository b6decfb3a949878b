"""Import asammdf without loading sympy until a file needs it.

asammdf imports ``from sympy import lambdify, symbols`` (inside ``try``: sympy is
optional for asammdf) only to evaluate algebraic conversion formulas that numexpr
cannot parse. Loading sympy costs every MDF4 read about 32 MiB of resident memory
and 0.5 s of import time, although almost no log has such a formula.

:func:`import_asammdf` imports asammdf while ``sympy`` resolves to a placeholder
module whose ``lambdify`` and ``symbols`` import the real sympy on their first call
and forward to it (any other attribute loads the real sympy at once). The
placeholder is taken out of ``sys.modules`` as soon as asammdf is imported, so a
later ``import sympy`` anywhere gets the real package. Conversions therefore work
exactly as with a plain ``import asammdf``; only their cost moves to the first file
that needs them. Without sympy installed nothing is replaced (asammdf's own
fallback applies).

:func:`import_asammdf` also guards the finaliser of asammdf's MDF3/MDF4 objects: when a truncated or
corrupt file makes the constructor fail, the half-built object's ``__del__`` calls ``close()``, which
raises (``'MDF4' object has no attribute 'header'``) and Python prints that traceback as "Exception
ignored in ...", after the reader's own one-line error. The guarded finaliser closes a half-built
object quietly; a fully built one is closed as before.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import threading
import types

#: modules asammdf imports only for rare work -> the names it takes from them
DEFERRED = {"sympy": ("lambdify", "symbols")}
_LOCK = threading.RLock()


def _real(module: str, placeholder: types.ModuleType | None = None) -> types.ModuleType:
    """The real ``module``, imported now (the placeholder, if still registered, makes way)."""
    with _LOCK:
        if placeholder is not None and sys.modules.get(module) is placeholder:
            del sys.modules[module]
        return importlib.import_module(module)


def _placeholder(module: str, names) -> types.ModuleType:
    stub = types.ModuleType(module, f"placeholder for {module}: loaded on first use (roadbank.io.mdfimport)")

    def forward(name):
        def call(*args, **kwargs):
            return getattr(_real(module, stub), name)(*args, **kwargs)
        call.__name__ = call.__qualname__ = name
        return call

    for n in names:
        setattr(stub, n, forward(n))

    def __getattr__(name):       # anything else: the real module now
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(_real(module, stub), name)

    stub.__getattr__ = __getattr__  # type: ignore[method-assign]  # a module's __getattr__ (PEP 562)
    return stub


def import_deferring(module: str, deferred: dict) -> types.ModuleType:
    """Import ``module`` while every module named in ``deferred`` (name -> the names ``module``
    takes from it) that is installed but not loaded yet is a placeholder (see the module doc).

    Returns
    -------
    module
        ``module``, imported (or as already loaded).

    Raises
    ------
    ImportError
        If ``module`` (or one of its required dependencies) is not installed.
    """
    mod = sys.modules.get(module)
    if mod is not None:
        return mod
    with _LOCK:
        placed = {}
        for name, names in deferred.items():
            if name not in sys.modules and importlib.util.find_spec(name) is not None:
                sys.modules[name] = placed[name] = _placeholder(name, names)
        try:
            return importlib.import_module(module)
        finally:
            for name, stub in placed.items():
                if sys.modules.get(name) is stub:
                    del sys.modules[name]


def import_asammdf() -> types.ModuleType:
    """The ``asammdf`` module, imported with sympy deferred (see the module doc).

    Raises
    ------
    ImportError
        If asammdf (or one of its required dependencies) is not installed.
    """
    mod = import_deferring("asammdf", DEFERRED)
    _guard_finalisers()
    return mod


def _guard_finalisers() -> None:
    """Make ``__del__`` of asammdf's MDF3 and MDF4 classes quiet on an object whose constructor failed
    (no ``header`` yet): ``close()`` releases the file first and then fails on the attributes the
    constructor never set; that error is dropped. Idempotent."""
    for module, name in (("asammdf.blocks.mdf_v4", "MDF4"), ("asammdf.blocks.mdf_v3", "MDF3")):
        cls = getattr(sys.modules.get(module), name, None)
        original = None if cls is None else getattr(cls, "__del__", None)
        if cls is None or original is None or getattr(original, "_roadbank_guarded", False):
            continue

        def __del__(self, _close=original):
            try:
                _close(self)
            except Exception:
                if hasattr(self, "header"):     # a fully built object: not ours to hide
                    raise

        __del__._roadbank_guarded = True  # type: ignore[attr-defined]
        setattr(cls, "__del__", __del__)  # noqa: B010  (a method assigned on a class: mypy refuses the plain form)
