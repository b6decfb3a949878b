"""C export (issue 13): the generated C99 module computes what Estimator.step() computes.

Every exportable estimator (lpv kernel) is generated, compiled with strict C99 warnings
as errors, loaded through ctypes and compared sample by sample with the Python
``Estimator.step()`` on every paper scenario and on a log with gaps, a low-speed
stretch, NaN/inf samples, repeated and backward time stamps and irregular steps:
float64 within 1e-9 rad, float32 within 1e-3 deg of bank, the same valid flags.
A driver program built with AddressSanitizer/UBSan runs the same log.
"""

from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank import estimators as E
from roadbank.export import CModule, NotExportable, build_driver, export_c, export_design, measure_c_step_ns
from roadbank.export.build import object_report
from roadbank.sim import SCENARIOS, run_scenario

def make(name, **kw):
    """The estimator on its general (per-sample trapezoidal) path only (no automatic fixed rate):
    the export then follows it without the fixed-rate tables."""
    return E.make(name, sample_rate=None, **kw)


#: estimators built once (designs are cached by the estimators module too)
BUILT = {name: make(name) for name in E.NAMES}
EXPORTABLE = [n for n, est in BUILT.items() if est.kernel in ("lpv", "gated") and n not in E.OFFLINE]
NOT_EXPORTABLE = [n for n in E.NAMES if n not in EXPORTABLE]

TOL64 = 1e-9                     # rad
TOL32_BANK = np.deg2rad(1e-3)    # rad


@pytest.fixture(scope="module")
def scenarios():
    """Every paper scenario simulated once (nominal condition), as raw arrays."""
    out = {}
    for name in SCENARIOS:
        s = run_scenario(name).signals
        out[name] = tuple(np.array(a) for a in (s.t, s.vx, s.ay, s.r, s.delta_f))
    return out


def hard_log(scenarios, *, nan_time=True, v_min=5.0):
    """bank-lane-change with a 2.5 s gap, a slow stretch (below ``v_min``, m/s: the estimator's), speeds
    at and beyond the grid's ends, an implausible lateral acceleration, NaN/inf inputs, a repeated and
    a backward time stamp, samples beyond a car's limits and irregular steps up to 45 ms (several substeps)."""
    t, vx, ay, r, d = (a.copy() for a in scenarios["bank-lane-change"])
    n = len(t)
    t[400:] += 2.5
    vx[600:700] = 0.6 * v_min
    ay[800:805] = np.nan
    r[900] = np.inf
    d[950:960] = np.nan
    vx[1000] = np.nan
    vx[720:740] = v_min                                # exactly v_min: the first grid speed
    vx[740:760] = 110.0                                # beyond the grid: clamped schedule
    ay[1020:1040] = 25.0                               # |w| > sin(max_angle): flagged implausible
    ay[1060], r[1070], vx[1080] = 655.35, 1e20, 1e4    # glitches beyond a car's limits: held as NaN is
    t[1100] = t[1099]
    t[1200] = t[1150]
    if nan_time:
        t[1300] = np.nan
    t[1400:] += np.cumsum(np.random.default_rng(0).uniform(0.0, 0.035, n - 1400))
    return t, vx, ay, r, d


def python_steps(est, cols):
    est.reset()
    res = [est.step(*a) for a in zip(*cols)]
    return {"w": np.array([o.w for o in res]), "theta": np.array([o.theta for o in res]),
            "phi_b": np.array([o.phi_b for o in res]), "valid": np.array([o.valid for o in res])}


def assert_same(py, c, tol_angle, tol_bank, what):
    assert np.array_equal(py["valid"], c["valid"]), f"{what}: valid flags differ at " \
        f"{np.flatnonzero(py['valid'] != c['valid'])[:10]}"
    assert np.max(np.abs(py["phi_b"] - c["phi_b"])) <= tol_bank, what
    if tol_angle is not None:
        assert np.max(np.abs(py["theta"] - c["theta"])) <= tol_angle, what
        assert np.max(np.abs(py["w"] - c["w"])) <= tol_angle, what


@pytest.fixture(scope="module")
def built_modules(tmp_path_factory):
    """Generated and compiled (strict flags) modules, built on first use: {(name, float32): CModule}."""
    root = tmp_path_factory.mktemp("export")
    cache = {}

    def get(name, float32=False, est=None, tag=""):
        key = (name, float32, tag)
        if key not in cache:
            d = root / f"{name}{tag}-{'f32' if float32 else 'f64'}"
            res = export_c(est or BUILT[name], d, rate=100.0, float32=float32)
            cache[key] = CModule(res.source, d)
        return cache[key]
    return get


def test_the_issue_list_is_exportable_and_the_others_say_why():
    assert {"kinematic", "pio-original", "pio-modified", "pif-modified", "pif-original",
            "kalman"} <= set(EXPORTABLE)
    assert "dfc" in NOT_EXPORTABLE
    for name in NOT_EXPORTABLE:
        with pytest.raises(NotExportable, match=f"{name}: not exportable: .+"):
            export_c(BUILT[name], "/nonexistent/never-written", rate=100.0)
    riccati = make("pif-modified", variant="riccati", roll="dynamic")   # the design test_streaming uses
    with pytest.raises(NotExportable, match="Riccati.*steady"):
        export_c(riccati, "/nonexistent/never-written", rate=100.0)


@pytest.mark.parametrize("name", ["kinematic", "kinematic-lp", "pif-modified", "uio", "pif-gated"])
def test_the_c_tables_are_read_at_the_kernels_offsets(name):
    """The generated C indexes its table rows at the offsets of the kernels' layout
    (``layout.lpv_row``), for every state count and with the fixed-rate tables, and its
    observer and roll updates are the loops written from the one update description."""
    import re

    from roadbank.estimators import update_spec as U
    from roadbank.estimators.layout import lpv_row
    from roadbank.export.ccode import _fix_literals, _observer_system, _roll_system, generate
    from roadbank.export import update_c

    def c_sum(*a, **kw):
        return _fix_literals(update_c.c_sum(*a, **kw), False)

    est = E.make(name)                             # sample_rate "auto": with the fixed-rate tables
    d = export_design(est, 100.0)
    src = next(t for f, t in generate(d).items() if f.endswith(".c"))
    enum = {k: int(v) for k, v in re.findall(r"\b(RB_O[A-Z0-9]+|RB_NK|RB_NROW|RB_D(?:PHI|GAM0|GAM1))\s*=\s*(\d+)",
                                             src)}
    row = lpv_row(est._nstate)
    assert enum["RB_NK"] == row.cont == est._tab_cont.shape[1]
    assert enum["RB_NROW"] == row.end
    assert {b: enum[f"RB_O{b.upper()}"] for b in ("F", "G", "H", "D", "J", "Phi", "Gam0", "Gam1")} == \
        {b: getattr(row, b) for b in ("F", "G", "H", "D", "J", "Phi", "Gam0", "Gam1")}
    if est._nstate:
        assert (enum["RB_DPHI"], enum["RB_DGAM0"], enum["RB_DGAM1"]) == \
            (0, row.Gam0 - row.Phi, row.Gam1 - row.Phi)
    obs, roll = _observer_system(est._nstate), _roll_system(d.nr)
    for s in (U.RESTART, U.FIXED):
        assert _fix_literals(update_c.c_update_output(s, U.OUTPUT, obs, "w"), False) in src
        assert c_sum(s, roll, indent="        ") in src
    assert c_sum(U.OUTPUT, obs, target="w") in src and c_sum(U.OUTPUT, roll, target="phi") in src
    if est._nstate == 3:                           # the loops name the blocks at the layout's offsets
        assert "acc += c[RB_OGAM0 + p * 3 + q] * st->eta[q] + c[RB_OGAM1 + p * 3 + q] * u[q];" in src
        assert "acc += c[RB_OJ + p * 3 + q] * u[q];" in src and "w += c[RB_OH + q] * x[q];" in src


@pytest.mark.parametrize("name", EXPORTABLE)
def test_float64_equals_step_on_every_scenario_and_a_hard_log(name, scenarios, built_modules):
    mod = built_modules(name)
    est = BUILT[name]
    for scen, cols in {**scenarios, "hard": hard_log(scenarios, v_min=est.v_min)}.items():
        py = python_steps(est, cols)
        assert_same(py, mod.run(*cols), TOL64, TOL64, f"{name} on {scen}")
        if scen == "hard":
            assert 50 < np.count_nonzero(~py["valid"]) < len(py["valid"]) // 2   # the log exercises flags
    # the dt entry point (time since the previous call) on the same log, time stamps all finite
    cols = hard_log(scenarios, nan_time=False, v_min=est.v_min)
    assert_same(python_steps(est, cols), mod.run(*cols, use_dt=True), TOL64, TOL64, f"{name} step_dt")


def test_a_limited_low_pass_exports_its_limit(scenarios, tmp_path):
    """kinematic-lp with its update limited (the map smoother's passes; the limit acts on the paper's
    manoeuvres at the data sheet's noise): the module reads the limited ay in the steering's slot as the kernel
    does, float64 equal to step() on every scenario and a hard log; without the limit the module has none."""
    est = make("kinematic-lp", clip=2.5, Q_ay=float(BUILT["pif-modified"].Q_ay), R=1e-6)
    assert est.limited
    res = export_c(est, tmp_path / "lim", rate=100.0)
    assert "RB_CLIP" in res.source.read_text()
    assert "RB_CLIP" not in export_c(BUILT["kinematic-lp"], tmp_path / "lin", rate=100.0).source.read_text()
    assert_module_steps_and_acts(est, make("kinematic-lp"), CModule(res.source, tmp_path / "lim"), scenarios,
                                 "limited kinematic-lp")


def assert_module_steps_and_acts(est, plain, mod, scenarios, label):
    """``mod`` (the C module of ``est``) float64 equal to ``est``'s steps on every scenario and a hard log, and ``est``
    different from ``plain`` (the same without the option under test) by more than 1e-6 on one of them."""
    acted = False
    for scen, cols in {**scenarios, "hard": hard_log(scenarios, v_min=est.v_min)}.items():
        py = python_steps(est, cols)
        assert_same(py, mod.run(*cols), TOL64, TOL64, f"{label} on {scen}")
        acted |= bool(np.nanmax(np.abs(py["w"] - python_steps(plain, cols)["w"])) > 1e-6)
    assert acted


def test_the_gates_lowest_speed_is_exported(scenarios, tmp_path):
    """kinematic-pif with its gate counted only from 25 m/s (the paper's manoeuvres at 60-100 km/h): the module reads
    RB_GATE_VMIN as the kernel does, float64 equal to step() on every scenario and a hard log; it differs from the
    gate at every speed where the car turns hard below 25 m/s."""
    est, plain = make("kinematic-pif", gate_v_min=25.0), make("kinematic-pif")
    res = export_c(est, tmp_path / "vmin", rate=100.0)
    assert "#define RB_GATE_VMIN (25.0" in res.source.read_text()
    assert_module_steps_and_acts(est, plain, CModule(res.source, tmp_path / "vmin"), scenarios,
                                 "kinematic-pif gated from 25 m/s")


@pytest.mark.parametrize("discrete,limit_tau", [(False, None), (True, None), (False, 0.0)])
def test_a_low_pass_following_its_running_noise_exports_it(discrete, limit_tau, scenarios, tmp_path):
    """kinematic-pif as built for a log (a running noise estimate relative to the design span's: here a reference
    a quarter of what the paper's manoeuvres read, so that the ratio moves, to about 4): the module keeps
    the ratio and the previous kinematic acceleration as state and scales the low-pass's update as the kernel
    does, float64 equal to step() on every scenario and a hard log (general and fixed-rate paths), float32 within
    a thousandth of a degree; it differs from the same design without the running noise. The limit reads its
    shorter ratio (the default limit_tau) or the gain's (limit_tau=0)."""
    from roadbank.signals import diff_noise_std

    t, vx, ay, r, d = scenarios["bank-lane-change"]
    ref = 0.25 * diff_noise_std(ay - vx * r) ** 2
    est = make("kinematic-pif", noise_ref=ref, noise_tau=5.0, limit_tau=limit_tau,
               Q_ay=float(BUILT["pif-modified"].Q_ay) * 25)
    assert (est.limit_tau > 0) == (limit_tau is None)
    plain = make("kinematic-pif", Q_ay=float(BUILT["pif-modified"].Q_ay) * 25)
    assert est.noise_tau == 5.0 and plain.noise_tau == 0.0      # no reference, no running noise
    if discrete:
        est.set_sample_rate(100.0)
        plain.set_sample_rate(100.0)
    cols_all = {**scenarios, "hard": hard_log(scenarios, v_min=est.v_min)}
    acted = False
    for f32 in (False, True):
        res = export_c(est, tmp_path / f"n{f32}", rate=100.0, float32=f32, discrete=discrete)
        assert "RB_NOISE_TN" in res.source.read_text()
        mod = CModule(res.source, tmp_path / f"n{f32}")
        assert mod.state_size == export_design(est, 100.0).state_bytes(float32=f32)
        for scen, cols in cols_all.items():
            py = python_steps(est, cols)
            assert_same(py, mod.run(*cols), None if f32 else TOL64, TOL32_BANK if f32 else TOL64,
                        f"kinematic-pif with running noise {'f32' if f32 else 'f64'} on {scen}")
            acted |= bool(np.nanmax(np.abs(py["w"] - python_steps(plain, cols)["w"])) > 1e-4)
    assert acted
    assert "RB_NOISE_TN" not in export_c(plain, tmp_path / "plain", rate=100.0, discrete=discrete).source.read_text()
    est.set_sample_rate(None)


@pytest.mark.slow
@pytest.mark.parametrize("name", EXPORTABLE)
def test_float32_within_a_thousandth_of_a_degree(name, scenarios, built_modules):
    mod = built_modules(name, float32=True)
    assert mod.float32
    assert mod.state_size == export_design(BUILT[name], 100.0).state_bytes(float32=True)
    assert built_modules(name).state_size == export_design(BUILT[name], 100.0).state_bytes()
    est = BUILT[name]
    worst = 0.0
    for scen, cols in {**scenarios, "hard": hard_log(scenarios)}.items():
        py = python_steps(est, cols)
        c = mod.run(*cols)
        assert_same(py, c, None, TOL32_BANK, f"{name} float32 on {scen}")
        worst = max(worst, np.max(np.abs(py["phi_b"] - c["phi_b"])))
    assert worst > 0.0          # it really is single precision


@pytest.mark.parametrize("name,roll,grid", [("pif-modified", "dynamic", {}), ("uio", "dynamic", {}),
                                            ("kinematic", "none", {}), ("kalman", "dynamic", {}),
                                            ("pio-modified", "static", {"v_step": 1.0, "v_max": 60.0})])
@pytest.mark.slow
def test_roll_models_grids_and_the_general_observer_path(name, roll, grid, scenarios, built_modules):
    """Static, dynamic and no roll; the four-state (LU) path; a coarse, short speed grid."""
    est = make(name, roll=roll, **grid)
    mod = built_modules(name, est=est, tag=roll + "".join(f"-{k}{v}" for k, v in grid.items()))
    assert mod.state_size == export_design(est, 100.0).state_bytes()
    for scen in ("hard", "track-lane-change"):
        cols = hard_log(scenarios) if scen == "hard" else scenarios[scen]
        assert_same(python_steps(est, cols), mod.run(*cols), TOL64, TOL64, f"{name} roll={roll} {scen}")


@pytest.mark.slow
@pytest.mark.parametrize("car", ["suv-paper", "van"])
def test_what_export_c_gives_by_default_for_a_car(car, scenarios, built_modules):
    """What `roadbank export c --vehicle CAR` exports: the car's default pif-modified as roadbank runs
    it by default (automatic sample rate: the fixed-rate path at 100 Hz), fixed-rate tables included."""
    from roadbank.vehicle import load_vehicle

    est = load_vehicle(car).make("pif-modified")
    for f32 in (False, True):
        mod = built_modules("pif-modified", float32=f32, est=est, tag=car)
        assert "RB_DTAB" in mod.source.read_text()
        for scen, cols in {**scenarios, "hard": hard_log(scenarios)}.items():
            assert_same(python_steps(est, cols), mod.run(*cols), None if f32 else TOL64,
                        TOL32_BANK if f32 else TOL64, f"{car} pif-modified {'f32' if f32 else 'f64'} {scen}")


@pytest.mark.slow
@pytest.mark.parametrize("name,roll", [("pif-modified", "dynamic"), ("uio", "static"), ("kinematic", "dynamic"),
                                       ("kinematic-pif", "dynamic")])
def test_fixed_rate_tables_follow_the_kernels_fixed_rate_path(name, roll, scenarios, tmp_path):
    """``discrete=True`` adds the kernels' fixed-rate tables (Estimator.discrete_tables): the module
    then equals step() with that sample rate set; an estimator fixed at another rate is refused."""
    est = make(name, roll=roll)
    cols_all = {**scenarios, "hard": hard_log(scenarios)}
    for f32 in (False, True):
        res = export_c(est, tmp_path / str(f32), rate=100.0, float32=f32, discrete=True)
        general = export_c(est, tmp_path / "g", rate=100.0, discrete=False)
        assert res.table_bytes > general.table_bytes * (0.5 if f32 else 1)
        mod = CModule(res.source, tmp_path / str(f32))
        for scen, cols in cols_all.items():
            est.set_sample_rate(100.0)
            est.reset()
            res_py = [est.step(*a) for a in zip(*cols)]
            py = {k: np.array([getattr(o, k) for o in res_py]) for k in ("w", "theta", "phi_b", "valid")}
            assert_same(py, mod.run(*cols), None if f32 else TOL64, TOL32_BANK if f32 else TOL64,
                        f"{name} fixed-rate {'float32' if f32 else 'float64'} on {scen}")
    est.set_sample_rate(50.0)
    with pytest.raises(ValueError, match="fixed-rate path at 50 Hz, not at the export rate 100 Hz"):
        export_c(est, tmp_path / "50", rate=100.0)
    est.set_sample_rate(None)


def test_ctypes_step_by_step_and_reset(scenarios, built_modules):
    est = BUILT["pif-modified"]
    mod = built_modules("pif-modified")
    cols = hard_log(scenarios)
    py = python_steps(est, cols)
    mod.reset()
    first = mod.step(*(c[0] for c in cols))
    assert first.valid and abs(first.phi_b - py["phi_b"][0]) <= TOL64
    mod.reset()
    out = [mod.step(*a) for a in zip(*cols)]
    assert np.array_equal([o.valid for o in out], py["valid"])
    assert np.max(np.abs(np.array([o.phi_b for o in out]) - py["phi_b"])) <= TOL64
    mod.reset()                                  # a reset state starts like a new one
    again = mod.step(*(c[0] for c in cols))
    assert again == first


@pytest.mark.slow
def test_sanitizers_on_a_driver_linking_several_modules(scenarios, tmp_path):
    """-fsanitize=address,undefined: five modules in one program (prefixed symbols), t and dt entry
    points; pif-gated for its gate code."""
    variants = {"pif": (make("pif-modified", roll="dynamic"), False),
                "uio": (BUILT["uio"], False), "kin": (BUILT["kinematic"], False),
                "gated": (BUILT["pif-gated"], False),
                "pif32": (make("pif-modified", roll="dynamic"), True)}
    sources = {}
    for key, (est, f32) in variants.items():
        # the same estimator twice in one program: the float32 one gets its own module name
        sources[key] = export_c(est, tmp_path / key, rate=100.0, float32=f32,
                                module_name="pif-modified-32" if key == "pif32" else None).source
    assert sources["pif32"].name == "roadbank_pif_modified_32.c"
    exe = build_driver(sources, tmp_path / "driver")
    # leak checking needs ptrace, which some CI containers forbid; the module allocates nothing
    # (test_generated_object_has_no_heap...) and the driver frees what it allocates
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=0:abort_on_error=0",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    for use_dt in (False, True):
        cols = hard_log(scenarios, nan_time=not use_dt)
        n = len(cols[0])
        inp = tmp_path / "in.bin"
        inp.write_bytes(np.int64(n).tobytes() + np.concatenate(cols).astype(np.float64).tobytes())
        for key, (est, f32) in variants.items():
            outp = tmp_path / f"out-{key}.bin"
            proc = subprocess.run([str(exe), key, str(inp), str(outp), "dt" if use_dt else "t"],
                                  capture_output=True, text=True, env=env)
            assert proc.returncode == 0, proc.stderr
            assert "runtime error" not in proc.stderr and "AddressSanitizer" not in proc.stderr
            raw = outp.read_bytes()
            vals = np.frombuffer(raw[:n * 32], dtype=np.float64).reshape(4, n)
            c = {"w": vals[0], "theta": vals[1], "phi_b": vals[2],
                 "valid": np.frombuffer(raw[n * 32:], dtype=np.uint8).astype(bool)}
            assert_same(python_steps(est, cols), c, None if f32 else TOL64,
                        TOL32_BANK if f32 else TOL64, f"driver {key} dt={use_dt}")


def test_generated_object_has_no_heap_no_mutable_globals_no_recursion(tmp_path):
    from roadbank.estimators.gyro import KinematicGyro
    for name, est in (("uio", make("uio", roll="dynamic")), ("pif-modified", make("pif-modified", roll="static")),
                      ("gyro-window", KinematicGyro(roll="dynamic")),       # with the grade correction in C
                      ("gyro-observer", KinematicGyro(pitch_bandwidth=0.5, pitch_anchor=1.0))):
        src = export_c(est, tmp_path / name, rate=100.0).source
        rep = object_report(src)
        assert rep["mutable_symbols"] == set()
        assert rep["sections"].get(".data", 0) == 0 and rep["sections"].get(".bss", 0) == 0
        libm = {"asin", "fabs", "ceil"} | ({"tan", "sin", "cos"} if name.startswith("gyro") else set())
        assert rep["undefined"] <= libm, rep["undefined"]
        assert all(q in ("static", "dynamic,bounded") for _, q in rep["stack"].values()), rep["stack"]
        # no recursion: the call graph (no inlining at -O0) is acyclic
        graph = {}
        for a, b in rep["calls"]:
            graph.setdefault(a, set()).add(b)
        state = {}

        def visit(f, state=state, graph=graph):
            state[f] = 1
            for g in graph.get(f, ()):
                assert state.get(g) != 1, f"recursion through {f} -> {g}"
                if g not in state:
                    visit(g)
            state[f] = 2
        for f in list(graph):
            if f not in state:
                visit(f)
        # the tables are in read-only data, 8 bytes per value
        assert rep["sections"][".rodata"] >= export_c(est, tmp_path / name, rate=100.0).table_bytes


def test_cli_designs_for_the_target_rate(tmp_path):
    """``--rate 10`` designs as for a 10 Hz log: the default's low-pass takes half of that interval as its
    lead and the PIF the sensors' noise densities at 10 Hz, so the module is the one of
    ``Vehicle.make(name, log_rate=10)``, not of the sensors' own 100 Hz."""
    from roadbank.cli import main
    from roadbank.vehicle import load_vehicle

    res = CliRunner().invoke(main, ["export", "c", "--vehicle", "suv-paper", "-e", "kinematic-pif", "--rate", "10",
                                   "-o", str(tmp_path / "cli")])
    assert res.exit_code == 0, res.output
    car = load_vehicle("suv-paper")
    at10, at100 = car.make("kinematic-pif", log_rate=10.0), car.make("kinematic-pif")
    assert at10.lead == pytest.approx(0.05) and at100.lead == pytest.approx(0.005)
    got = (tmp_path / "cli" / "roadbank_kinematic_pif.c").read_text()
    assert got == export_c(at10, tmp_path / "py10", rate=10.0).source.read_text()
    assert got != export_c(at100, tmp_path / "py100", rate=10.0).source.read_text()


def test_cli_designs_for_a_recorded_drive(tmp_path):
    """``--log``: the module is the one of the estimator `roadbank estimate` builds for that log (for_log: the car
    fitted to it, its rate, its road noise and the running noise's reference), here for a loud 10 Hz drive; with
    --vehicle the car's, at --rate. A quiet log's kinematic-pif (the car's model) is refused with the reason, and
    a log that cannot be read names the file."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from roadbank.cli import main
    from roadbank.io import load_log
    from roadbank.vehicle import for_log, load_vehicle, log_conditions

    rng = np.random.default_rng(2)
    t = np.arange(0.0, 120.0, 0.1)
    vx = 15.0 + 2.0 * np.sin(0.05 * t)
    r = 0.05 * np.sin(0.2 * t)
    ay = vx * r + 9.81 * np.sin(np.radians(2.0)) + 0.3 * rng.standard_normal(t.size)
    pq.write_table(pa.table({"t": t, "vx": vx, "ay": ay, "r": r}), tmp_path / "drive.parquet")
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(tmp_path / "drive.parquet"),
                                   "-o", str(tmp_path / "cli")])
    assert res.exit_code == 0, res.output
    assert "fitted to drive.parquet" in res.output
    s = load_log(tmp_path / "drive.parquet").signals
    est = for_log("kinematic-pif", s)
    assert est.noise_ref > 0
    got = (tmp_path / "cli" / "roadbank_kinematic_pif.c").read_text()
    assert "RB_NOISE_TN" in got
    assert got == export_c(est, tmp_path / "py", rate=log_conditions(s)["log_rate"]).source.read_text()
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(tmp_path / "drive.parquet"),
                                   "--vehicle", "van", "--rate", "10", "-o", str(tmp_path / "van")])
    assert res.exit_code == 0, res.output
    van = load_vehicle("van").make("kinematic-pif", **{**log_conditions(s), "log_rate": 10.0})
    assert (tmp_path / "van" / "roadbank_kinematic_pif.c").read_text() == \
        export_c(van, tmp_path / "pyvan", rate=10.0).source.read_text()
    quiet = run_scenario("s-curve").signals
    pq.write_table(pa.table({"t": quiet.t, "vx": quiet.vx, "ay": quiet.ay, "r": quiet.r, "delta_f": quiet.delta_f}),
                   tmp_path / "quiet.parquet")
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(tmp_path / "quiet.parquet"),
                                   "--vehicle", "suv-paper", "-o", str(tmp_path / "q")])
    assert res.exit_code == 1 and "the log is quiet, so kinematic-pif is pif-adaptive for it" in res.output
    # a car nobody described: the quiet log is designed loud (the sixty-second stage), as for_log builds it
    res = CliRunner().invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(tmp_path / "quiet.parquet"),
                                   "-o", str(tmp_path / "qn")])
    assert res.exit_code == 0, res.output
    blend = for_log("kinematic-pif", quiet)
    assert isinstance(blend, E.KinematicPIF)
    assert (tmp_path / "qn" / "roadbank_kinematic_pif.c").read_text() == export_c(
        blend, tmp_path / "pyq", rate=log_conditions(quiet)["log_rate"]).source.read_text()
    res = CliRunner().invoke(main, ["export", "c", "--log", str(tmp_path / "none.csv"), "-o", str(tmp_path / "n")])
    assert res.exit_code == 1 and "none.csv" in res.output and "Traceback" not in res.output


def test_cli_writes_the_module_and_refuses_dfc(tmp_path):
    from roadbank.cli import main

    runner = CliRunner()
    res = runner.invoke(main, ["export", "c", "--estimator", "pio-modified", "--rate", "50", "--float32",
                               "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    files = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert files == ["README_roadbank_pio_modified.md", "roadbank_pio_modified.c", "roadbank_pio_modified.h"]
    header = (tmp_path / "out" / "roadbank_pio_modified.h").read_text()
    assert "typedef float roadbank_pio_modified_real;" in header and "RATE_HZ 50.0" in header
    res = runner.invoke(main, ["export", "c", "-e", "kinematic", "--v-step", "1", "--v-max", "41",
                               "-o", str(tmp_path / "coarse")])
    assert res.exit_code == 0, res.output
    from roadbank.estimators.kinematic import KINEMATIC_V_MIN             # the grid: v_min, v_min + 1, .., 41 m/s
    assert f"RB_NG = {int(41 - KINEMATIC_V_MIN) + 1}," in (tmp_path / "coarse" / "roadbank_kinematic.c").read_text()
    from roadbank.vehicle import load_vehicle                 # the car's tuning reaches the design

    car = load_vehicle("sedan").with_tuning("kalman", {"v_step": 1.0})
    car.to_toml(tmp_path / "car.toml")
    res = runner.invoke(main, ["export", "c", "--vehicle", str(tmp_path / "car.toml"), "-e", "kalman",
                               "-o", str(tmp_path / "car")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "car" / "roadbank_kalman.c").read_text()
    assert "RB_NG = 96," in text and f"m={car.params.m:.6g}" in text
    res = runner.invoke(main, ["export", "c", "--estimator", "dfc", "-o", str(tmp_path / "dfc")])
    assert res.exit_code != 0 and "not exportable" in res.output and "Traceback" not in res.output
    res = runner.invoke(main, ["export", "c", "--estimator", "nope", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2 and "unknown estimator" in res.output


def test_measure_c_step_ns_times_the_compiled_step():
    ns = measure_c_step_ns(BUILT["pif-modified"], repeats=1, min_samples=20_000)
    assert 0.5 < ns < 1e5


@pytest.mark.parametrize("args, said", [(["--v-step", "1e-4"], "more than 4000"),
                                        (["--v-max", "inf"], "both finite"), (["--v-max", "nan"], "both finite")])
def test_a_schedule_too_fine_or_endless_is_refused_before_the_design(tmp_path, args, said):
    """A speed grid of 950 000 speeds (--v-step 1e-4 m/s: gigabytes and minutes before) and an infinite or NaN last
    speed (an OverflowError before) are refused naming the limit, with no output and no traceback; the library says
    the same (estimators.make)."""
    from roadbank import estimators
    from roadbank.cli import main

    res = CliRunner().invoke(main, ["export", "c", *args, "-o", str(tmp_path / "out")])
    assert res.exit_code != 0 and said in res.output and "Traceback" not in res.output, res.output
    assert not (tmp_path / "out").exists()
    option = {"--v-step": "v_step", "--v-max": "v_max"}[args[0]]
    with pytest.raises(ValueError, match=said):
        estimators.make("pif-modified", **{option: float(args[1])})


@pytest.mark.parametrize("name", ["pif-modified", "kinematic-pif"])
def test_a_vehicle_files_offsets_are_taken_off_the_measured_channels(name, scenarios, tmp_path):
    """`export c --vehicle car.toml` with identified offsets: both step functions take the measured channels and
    remove the offsets as `roadbank estimate --vehicle` does (the module had left them out, 1.29 deg from estimate);
    the fingerprint tells the modules apart."""
    off = {"r": 0.004, "ay": 0.12, "delta_f": -0.01}
    est = BUILT[name]
    plain = export_c(est, tmp_path / "plain", rate=100.0)
    res = export_c(est, tmp_path / "filed", rate=100.0, offsets=off)
    assert plain.design.fingerprint() != res.design.fingerprint()
    mod = CModule(res.source, tmp_path / "filed")
    for use_dt in (False, True):
        cols = hard_log(scenarios, nan_time=not use_dt, v_min=est.v_min)
        t, vx, ay, r, d = cols
        seen = (t, vx, ay - off["ay"], r - off["r"], d - off["delta_f"])
        assert_same(python_steps(est, seen), mod.run(*cols, use_dt=use_dt), TOL64, TOL64, f"{name} dt={use_dt}")


def test_the_fingerprint_tells_learners_and_precisions_apart(tmp_path):
    """The header's fingerprint traces a build to what generated it: the learner and its settings, the precision
    (it had been one string for all of them)."""
    from roadbank.estimators import OffsetSettings, with_online_offsets

    est = BUILT["pif-modified"]
    prints = [export_c(e, tmp_path / str(k), rate=100.0, float32=f32).design.fingerprint(f32)
              for k, (e, f32) in enumerate([(est, False), (est, True), (with_online_offsets(est), False),
                                            (with_online_offsets(est, settings=OffsetSettings(straight_ay=0.3)),
                                             False)])]
    assert len(set(prints)) == 4, prints
    assert prints[0] == export_design(est, 100.0).fingerprint()       # a plain module keeps its old fingerprint
