"""``roadbank bench``: the performance benchmark suite (issue 5).

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
* cold start (numba compilation vs cache load) in fresh processes.

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
import shlex
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import click

#: targets of issue 5: key -> (comparison, threshold, text)
TARGETS = {
    "pif_ns_per_sample": ("<=", 50.0, "<= 50 ns/sample/core"),
    "pif_vs_filterpy": (">=", 1000.0, ">= 1000x filterpy"),
    "step_us_median": ("<=", 2.0, "<= 2 us"),
    "plant_realtime_factor": (">=", 2000.0, ">= 2000x real time"),
    "plant_vs_commonroad": (">=", 100.0, ">= 100x CommonRoad MB"),
    "reproduce_s": ("<=", 10.0, "<= 10 s on 2 cores (warm)"),
}

#: run sizes: log duration (s), repeats, filterpy samples, step calls, CommonRoad seconds
SIZES = {
    "full": dict(log_s=3600.0, repeats=5, riccati_s=600.0, peer_n=30000, step_n=50000,
                 cr_s=25.0, plant_repeats=5, reproduce=True, cold=True),
    "quick": dict(log_s=3600.0, repeats=3, riccati_s=60.0, peer_n=3000, step_n=20000,
                  cr_s=25.0, plant_repeats=3, reproduce=False, cold=True),
    "tiny": dict(log_s=10.0, repeats=1, riccati_s=10.0, peer_n=300, step_n=300,
                 cr_s=0.5, plant_repeats=1, reproduce=False, cold=False),
}

RATE_HZ = 100.0

#: environment variables the bench command set for itself (not passed on to `reproduce`)
_SET_BY_BENCH: set[str] = set()


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

    from ..signals import Signals

    n = int(round(duration * rate)) + 1
    t = np.arange(n) / rate
    rng = np.random.default_rng(seed)
    vx = 21.0 + 13.0 * np.sin(2 * np.pi * t / 600.0) + 0.05 * rng.normal(size=n)
    ay_true = 3.0 * np.sin(2 * np.pi * t / 17.0) * np.sin(2 * np.pi * t / 97.0)
    r = ay_true / vx + 0.002 * rng.normal(size=n)
    bank = 0.05 * np.sin(2 * np.pi * t / 300.0)
    ay = ay_true + 9.81 * np.sin(bank) + 0.05 * rng.normal(size=n)
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
    return cases


def time_batch(est, signals, repeats: int) -> dict:
    """Warm batch timing of ``est.run(signals)``: median and best (ns/sample)."""
    est.run(signals[:10])  # make sure the kernel is loaded
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


def bench_estimators(signals, short, repeats: int) -> list[dict]:
    """Design time, first call and warm throughput of every estimator.

    ``short`` (a shorter log) is used for the Riccati-ODE PIF, which is slower.
    """
    from .. import estimators
    rows = []
    for label, name, tuning in estimator_cases():
        t0 = time.perf_counter()
        est = estimators.make(name, **tuning)
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


def filterpy_peer(signals, n_samples: int) -> dict:
    """ns/sample of the same Kalman recursion with filterpy (Python loop).

    Table 4 weights (``Q = 0.1`` on ``w'``, ``R = 0.0035``) discretised at the
    log's step (``R_d = R/dt``); per sample the matrices of the nearest grid
    speed are assigned, then ``predict(u=ay)`` and ``update(r)``. Measured on the
    first ``n_samples`` samples and reported per sample.
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
    wall = time.perf_counter() - t0
    return {"peer_ns_per_sample": wall / n * 1e9, "samples": int(n), "peer_w": w}


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

def _timed_reproduce(outdir: Path, timeout: float, env=None):
    """Run ``roadbank reproduce -o outdir`` in a fresh process: ``(wall s, None)`` or ``(None, reason)``."""
    cmd = [sys.executable, "-m", "roadbank.cli", "reproduce", "-o", str(outdir)]
    if env is None:   # the user's environment, as `roadbank reproduce` would see it
        env = {k: v for k, v in os.environ.items() if k not in _SET_BY_BENCH}
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return None, f"roadbank reproduce exceeded {timeout:.0f} s"
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["?"]
        return None, f"roadbank reproduce failed (exit {proc.returncode}): {tail[0]}"
    return wall, None


def reproduce_bench(timeout: float = 900.0, warm_runs: int = 2) -> dict:
    """Wall time of ``roadbank reproduce`` in fresh processes (default ``-j``: all cores).

    One cold run, then ``warm_runs`` with a warm numba cache (median reported),
    then one warm run with single-threaded BLAS (``OPENBLAS_NUM_THREADS=1``):
    the gain-schedule designs call LAPACK on 3x3 to 6x6 matrices, where
    OpenBLAS worker threads only add spinning, badly so when processes share
    the cores.
    """
    import importlib.util
    if importlib.util.find_spec("roadbank.cli.reproduce") is None:
        return {"reproduce_s": None, "reason": "roadbank reproduce is not available yet (issue 4)"}
    walls = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(1 + warm_runs):
            wall, reason = _timed_reproduce(Path(tmp) / f"r{k}", timeout)
            if wall is None:
                return {"reproduce_s": None, "reason": reason}
            walls.append(wall)
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        blas1, _ = _timed_reproduce(Path(tmp) / "blas1", timeout, env)
    return {"reproduce_s": _median(walls[1:]), "reproduce_cold_s": walls[0], "reproduce_warm_all_s": walls[1:],
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
loaded = sorted(k for k in (f"{f}_{s}" for f in ("lpv", "dfc", "riccati") for s in ("run", "step"))
                if getattr(K, k).signatures)
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
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            return {"compile": _probe(env), "cache_load": _probe(env)}
    except (RuntimeError, subprocess.TimeoutExpired) as exc:
        return {"reason": str(exc)}


# --------------------------------------------------------------------------
# assembling the results
# --------------------------------------------------------------------------

def _ratio(a, b):
    return None if a is None or b is None or b == 0 else a / b


def run_suite(size: str = "full", progress=None) -> dict:
    """Run every benchmark of the given ``size`` ("full", "quick", "tiny") and return the results.

    The top-level keys required by issue 5 are always present; a value is
    ``None`` when the measurement was not possible, with the reason in
    ``reasons[key]``.
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

    say("filterpy peer")
    peer = filterpy_peer(log, cfg["peer_n"])
    peer_w = peer.pop("peer_w", None)
    res["filterpy"] = peer
    res["filterpy_ns_per_sample"] = peer["peer_ns_per_sample"]
    res["pif_vs_filterpy"] = _ratio(peer["peer_ns_per_sample"], res["pif_ns_per_sample"])
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

    if cfg["cold"]:
        say("cold start (fresh processes)")
        res["cold_start"] = cold_start(compile_=size == "full")
    say("done")
    res["targets"] = {key: target_status(res.get(key), key) for key in TARGETS}
    res["suite_wall_s"] = time.perf_counter() - wall0
    return res


def target_status(value, key: str):
    """True/False when ``value`` meets the issue-5 target of ``key``; None when not measured."""
    if value is None:
        return None
    op, thr, _ = TARGETS[key]
    return bool(value <= thr) if op == "<=" else bool(value >= thr)


# --------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------

def _fmt(v, nd=1):
    if v is None:
        return "n/a"
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    if abs(v) >= 1000:
        return f"{v:,.0f}"
    return f"{v:.{nd}f}"


def _met(res, key):
    return {True: "yes", False: "**no**", None: "not measured"}[res["targets"][key]]


def markdown(res: dict, command: str) -> str:
    """The benchmark report (markdown) of :func:`run_suite` results."""
    m = res["machine"]
    r = res["reasons"]
    lines = [f"# Benchmarks", "", f"Generated by `{command}` ({res['size']} suite, "
             f"{res['suite_wall_s']:.0f} s).", "",
             f"Machine: {m['cpu']}, {m['cores_usable']} usable / {m['cores_logical']} logical cores; "
             f"load average {m['load_1min']:.2f} at start (other processes share the cores); "
             f"BLAS threads in the bench process: {m.get('openblas_num_threads', 'default')}; "
             f"{m['os']}; Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, numba {m['numba']}.",
             "", "All numbers are warm (kernels compiled or loaded from the numba cache) medians "
             "unless marked otherwise; single-threaded except `reproduce`.", "",
             "## Headline and targets (issue 5)", "",
             "| what | value | peer | ratio | target | met? |", "|---|---|---|---|---|---|"]
    fp = res["filterpy"]
    cr = res["commonroad"]
    peer_note = (f"{_fmt(fp['peer_ns_per_sample'])} ns/sample (filterpy, {fp.get('samples')} samples)"
                 if fp.get("peer_ns_per_sample") else f"n/a: {r.get('pif_vs_filterpy')}")
    lines.append(f"| PIF (pif-modified, steady) batch, ns/sample | {_fmt(res['pif_ns_per_sample'])} | {peer_note} | "
                 f"{_fmt(res['pif_vs_filterpy'])}x | {TARGETS['pif_ns_per_sample'][2]}; "
                 f"{TARGETS['pif_vs_filterpy'][2]} | {_met(res, 'pif_ns_per_sample')}; {_met(res, 'pif_vs_filterpy')} |")
    st = res["step"]
    lines.append(f"| `step()` latency, us per call (median / p99) | {st['step_us_median']:.2f} / "
                 f"{st['step_us_p99']:.2f} | - | - | {TARGETS['step_us_median'][2]} median | "
                 f"{_met(res, 'step_us_median')} |")
    pv = res["plant_realtime_factor"]
    crv = res["commonroad_realtime_factor"]
    cr_note = (f"{_fmt(crv)}x real time (CommonRoad MB, {cr['duration_s']:g} s)" if crv
               else f"n/a: {cr.get('reason')}")
    lines.append(f"| plant, simulated s per wall s (25 s S-curve) | "
                 f"{_fmt(pv) if pv else 'n/a: ' + str(r.get('plant_realtime_factor'))} | {cr_note} | "
                 f"{_fmt(res['plant_vs_commonroad'])}x | {TARGETS['plant_realtime_factor'][2]}; "
                 f"{TARGETS['plant_vs_commonroad'][2]} | {_met(res, 'plant_realtime_factor')}; "
                 f"{_met(res, 'plant_vs_commonroad')} |")
    rp = res["reproduce_s"]
    lines.append(f"| `roadbank reproduce` wall time, s (warm cache, median, {m['cores_usable']} cores) | "
                 f"{_fmt(rp) if rp is not None else 'n/a: ' + str(r.get('reproduce_s'))} | - | - | "
                 f"{TARGETS['reproduce_s'][2]} | {_met(res, 'reproduce_s')} |")
    lines += ["", f"## Batch throughput of every estimator ({res['estimators'][0]['samples']} samples = "
              f"{(res['estimators'][0]['samples'] - 1) / RATE_HZ / 3600:.3g} h at 100 Hz)", "",
              "| estimator | ns/sample (median) | ns/sample (best) | CPU ns/sample (median) | samples "
              "| design (s, first build) | first run() call (s, cold in process) |", "|---|---|---|---|---|---|---|"]
    for e in res["estimators"]:
        lines.append(f"| {e['name']} | {_fmt(e['ns_per_sample'])} | {_fmt(e['ns_per_sample_best'])} | "
                     f"{_fmt(e['cpu_ns_per_sample'])} | {e['samples']} | {e['design_s']:.3f} | {e['first_call_s']:.3f} |")
    lines += ["", "Wall-clock ns/sample is the headline; CPU ns/sample (thread CPU time) is shown "
              "because other processes share this machine's cores: where the two differ, the "
              "difference is time the benchmark was descheduled.",
              "", "Design = building the gain schedule (Riccati/ARE or pole placement per grid speed, "
              "memoised per parameter set within a process).", ""]
    lines += ["## Peers", "",
              f"- filterpy `KalmanFilter`: the modified augmented model (states vy, r, w; input ay; "
              f"output r), ZOH/Van Loan discretisation per grid speed (0.25 m/s), Table 4 weights, "
              f"`predict(u=ay)` / `update(r)` per sample in a Python loop, measured on the first "
              f"{fp.get('samples', 'n/a')} samples of the log and reported per sample. RMS difference "
              f"of its w from roadbank's PIF: {_fmt(fp.get('rms_w_difference_vs_pif'), 4)} "
              f"(a Kalman gain is not the H-infinity gain, so they are close, not equal).",
              f"- CommonRoad `vehicle_dynamics_mb` (vehicle 2) with `scipy.integrate.odeint`, "
              f"{cr.get('duration_s', 'n/a')} s S-curve at 60 km/h: wall {_fmt(cr.get('wall_s'), 3)} s.",
              ""]
    pl = res["plant"]
    if pl.get("plant_realtime_factor") is not None:
        lines += ["## Plant", "",
                  f"- `roadbank.sim.measure_realtime_factor()` (integration only, best of repeats, "
                  f"pre-roll counted): {_fmt(pl['plant_realtime_factor'])}x real time.",
                  f"- `run_scenario('s-curve')` end to end (integration + sensors + truth): median "
                  f"{pl['plant_scenario_wall_s']:.3f} s for {pl['duration_s']:g} s = "
                  f"{_fmt(pl['plant_scenario_realtime_factor'])}x; first call in process (cold) "
                  f"{pl['plant_cold_s']:.2f} s.", ""]
    rep = res["reproduce"]
    if rep.get("reproduce_s") is not None:
        lines += ["## reproduce", "",
                  f"`{rep['command']}` (default `-j` = all cores) in fresh processes: first run "
                  f"{rep['reproduce_cold_s']:.1f} s (numba cache possibly stale: compiles in every worker), "
                  f"then warm runs {', '.join(f'{w:.1f}' for w in rep['reproduce_warm_all_s'])} s "
                  f"(median {rep['reproduce_s']:.1f} s). Warm with `OPENBLAS_NUM_THREADS=1`: "
                  f"{_fmt(rep.get('reproduce_blas1_s'))} s.", ""]
    lines += ["## step() latency", "",
              f"{st['calls']} calls of `pif-modified` `step()`, each timed with `perf_counter_ns` "
              f"(timer overhead {st['timer_overhead_us'] * 1e3:.0f} ns, included): median "
              f"{st['step_us_median']:.3f} us, p99 {st['step_us_p99']:.3f} us, mean {st['step_us_mean']:.3f} us; "
              f"first call in process {st['step_first_call_us']:.0f} us.", ""]
    cs = res.get("cold_start")
    if cs and "cache_load" in cs:
        lines += ["## Cold start: compilation vs numba cache (fresh processes, pif-modified)", "",
                  "| | import roadbank (s) | design (s) | first run() (s) | second run() (s) "
                  "| first step() (s) |", "|---|---|---|---|---|---|"]
        for label, text in (("compile", "cold, empty cache (compiles)"), ("cache_load", "cold, cached")):
            if label not in cs:
                continue
            c = cs[label]
            lines.append(f"| {text} | {c['import_s']:.3f} | {c['design_s']:.3f} | {c['first_run_s']:.3f} | "
                         f"{c['second_run_s']:.5f} | {c['first_step_s']:.3f} |")
        lines += ["", f"Kernels loaded by a process that only used pif-modified: "
                  f"{', '.join(cs['cache_load']['kernels_loaded'])} (the others are never compiled).", ""]
    elif cs:
        lines += [f"Cold start: {cs.get('reason')}", ""]
    obs = obstacles(res)
    if obs:
        lines += ["## What stands in the way of the unmet targets", ""] + obs + [""]
    return "\n".join(lines) + "\n"


def obstacles(res: dict) -> list[str]:
    """Markdown lines explaining each unmet target, with the measured numbers."""
    t = res["targets"]
    pif = next(e for e in res["estimators"] if e["name"] == "pif-modified")
    kin = next(e for e in res["estimators"] if e["name"] == "kinematic")
    out = []
    if t["pif_ns_per_sample"] is False or t["pif_vs_filterpy"] is False:
        out.append(
            f"- **PIF throughput** ({_fmt(pif['ns_per_sample'])} ns/sample wall, "
            f"{_fmt(pif['cpu_ns_per_sample'])} ns CPU; the kinematic estimate, which has no observer "
            f"state, costs {_fmt(kin['cpu_ns_per_sample'])} ns CPU through the same kernel). Per sample "
            "the recursion checks validity, locates vx on the schedule (one division), interpolates "
            "24 table entries, solves the 3x3 trapezoidal step (adjugate, one division), takes an "
            "asin and stores 8 outputs; x[k+1] depends on x[k], so samples cannot be vectorised "
            "within one log. Wall time on a shared machine (load average above) includes time "
            "descheduled; the CPU column excludes that, though not the cache and memory "
            "interference of the other processes. 1000x filterpy needs "
            f"<= {_fmt((res['filterpy_ns_per_sample'] or 0) / 1000)} ns/sample against this filterpy "
            "measurement. What would still help: a per-log discrete table for a fixed "
            "sample time (interpolating discrete instead of continuous matrices: no solve per "
            "sample, a small change of numbers) or several logs per call (SIMD across logs).")
    if t["step_us_median"] is False:
        out.append("- **step()**: the numba dispatch of 9 arguments (4 arrays) dominates; a "
                   "fused argument buffer would shave a few hundred ns more.")
    if t["plant_realtime_factor"] is False:
        out.append("- **Plant** (owned by the simulator): RK4 at 1 kHz means 4 plant evaluations "
                   "(18 states, 4 Magic-Formula tyres with combined slip) per simulated ms; 2000x "
                   "real time leaves 0.5 us per RK4 step. The step is set by the stiff "
                   "wheel-spin/slip dynamics; options: a larger step with a semi-implicit "
                   "wheel-spin update, or an adaptive step.")
    if t["plant_vs_commonroad"] is False:
        out.append("- **Plant vs CommonRoad**: follows from the plant's own real-time factor.")
    if t["reproduce_s"] is False:
        rep = res["reproduce"]
        out.append(
            f"- **reproduce** ({_fmt(rep.get('reproduce_s'))} s warm; "
            f"{_fmt(rep.get('reproduce_blas1_s'))} s with `OPENBLAS_NUM_THREADS=1`). A single-process "
            "profile showed most time in the gain-schedule designs (about 1100 Riccati solves with "
            "scipy: multithreaded OpenBLAS spins for milliseconds per 3x3..6x6 triangular solve "
            "when the cores are shared) and in matplotlib `savefig`. Fixes (in reproduce/"
            "synthesis, not here): single-threaded BLAS in the workers, designs shared between "
            "worker processes (or stored on disk), cheaper figures.")
    return out


def to_json(res: dict) -> dict:
    """JSON-serialisable copy of the results (NaN/inf become null)."""
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v
    return clean(res)


@click.command()
@click.option("-o", "--output", type=click.Path(path_type=Path), default=None,
              help="Write the markdown report here (e.g. docs/benchmarks.md).")
@click.option("--quick", is_flag=True, help="Shorter repeats and peers; finishes within 45 s (no reproduce).")
@click.option("--tiny", is_flag=True, help="A 10 s log, for tests: checks the runner, not the speed.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with all results on stdout.")
def bench(output, quick, tiny, as_json):
    """Benchmark the estimators, the plant and reproduce against peers (issue 5)."""
    size = "tiny" if tiny else "quick" if quick else "full"
    # The kernels are single-threaded; the designs call LAPACK on 3x3..6x6 matrices
    # where BLAS worker threads only spin (badly so on shared cores). Only effective
    # when numpy is not imported yet (always the case for the `roadbank` command).
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        if var not in os.environ:
            os.environ[var] = "1"
            _SET_BY_BENCH.add(var)
    command = "roadbank bench" + "".join(f" {a}" for a in sys.argv[2:]) if sys.argv[1:2] == ["bench"] \
        else "roadbank bench" + (f" -o {output}" if output else "") + (f" --{size}" if size != "full" else "")
    res = run_suite(size, progress=lambda msg: click.echo(f"[bench] {msg}", err=True))
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(markdown(res, shlex.join(shlex.split(command))))
        click.echo(f"wrote {output}", err=True)
    if as_json:
        click.echo(json.dumps(to_json(res), indent=1))
    elif output is None:
        click.echo(markdown(res, command))
