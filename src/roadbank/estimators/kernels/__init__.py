r"""Compiled per-sample recursions of all estimators (numba, ``cache=True``).

This is the only package with compiled estimator code; Python prepares the
arrays, whose layout :mod:`roadbank.estimators.layout` defines (the kernels call
its offset functions, compiled). One module per family, over shared parts:

* :mod:`.sample` — validity, timing, speed grid, roll model, output angles;
* :mod:`.linalg` — LU with partial pivoting and the trapezoidal step on flat storage;
* :mod:`.simd` — the four-lane intrinsics of the three-state batch loop;
* :mod:`.lpv` — the one observer update (:func:`~.lpv.observer_update`, with
  :func:`~.lpv.fixed3` its three-state fixed-rate form) and the ``lpv`` family;
* :mod:`.adaptive`, :mod:`.gated`, :mod:`.dfc`, :mod:`.riccati`, :mod:`.smoother`;
* :mod:`.offsets` — the online sensor-offset learner that corrects an estimator's inputs;
* :mod:`.attitude` — the pitch observer that corrects the gyro-aided filter's roll rate for the grade
  (:mod:`roadbank.estimators.pitch`).

The families:

* ``lpv``  — linear observers with a speed-scheduled table (kinematic, UIO,
  PIO, steady-state PIF, Kalman): :math:`\xi' = F(v_x)\xi + G(v_x)\eta`,
  :math:`w = H(v_x)\xi + D(v_x)\eta` with :math:`\eta = [\delta_f, a_y, r]`.
  Variant (:func:`entries`): ``lpv3_run`` for three states (the batch loop).
* ``riccati`` — the PIF with the time-varying Riccati ODE (paper eq 43).
* ``dfc`` — dynamic filter compensation (nonlinear gate + low-pass).
* ``adaptive`` — linear observers scheduled on speed *and* excitation
  (``pif-adaptive``): the ``lpv`` recursion with the matrices interpolated
  bilinearly in ``(vx, e)``, ``e`` a peak follower of the low-passed ``|ay|``; general
  (trapezoidal) path only, no fixed-rate tables.
* ``smooth`` — the backward pass of the offline ``pif-smoother`` (:func:`smooth_backward`),
  run over a whole log after its forward ``lpv`` pass; no per-sample ``step()``.

Sample handling (every per-sample family): a sample is *valid* when the time is finite
and later than the last valid sample, ``vx`` is finite and ``>= v_min`` and
every input channel the estimator uses is finite. Invalid samples leave the
state untouched and repeat the last outputs. After a gap longer than
``max_gap`` (or at the first valid sample) the state is re-initialised at the
observer's equilibrium for the current inputs, ``xi = -F^{-1} G eta``.

Schedules are interpolated linearly in ``vx`` (the current sample's speed)
between the two neighbouring grid speeds, entry by entry:
``M(vx) = M[i] + a (M[i+1] - M[i])``, ``i = floor((vx - v0)/dv)``, ``a`` the
remainder, clamped at both ends of the grid.

**Fixed-rate path** (``lpv``, when the estimator has tables for a sample
interval ``h`` and the sample's interval equals ``h`` within ``DT_REL_TOL``
relative; what an ECU runs). Per sample, with the previous inputs ``eta-``::

    xi  = Phi(vx) xi + Gam0(vx) eta- + Gam1(vx) eta
    w   = H(vx) xi + D(vx) eta
    z   = Phi_r z + Gam0_r ay- + Gam1_r ay          (roll model, speed independent)
    phi = H_r z + D_r ay
    theta = asin(clip(w, -1, 1)),  phi_b = theta - phi,  valid = |w| <= sin(max_angle)

``Phi, Gam0, Gam1`` are the exact discretisation of the continuous observer at
each grid speed for inputs varying linearly between samples (first-order hold,
:meth:`Estimator.discrete_tables`), so this path is exact for a frozen speed.
In a batch, consecutive samples on this path of a three-state observer run in
:func:`~.lpv.lpv3_fixed_run` (constants read once, the state in registers, the three
state rows in the lanes of one SIMD register; theta, phi_b and valid per block of
samples in a SIMD loop); per sample it calls the same :func:`~.lpv.fixed3` and
:func:`~.sample.roll_fixed2` as :func:`lpv_step`, so ``run()`` and ``step()``
agree bit for bit. ``asin`` is :func:`asin_fast` (a polynomial within 2 ulp up
to 17 deg, libm beyond) on every path.

**General path** (any other interval: irregular sampling, jitter, after a
gap): the trapezoidal rule (Tustin), which is A-stable — for a frozen ``vx``
the discrete map :math:`(I - hF/2)^{-1}(I + hF/2)` is a contraction whenever
``F`` is Hurwitz, at any step ``h`` — with the step split into substeps of at
most ``max_substep`` seconds so that the stiff low-speed poles (about -150
1/s) are not mapped close to -1 at low sample rates, on the interpolated
continuous matrices, the input interpolated linearly between the previous and
the current sample. The Riccati ODE is advanced with the same trapezoidal
rule applied to its linear Hamiltonian form
:math:`[X; Y]' = \mathcal{H}[X; Y]`, :math:`P = Y X^{-1}`.

Compile time (a fresh process with an empty cache compiles each family in a few
seconds; ``python -m roadbank.bench.cold``): every function is compiled once as a
normal numba function (no ``fastmath``; LLVM inlines the small helpers marked
``forceinline``), except the layout's offset functions and the steps shared between
families or paths (:func:`~.lpv.observer_update`, :func:`~.lpv.fixed3`, :func:`~.linalg.tustin`,
:func:`~.sample.output`, :func:`~.sample.roll_map`, :func:`~.sample.roll_fixed2`), which
numba inlines into their callers (``inline="always"``: no compiled function of their own,
whose optimisation every caller would repeat), and in one specialisation only: no literal
arguments (``np.int64`` offsets, not ``0``), no ``int()``/``min()``/``max()``
(each an overload numba compiles per flag set; ``np.int64`` casts and conditional
expressions instead), helpers without Python or C wrappers
(``no_cpython_wrapper``), no array views or allocation (``_nrt=False``: nothing
reference-counted in the per-sample loops). Numba links every callee's code into
each caller and optimises and emits it again there, so the size of what a kernel
reaches counts as much as the number of functions: the Riccati PIF and the gated blend are
one function each (``riccati_step`` and ``gated_step`` are Python that run ``riccati_run`` and
``gated_run`` on one-sample arrays, :func:`.sample.step_by_run`: the gated family compiles in about a fifth
less time, 3.2 s instead of 4.0 when this was measured, at about 8 us per Python ``step()`` call instead of
1.2-1.6, the dispatch of fifteen arrays), the general
path has no per-dimension special cases, and ``lpv_step`` is compiled once and called
(not inlined) by ``lpv_run``, ``lpv3_run`` and ``gated_run``. The three-state batch loop is a variant
chosen in Python (:func:`entries`: ``lpv3_run``), its body written once as an inlined helper taking the
variant as a constant that numba prunes before typing, so an observer of another size (the gyro-aided
default, two states) never compiles it: its first run on a KITTI drive 8.0 s instead of 9.1 when this was
measured, the same output to the bit. (A variant for the limited low-pass too saved another 0.7 s there but
cost the first ``roadbank reproduce``, which runs both, 4 s: not kept.) Nor does ``pif-smoother``'s forward pass
(``Estimator.batch3_loop``), whose backward pass takes most of its run: a first ``roadbank map`` on an ESP log 2 s
shorter, 20 ns/sample more warm. LLVM optimises the per-sample step and
the general path for size (:func:`._jit.optimise_for_size`: ``lpv_step``, ``gated_run``, ``riccati_run``, the LU),
not the fixed-rate batch loop: their loops over a few states are then not vectorised nor unrolled, which only cost
compile time (CPU s of the first calls, median of five: lpv 5.6 -> 4.3, gated 4.9 -> 4.0, riccati 4.8 -> 3.6; the
general path about a third faster per sample, the fixed-rate batch loop and ``step()`` unchanged, the same output
to the bit). The kernels' disk cache is checked
against all of the package's files and the layout at once (:mod:`._jit`).

**Calling convention** (every family): ``<family>_step(mem, cfg, tab, work, t, vx, d, ay, r)``
returns ``(w, theta, phi_b, valid)``; ``<family>_run(mem, cfg, tab, work, t, vx, d, ay, r,
out_w, out_theta, out_phib, out_phi, out_valid, out_x)`` fills the output arrays (``out_x``:
the states, shape ``(N, max(n, 2))``). The inputs come in the order of
``eta = [delta_f, ay, r]`` (the tables' columns), ``d`` being ``delta_f`` (rad); the public
:meth:`Estimator.step(t, vx, ay, r, delta_f) <roadbank.estimators.base.Estimator.step>`
puts ``delta_f`` last because it is optional, and is the one place that reorders them.
Units: t (s), vx (m/s), ay (m/s^2), r (rad/s), d (rad). ``smooth_backward`` has its own
arguments (its docstring); the offset learner's (:mod:`.offsets`)
``offsets_step(mem, cfg, t, vx, d, ay, r, out)`` takes its inputs in the same order.
"""

from __future__ import annotations

from ..layout import DT_REL_TOL
from .adaptive import adaptive_run, adaptive_step
from .dfc import dfc_run, dfc_step
from .gated import gated_run, gated_step
from .lpv import lpv3_run, lpv_run, lpv_step, observer_update
from .riccati import riccati_run, riccati_step
from .sample import ASIN_POLY_MAX, asin_fast
from .smoother import jerk_ramps, smooth_backward, window_max

__all__ = ["ASIN_POLY_MAX", "DT_REL_TOL", "ENTRIES", "adaptive_run", "adaptive_step", "asin_fast", "dfc_run",
           "dfc_step", "entries", "gated_run", "gated_step", "jerk_ramps", "lpv3_run", "lpv_run", "lpv_step",
           "observer_update", "riccati_run", "riccati_step", "smooth_backward", "window_max"]

#: the ``(run, step)`` kernels by family and variant (:func:`entries`)
ENTRIES = {
    "lpv": (lpv_run, lpv_step), "lpv3": (lpv3_run, lpv_step), "gated": (gated_run, gated_step),
    "adaptive": (adaptive_run, adaptive_step), "dfc": (dfc_run, dfc_step), "riccati": (riccati_run, riccati_step),
}


def entries(family: str, batch3: bool = False):
    """The ``(run, step)`` kernels of an estimator of ``family`` (``"lpv"``, ``"gated"``, ...); ``batch3``: a
    three-state ``lpv`` observer whose roll model has 0 or 2 states, whose batch run takes its fixed-rate samples
    through the three-state loop (:func:`lpv3_run`; any other ``lpv`` observer never compiles that loop)."""
    key = "lpv3" if (family == "lpv" and batch3) else family
    if key not in ENTRIES:
        raise ValueError(f"no {family!r} kernels (families: lpv, gated, adaptive, dfc, riccati)")
    return ENTRIES[key]
