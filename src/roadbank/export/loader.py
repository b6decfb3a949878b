"""Load an exported C module into Python through :mod:`ctypes` (tests, benchmarks).

The module is compiled with the strict C99 flags together with a small harness
(:func:`roadbank.export.build.harness_source`) into a shared library; the state
struct lives in a numpy buffer owned by the :class:`CModule`.
"""

from __future__ import annotations

import ctypes
import hashlib
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from ..estimators.base import StepResult
from .build import compile_c, harness_source

_D = ctypes.c_double
_P = ctypes.POINTER(ctypes.c_double)
_PB = ctypes.POINTER(ctypes.c_ubyte)


class CModule:
    """An exported estimator compiled and loaded with :mod:`ctypes`.

    Parameters
    ----------
    source : path
        The generated ``roadbank_<name>.c`` (its header beside it).
    build_dir : path, optional
        Where the shared library goes (default: a new temporary directory).
    opt : str
        Optimisation flags of the build, space-separated (e.g. ``"-O2 -march=native"``).

    ``step()`` and ``run()`` take and return SI float64 values as
    :meth:`roadbank.estimators.base.Estimator.step` does; in a float32 build the
    inputs are rounded to float32 at the call, as on a float32 target.
    """

    def __init__(self, source, build_dir=None, *, opt: str = "-O2"):
        source = Path(source)
        self.source = source
        self.prefix = source.stem
        header = source.with_suffix(".h").read_text()
        self.float32 = f"typedef float {self.prefix}_real;" in header
        self._tmp = None
        if build_dir is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="roadbank-export-")
            build_dir = self._tmp.name
        build_dir = Path(build_dir)
        harness = build_dir / f"{self.prefix}_harness.c"
        harness.write_text(harness_source(self.prefix))
        # a distinct file per source text: the dynamic loader caches libraries by path
        digest = hashlib.sha256(source.read_bytes() + opt.encode()).hexdigest()[:12]
        self.path = compile_c([source, harness], build_dir / f"lib{self.prefix}-{digest}.so", shared=True,
                              flags=tuple(opt.split()), include=[source.parent])
        lib = ctypes.CDLL(str(self.path))
        lib.rbh_state_size.restype = ctypes.c_size_t
        lib.rbh_init.argtypes = [ctypes.c_void_p]
        lib.rbh_step.argtypes = [ctypes.c_void_p, _D, _D, _D, _D, _D, _P]
        lib.rbh_step.restype = ctypes.c_int
        lib.rbh_run.argtypes = [ctypes.c_void_p, ctypes.c_long, _P, _P, _P, _P, _P, ctypes.c_int, _P, _PB]
        real_p = ctypes.POINTER(ctypes.c_float if self.float32 else ctypes.c_double)
        lib.rbh_bench.argtypes = [ctypes.c_long, real_p, real_p, real_p, real_p, real_p, ctypes.c_long]
        lib.rbh_bench.restype = _D
        #: whether the module has the gyro-aided filter's grade correction (``<prefix>_roll_rate``)
        self.has_grade = hasattr(lib, "rbh_roll_rates")
        if self.has_grade:
            lib.rbh_roll_rates.argtypes = [ctypes.c_long] + [_P] * 8
            lib.rbh_roll_rates.restype = ctypes.c_int
        self._lib = lib
        self.state_size = int(lib.rbh_state_size())
        self._state = np.zeros(self.state_size // 8 + 2)     # 8-byte aligned, owned here
        self._sp = self._state.ctypes.data_as(ctypes.c_void_p)
        self._out = np.zeros(4)
        self._outp = self._out.ctypes.data_as(_P)
        self.reset()

    def reset(self) -> None:
        """``<prefix>_init()``: forget all history."""
        self._lib.rbh_init(self._sp)

    def step(self, t: float, vx: float, ay: float, r: float, delta_f: float = float("nan")) -> StepResult:
        """One sample through ``<prefix>_step()``: time (s), vx (m/s), ay (m/s^2), r (rad/s), delta_f (rad)."""
        ok = self._lib.rbh_step(self._sp, t, vx, ay, r, delta_f, self._outp)
        o = self._out
        return StepResult(float(o[0]), float(o[1]), float(o[2]), bool(ok))

    def run(self, t, vx, ay, r, delta_f, *, use_dt: bool = False, reset: bool = True) -> dict:
        """Every sample in C (one call): returns arrays ``w, theta, phi_b, phi`` (rad) and ``valid``.

        ``use_dt`` drives ``<prefix>_step_dt()`` with ``dt = t[k] - t[k-1]`` instead of
        ``<prefix>_step()``. The arrays may hold NaN/inf and non-increasing times.
        """
        cols = [np.ascontiguousarray(a, dtype=np.float64) for a in (t, vx, ay, r, delta_f)]
        n = len(cols[0])
        if any(len(c) != n for c in cols):
            raise ValueError("run(): t, vx, ay, r, delta_f must have the same length")
        if reset:
            self.reset()
        out = np.empty((n, 4))
        valid = np.empty(n, dtype=np.uint8)
        self._lib.rbh_run(self._sp, n, *(c.ctypes.data_as(_P) for c in cols), int(use_dt),
                          out.ctypes.data_as(_P), valid.ctypes.data_as(_PB))
        return {"w": out[:, 0].copy(), "theta": out[:, 1].copy(), "phi_b": out[:, 2].copy(),
                "phi": out[:, 3].copy(), "valid": valid.astype(bool)}

    def roll_rates(self, t, vx, ay, r, p, ax, q) -> np.ndarray:
        """The roll rate (rad/s) ``<prefix>_roll_rate()`` gives for each sample, from a fresh grade state: time (s),
        vx (m/s), ay (m/s^2), r (rad/s), p (rad/s), ax (m/s^2), q (rad/s; NaN where there is none). Only for a module
        with the grade correction (:attr:`has_grade`)."""
        if not self.has_grade:
            raise ValueError(f"{self.prefix}: the module has no grade correction (no {self.prefix}_roll_rate)")
        cols = [np.ascontiguousarray(a, dtype=np.float64) for a in (t, vx, ay, r, p, ax, q)]
        out = np.empty(len(cols[0]))
        if not self._lib.rbh_roll_rates(len(out), *(c.ctypes.data_as(_P) for c in cols), out.ctypes.data_as(_P)):
            raise MemoryError(f"{self.prefix}: no memory for the grade state")
        return out

    def bench_ns(self, t, vx, ay, r, delta_f, *, min_samples: int = 200_000, repeats: int = 5) -> float:
        """C step cost (ns/sample, best of ``repeats``) of ``<prefix>_step_dt()`` over the log."""
        dt = np.diff(np.asarray(t, float), prepend=float(t[0]))
        typ = np.float32 if self.float32 else np.float64
        cols = [np.ascontiguousarray(a, dtype=typ) for a in (dt, vx, ay, r, delta_f)]
        ctype = ctypes.POINTER(ctypes.c_float if self.float32 else ctypes.c_double)
        n = len(cols[0])
        reps = max(1, math.ceil(min_samples / n))
        ptrs = [c.ctypes.data_as(ctype) for c in cols]
        self._lib.rbh_bench(n, *ptrs, 1)          # warm caches
        best = math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            self._lib.rbh_bench(n, *ptrs, reps)
            best = min(best, time.perf_counter() - t0)
        return best / (n * reps) * 1e9
