r"""C99 source of the roll rate's grade correction, added to an exported gyro-aided module.

The gyro-aided filter (:class:`roadbank.estimators.gyro.KinematicGyro`) reads the rate of the roll angle,
:math:`p + r \tan\vartheta` (:func:`roadbank.models.attitude.euler_roll_rate`), the pitch :math:`\vartheta` (rad,
positive nose down) read from the speed and the longitudinal accelerometer over a window
(:func:`roadbank.models.attitude.grade_pitch`) or, with a pitch rate, from the pitch observer
(:mod:`roadbank.estimators.kernels.attitude`). :class:`~roadbank.estimators.gyro.GradeCarry` does that in Python
before the filter's kernel; the exported module does it in ``<prefix>_roll_rate`` (one sample: the corrected roll
rate), with a caller-owned ``<prefix>_grade`` state, before ``<prefix>_step``. The window's samples are kept in a
ring of fixed size (twice the window at the module's rate, and 8 more): samples denser than that shorten the window
(the oldest is dropped), which roadbank's Python never does. Times are ``double``, the running integral of ``ax``
too; everything else is the module's ``real`` type.
"""

from __future__ import annotations

import math
from string import Template

import numpy as np

from ..estimators.kernels import attitude as K
from .ccode import _fix_literals, add_part, real_literal

_WINDOW_HEADER = Template("""
/* ---- the roll rate corrected for the road's grade (roadbank.estimators.gyro.GradeCarry) --------
 * This module's first input p is the rate of the roll angle, p + r tan(pitch) (rad/s), the pitch
 * (rad, positive nose down) from the speed and the longitudinal accelerometer over the last
 * ${window} s (from the first sample once the log has lasted ${first} s): asin((vx - vx_w -
 * int ax) / (g dt)). After more than ${max_gap} s between samples (where the filter starts again)
 * the window starts again as at a log's start: it never reaches back across such a gap.
 * ${p}_roll_rate() gives it: call it on every sample, in time order, and give
 * its result to ${p}_step (or _step_dt) as p. Where no pitch is read (the log has not lasted
 * long enough, a non-finite vx or ax lies in the window, or a pitch steeper than asin(${maxsin}))
 * it returns p as measured. q is not read by this module. */
#define ${P}_GRADE_WINDOW_S ${window_lit}
#define ${P}_GRADE_CAP ${cap}   /* samples the window keeps: denser sampling shortens it */
typedef struct {
    int n_seen;                     /* samples taken (0: none yet) */
    int head;                       /* ring index of the oldest sample kept */
    int count;                      /* samples kept */
    unsigned char bad_last;         /* the last sample's vx or ax was not finite */
    double t0;                      /* s, the first sample's time */
    double t_last;                  /* s, the last sample's time */
    double area;                    /* m/s, running integral of ax (trapezoids; non-finite read as 0) */
    long nbad;                      /* running count of intervals touching a non-finite vx or ax */
    ${real} a_last;                 /* m/s^2, the last sample's ax (0 where not finite) */
    double rt[${P}_GRADE_CAP];      /* kept samples: time (s), */
    double ra[${P}_GRADE_CAP];      /* running integral (m/s), */
    long rn[${P}_GRADE_CAP];        /* running count, */
    ${real} rv[${P}_GRADE_CAP];     /* speed (m/s), */
    unsigned char rb[${P}_GRADE_CAP];  /* vx or ax not finite */
} ${p}_grade;
""")

_OBSERVER_HEADER = Template("""
/* ---- the roll rate corrected for the road's grade (roadbank.estimators.gyro.GradeCarry) --------
 * This module's first input p is the rate of the roll angle, p + r tan(pitch) (rad/s), the pitch
 * (rad, positive nose down) from an observer of speed and pitch driven by the pitch rate q (rad/s,
 * positive nose down) and corrected by the speed the longitudinal accelerometer predicts
 * (roadbank.estimators.pitch: bandwidth ${w} rad/s${start}${anchor}${offset}).${restart}
 * ${p}_roll_rate() gives it: call it on every sample, in time order, and give its result to
 * ${p}_step (or _step_dt) as p. Where no pitch is read (a non-finite vx, ax, q, ay or r, or a
 * pitch steeper than asin(${maxsin})) it returns p as measured. */
#define ${P}_GRADE_OBSERVER 1
typedef struct {
    double mem[${nmem}];            /* the observer's state, as roadbank's attitude kernel holds it */
} ${p}_grade;
""")

_DECLS = Template("""
/* Initialise or reset a grade state: the next sample starts a log. */
void ${p}_grade_init(${p}_grade *g);

/* One sample at time t (s): vx (m/s), ay (m/s^2), r (rad/s), the measured roll rate p (rad/s), ax
 * (m/s^2, positive forward) and the pitch rate q (rad/s); returns the roll rate to give ${p}_step. A
 * sample whose t is not finite or not later than the last one's changes nothing and returns p. */
${real} ${p}_roll_rate(${p}_grade *g, double t, ${real} vx, ${real} ay, ${real} r, ${real} p, ${real} ax,
    ${real} q);
""")

_LEAN = """
/* p + r tan(pitch); p where that is not finite (roadbank.models.attitude.euler_roll_rate) */
static real_t rbg_lean(real_t p, real_t r, real_t pitch)
{
    real_t lean = r * RBG_TAN(pitch);
    return isfinite(lean) ? p + lean : p;
}
"""

_WINDOW_SOURCE = Template("""
/* ---- the grade correction over a window: roadbank.models.attitude.grade_pitch, streamed ------- */
#define RBG_TAN ${tan}
#define RBG_WINDOW (${window})
#define RBG_FIRST (${first})
#define RBG_MAX_GAP (${max_gap})
#define RBG_G (${g})
#define RBG_MAXSIN (${maxsin})

typedef ${p}_grade grade_t;
${lean}
void ${p}_grade_init(grade_t *g)
{
    g->n_seen = 0;
    g->head = 0;
    g->count = 0;
    g->bad_last = 0;
    g->t0 = 0.0;
    g->t_last = 0.0;
    g->area = 0.0;
    g->nbad = 0;
    g->a_last = 0.0_R;
}

/* The vehicle file's identified offsets (RB_OFF_*) are taken off the measured ay and r first; the learner's path
 * (already corrected) calls rbg_roll_rate. */
static real_t rbg_roll_rate(grade_t *g, double t, real_t vx, real_t ay, real_t r, real_t p, real_t ax, real_t q);

real_t ${p}_roll_rate(grade_t *g, double t, real_t vx, real_t ay, real_t r, real_t p, real_t ax, real_t q)
{
    return rbg_roll_rate(g, t, vx, ay - RB_OFF_AY, r - RB_OFF_R, p, ax, q);
}

static real_t rbg_roll_rate(grade_t *g, double t, real_t vx, real_t ay, real_t r, real_t p, real_t ax, real_t q)
{
    unsigned char bad;
    real_t a;
    int k;
    int m;
    int ok;
    double s;
    (void)ay;
    (void)q;
    if (!isfinite(t) || (g->n_seen > 0 && !(t > g->t_last))) {
        return p;
    }
    bad = (unsigned char)!(isfinite(vx) && isfinite(ax));
    a = bad ? 0.0_R : ax;
    if (g->n_seen == 0) {
        g->t0 = t;
        g->area = 0.0;
        g->nbad = 0;
    } else {
        g->area += 0.5 * ((double)a + (double)g->a_last) * (t - g->t_last);
        g->nbad += (bad || g->bad_last) ? 1 : 0;
        if (t - g->t_last > RBG_MAX_GAP) {     /* the filter's restart gap: the window starts again */
            g->head = 0;
            g->count = 0;
            g->t0 = t;
        }
    }
    g->n_seen = 1;
    g->t_last = t;
    g->a_last = a;
    g->bad_last = bad;
    if (g->count == ${P}_GRADE_CAP) {          /* full: the oldest goes (a shorter window) */
        g->head = (g->head + 1) % ${P}_GRADE_CAP;
        g->count -= 1;
    }
    k = (g->head + g->count) % ${P}_GRADE_CAP;
    g->rt[k] = t;
    g->ra[k] = g->area;
    g->rn[k] = g->nbad;
    g->rv[k] = vx;
    g->rb[k] = bad;
    g->count += 1;
    /* the oldest kept: the last sample at least the window back (while a later one also is, drop it) */
    while (g->count >= 2 && g->rt[(g->head + 1) % ${P}_GRADE_CAP] <= t - RBG_WINDOW) {
        g->head = (g->head + 1) % ${P}_GRADE_CAP;
        g->count -= 1;
    }
    m = g->head;
    ok = g->rt[m] <= t - RBG_WINDOW || t - g->t0 >= RBG_FIRST;
    s = ((double)vx - (double)g->rv[m] - (g->area - g->ra[m])) / (RBG_G * (t - g->rt[m]));
    ok = ok && g->nbad - g->rn[m] == 0 && !bad && !g->rb[m] && fabs(s) <= RBG_MAXSIN;
    if (!ok) {
        return p;
    }
    return rbg_lean(p, r, (real_t)asin(s));
}
""")

_OBSERVER_SOURCE = Template("""
/* ---- the grade correction by the pitch observer: roadbank.estimators.kernels.attitude --------- */
#define RBG_TAN ${tan}
#define RBG_W (${w})
#define RBG_ZETA (${zeta})
#define RBG_G (${g})
#define RBG_WSTART (${wstart})
#define RBG_TSTART (${tstart})
#define RBG_GAP (${gap})
#define RBG_TQ (${tq})
#define RBG_ANCHOR (${anchor})
#define RBG_PRIOR (${prior})
#define RBG_RESTART (${restart})
#define RBG_MAXSIN (${maxsin})
enum { RBG_V, RBG_PITCH, RBG_B, RBG_TLAST, RBG_TFIRST, RBG_INIT, RBG_ANCHORED, RBG_AXLAST, RBG_RLAST, RBG_A,
       RBG_Q, RBG_S, RBG_N, RBG_ST, RBG_STT, RBG_SY, RBG_STY, RBG_NMEM };

typedef ${p}_grade grade_t;
${lean}
void ${p}_grade_init(grade_t *g)
{
    int k;
    for (k = 0; k < RBG_NMEM; ++k) {
        g->mem[k] = 0.0;
    }
}

/* the anchored start's sample (the attitude kernel's anchor_step); returns the pitch */
static double rbg_anchor(double *mem, double ti, double v, double a, double q, double h)
{
    double q_new;
    double tau;
    double y;
    double n;
    double sxx;
    double sxy;
    double s0;
    double v0;
    double s0c;
    mem[RBG_A] += 0.5 * h * (a + mem[RBG_AXLAST]);
    q_new = mem[RBG_Q] + 0.5 * h * (q + mem[RBG_RLAST]);
    mem[RBG_S] += 0.5 * h * (mem[RBG_Q] + q_new);
    mem[RBG_Q] = q_new;
    mem[RBG_AXLAST] = a;
    mem[RBG_RLAST] = q;
    mem[RBG_TLAST] = ti;
    tau = ti - mem[RBG_TFIRST];
    y = v - mem[RBG_A] - RBG_G * mem[RBG_S];
    mem[RBG_N] += 1.0;
    mem[RBG_ST] += tau;
    mem[RBG_STT] += tau * tau;
    mem[RBG_SY] += y;
    mem[RBG_STY] += tau * y;
    n = mem[RBG_N];
    sxx = RBG_G * RBG_G * (mem[RBG_STT] - mem[RBG_ST] * mem[RBG_ST] / n);
    sxy = RBG_G * (mem[RBG_STY] - mem[RBG_ST] * mem[RBG_SY] / n);
    s0 = sxy / (sxx + RBG_PRIOR);
    v0 = (mem[RBG_SY] - RBG_G * s0 * mem[RBG_ST]) / n;
    s0c = s0 > -1.0 ? s0 : -1.0;
    s0c = s0c < 1.0 ? s0c : 1.0;
    mem[RBG_PITCH] = asin(s0c) + q_new;
    mem[RBG_V] = v0 + mem[RBG_A] + RBG_G * (s0 * tau + mem[RBG_S]);
    return mem[RBG_PITCH];
}

/* one sample of the observer (the attitude kernel's pitch_run); returns the pitch (NaN: skipped) */
static double rbg_pitch(double *mem, double ti, double v, double a, double q)
{
    double h;
    double w;
    double inv_t;
    double zw;
    double k1;
    double k2;
    double k3;
    double th0;
    double v0;
    double b0;
    double s;
    double c;
    double k2h;
    double rhs_v;
    double rhs_t;
    double vn;
    if (!(isfinite(ti) && isfinite(v) && isfinite(a) && isfinite(q))) {
        return NAN;
    }
    if (mem[RBG_INIT] == 0.0 || ti - mem[RBG_TLAST] > RBG_RESTART) {   /* a (re)start */
        mem[RBG_V] = v;
        mem[RBG_PITCH] = 0.0;
        mem[RBG_B] = 0.0;
        mem[RBG_TLAST] = ti;
        mem[RBG_TFIRST] = ti;
        mem[RBG_INIT] = 1.0;
        mem[RBG_ANCHORED] = RBG_ANCHOR > 0.0 ? 1.0 : 0.0;
        mem[RBG_AXLAST] = a;
        mem[RBG_RLAST] = q;
        mem[RBG_A] = 0.0;
        mem[RBG_Q] = 0.0;
        mem[RBG_S] = 0.0;
        mem[RBG_N] = 1.0;
        mem[RBG_ST] = 0.0;
        mem[RBG_STT] = 0.0;
        mem[RBG_SY] = v;
        mem[RBG_STY] = 0.0;
        return 0.0;
    }
    h = ti - mem[RBG_TLAST];
    if (!(h > 0.0)) {
        return mem[RBG_PITCH];
    }
    if (mem[RBG_ANCHORED] > 0.0 && h <= RBG_GAP && ti - mem[RBG_TFIRST] <= RBG_ANCHOR) {
        return rbg_anchor(mem, ti, v, a, q, h);
    }
    mem[RBG_ANCHORED] = 0.0;
    if (h > RBG_GAP) {
        mem[RBG_V] = v;
        mem[RBG_TLAST] = ti;
        return mem[RBG_PITCH];
    }
    w = ti - mem[RBG_TFIRST] <= RBG_TSTART ? RBG_WSTART : RBG_W;
    inv_t = RBG_TQ > 0.0 ? 1.0 / RBG_TQ : 0.0;
    zw = 2.0 * RBG_ZETA * w;
    k1 = zw + inv_t;
    k2 = (w * w + zw * inv_t) / RBG_G;
    k3 = w * w * inv_t / RBG_G;
    th0 = mem[RBG_PITCH];
    v0 = mem[RBG_V];
    b0 = mem[RBG_B];
    s = sin(th0);
    c = cos(th0);
    k2h = k2 + h * k3;
    rhs_v = v0 + h * (a + RBG_G * (s - c * th0) + k1 * v);
    rhs_t = th0 + h * (q - b0 + k2h * v);
    vn = (rhs_v + h * RBG_G * c * rhs_t) / (1.0 + h * k1 + h * h * RBG_G * c * k2h);
    mem[RBG_V] = vn;
    mem[RBG_PITCH] = rhs_t - h * k2h * vn;
    mem[RBG_B] = b0 - h * k3 * (v - vn);
    mem[RBG_TLAST] = ti;
    return mem[RBG_PITCH];
}

/* The vehicle file's identified offsets (RB_OFF_*) are taken off the measured ay and r first; the learner's path
 * (already corrected) calls rbg_roll_rate. */
static real_t rbg_roll_rate(grade_t *g, double t, real_t vx, real_t ay, real_t r, real_t p, real_t ax, real_t q);

real_t ${p}_roll_rate(grade_t *g, double t, real_t vx, real_t ay, real_t r, real_t p, real_t ax, real_t q)
{
    return rbg_roll_rate(g, t, vx, ay - RB_OFF_AY, r - RB_OFF_R, p, ax, q);
}

static real_t rbg_roll_rate(grade_t *g, double t, real_t vx, real_t ay, real_t r, real_t p, real_t ax, real_t q)
{
    double k;
    double rate;
    double pitch;
    k = ((double)ay - (double)vx * (double)r) / RBG_G;      /* the kinematic roll, clipped (NaN kept) */
    if (k < -1.0) {
        k = -1.0;
    } else if (k > 1.0) {
        k = 1.0;
    }
    k = asin(k);
    rate = (double)q * cos(k) - (double)r * sin(k);          /* the rate of the Euler pitch */
    pitch = rbg_pitch(g->mem, t, (double)vx, (double)ax, rate);
    if (!(fabs(sin(pitch)) <= RBG_MAXSIN)) {
        return p;
    }
    return rbg_lean(p, r, (real_t)pitch);
}
""")

README = """
## The roll rate corrected for the grade

This module is the gyro-aided filter: its first input is a roll rate (rad/s), not a steering angle. On a
graded road the roll angle's rate is `p + r tan(pitch)`; `{p}_roll_rate(&grade, t, vx, ay, r, p, ax, q)`
(state `{p}_grade`, `{p}_grade_init`) reads the pitch {how} and returns that rate: call it on every
sample, in time order, then `{p}_step(&state, t, vx, ay, r, rate, &out)`. The same operations as roadbank's
`GradeCarry` before the filter's kernel (`KinematicGyro.run`/`step`). After an interval longer than the filter's
`max_gap` between samples, where the filter starts again, the grade's pitch starts again too, as at a log's start
(no window reaches back across the gap; the pitch observer begins anew, its start included). Across an interval of
1-10 s between samples (a logger's dropout in a replayed log; an ECU's task has none) the module takes the roll
rate linear between the samples either side, as roadbank's `log_gaps="trapezoid"`; roadbank's filter holds its state
across such a gap by default (`roadbank.estimators.gyro.gap_time`): to replay such a log as it does, give both calls
the time stamps `gap_time(t, (nan, 0, nan), 1.0, 10.0, "hold")` returns.
"""


def _cap(grade: dict, rate: float) -> int:
    """Samples the window's ring keeps: twice the window at ``rate`` (Hz), and 8 more."""
    return int(math.ceil(2.0 * grade["window"] * rate)) + 8


def grade_parts(prefix: str, grade: dict, rate: float, float32: bool) -> tuple[str, str, str]:
    """``(header, source, readme)`` text of the grade correction ``grade`` (an
    :attr:`~roadbank.export.design.ExportDesign.grade`) of the module ``prefix`` at ``rate`` (Hz)."""
    names = dict(p=prefix, P=prefix.upper(), real=f"{prefix}_real")
    lit = lambda x: real_literal(x, False)  # noqa: E731  (double constants: times and the pitch in double)
    maxsin = float(grade["max_sin"])
    tan = "tanf" if float32 else "tan"
    obs = grade["observer"]
    if obs is None:
        first = grade["first_span"]
        cap = _cap(grade, rate)
        gap = float(grade.get("max_gap", math.inf))
        head = _WINDOW_HEADER.substitute(names, window=f"{grade['window']:g}", first=f"{first:g}",
                                         maxsin=f"{maxsin:g}", window_lit=lit(grade["window"]),
                                         cap=cap, max_gap=f"{gap:g}")
        src = _WINDOW_SOURCE.substitute(names, tan=tan, lean=_LEAN, window=lit(grade["window"]),
                                        first=lit(first if math.isfinite(first) else 1e300), g=lit(grade["g"]),
                                        maxsin=lit(maxsin), max_gap=lit(gap if math.isfinite(gap) else 1e300))
        nbytes = 48 + cap * (8 + 8 + 8 + (4 if float32 else 8) + 1)
        how = (f"from the speed and `ax` over the last {grade['window']:g} s (the state keeps {cap} samples, about "
               f"{nbytes / 1024:.1f} KiB of RAM)")
    else:
        cfg = np.asarray(obs, dtype=np.float64)
        w, ws, ts, tq, anchor = (float(cfg[i]) for i in (K.C_W, K.C_WSTART, K.C_TSTART, K.C_TQ, K.C_ANCHOR))
        restart = float(cfg[K.C_RESTART]) if len(cfg) > K.C_RESTART else math.inf
        head = _OBSERVER_HEADER.substitute(
            names, w=f"{w:g}", maxsin=f"{maxsin:g}", nmem=K.N_MEM,
            restart=(f"\n * After more than {restart:g} s between the samples it reads (where the filter starts again)"
                     "\n * the observer starts again as at a log's first sample, its start included."
                     if math.isfinite(restart) else ""),
            start=f", {ws:g} rad/s for the first {ts:g} s" if ts > 0 and ws != w else "",
            anchor=f", the first pitch fitted over the first {anchor:g} s" if anchor > 0 else "",
            offset=f", the pitch rate's offset learnt in {tq:g} s" if tq > 0 else "")
        src = _OBSERVER_SOURCE.substitute(
            names, tan=tan, lean=_LEAN, w=lit(w), zeta=lit(cfg[K.C_ZETA]), g=lit(cfg[K.C_G]), wstart=lit(ws),
            tstart=lit(ts), gap=lit(cfg[K.C_GAP]), tq=lit(tq), anchor=lit(anchor), prior=lit(cfg[K.C_PRIOR]),
            restart=lit(restart if math.isfinite(restart) else 1e300), maxsin=lit(maxsin))
        how = "from the pitch observer (pitch rate `q`, `ax` and the speed)"
    decls = _DECLS.substitute(names)
    return head + decls, src, README.format(p=prefix, how=how)


def add_grade(files: dict[str, str], prefix: str, grade: dict, rate: float, float32: bool) -> dict[str, str]:
    """The generated module ``files`` (:func:`roadbank.export.ccode.generate`) with the grade correction added to its
    header (before the closing guard), source (at the end) and README."""
    head, src, readme = grade_parts(prefix, grade, rate, float32)
    return add_part(files, prefix, _fix_literals(head, float32), _fix_literals(src, float32), readme,
                    "the grade correction")
