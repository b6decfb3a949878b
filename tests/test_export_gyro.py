"""The gyro-aided filter exported to C (roadbank.export with a KinematicGyro; the grade correction of
roadbank.export.grade_c): the C module's corrected roll rate and estimate against the Python estimator's on the same
samples (the independent implementation being roadbank's own kernels and numpy, which the C must reproduce), on a
synthetic drive with faults and on the shared KITTI drive, and the command line."""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.constants import G
from roadbank.estimators.gyro import KinematicGyro
from roadbank.export import CModule, NotExportable, export_c
from roadbank.models.attitude import grade_pitch
from roadbank.signals import Signals

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
KITTI = DATA / "kitti-oxts" / "2011_09_26_drive_0070"
needs_kitti = pytest.mark.skipif(not KITTI.is_dir(), reason=f"shared KITTI data not found at {KITTI}")
TOL64 = 1e-9          # rad, rad/s


def _drive(rate: float = 50.0, duration: float = 90.0, seed: int = 0) -> Signals:
    """A drive on a road that climbs and falls (pitch to 4 deg) and banks (to 3 deg) while the car weaves, with an
    INS-like roll rate (the roll's rate plus r tan(pitch)), ax (the speed's rate less g sin(pitch)) and pitch rate;
    jittered time stamps, a standstill at the start, NaN samples in ax, q, p and vx, a 1.5 s and a 12 s gap."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / rate)
    t = t + rng.uniform(-0.2, 0.2, len(t)) / rate
    keep = ~(((t > 30.0) & (t < 31.5)) | ((t > 60.0) & (t < 72.0)))
    t = t[keep]
    vx = np.clip(2.0 * t, 0.0, 1.0) * (12.0 + 4.0 * np.sin(2 * np.pi * t / 40.0))
    pitch = np.radians(4.0) * np.sin(2 * np.pi * t / 35.0)
    bank = np.radians(3.0) * np.sin(2 * np.pi * t / 23.0)
    r = 0.15 * np.sin(2 * np.pi * t / 9.0)
    ay = vx * r + G * np.sin(bank) + rng.normal(0.0, 0.1, len(t))
    ax = np.gradient(vx, t) - G * np.sin(pitch) + rng.normal(0.0, 0.05, len(t))
    q = np.gradient(pitch, t)
    p = np.gradient(bank, t) - r * np.tan(pitch) + math.radians(0.2)
    for x, at in ((ax, [40, 700]), (q, [900]), (p, [1300]), (vx, [1700])):
        x[at] = np.nan
    return Signals(t, vx, ay, r, np.full(len(t), np.nan), p=p, ax=ax, q=q)


def _export(est, tmp_path, rate: float, float32: bool = False) -> CModule:
    res = export_c(est, tmp_path / ("f32" if float32 else "f64"), rate=rate, float32=float32)
    return CModule(res.source, tmp_path / ("f32" if float32 else "f64"))


def _c_run(mod: CModule, s: Signals, use_dt: bool = False) -> tuple[np.ndarray, dict]:
    q = s.q if s.q is not None else np.full(len(s), np.nan)
    rate = mod.roll_rates(s.t, s.vx, s.ay, s.r, s.p, s.ax, q)
    return rate, mod.run(s.t, s.vx, s.ay, s.r, rate, use_dt=use_dt)


# the module takes the roll rate linear across a gap of the log, as log_gaps="trapezoid" does (its README says so;
# the drive has a 1.5 s gap)
GRADES = {"window": dict(grade_window=4.0, grade_first_span=2.0, log_gaps="trapezoid"),
          "observer": dict(grade_window=4.0, pitch_bandwidth=0.5, pitch_anchor=1.0, cutoff=0.05, bias_tau=40.0,
                           log_gaps="trapezoid"),
          "observer with a start and an offset state": dict(grade_window=4.0, pitch_bandwidth=0.5,
                                                            pitch_start=(3.0, 3.0), pitch_offset_tau=20.0,
                                                            log_gaps="trapezoid")}


@pytest.mark.parametrize("grade", list(GRADES))
def test_the_c_module_corrects_the_roll_rate_and_estimates_as_the_python_filter(grade, tmp_path):
    """The corrected roll rate of <prefix>_roll_rate equals GradeCarry.correct's (NaN where it is, the faults and
    gaps included) and the C step on it equals KinematicGyro.run to 1e-9 rad (valid flags identical), through both
    entry points."""
    s = _drive()
    est = KinematicGyro(**GRADES[grade])
    if grade == "window":
        s = dataclasses.replace(s, q=None)
    ref = est.run(s)
    est.grade.reset()
    py_rate = est.grade.correct(s).p
    mod = _export(est, tmp_path, 1.0 / est.fixed_dt)
    assert mod.has_grade
    rate, c = _c_run(mod, s)
    np.testing.assert_array_equal(np.isnan(rate), np.isnan(py_rate))
    assert np.nanmax(np.abs(rate - py_rate)) <= TOL64
    assert np.nanmax(np.abs(rate - s.p)) > 1e-3              # the correction acts
    np.testing.assert_array_equal(c["valid"], ref.valid)
    assert np.max(np.abs(c["theta"] - ref.theta)) <= TOL64 and np.max(np.abs(c["phi_b"] - ref.phi_b)) <= TOL64
    _, c_dt = _c_run(mod, s, use_dt=True)
    assert np.max(np.abs(c_dt["theta"][c_dt["valid"]] - ref.theta[ref.valid])) <= TOL64


def test_a_float32_module_stays_within_a_thousandth_of_a_degree(tmp_path):
    s = _drive()
    est = KinematicGyro(**GRADES["observer"])
    ref = est.run(s)
    _, c = _c_run(_export(est, tmp_path, 1.0 / est.fixed_dt, float32=True), s)
    ok = ref.valid & c["valid"]
    assert ok.mean() > 0.9
    assert np.degrees(np.max(np.abs(c["phi_b"][ok] - ref.phi_b[ok]))) < 1e-3


def test_samples_denser_than_the_module_rate_shorten_the_window_to_the_ring(tmp_path):
    """Exported for 10 Hz (a ring of 2 x 4 s x 10 Hz + 8 = 88 samples) and fed at 100 Hz: once the log has lasted the
    first span (2 s), the pitch is grade_pitch's over the 87 intervals the ring holds (0.87 s), as documented."""
    n = 1500
    t = np.arange(n) / 100.0
    vx = 10.0 + np.sin(t)
    ax = np.cos(t) - G * np.sin(np.radians(3.0) * np.sin(t / 3.0))
    r = np.full(n, 0.1)
    s = Signals(t, vx, vx * r, r, np.full(n, np.nan), p=np.zeros(n), ax=ax)
    est = KinematicGyro(grade_window=4.0, grade_first_span=2.0, sample_rate=None, log_gaps="trapezoid")
    mod = _export(est, tmp_path, 10.0)
    rate = mod.roll_rates(t, vx, s.ay, r, s.p, ax, np.full(n, np.nan))
    short = grade_pitch(t, vx, ax, 0.87 - 1e-9, est.params.g)     # the last sample 0.87 s back
    late = t >= 2.0
    np.testing.assert_allclose(rate[late], r[late] * np.tan(short[late]), rtol=0, atol=1e-12)


def test_the_python_side_starts_are_refused_with_the_reason(tmp_path):
    with pytest.raises(NotExportable, match="start_hold or start_span"):
        export_c(KinematicGyro(start_span=3.0), tmp_path, rate=100.0)


_LEARNING_HARNESS = """
#include "{p}.h"
#include <stdlib.h>
int h_run(long n, const double *t, const double *vx, const double *ay, const double *r, const double *d,
          const double *p, const double *ax, const double *q, double *out);
int h_run(long n, const double *t, const double *vx, const double *ay, const double *r, const double *d,
          const double *p, const double *ax, const double *q, double *out)
{{
    {p}_state s;
    {p}_offsets o;
    {p}_output e;
    {p}_offsets_output c;
    {p}_grade *g = malloc(sizeof *g);
    long k;
    if (g == NULL) {{
        return 0;
    }}
    {p}_init(&s);
    {p}_offsets_init(&o);
    {p}_grade_init(g);
    for (k = 0; k < n; ++k) {{
        int ok = {p}_step_learning(&s, &o, g, t[k], vx[k], ay[k], r[k], d[k], p[k], ax[k], q[k], &e, &c);
        out[4 * k] = e.theta;
        out[4 * k + 1] = e.phi_b;
        out[4 * k + 2] = (double)ok;
        out[4 * k + 3] = c.r_offset;
    }}
    free(g);
    return 1;
}}
"""


@pytest.mark.parametrize("filed", [False, True])
def test_with_the_online_offset_learner_the_module_steps_as_with_online_offsets(tmp_path, filed):
    """A drive that starts with 4 s at standstill, its yaw rate off by 0.5 deg/s: <prefix>_step_learning (the
    learner, the grade correction on the corrected yaw rate, the filter) equals
    with_online_offsets(KinematicGyro(...)).step() to 1e-9 rad, and the learnt offset is the drawn one. With a vehicle
    file's offsets (``filed``) the module takes the measured channels and removes them first, as estimate does."""
    import ctypes

    from roadbank.estimators import with_online_offsets
    from roadbank.export.build import compile_c
    s = _drive(duration=60.0)
    stand = s.t < 4.0
    vx = np.where(stand, 0.0, s.vx)
    bias = math.radians(0.5)
    s = dataclasses.replace(s, vx=vx, r=np.where(stand, 0.0, s.r) + bias, delta_f=np.zeros(len(s)))
    est = with_online_offsets(KinematicGyro(**GRADES["observer"]))
    off = {"r": 0.003, "ay": 0.05, "delta_f": 0.0} if filed else {}
    seen = dataclasses.replace(s, ay=s.ay - off.get("ay", 0.0), r=s.r - off.get("r", 0.0))
    py = [est.step(*(float(getattr(seen, c)[k]) for c in ("t", "vx", "ay", "r", "delta_f")),
                   p=float(s.p[k]), ax=float(s.ax[k]), q=float(s.q[k])) for k in range(len(s))]
    res = export_c(est, tmp_path, rate=1.0 / est.inner.fixed_dt, offsets=off)    # the rate step() took from the log
    p = res.source.stem
    harness = tmp_path / "h.c"
    harness.write_text(_LEARNING_HARNESS.format(p=p))
    lib = ctypes.CDLL(str(compile_c([res.source, harness], tmp_path / "libh.so", shared=True, flags=("-O2",),
                                    include=[tmp_path])))
    cols = [np.ascontiguousarray(getattr(s, c), dtype=float) for c in ("t", "vx", "ay", "r", "delta_f", "p", "ax",
                                                                         "q")]
    out = np.zeros((len(s), 4))
    ptr = ctypes.POINTER(ctypes.c_double)
    assert lib.h_run(ctypes.c_long(len(s)), *(c.ctypes.data_as(ptr) for c in cols), out.ctypes.data_as(ptr))
    np.testing.assert_array_equal(out[:, 2], [o.valid for o in py])
    np.testing.assert_allclose(out[:, 0], [o.theta for o in py], rtol=0, atol=TOL64)
    assert est.offsets["r_learnt"] and est.offsets["r"] == pytest.approx(bias - off.get("r", 0.0),
                                                                         abs=math.radians(0.02))
    assert out[-1, 3] == pytest.approx(est.offsets["r"], abs=1e-12)


@needs_kitti
def test_the_default_of_a_kitti_drive_exports_with_the_pitch_observer_and_runs_as_in_python(tmp_path):
    """roadbank's default for 0070 (the gyro filter with the INS's constants, the observer's pitch and its anchored
    start), exported at the rate it runs at: the C module gives the Python estimate to 1e-9 rad."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.vehicle import for_log
    s = load_kitti_oxts(KITTI).signals
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        est = for_log("kinematic-pif", s)
    ref = est.run(s)
    assert isinstance(est, KinematicGyro) and est.grade.pitch is not None
    _, c = _c_run(_export(est, tmp_path, 1.0 / est.fixed_dt), s)
    np.testing.assert_array_equal(c["valid"], ref.valid)
    assert np.max(np.abs(c["theta"] - ref.theta)) <= TOL64


@needs_kitti
def test_export_c_with_roll_rate_designs_the_gyro_module_for_the_log(tmp_path):
    runner = CliRunner()
    res = runner.invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(KITTI), "--roll-rate",
                               "-o", str(tmp_path / "g")])
    assert res.exit_code == 0, res.output
    assert "reads the roll rate, corrected for the grade by ax and the pitch rate" in res.output
    header = (tmp_path / "g" / "roadbank_kinematic_pif.h").read_text()
    assert "roadbank_kinematic_pif_roll_rate(" in header
    # the module of the estimator roadbank estimate builds for the log (for_log), at the log's rate
    from roadbank.io import load_log
    from roadbank.vehicle import for_log, log_conditions
    s = load_log(KITTI).signals
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        est = for_log("kinematic-pif", s)
    assert (tmp_path / "g" / "roadbank_kinematic_pif.c").read_text() == \
        export_c(est, tmp_path / "py", rate=log_conditions(s)["log_rate"]).source.read_text()
    # a log without a roll rate: the ESP module, and a warning that says so
    import pyarrow as pa
    import pyarrow.parquet as pq
    pq.write_table(pa.table({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r}), tmp_path / "esp.parquet")
    plain = runner.invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(tmp_path / "esp.parquet"),
                                 "--roll-rate", "-o", str(tmp_path / "p")])
    assert plain.exit_code == 0 and "the log's roll rate is not used" in plain.output
    assert "_roll_rate(" not in (tmp_path / "p" / "roadbank_kinematic_pif.h").read_text()
    esp = runner.invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(KITTI), "-o", str(tmp_path / "e")])
    assert esp.exit_code == 0 and "roll rate" not in esp.output
    assert "_roll_rate(" not in (tmp_path / "e" / "roadbank_kinematic_pif.h").read_text()
    both = runner.invoke(main, ["export", "c", "-e", "kinematic-pif", "--log", str(KITTI), "--roll-rate",
                                "--online-offsets", "-o", str(tmp_path / "o")])
    assert both.exit_code == 0, both.output
    header = (tmp_path / "o" / "roadbank_kinematic_pif.h").read_text()
    assert "roadbank_kinematic_pif_grade *g, double t" in header      # _step_learning takes the grade state
    # every name estimate takes means the same filter here (kinematic-gyro, pif-paper had been "unknown")
    gyro = runner.invoke(main, ["export", "c", "-e", "kinematic-gyro", "--log", str(KITTI), "--roll-rate",
                                "-o", str(tmp_path / "k")])
    assert gyro.exit_code == 0, gyro.output
    assert "_roll_rate(" in (tmp_path / "k" / "roadbank_kinematic_gyro.h").read_text()
    paper = runner.invoke(main, ["export", "c", "-e", "pif-paper", "-o", str(tmp_path / "pp")])
    assert paper.exit_code == 0, paper.output
    model = runner.invoke(main, ["export", "c", "-e", "pif-modified", "--log", str(KITTI), "--roll-rate",
                                 "-o", str(tmp_path / "pm")])
    assert model.exit_code == 0 and "pif-modified reads none" in model.output, model.output
    alone = runner.invoke(main, ["export", "c", "-e", "kinematic-pif", "--roll-rate", "-o", str(tmp_path / "n")])
    assert alone.exit_code == 2 and "--roll-rate describes --log" in alone.output


_SANITIZED_MAIN = """
#include <math.h>
#include <stdio.h>
#include "{p}.h"
int main(void) {{
    static {p}_grade g;
    {p}_state s;
    {p}_output o;
    long k;
    double acc = 0.0;
    {p}_grade_init(&g);
    {p}_init(&s);
    for (k = 0; k < 20000; ++k) {{
        double t = (double)k * 0.003 + (k % 7 == 0 ? 0.001 : 0.0);
        double vx = (k % 997 == 0) ? (double)NAN : 10.0 + sin(t);
        double ax = (k % 1301 == 0) ? (double)INFINITY : cos(t);
        double q = (k % 501 == 0) ? (double)NAN : 0.01 * sin(t);
        double pe;
        if (k == 9000) {{
            t -= 1.0;
        }}
        if (k > 12000) {{
            t += 30.0;
        }}
        pe = {p}_roll_rate(&g, t, vx, 0.3, 0.05, 0.001, ax, q);
        {p}_step(&s, t, vx, 0.3, 0.05, pe, &o);
        acc += o.theta;
    }}
    printf("%g\\n", acc);
    return isfinite(acc) ? 0 : 1;
}}
"""


@pytest.mark.slow
@pytest.mark.parametrize("grade", ["window", "observer"])
def test_the_grade_correction_runs_clean_under_the_sanitizers(grade, tmp_path):
    """The module and a driver built with AddressSanitizer and UndefinedBehaviorSanitizer (no recovery), fed 20000
    samples at 333 Hz into a module made for 50 Hz (the ring full, the oldest dropped), with NaN and inf samples, a
    backward time stamp and a 30 s gap: it exits cleanly with a finite sum."""
    import subprocess

    from roadbank.export.build import SANITIZE_FLAGS, compile_c
    est = KinematicGyro(**GRADES[grade])
    res = export_c(est, tmp_path, rate=50.0)
    main_c = tmp_path / "main.c"
    main_c.write_text(_SANITIZED_MAIN.format(p=res.source.stem))
    exe = compile_c([res.source, main_c], tmp_path / "main", flags=SANITIZE_FLAGS + ("-lm",), include=[tmp_path])
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stderr == "", run.stderr
