r"""``pif-smoother`` — the default PIF run forward, then a backward pass over the whole log.

An *offline* estimator (beyond the paper): for post-processing, bank maps and reference
signals, where the whole log is known before the bank is needed. A causal filter must
trade lag behind bank changes against noise; the smoother removes the lag by using the
samples *after* each instant too.

Forward: the steady-state PIF on the modified model (``pif-modified`` with the same options,
default tuning unless given), states :math:`\hat x = [v_y, r, w]`. Backward: the
Rauch-Tung-Striebel form of the fixed-interval smoother on the same model and the filter's own
Riccati solution :math:`P(v_x)` (eq 44 at each grid speed),

.. math::
    \dot x_s = A x_s + b\,a_y + W P^{-1} (x_s - \hat x), \qquad x_s(T) = \hat x(T),

integrated from the end of each segment of valid samples back to its start (``W``: the filter's
process-noise density, ``b``: the ``ay`` column of ``B``). With :math:`\theta = 0` this is the
Kalman (RTS) smoother of the design model. For the stabilising solution,
:math:`A + W P^{-1} = -P (A - P\Gamma)^T P^{-1}` with
:math:`\Gamma = C^T R^{-1} C - \theta L_w^T S L_w` (right-multiply eq 44 by :math:`P^{-1}`), so
the backward system is stable in reversed time for any ``th`` the filter accepts. It is run by
:func:`roadbank.estimators.kernels.smooth_backward`: inputs linear between samples, matrices
scheduled on speed like the filter's; the log's common sample interval (at least half of the
intervals) by the exact step for a frozen speed (:func:`~roadbank.estimators.discretise.foh`),
any other interval by the trapezoidal rule in substeps of at most
``min(max_substep, BACKWARD_SUBSTEP)``.

Interface: :meth:`PIFSmoother.run` returns the smoothed estimate of the whole log given;
:meth:`~roadbank.estimators.base.Estimator.step` is the forward filter's, which *is* the
smoothed estimate of the newest sample given the samples so far (no later sample exists yet).
So ``run()`` differs from a sequence of ``step()`` calls everywhere but at the last sample. A log
processed in chunks (``run(reset=False)``) is smoothed as a whole when each chunk comes with the
next one as ``lookahead`` (covering :attr:`PIFSmoother.lookahead_s` or reaching the log's end;
``roadbank estimate`` and ``roadbank map`` do so), else within each chunk only. The backward
pass steps over invalid samples as the forward pass does (their outputs held, flagged not valid)
and starts again where the forward pass restarted, after a gap longer than ``max_gap``. The
body roll is the forward pass's (the roll model follows ``ay`` causally, as the body does).
Not for an ECU: no C export.
"""

from __future__ import annotations

import numpy as np

from .. import cache
from ..signals import Estimate, Signals, interval_rate
from . import kernels as K
from .discretise import foh_grid
from .layout import DT_REL_TOL
from .pif import PIF, modified_steady

_TABLES: dict = {}
#: longest substep of the backward pass (s): its fastest modes mirror the filter's (up to about
#: 90 1/s at low speed), for which one 10 ms trapezoidal step errs by up to 0.1 deg of theta
BACKWARD_SUBSTEP = 0.002


class PIFSmoother(PIF):
    """``pif-smoother``: forward PIF plus backward RTS-form pass (see module docstring).

    Parameters
    ----------
    Q, R, S, th, Q_ay, tuning, **kw
        As :class:`~roadbank.estimators.pif.PIF` (``model`` and ``variant`` are fixed:
        modified, steady); any weights the filter accepts, Table 4's included.

    Raises
    ------
    ValueError
        when the Riccati solution ``P`` is numerically singular at some grid speed (the
        backward pass needs ``P^-1``; noise on ``w`` reaches every state through the model,
        so this only happens for degenerate weights).
    """

    label = "pif-smoother"
    #: the outputs of :meth:`run` use later samples (not causal)
    offline = True
    #: the causal estimator of its forward pass (what an ECU runs instead)
    forward_filter = "pif-modified"
    #: the forward pass through the general batch loop, not the three-state one: on a first run that is one kernel less
    #: to compile (``roadbank map`` on an ESP log builds this smoother: its first run 2.0 s shorter, 10.2 -> 8.2 s),
    #: at 20 ns more per sample warm (the backward pass takes most of a run: 90 -> 110 ns/sample on a 1 h 100 Hz
    #: log; the map's gated smoother about 250 ns/sample); the same output to the bit
    batch3_loop = False

    def __init__(self, params=None, *, tuning=None, **kw):
        super().__init__(params, **modified_steady(self.label, kw), tuning=tuning)
        self._smooth_tab = self._smoother_table()
        self._lookahead = None

    def smoother_matrices(self, vx: float):
        """``(S, M, b)`` of the backward pass at ``vx`` (m/s): ``S = -(A + M)`` (1/s),
        ``M = W P^{-1}`` (1/s), ``b`` the ``ay`` column of ``B`` (per m/s^2 of ``ay``)."""
        model = self.design_model(vx)
        A, B = model[0], model[1]
        W = self.process_density(model)
        P = self.riccati_solution(vx)        # at a grid speed: the forward filter's own
        ev = np.linalg.eigvalsh(0.5 * (P + P.T))
        if not ev[0] > 1e-12 * ev[-1]:
            raise ValueError(f"{self.label}: the Riccati solution is singular at vx={vx:.2f} m/s (eigenvalues "
                             f"{ev[0]:.3g} .. {ev[-1]:.3g}); the smoother needs process noise that reaches every "
                             "state (Q > 0)")
        M = np.linalg.solve(P, W).T          # W P^-1 (P and W symmetric)
        return -(A + M), M, B[:, 1].copy()

    def _smoother_table(self) -> np.ndarray:
        """Rows ``[S, M, b]`` per grid speed, memoised and kept on disk like the design."""
        key = self._disk_key()
        mem_key = key or self._design_key()
        tab = _TABLES.get(mem_key)
        if tab is None and key is not None:
            z = cache.load("smoother", key)
            tab = None if z is None else z.get("tab")
        if tab is None:
            rows = [np.concatenate([m.ravel() for m in self.smoother_matrices(float(v))]) for v in self.vgrid]
            tab = np.ascontiguousarray(np.array(rows))
            if key is not None:
                cache.store("smoother", key, {"tab": tab})
        _TABLES[mem_key] = tab
        self._table_key = mem_key
        return tab

    def _fixed_table(self, h: float) -> np.ndarray:
        """Rows ``[Phi, Gam0, Gam1]`` per grid speed of the backward pass over ``h`` seconds
        (exact for a frozen speed, inputs ``[x_f, ay]`` linear between samples; memoised)."""
        key = (self._table_key, h)
        ftab = _TABLES.get(key)
        if ftab is None:
            n = self._nstate
            tab = self._smooth_tab
            g = tab.shape[0]
            S, M, b = tab[:, :n * n].reshape(g, n, n), tab[:, n * n:2 * n * n].reshape(g, n, n), tab[:, 2 * n * n:]
            Phi, G0, G1 = foh_grid(S, np.concatenate([M, -b[:, :, None]], axis=2), h)
            ftab = _TABLES[key] = np.ascontiguousarray(
                np.hstack([Phi.reshape(g, -1), G0.reshape(g, -1), G1.reshape(g, -1)]))
        return ftab

    @property
    def lookahead_s(self) -> float:
        """Samples after a log's end (s) that make :meth:`run` agree with smoothing the whole:
        25 time constants of the backward pass's slowest mode over the speed grid (about 5 s for
        the default car), after which their influence is below 1e-10."""
        if self._lookahead is None:
            n = self._nstate
            slowest = min(-np.max(np.linalg.eigvals(row[:n * n].reshape(n, n)).real) for row in self._smooth_tab)
            self._lookahead = 25.0 / slowest
        return self._lookahead

    def run(self, signals: Signals, *, reset: bool = True, lookahead: Signals | None = None) -> Estimate:
        """Smoothed estimate over the log ``signals`` (see module docstring); ``reset`` as
        :meth:`~roadbank.estimators.base.Estimator.run`. Units: ``w`` (-), angles (rad).

        ``lookahead``: the samples that follow ``signals`` (e.g. the next chunk of a streamed log),
        of which the first :attr:`lookahead_s` seconds are used as the later samples of the
        backward pass and then forgotten: the forward state stays that at the end of
        ``signals``, so consecutive chunks, each with the next one as ``lookahead``, give what
        one run over the whole log gives (to about 1e-10 rad) when each lookahead covers
        :attr:`lookahead_s` or reaches the log's end.
        """
        n = len(signals)
        fwd = super().run(signals, reset=reset)
        parts = [(signals, fwd)]
        if lookahead is not None and len(lookahead) and n:
            ref = signals.t[np.isfinite(signals.t)]
            end = (ref[-1] if ref.size else -np.inf) + self.lookahead_s
            m = np.flatnonzero(lookahead.t > end)
            ahead = lookahead[:m[0] + 1] if m.size else lookahead
            saved = self._carried()     # the forward pass over the lookahead must leave no trace
            parts.append((ahead, super().run(ahead, reset=False)))
            self._carry_on(saved)
        xs, valid = self._backward(parts)
        xs, valid = xs[:n], valid[:n]
        w = xs[:, 2].copy()
        theta = np.arcsin(np.clip(w, -1.0, 1.0))
        phi = fwd.states["phi"].copy()
        valid &= np.abs(w) <= np.sin(self.max_angle)
        states = {name: xs[:, i] for i, name in enumerate(self.state_names)}
        states["phi"] = phi
        return Estimate(self.name, fwd.t, w, theta, theta - phi, valid, states, valid & fwd.settled)

    def _backward(self, parts):
        """Smoothed states ``(N, n)`` and the forward validity of the consecutive ``(signals,
        forward Estimate)`` ``parts``; invalid samples hold the last smoothed state."""
        ns = self._nstate
        cat = (lambda f: f(parts[0])) if len(parts) == 1 else (lambda f: np.concatenate([f(p) for p in parts]))
        t, vx, ay = (cat(lambda p, c=c: getattr(p[0], c)) for c in ("t", "vx", "ay"))
        valid = cat(lambda p: p[1].valid).copy()
        xs = np.empty((len(t), ns))
        for i, name in enumerate(self.state_names):
            xs[:, i] = cat(lambda p, name=name: p[1].states[name])
        every = bool(valid.all())
        idx = None if every else np.flatnonzero(valid)
        if (len(t) if every else idx.size) > 1:
            # the valid samples, as the forward pass saw them: it steps over invalid ones and
            # restarts after a gap longer than max_gap
            if not every:
                t, vx, ay = t[idx], vx[idx], ay[idx]
            # read-only and contiguous as a log's channels are, whether taken whole, selected or
            # joined: the compiled pass has one signature (a writable or strided array would
            # compile it a second time)
            t, vx, ay = (_read_only(a) for a in (t, vx, ay))
            xv = xs if every else xs[idx]
            xo = xv.copy()                           # the pass reads xv[k + 1] after writing xo[k + 1]
            dt = np.diff(t)
            cut = np.flatnonzero(dt > self.max_gap) + 1
            hfix = self.fixed_dt or _common_interval(dt)     # the forward pass's fixed rate, if any
            ftab = self._fixed_table(hfix) if hfix > 0 else np.zeros((1, 1))
            work = np.zeros(3 * ns * ns + 4 * ns)
            g = self.vgrid
            for a, b in zip(np.r_[0, cut], np.r_[cut, len(t)]):
                if b - a > 1:
                    K.smooth_backward(self._smooth_tab, ftab, hfix, float(g[0]), float(g[1] - g[0]), np.int64(ns),
                                      min(self.max_substep, BACKWARD_SUBSTEP), t, vx, ay, xv, np.int64(a),
                                      np.int64(b), xo, work)
            if every:
                xs = xo
            else:
                xs[idx] = xo
        if not every:
            last = np.maximum.accumulate(np.where(valid, np.arange(len(valid)), -1))
            held = last >= 0
            xs[held] = xs[last[held]]
        return xs, valid


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only, C-contiguous view of ``a`` (a copy where ``a`` is strided, e.g. a column of a
    table; same units): the compiled pass then sees one array type whatever it was given."""
    v = np.ascontiguousarray(a).view()
    v.flags.writeable = False
    return v


def _common_interval(dt: np.ndarray) -> float:
    """The sample interval (s) shared by at least half of the intervals ``dt`` (relative tolerance
    ``DT_REL_TOL``; that of a whole rate in Hz when it is one, as the forward pass rounds it),
    which the backward pass takes exactly; 0 if there is none (then every interval takes the
    trapezoidal substeps). Used when the forward pass has no fixed rate of its own."""
    if dt.size == 0:
        return 0.0
    h = float(np.median(dt))
    if not h > 0 or np.count_nonzero(np.abs(dt - h) <= DT_REL_TOL * h) * 2 < dt.size:
        return 0.0
    return 1.0 / interval_rate(h)
