"""Which numba kernel families a run will compile first (no cached machine code yet), and about
how long that takes: what ``roadbank reproduce`` tells the user before its first cell.

The check is cheap: it reads each family's numba cache index (a few hundred bytes), which numba
itself treats as stale when the kernel's source file changed, and compiles nothing.
"""

from __future__ import annotations

#: compile time (s) of each kernel family in a fresh process with an empty cache
#: (``python -m roadbank.bench.cold``, docs/benchmarks.md; more on a loaded machine)
COMPILE_S = {"plant": 3.6, "lpv": 4.2, "dfc": 1.2, "riccati": 3.5, "adaptive": 3.4, "gated": 4.0,
             "smooth": 0.9}

#: the kernel families an estimator's ``run()`` needs (default: the scheduled linear observers')
_FAMILIES = {"dfc": ("dfc",), "pif-adaptive": ("adaptive",), "pif-rate-adaptive": ("adaptive",),
             "pif-gated": ("gated",), "pif-smoother": ("lpv", "smooth")}


def families_for(names, simulate: bool = True) -> list[str]:
    """Kernel families that running the estimators ``names`` (and, with ``simulate``, the
    simulator) compiles, in :data:`COMPILE_S` order."""
    need = {"plant"} if simulate else set()
    for n in names:
        need.update(_FAMILIES.get(n, ("lpv",)))
    return [f for f in COMPILE_S if f in need]


def _dispatcher(family: str):
    """The numba dispatcher whose cache stands for ``family`` (its entry point)."""
    if family == "plant":
        from ..sim.integrate import simulate_core
        return simulate_core
    from ..estimators import kernels
    return getattr(kernels, {"smooth": "smooth_backward"}.get(family, f"{family}_run"))


def is_cold(family: str) -> bool:
    """True when ``family`` has neither machine code in this process nor a valid numba cache
    entry (so its first call compiles); False when it is loaded or cached, or cannot be told."""
    try:
        disp = _dispatcher(family)
        if disp.signatures:                      # already compiled or loaded in this process
            return False
        cache = getattr(disp, "_cache", None)
        if cache is None or not getattr(cache, "_enabled", True):
            return False
        return not cache._cache_file._load_index()
    except Exception:                            # numba internals changed: say nothing
        return False


def cold_families(names, simulate: bool = True) -> list[str]:
    """The families of :func:`families_for` that :func:`is_cold` says will compile."""
    return [f for f in families_for(names, simulate) if is_cold(f)]


def compile_estimate_s(families) -> float:
    """About how long (s) compiling ``families`` takes (:data:`COMPILE_S`, one core)."""
    return float(sum(COMPILE_S[f] for f in families))
