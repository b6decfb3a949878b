"""The performance benchmark suite behind ``roadbank bench``: throughput, latency and cold start against peers.

Measures, in one run on one machine, and writes a table with medians and ratios:

* every estimator's batch throughput (ns/sample) on a synthetic 1-hour, 100 Hz log;
* the peer: the same augmented-model (modified model, states ``[vy, r, w]``,
  input ``ay``, output ``r``) Kalman recursion written with filterpy's
  ``KalmanFilter`` (predict/update per sample in a Python loop);
* streaming ``step()`` latency per call (median, 99th percentile);
* the plant: simulated seconds per wall second of the 25 s S-curve, and the
  CommonRoad multi-body model (``vehicle_dynamics_mb`` + ``scipy.integrate.odeint``,
  as its documentation does) on a manoeuvre of the same length as the peer;
* ``roadbank reproduce`` wall time (warm cache) on the machine's cores;
* cold start (numba compilation vs cache load) in fresh processes, and the
  compile time of every kernel family with an empty cache (:mod:`.cold`);
* extra sections registered with :func:`register_section` (other parts of
  roadbank add theirs, e.g. a C step cost or a long-log streaming run).

Anything that cannot be measured (peer library missing, simulator or
``reproduce`` not available) is reported as ``null`` with the reason; no number
is ever invented. Timings are wall-clock (``time.perf_counter``); the runner
itself asserts nothing about them.
"""

from __future__ import annotations

import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from .cold import FAMILY_PROBES, cold_compile

#: the speed targets: key -> (comparison, threshold, text)
TARGETS = {
    "pif_ns_per_sample": ("<=", 50.0, "<= 50 ns/sample/core"),
    "pif_vs_filterpy": (">=", 1000.0, ">= 1000x filterpy"),
    "step_us_median": ("<=", 1.0, "<= 1 us"),
    "plant_realtime_factor": (">=", 2000.0, ">= 2000x real time"),
    "plant_vs_commonroad": (">=", 150.0, ">= 150x CommonRoad MB"),
    "reproduce_s": ("<=", 5.0, "<= 5 s on 2 cores (warm)"),
    "reproduce_cold_s": ("<=", 30.0, "<= 30 s on 2 cores (empty numba cache)"),
    "cold_compile_max_s": ("<=", 5.0, "<= 5 s per kernel family"),
}


@dataclass(frozen=True)
class Section:
    """An extra benchmark section.

    ``run(size_cfg) -> dict`` measures (``size_cfg`` is the :data:`SIZES` entry
    of the run, plus its ``"size"`` name) and returns JSON-serialisable results
    stored under ``res[name]``; ``markdown(result) -> list[str]`` renders them
    (optional). Anything it cannot measure it reports as ``None`` with a reason,
    like the built-in sections.
    """

    name: str
    title: str
    run: Callable[[dict], dict]
    markdown: Callable[[dict], list] | None = None


#: extra sections, run after the built-in ones in registration order
SECTIONS: list[Section] = []


def register_section(section: Section) -> None:
    """Add (or replace, by name) an extra section of :func:`run_suite`."""
    SECTIONS[:] = [s for s in SECTIONS if s.name != section.name] + [section]

#: run sizes: log duration (s), repeats, filterpy samples, step calls, CommonRoad seconds
SIZES = {
    "full": dict(log_s=3600.0, repeats=5, riccati_s=600.0, peer_n=30000, peer_rounds=5, step_n=50000,
                 cr_s=25.0, plant_repeats=5, reproduce=True, cold=True, compile=True, compile_repeats=3),
    "quick": dict(log_s=3600.0, repeats=3, riccati_s=60.0, peer_n=3000, peer_rounds=3, step_n=20000,
                  cr_s=25.0, plant_repeats=3, reproduce=False, cold=True, compile=False),
    "tiny": dict(log_s=10.0, repeats=1, riccati_s=10.0, peer_n=300, step_n=300,
                 cr_s=0.5, plant_repeats=1, reproduce=False, cold=False, compile=False),
}

RATE_HZ = 100.0



# --------------------------------------------------------------------------
# machine and inputs
# --------------------------------------------------------------------------

def machine_info() -> dict:
    """CPU model, logical cores usable by this process, OS and library versions."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        usable = os.cpu_count()
    import numba
    import numpy
    import scipy
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {"cpu": cpu, "cores_logical": os.cpu_count(), "cores_usable": usable, "load_1min": load[0],
            "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
            "os": platform.platform(), "python": platform.python_version(),
            "numpy": numpy.__version__, "scipy": scipy.__version__, "numba": numba.__version__}


def synthetic_log(duration: float, rate: float = RATE_HZ, seed: int = 0):
    """A deterministic ESP log of ``duration`` seconds at ``rate`` Hz (SI, ISO 8855).

    Speed sweeps 8-34 m/s (every part of the gain schedule is visited), the car
    weaves (ay up to about 3 m/s^2) and the signals carry sensor-like noise.

    Returns
    -------
    roadbank.Signals
    """
    import numpy as np

    from ..constants import G
    from ..signals import Signals

    n = int(round(duration * rate)) + 1
    t = np.arange(n) / rate
    rng = np.random.default_rng(seed)
    vx = 21.0 + 13.0 * np.sin(2 * np.pi * t / 600.0) + 0.05 * rng.normal(size=n)
    ay_true = 3.0 * np.sin(2 * np.pi * t / 17.0) * np.sin(2 * np.pi * t / 97.0)
    r = ay_true / vx + 0.002 * rng.normal(size=n)
    bank = 0.05 * np.sin(2 * np.pi * t / 300.0)
    ay = ay_true + G * np.sin(bank) + 0.05 * rng.normal(size=n)
    delta_f = 2.62 * ay_true / vx**2 + 1e-4 * rng.normal(size=n)
    return Signals(t, vx, ay, r, delta_f)


def _median(xs) -> float:
    s = sorted(xs)
    k = len(s) // 2
    return s[k] if len(s) % 2 else 0.5 * (s[k - 1] + s[k])


# --------------------------------------------------------------------------
# estimators
# --------------------------------------------------------------------------

def estimator_cases() -> list[tuple[str, str, dict]]:
    """(label, factory name, tuning) of every estimator benchmarked."""
    from .. import estimators
    cases = [(name, name, {}) for name in estimators.NAMES]
    cases.append(("pif-modified (riccati)", "pif-modified", {"variant": "riccati"}))
    cases.append((GATED_SMOOTHER_LABEL, "kinematic-smoother", {"described": False}))
    return cases


#: the row of ``kinematic-smoother`` as ``roadbank map`` builds it for a log of a car nobody described: the low-pass
#: smoother gated to ``pif-smoother`` (:class:`roadbank.estimators.GatedSmoother`)
GATED_SMOOTHER_LABEL = "kinematic-smoother (gated: roadbank map's)"


def _built(name: str, tuning: dict):
    """The estimator of a case and the estimators whose designs it times: ``estimators.make``, or for the gated
    smoother ``roadbank.vehicle.make_estimator`` (the command's design, the data sheet's sensors)."""
    from .. import estimators, vehicle
    if "described" not in tuning:
        est = estimators.make(name, **tuning)
        return est, [est]
    est = vehicle.make_estimator(name, **tuning)
    return est, [est.inner, est.model]


def time_batch(est, signals, repeats: int) -> dict:
    """Warm batch timing of ``est.run(signals)``: median and best (ns/sample).

    Steady: an untimed run first loads the kernel and leaves output arrays of the log's length that each timed run
    writes into again (``Estimator._outputs``, as in a loop over logs); :func:`time_batch_kept` times fresh memory."""
    est.run(signals)
    walls, cpus = [], []
    for _ in range(repeats):
        c0 = time.thread_time()
        t0 = time.perf_counter()
        est.run(signals)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.thread_time() - c0)
    n = len(signals)
    return {"ns_per_sample": _median(walls) / n * 1e9, "ns_per_sample_best": min(walls) / n * 1e9,
            "cpu_ns_per_sample": _median(cpus) / n * 1e9, "samples": n, "repeats": repeats}


def time_batch_kept(est, signals, repeats: int) -> dict:
    """:func:`time_batch` with every result kept until all repeats are done, so that each
    ``run()`` writes into fresh memory (the page faults of new output arrays) instead of the
    block the estimator reuses once the previous result is dropped (``Estimator._outputs``).
    """
    est.run(signals[:10])
    kept, walls, cpus = [], [], []
    for _ in range(repeats):
        c0 = time.thread_time()
        t0 = time.perf_counter()
        kept.append(est.run(signals))
        walls.append(time.perf_counter() - t0)
        cpus.append(time.thread_time() - c0)
    n = len(signals)
    del kept
    return {"kept_ns_per_sample": _median(walls) / n * 1e9, "kept_cpu_ns_per_sample": _median(cpus) / n * 1e9}


def time_kernel(est, signals, repeats: int) -> dict:
    """The compiled batch kernel alone on ``signals`` (ns/sample, median of CPU time): outputs
    preallocated once and reused, so no allocation and no page faults of fresh memory, which
    ``run()`` (:func:`time_batch`) pays for its new output arrays."""
    import numpy as np
    n = len(signals)
    outs = [np.empty(n) for _ in range(4)] + [np.empty(n, dtype=np.bool_),
                                              np.empty((n, max(est._nstate, 2)))]
    est.run(signals[:10])                  # the sample rate ("auto") and the kernel
    args = [signals.t, signals.vx, signals.delta_f, signals.ay, signals.r]
    cpus = []
    for _ in range(repeats + 1):
        est.reset()
        c0 = time.thread_time()
        est._run_fn(est._mem, est._cfg, est._tab, est._work, *args, *outs)
        cpus.append(time.thread_time() - c0)
    return {"kernel_cpu_ns_per_sample": _median(cpus[1:]) / n * 1e9,
            "output_bytes_per_sample": int(sum(o.itemsize * (o.shape[1] if o.ndim == 2 else 1) for o in outs))}


def bench_estimators(signals, short, repeats: int) -> list[dict]:
    """Design time, first call and warm throughput of every estimator.

    ``short`` (a shorter log) is used for the Riccati-ODE PIF, which is slower.
    """
    rows = []
    for label, name, tuning in estimator_cases():
        est, parts = _built(name, tuning)          # tables may come from the memo or disk cache
        t0 = time.perf_counter()
        for part in parts:
            part._design()                         # the design itself, uncached
        t1 = time.perf_counter()
        est.run(signals[:10])
        t2 = time.perf_counter()
        log = short if tuning.get("variant") == "riccati" else signals
        row = {"name": label, "design_s": t1 - t0, "first_call_s": t2 - t1}
        row.update(time_batch(est, log, repeats))
        rows.append(row)
    return rows


def step_latency(signals, n_calls: int) -> dict:
    """Per-call wall time of ``pif-modified`` ``step()`` (us): median, p99, mean.

    Each call is timed individually with ``perf_counter_ns``; the timer's own
    overhead (median of an empty timed pair) is reported, not subtracted.
    """
    import numpy as np

    from .. import estimators
    est = estimators.make("pif-modified")
    est.reset()
    n = min(n_calls, len(signals))
    t, vx, ay, r, d = (np.asarray(getattr(signals, c)[:n]).tolist()
                       for c in ("t", "vx", "ay", "r", "delta_f"))
    step = est.step
    clock = time.perf_counter_ns
    t0 = clock()
    step(t[0], vx[0], ay[0], r[0], d[0])
    first = (clock() - t0) * 1e-3
    out = np.empty(n - 1)
    for k in range(1, n):
        a = clock()
        step(t[k], vx[k], ay[k], r[k], d[k])
        out[k - 1] = clock() - a
    empty = np.empty(1000)
    for k in range(1000):
        a = clock()
        empty[k] = clock() - a
    return {"step_us_median": float(np.median(out)) * 1e-3,
            "step_us_p99": float(np.percentile(out, 99)) * 1e-3,
            "step_us_mean": float(out.mean()) * 1e-3, "step_first_call_us": first,
            "timer_overhead_us": float(np.median(empty)) * 1e-3, "calls": int(n - 1)}


# --------------------------------------------------------------------------
# the filterpy peer
# --------------------------------------------------------------------------

def discrete_augmented_schedule(params, vgrid, dt: float, Q: float):
    """Zero-order-hold discretisation of the modified augmented model on ``vgrid``.

    Returns ``(F, B, Qd)`` stacks (per grid speed) for filterpy: ``F = e^{A dt}``,
    ``B`` the ZOH input matrix of ``ay`` and ``Qd`` the Van Loan process-noise
    covariance of ``w' = n`` with spectral density ``Q``.
    """
    import numpy as np
    from scipy.linalg import expm

    from ..estimators.base import augmented_design_model
    Fs, Bs, Qs = [], [], []
    for v in vgrid:
        A, B, C, Dy, Lw, Ew = augmented_design_model(params, float(v), "modified")
        n = A.shape[0]
        M = np.zeros((n + 1, n + 1))
        M[:n, :n] = A
        M[:n, n:] = B[:, 1:2]
        E = expm(M * dt)
        W = Q * Ew @ Ew.T
        V = np.zeros((2 * n, 2 * n))
        V[:n, :n] = -A
        V[:n, n:] = W
        V[n:, n:] = A.T
        EV = expm(V * dt)
        Fd = E[:n, :n]
        Fs.append(Fd)
        Bs.append(E[:n, n:])
        Qs.append(Fd @ EV[:n, n:])
    return np.array(Fs), np.array(Bs), np.array(Qs)


def filterpy_peer(signals, n_samples: int, est=None, rounds: int = 1) -> dict:
    """ns/sample of the same Kalman recursion with filterpy (Python loop), and its ratio to ``est``.

    Table 4 weights (``Q = 0.1`` on ``w'``, ``R = 0.0035``) discretised at the
    log's step (``R_d = R/dt``); per sample the matrices of the nearest grid
    speed are assigned, then ``predict(u=ay)`` and ``update(r)``. Measured on the
    first ``n_samples`` samples and reported per sample: the median of ``rounds`` runs.
    With ``est`` (a built estimator), each round also times a steady ``est.run(signals)`` (:func:`time_batch`)
    right after the filterpy loop, so that both meet the same state of a shared machine; ``ratio`` is the median
    over the rounds of filterpy's ns/sample over ``est``'s in the same round (``ratios``: each round's).
    """
    try:
        from filterpy.kalman import KalmanFilter
    except ImportError as exc:
        return {"peer_ns_per_sample": None,
                "reason": f"filterpy not installed ({exc}); pip install 'roadbank[test]'"}
    import numpy as np

    from ..estimators.base import speed_grid
    from ..estimators.pif import TABLE4
    from ..params import VehicleParams
    params = VehicleParams()
    dt = float(signals.t[1] - signals.t[0])
    vgrid = speed_grid(5.0)
    Fs, Bs, Qs = discrete_augmented_schedule(params, vgrid, dt, TABLE4["Q"])
    n = min(n_samples, len(signals))
    vx, ay, r = (np.asarray(getattr(signals, c)[:n]) for c in ("vx", "ay", "r"))
    idx = np.clip(np.rint((vx - vgrid[0]) / (vgrid[1] - vgrid[0])), 0, len(vgrid) - 1).astype(int)

    def loop():
        kf = KalmanFilter(dim_x=3, dim_z=1, dim_u=1)
        kf.H = np.array([[0.0, 1.0, 0.0]])
        kf.R = np.array([[TABLE4["R"] / dt]])
        kf.P = np.diag(TABLE4["P0"]) + 1e-6 * np.eye(3)
        w = np.empty(n)
        t0 = time.perf_counter()
        for k in range(n):
            i = idx[k]
            kf.F = Fs[i]
            kf.B = Bs[i]
            kf.Q = Qs[i]
            kf.predict(u=ay[k])
            kf.update(r[k])
            w[k] = kf.x[2, 0]
        return (time.perf_counter() - t0) / n * 1e9, w

    peers, ratios = [], []
    for _ in range(max(1, rounds)):
        ns, w = loop()
        peers.append(ns)
        if est is not None:
            ratios.append(ns / time_batch(est, signals, 1)["ns_per_sample"])
    out = {"peer_ns_per_sample": _median(peers), "peer_rounds_ns": peers, "samples": int(n), "peer_w": w}
    if ratios:
        out.update(ratio=_median(ratios), ratios=ratios)
    return out


# --------------------------------------------------------------------------
# plant and CommonRoad peer
# --------------------------------------------------------------------------

def plant_bench(repeats: int) -> dict:
    """Real-time factor of roadbank's plant on the 25 s S-curve (``roadbank.sim``)."""
    try:
        from ..sim import measure_realtime_factor, run_scenario
    except ImportError as exc:
        return {"plant_realtime_factor": None, "reason": f"roadbank.sim not available ({exc})"}
    t0 = time.perf_counter()
    run_scenario("s-curve", "nominal", 0)
    cold = time.perf_counter() - t0
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = run_scenario("s-curve", "nominal", 0)
        walls.append(time.perf_counter() - t0)
    duration = float(res.signals.t[-1] - res.signals.t[0])
    rtf = measure_realtime_factor(repeats=repeats)
    return {"plant_realtime_factor": rtf, "plant_scenario_realtime_factor": duration / _median(walls),
            "plant_scenario_wall_s": _median(walls), "plant_cold_s": cold, "duration_s": duration}


def commonroad_peer(duration: float, vx0: float = 60 / 3.6) -> dict:
    """Real-time factor of CommonRoad's multi-body model on an S-curve of ``duration`` s.

    ``vehicle_dynamics_mb`` (parameters of vehicle 2) integrated with
    ``scipy.integrate.odeint`` on a 100 Hz output grid, as the package's
    documentation and tests do. Inputs: a sinusoidal steering rate giving a
    road-wheel angle of +-2.5 deg with a 5 s period (an S-curve the model
    drives through without leaving the tyres' linear range; the paper's
    +-360 deg at the steering wheel spins this car, and the integration of a
    spinning car is neither comparable nor robust) and a proportional speed hold.
    """
    try:
        import numpy as np
        from scipy.integrate import odeint
        from vehiclemodels.init_mb import init_mb
        from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
        from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb
    except ImportError as exc:
        return {"commonroad_realtime_factor": None,
                "reason": f"commonroad-vehicle-models not installed ({exc}); pip install 'roadbank[test]'"}
    p = parameters_vehicle2()
    amp = math.radians(2.5)
    period = 5.0

    def rhs(x, t):
        u = [amp * 2 * math.pi / period * math.cos(2 * math.pi * t / period), 1.0 * (vx0 - x[3])]
        return vehicle_dynamics_mb(x, u, p)

    x0 = init_mb([0.0, 0.0, 0.0, vx0, 0.0, 0.0, 0.0], p)
    t = np.arange(0.0, duration + 1e-9, 0.01)
    t0 = time.perf_counter()
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        X = odeint(rhs, x0, t)
    wall = time.perf_counter() - t0
    ok = bool(np.all(np.isfinite(X))) and abs(X[-1, 3] - vx0) < 0.2 * vx0
    return {"commonroad_realtime_factor": duration / wall if ok else None, "wall_s": wall,
            "duration_s": duration, **({} if ok else {"reason": "CommonRoad integration diverged"})}


# --------------------------------------------------------------------------
# reproduce and cold start (fresh processes)
# --------------------------------------------------------------------------

def timed_command(args, timeout: float, env=None, about: str | None = None):
    """Run ``roadbank *args`` (``python -m roadbank.cli``) in a fresh process with ``env`` (default the user's
    environment): ``(wall s, None)``, or ``(None, reason)`` where it exceeded ``timeout`` (s) or failed. A failure's
    reason quotes the last line of its output that contains ``about`` (e.g. the log's path), else its last line."""
    cmd = [sys.executable, "-m", "roadbank.cli", *map(str, args)]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                              env=dict(os.environ) if env is None else env)
    except subprocess.TimeoutExpired:
        return None, f"roadbank {args[0]} exceeded {timeout:.0f} s"
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines() or ["?"]
        line = next((ln for ln in reversed(lines) if about and about in ln), lines[-1])
        return None, f"roadbank {args[0]} failed (exit {proc.returncode}): {line}"
    return wall, None


def _timed_reproduce(outdir: Path, timeout: float, env=None):
    """Run ``roadbank reproduce -o outdir`` in a fresh process: ``(wall s, None)`` or ``(None, reason)``."""
    return timed_command(["reproduce", "-o", outdir], timeout, env)


def reproduce_bench(timeout: float = 900.0, warm_runs: int = 2) -> dict:
    """Wall time of ``roadbank reproduce`` in fresh processes (default ``-j``: all cores).

    One cold run with an empty ``NUMBA_CACHE_DIR`` (everything compiles, as
    after ``pip install``), one run that fills the normal cache, then
    ``warm_runs`` with a warm numba cache (median reported), then one warm run
    with single-threaded BLAS (``OPENBLAS_NUM_THREADS=1``):
    the gain-schedule designs call LAPACK on 3x3 to 6x6 matrices, where
    OpenBLAS worker threads only add spinning, badly so when processes share
    the cores.
    """
    import importlib.util
    if importlib.util.find_spec("roadbank.cli.reproduce") is None:
        return {"reproduce_s": None, "reason": "roadbank reproduce is not available in this installation"}
    walls = []
    with tempfile.TemporaryDirectory() as tmp, tempfile.TemporaryDirectory() as cache:
        # the first run as after `pip install`: an empty numba cache (its own directory)
        env = dict(os.environ)
        # (and an empty design cache, roadbank.cache)
        cold, reason = _timed_reproduce(Path(tmp) / "cold", timeout,
                                        dict(env, NUMBA_CACHE_DIR=cache, ROADBANK_CACHE_DIR=f"{cache}/roadbank"))
        if cold is None:
            return {"reproduce_s": None, "reproduce_cold_s": None, "reason": reason}
        for k in range(warm_runs + 1):      # the first of these warms the normal cache
            wall, reason = _timed_reproduce(Path(tmp) / f"r{k}", timeout)
            if wall is None:
                return {"reproduce_s": None, "reproduce_cold_s": cold, "reason": reason}
            walls.append(wall)
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        blas1, _ = _timed_reproduce(Path(tmp) / "blas1", timeout, env)
    return {"reproduce_s": _median(walls[1:]), "reproduce_cold_s": cold, "reproduce_warm_all_s": walls[1:],
            "reproduce_blas1_s": blas1, "command": "roadbank reproduce -o DIR"}


_COLD_SCRIPT = r"""
import json, time
t0 = time.perf_counter()
import numpy as np
from roadbank import Signals, estimators
from roadbank.estimators import kernels as K
t1 = time.perf_counter()
est = estimators.make("pif-modified")
t2 = time.perf_counter()
n = 50
s = Signals(np.arange(n) * 0.01, np.full(n, 20.0), np.zeros(n), np.zeros(n), np.zeros(n))
est.run(s)
t3 = time.perf_counter()
est.run(s)
t4 = time.perf_counter()
est.reset(); est.step(0.0, 20.0, 0.0, 0.0, 0.0)
t5 = time.perf_counter()
est.step(0.01, 20.0, 0.0, 0.0, 0.0)
t6 = time.perf_counter()
loaded = sorted({getattr(f, "py_func", f).__name__ for pair in K.ENTRIES.values() for f in pair
                 if getattr(f, "signatures", None)})   # riccati_step, gated_step are Python (they run the run)
print(json.dumps({"import_s": t1 - t0, "design_s": t2 - t1, "first_run_s": t3 - t2,
                  "second_run_s": t4 - t3, "first_step_s": t5 - t4, "second_step_s": t6 - t5,
                  "kernels_loaded": loaded}))
"""


def _probe(env) -> dict:
    proc = subprocess.run([sys.executable, "-c", _COLD_SCRIPT], capture_output=True, text=True,
                          env=env, timeout=600)
    if proc.returncode != 0:
        raise RuntimeError(f"cold-start probe failed: {proc.stderr.strip().splitlines()[-1:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def cold_start(compile_: bool = True) -> dict:
    """First-call cost of ``pif-modified`` in fresh processes.

    With ``compile_``, two processes share an empty temporary ``NUMBA_CACHE_DIR``:
    the first compiles (cold, no cache), the second loads the cache (cold,
    cached). Without, one process uses the normal cache (``--quick``: a full
    compilation takes longer than the quick budget). Also lists the kernels
    the process loaded (numba compiles lazily: the others are never compiled).
    """
    try:
        if not compile_:
            return {"cache_load": _probe(dict(os.environ))}
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, ROADBANK_CACHE_DIR=f"{cache}/roadbank")
            return {"compile": _probe(env), "cache_load": _probe(env)}
    except (RuntimeError, subprocess.TimeoutExpired) as exc:
        return {"reason": str(exc)}


# --------------------------------------------------------------------------
# assembling the results
# --------------------------------------------------------------------------

def _ratio(a, b):
    return None if a is None or b is None or b == 0 else a / b


def run_suite(size: str = "full", progress=None, options: dict | None = None) -> dict:
    """Run every benchmark of the given ``size`` ("full", "quick", "tiny") and return the results.

    ``options`` are passed to the extra sections with the size's settings (e.g. ``fleet_logs``:
    the fleet at scale of :mod:`roadbank.bench.fleet`).

    The top-level keys of :data:`TARGETS` are always present; a value is
    ``None`` when the measurement was not possible, with the reason in
    ``reasons[key]``. ``cold_compile_s`` maps each kernel family to its compile
    time (s) in a fresh process with an empty numba cache (full suite only).
    """
    import numpy as np

    cfg = SIZES[size]
    res = {"size": size, "machine": machine_info(), "reasons": {}, "phase_s": {}}
    wall0 = time.perf_counter()
    marks = [("setup", wall0)]

    def say(msg):
        now = time.perf_counter()
        res["phase_s"][marks[-1][0]] = now - marks[-1][1]
        marks.append((msg, now))
        if progress:
            progress(msg)

    say("synthetic log")
    log = synthetic_log(cfg["log_s"])
    short = log[: int(cfg["riccati_s"] * RATE_HZ) + 1]
    say(f"estimators: batch throughput on {len(log)} samples")
    res["estimators"] = bench_estimators(log, short, cfg["repeats"])
    pif = next(r for r in res["estimators"] if r["name"] == "pif-modified")
    res["pif_ns_per_sample"] = pif["ns_per_sample"]
    res["pif_cpu_ns_per_sample"] = pif["cpu_ns_per_sample"]
    from .. import estimators as _est
    pif.update(time_kernel(_est.make("pif-modified"), log, cfg["repeats"]))
    res["pif_kernel_cpu_ns_per_sample"] = pif["kernel_cpu_ns_per_sample"]
    pif.update(time_batch_kept(_est.make("pif-modified"), log, cfg["repeats"]))
    res["pif_kept_ns_per_sample"] = pif["kept_ns_per_sample"]

    say("filterpy peer")
    peer = filterpy_peer(log, cfg["peer_n"], _est.make("pif-modified"), cfg.get("peer_rounds", 1))
    peer_w = peer.pop("peer_w", None)
    res["filterpy"] = peer
    res["filterpy_ns_per_sample"] = peer["peer_ns_per_sample"]
    res["pif_vs_filterpy"] = peer.get("ratio")
    res["pif_kept_vs_filterpy"] = _ratio(peer["peer_ns_per_sample"], res["pif_kept_ns_per_sample"])
    if res["pif_vs_filterpy"] is None:
        res["reasons"]["pif_vs_filterpy"] = peer.get("reason")
    if peer_w is not None:
        from .. import estimators
        w = estimators.make("pif-modified").run(log[: len(peer_w)]).w
        settled = slice(len(peer_w) // 10, None)
        peer["rms_w_difference_vs_pif"] = float(np.sqrt(np.mean((w[settled] - peer_w[settled]) ** 2)))

    say("step() latency")
    res["step"] = step_latency(log, cfg["step_n"])
    res["step_us_median"] = res["step"]["step_us_median"]
    res["step_us_p99"] = res["step"]["step_us_p99"]

    say("plant (roadbank.sim)")
    plant = plant_bench(cfg["plant_repeats"])
    res["plant"] = plant
    res["plant_realtime_factor"] = plant.get("plant_realtime_factor")
    if res["plant_realtime_factor"] is None:
        res["reasons"]["plant_realtime_factor"] = plant.get("reason")
    say("CommonRoad multi-body peer")
    cr = commonroad_peer(cfg["cr_s"])
    res["commonroad"] = cr
    res["commonroad_realtime_factor"] = cr.get("commonroad_realtime_factor")
    res["plant_vs_commonroad"] = _ratio(res["plant_realtime_factor"], res["commonroad_realtime_factor"])
    if res["plant_vs_commonroad"] is None:
        res["reasons"]["plant_vs_commonroad"] = plant.get("reason") or cr.get("reason")

    if cfg["reproduce"]:
        say("roadbank reproduce (fresh processes: cold, 2 warm, 1 warm with single-threaded BLAS)")
        rep = reproduce_bench()
    else:
        rep = {"reproduce_s": None, "reason": f"not run with --{size} (run the full suite)"}
    res["reproduce"] = rep
    res["reproduce_s"] = rep.get("reproduce_s")
    if res["reproduce_s"] is None:
        res["reasons"]["reproduce_s"] = rep.get("reason")

    res["reproduce_cold_s"] = rep.get("reproduce_cold_s")
    if res["reproduce_cold_s"] is None:
        res["reasons"]["reproduce_cold_s"] = rep.get("reason")

    if cfg["cold"]:
        say("cold start (fresh processes)")
        res["cold_start"] = cold_start(compile_=size == "full")
    if cfg["compile"]:
        say(f"cold compile per kernel family ({', '.join(FAMILY_PROBES)}; fresh processes, empty cache, "
            f"{cfg['compile_repeats']} each)")
        cc = cold_compile(repeats=cfg["compile_repeats"])
        res["cold_compile"] = cc
        res["cold_compile_s"] = {f: v.get("cold_compile_s") for f, v in cc.items()}
        vals = [v for v in res["cold_compile_s"].values() if v is not None]
        res["cold_compile_max_s"] = max(vals) if len(vals) == len(cc) else None
        if res["cold_compile_max_s"] is None:
            res["reasons"]["cold_compile_max_s"] = "; ".join(v["reason"] for v in cc.values() if "reason" in v)
    else:
        res["cold_compile_s"] = {f: None for f in FAMILY_PROBES}
        res["cold_compile_max_s"] = None
        res["reasons"]["cold_compile_max_s"] = f"not run with --{size} (run the full suite)"
    for sec in SECTIONS:
        say(sec.title)
        try:
            res[sec.name] = sec.run(dict(cfg, size=size, **(options or {})))
        except Exception as exc:          # one failing extra section never loses the others
            res[sec.name] = {"reason": f"{type(exc).__name__}: {exc}"}
    say("done")
    res["targets"] = {key: target_status(res.get(key), key) for key in TARGETS}
    res["suite_wall_s"] = time.perf_counter() - wall0
    return res


def target_status(value, key: str):
    """True/False when ``value`` meets the target of ``key``; None when not measured."""
    if value is None:
        return None
    op, thr, _ = TARGETS[key]
    return bool(value <= thr) if op == "<=" else bool(value >= thr)


