"""Cold start: numba compilation time per kernel family, in fresh processes with an empty cache.

Each kernel family is exercised in its own fresh Python process whose
``NUMBA_CACHE_DIR`` is a new empty directory, so nothing can be loaded from a
cache: the measured time is compilation (typing, lowering, LLVM) plus a
negligible amount of running. The families are what a user's first run
compiles:

* ``plant`` — the simulator (:mod:`roadbank.sim`): integration loop with the
  inlined plant, driver and road, the auxiliary outputs and the truth bank;
* ``lpv`` — the scheduled linear observers (PIF steady-state, PIO, UIO,
  Kalman, kinematic), batch ``run()`` and streaming ``step()``, general and
  fixed-rate paths;
* ``dfc`` — dynamic filter compensation;
* ``riccati`` — the PIF with the Riccati ODE;
* ``adaptive`` — ``pif-adaptive``, scheduled on speed and excitation (general path only);
* ``gated`` — ``pif-gated``: the ``lpv`` step of its stacked observer plus the gate, batch and
  streaming, general and fixed-rate paths;
* ``smooth`` — the backward pass of the offline ``pif-smoother`` (its forward ``lpv`` pass is
  compiled before the timing) and the offline gate's measure and window of the map's ``kinematic-smoother``
  (:class:`roadbank.estimators.GatedSmoother`).

Each probe prints one JSON line; the compile time is measured as the wall
time of the first calls minus the wall time of the same calls repeated
(already compiled), and numba's own event API (``numba.core.event``) adds the
time it records under ``numba:compile``. The designs (and the fixed-rate
tables) are built before the timed calls: they are scipy, not compilation.
Run from a shell: ``python -m roadbank.bench.cold [family ...]``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile

#: a regular and an irregular 0.6 s log, ``s`` and ``s2``: the fixed-rate and the general path
_TWO_LOGS = """
import numpy as np
from roadbank import Signals, estimators
n = 60
t = np.arange(n) * 0.01
t_irr = t.copy(); t_irr[30:] += 0.003
s = Signals(t, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
s2 = Signals(t_irr, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
"""

#: probe code per family: ``work()`` is called twice (first: compile, second: run only)
FAMILY_PROBES = {
    "plant": """
from roadbank.sim import SCENARIOS, run
import dataclasses
sc = dataclasses.replace(SCENARIOS["s-curve"], duration=0.5, pre_roll=0.1)
def work():
    run(sc)
""",
    "lpv": _TWO_LOGS + """
ests = [estimators.make("pif-modified"), estimators.make("pio-modified")]
for e in ests:
    e.set_sample_rate(100.0)     # the fixed-rate tables (scipy, not compilation) outside the timing
def work():
    for e in ests:
        e.run(s); e.run(s2)
        e.reset(); e.step(0.0, 20.0, 0.5, 0.01, 0.002); e.step(0.01, 20.0, 0.5, 0.01, 0.002)
""",
    "dfc": """
import numpy as np
from roadbank import Signals, estimators
n = 60
s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
e = estimators.make("dfc")
def work():
    e.run(s); e.reset(); e.step(0.0, 20.0, 0.5, 0.01, 0.002); e.step(0.01, 20.0, 0.5, 0.01, 0.002)
""",
    "riccati": """
import numpy as np
from roadbank import Signals
from roadbank.estimators.pif import PIF
n = 60
s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
e = PIF(variant="riccati")
def work():
    e.run(s); e.reset(); e.step(0.0, 20.0, 0.5, 0.01, 0.002); e.step(0.01, 20.0, 0.5, 0.01, 0.002)
""",
    "adaptive": """
import numpy as np
from roadbank import Signals, estimators
n = 60
s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
e = estimators.make("pif-adaptive", v_max=30.0)     # small design: scipy, not compilation
def work():
    e.run(s); e.reset(); e.step(0.0, 20.0, 0.5, 0.01, 0.002); e.step(0.01, 20.0, 0.5, 0.01, 0.002)
""",
    "gated": _TWO_LOGS + """
e = estimators.make("pif-gated", v_max=30.0)     # small design: scipy, not compilation
e.set_sample_rate(100.0)
def work():
    e.run(s); e.run(s2); e.reset(); e.step(0.0, 20.0, 0.5, 0.01, 0.002); e.step(0.01, 20.0, 0.5, 0.01, 0.002)
""",
    "offsets": _TWO_LOGS + """
e = estimators.with_online_offsets(estimators.make("kinematic"))
e.inner.run(s); e.inner.step(0.0, 20.0, 0.5, 0.01, 0.002)   # the inner (lpv) kernel: its own family
def work():
    e.correct(s); e.reset(); e.step(0.0, 20.0, 0.5, 0.01, 0.002)
""",
    "attitude": """
import numpy as np
from roadbank.estimators.pitch import PitchObserver
n = 60
t, z = np.arange(n) * 0.01, np.zeros(n)
obs = PitchObserver(0.5, start=(3.0, 3.0))
def work():
    obs.reset(); obs.pitch(t, np.full(n, 20.0), z, z, z, z)
""",
    "smooth": """
import numpy as np
from roadbank import Signals, estimators
n = 60
s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.full(n, 0.5), np.full(n, 0.01), np.full(n, 0.002))
e = estimators.make("pif-smoother", v_max=30.0)     # small design: scipy, not compilation
estimators.PIF.run(e, s)      # its forward pass (the lpv kernel): that family's
from roadbank.estimators.gated_smoother import gate_ramps, held_open
def work():
    e.run(s)
    g, _ = gate_ramps(s.t, s.vx, s.r, np.ones(n, bool), 0.05, 4.0, 1.0, 1.0)
    held_open(s.t, s.t, g, 8.0, 8.0)
""",
}

_HARNESS = r"""
import json, time, resource
from numba.core import event as _ev
_rec = _ev.TimingListener()
{setup}
_ru0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
with _ev.install_listener("numba:compile", _rec):
    work()
t1 = time.perf_counter()
_ru1 = resource.getrusage(resource.RUSAGE_SELF)
work()
t2 = time.perf_counter()
print(json.dumps({{"first_s": t1 - t0, "again_s": t2 - t1,
                  "cpu_first_s": (_ru1.ru_utime - _ru0.ru_utime) + (_ru1.ru_stime - _ru0.ru_stime),
                  "numba_compile_event_s": _rec.duration if _rec.done else None}}))
"""


def probe_family(family: str, cache_dir: str | None = None, timeout: float = 900.0) -> dict:
    """Compile time (s) of one kernel family in a fresh process.

    Parameters
    ----------
    family : str
        A key of :data:`FAMILY_PROBES`.
    cache_dir : str, optional
        ``NUMBA_CACHE_DIR`` of the process; default a new empty directory
        (cold: everything compiles).

    Returns
    -------
    dict
        ``cold_compile_s`` (first calls minus the same calls again, s),
        ``cpu_first_s`` (CPU time of the first calls, s),
        ``numba_compile_event_s`` (numba's own compile timing, s) and the raw times;
        ``{"cold_compile_s": None, "reason": ...}`` if the probe failed.
    """
    code = _HARNESS.format(setup=FAMILY_PROBES[family])
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir or tmp)
        try:
            proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                  env=env, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"cold_compile_s": None, "reason": f"{family} probe exceeded {timeout:.0f} s"}
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["?"]
        return {"cold_compile_s": None, "reason": f"{family} probe failed: {tail[0]}"}
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["cold_compile_s"] = max(0.0, out["first_s"] - out["again_s"])
    return out


def cold_compile(families=None, repeats: int = 1) -> dict:
    """:func:`probe_family` for every family (default all), ``repeats`` times each, the families in turn (so a
    shared machine's slow minutes spread over them): ``{family: the run with the median compile time, with "runs":
    every run's cold_compile_s (s)}`` (the lower of the two middle runs for an even count); a failed run stands for
    its family."""
    fams = list(families or FAMILY_PROBES)
    runs: dict[str, list[dict]] = {f: [] for f in fams}
    for _ in range(max(1, int(repeats))):
        for f in fams:
            runs[f].append(probe_family(f))
    out = {}
    for f, rs in runs.items():
        failed = [r for r in rs if r.get("cold_compile_s") is None]
        if failed:
            out[f] = failed[0]
            continue
        ranked = sorted(rs, key=lambda r: r["cold_compile_s"])
        out[f] = dict(ranked[(len(ranked) - 1) // 2], runs=[r["cold_compile_s"] for r in rs])
    return out


if __name__ == "__main__":   # python -m roadbank.bench.cold [family ...]
    print(json.dumps(cold_compile(sys.argv[1:] or None), indent=1))
