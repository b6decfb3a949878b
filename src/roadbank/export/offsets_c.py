"""C99 source of the online sensor-offset learner, added to an exported module.

The operations of :func:`roadbank.estimators.kernels.offsets.offsets_step`, in the same
order, with the learner's settings as constants: a caller-owned ``<prefix>_offsets``
state, ``<prefix>_offsets_init``, ``<prefix>_offsets_step`` (one sample: learn, then
return the corrected channels, the offsets and their flags) and ``<prefix>_step_learning``
(the learner, then ``<prefix>_step`` on the corrected sample: what
:meth:`roadbank.estimators.offsets.OnlineOffsets.step` computes). Times and time stamps are
``double``; everything else is the module's ``real`` type.
"""

from __future__ import annotations

from string import Template

import numpy as np

from ..estimators.kernels import offsets as K
from .ccode import _fix_literals, add_part, real_literal

_HEADER = Template("""
/* ---- online sensor offsets (roadbank.estimators.offsets) --------------------------------
 * Yaw-rate offset learnt at standstill (|vx| < ${vstop} m/s for > ${tstop} s; the last
 * ${trail}-${trail2} s of each stop not used), else (where straight-driving evidence is on: a
 * straight's largest |ay| above 0) from straight driving against the steering angle's kinematic
 * yaw rate; the steering offset from straight driving once the yaw-rate offset has a
 * standstill; the ay offset is not learnt (given: ${ayoff} m/s^2). */
typedef struct {
    int initialised;      /* 0 until the first sample with a usable time */
    int filtered;         /* 1 once the straight-driving low-passes have started */
    int steer_moved;      /* 1 once the steering angle has changed (one that never does tells nothing) */
    double t_last;        /* s, last usable time stamp */
    double a_t;           /* s, time of the stop's newest snapshot */
    ${real} b_r;          /* rad/s, yaw-rate offset */
    ${real} b_d;          /* rad, steering (road-wheel) offset */
    ${real} e_stop;       /* s, committed standstill evidence */
    ${real} e_str_r;      /* s, straight-driving evidence of the yaw-rate offset */
    ${real} e_str_d;      /* s, straight-driving evidence of the steering offset */
    ${real} t_stop;       /* s, time the car has stood */
    ${real} t_str;        /* s, time the straight conditions have held */
    ${real} rf, df, af;   /* low-passed r (rad/s), delta_f (rad), ay (m/s^2) */
    ${real} s_sum, s_e;   /* the stop: sum of r dt (rad), its evidence (s) */
    ${real} a_sum, a_e;   /* newest snapshot of those */
    ${real} b_sum, b_e;   /* the snapshot at least the trail old */
    ${real} b_r0;         /* rad/s, offset committed before the stop */
} ${p}_offsets;

/* One sample of the learner: the corrected channels, the offsets and their flags. */
typedef struct {
    ${real} r;            /* rad/s, r - b_r */
    ${real} ay;           /* m/s^2, ay - the given ay offset */
    ${real} delta_f;      /* rad, delta_f - b_d */
    ${real} r_offset;     /* rad/s */
    ${real} delta_offset; /* rad */
    int r_learnt;         /* 1 once the yaw-rate offset has enough evidence */
    int delta_learnt;     /* 1 once the steering offset has enough evidence */
} ${p}_offsets_output;

/* Initialise or reset a learner: no offset learnt, no history. */
void ${p}_offsets_init(${p}_offsets *o);

/* Learn from one sample at time t (s) and write the corrected channels into *out (not NULL). */
void ${p}_offsets_step(${p}_offsets *o, double t, ${real} vx, ${real} ay, ${real} r, ${real} delta_f,
    ${p}_offsets_output *out);
${learning}""")

_LEARNING_DECL = """
/* ${what} *oo may be NULL. Returns valid. */
int ${p}_step_learning(${p}_state *s, ${p}_offsets *o, ${grade}double t, ${real} vx, ${real} ay, ${real} r,
    ${real} delta_f${more}, ${p}_output *out, ${p}_offsets_output *oo);
"""

_SOURCE = Template("""
/* ---- online sensor offsets: the operations of roadbank.estimators.kernels.offsets --------- */
#define RBO_VSTOP (${VSTOP})
#define RBO_TSTOP (${TSTOP})
#define RBO_TAUSTOP (${TAUSTOP})
#define RBO_NSTOP (${NSTOP})
#define RBO_RSTOP (${RSTOP})
#define RBO_TRAIL (${TRAIL})
#define RBO_VSTR (${VSTR})
#define RBO_AYSTR (${AYSTR})
#define RBO_DSTR (${DSTR})
#define RBO_RSTR (${RSTR})
#define RBO_RDOT (${RDOT})
#define RBO_DDOT (${DDOT})
#define RBO_TSTR (${TSTR})
#define RBO_TAUSTR (${TAUSTR})
#define RBO_NSTR (${NSTR})
#define RBO_L (${L})
#define RBO_KUS (${KUS})
#define RBO_TAUF (${TAUF})
#define RBO_RMAX (${RMAX})
#define RBO_DMAX (${DMAX})
#define RBO_AYOFF (${AYOFF})
#define RBO_GAP (${GAP})

typedef ${p}_offsets offsets_t;
typedef ${p}_offsets_output offsets_output_t;

static real_t rbo_clamp(real_t x, real_t lim)
{
    if (x > lim) {
        return lim;
    }
    if (x < -lim) {
        return -lim;
    }
    return x;
}

static real_t rbo_min(real_t a, real_t b)
{
    return b < a ? b : a;
}

static real_t rbo_combine(real_t b0, real_t e0, real_t ssum, real_t se)
{
    real_t w0 = rbo_min(e0, RBO_TAUSTOP);
    if (w0 + se <= 0.0_R) {
        return b0;
    }
    return rbo_clamp((w0 * b0 + ssum) / (w0 + se), RBO_RMAX);
}

/* The current stop's time and evidence sums, cleared (at its end, and at the start). */
static void rbo_clear_stop(offsets_t *o)
{
    o->t_stop = 0.0_R;
    o->s_sum = 0.0_R;
    o->s_e = 0.0_R;
    o->a_sum = 0.0_R;
    o->a_e = 0.0_R;
    o->b_sum = 0.0_R;
    o->b_e = 0.0_R;
}

static void rbo_end_stop(offsets_t *o)
{
    if (o->s_e > 0.0_R) {
        o->b_r = rbo_combine(o->b_r0, o->e_stop, o->b_sum, o->b_e);
        o->e_stop += o->b_e;
    }
    rbo_clear_stop(o);
}

void ${p}_offsets_init(offsets_t *o)
{
    o->initialised = 0;
    o->filtered = 0;
    o->steer_moved = 0;
    o->t_last = 0.0;
    o->a_t = 0.0;
    o->b_r = 0.0_R;
    o->b_d = 0.0_R;
    o->e_stop = 0.0_R;
    o->e_str_r = 0.0_R;
    o->e_str_d = 0.0_R;
    o->t_str = 0.0_R;
    o->rf = 0.0_R;
    o->df = 0.0_R;
    o->af = 0.0_R;
    o->b_r0 = 0.0_R;
    rbo_clear_stop(o);
}

void ${p}_offsets_step(offsets_t *o, double t, real_t vx, real_t ay, real_t r, real_t d, offsets_output_t *out)
{
    real_t dt = 0.0_R;
    const int ok_t = isfinite(t) && (!o->initialised || t > o->t_last);
    ay -= RB_OFF_AY;                         /* the vehicle file's offsets first, as ${p}_step takes them */
    r -= RB_OFF_R;
    d -= RB_OFF_D;
    const int fin_v = RB_FABS(vx) <= RB_VX_MAX;      /* within a car's limits (false for NaN) */
    const int fin_r = RB_FABS(r) <= RB_R_MAX;
    const int fin_a = RB_FABS(ay) <= RB_AY_MAX;
    const int fin_d = isfinite(d);
    if (ok_t) {
        if (o->initialised) {
            dt = (real_t)(t - o->t_last);
        }
        if (dt > RBO_GAP) {              /* a gap: no standstill or straight runs across it */
            dt = 0.0_R;
            rbo_end_stop(o);
            o->t_str = 0.0_R;
            o->filtered = 0;
        }
        o->t_last = t;
        o->initialised = 1;
    }
    /* standstill: the yaw rate must be zero */
    if (ok_t && fin_v && fin_r) {
        if (RB_FABS(vx) < RBO_VSTOP) {
            o->t_stop += dt;
            if (dt > 0.0_R && o->t_stop > RBO_TSTOP && RB_FABS(r - o->b_r) < RBO_RSTOP) {
                if (o->s_e == 0.0_R) {
                    o->b_r0 = o->b_r;
                    o->a_t = t;
                }
                o->s_sum += r * dt;
                o->s_e += dt;
                if ((real_t)(t - o->a_t) >= RBO_TRAIL) {
                    o->b_sum = o->a_sum;
                    o->b_e = o->a_e;
                    o->a_sum = o->s_sum;
                    o->a_e = o->s_e;
                    o->a_t = t;
                }
                o->b_r = rbo_combine(o->b_r0, o->e_stop, o->s_sum, o->s_e);
            }
        } else if (o->t_stop > 0.0_R) {
            rbo_end_stop(o);
        }
    }
    /* straight driving: the yaw rate must agree with the steering angle */
    if (ok_t && fin_v && fin_r && fin_a && fin_d) {
        if (!o->filtered) {
            o->rf = r;
            o->df = d;
            o->af = ay;
            o->filtered = 1;
            o->t_str = 0.0_R;
        } else if (dt > 0.0_R) {
            const real_t a = dt / (RBO_TAUF + dt);
            const real_t rf = o->rf + a * (r - o->rf);
            if (d != o->df) {
                o->steer_moved = 1;
            }
            const real_t df = o->df + a * (d - o->df);
            const real_t af = o->af + a * (ay - o->af);
            const real_t rdot = (rf - o->rf) / dt;
            const real_t ddot = (df - o->df) / dt;
            int straight;
            o->rf = rf;
            o->df = df;
            o->af = af;
            straight = vx >= RBO_VSTR && RB_FABS(af - RBO_AYOFF) < RBO_AYSTR && RB_FABS(df - o->b_d) < RBO_DSTR
                && RB_FABS(rf - o->b_r) < RBO_RSTR && RB_FABS(rdot) < RBO_RDOT && RB_FABS(ddot) < RBO_DDOT;
            if (straight) {
                o->t_str += dt;
            } else {
                o->t_str = 0.0_R;
            }
            if (straight && o->t_str > RBO_TSTR && o->steer_moved) {
                const real_t under = RBO_KUS * (af - RBO_AYOFF);   /* delta_f = L r / vx + K_us a_y */
                real_t e;
                if (o->e_stop < RBO_NSTOP) {
                    const real_t r_kin = vx * (d - o->b_d - under) / RBO_L;
                    e = o->e_str_r + dt;
                    o->e_str_r = e;
                    o->b_r = rbo_clamp(o->b_r + dt / rbo_min(e, RBO_TAUSTR) * (r - r_kin - o->b_r), RBO_RMAX);
                } else {
                    const real_t d_kin = RBO_L * (r - o->b_r) / vx + under;
                    e = o->e_str_d + dt;
                    o->e_str_d = e;
                    o->b_d = rbo_clamp(o->b_d + dt / rbo_min(e, RBO_TAUSTR) * (d - d_kin - o->b_d), RBO_DMAX);
                }
            }
        }
    } else if (ok_t && dt > 0.0_R) {
        o->t_str = 0.0_R;
    }
    out->r = r - o->b_r;
    out->ay = ay - RBO_AYOFF;
    out->delta_f = d - o->b_d;
    out->r_offset = o->b_r;
    out->delta_offset = o->b_d;
    out->r_learnt = (o->e_stop + o->b_e >= RBO_NSTOP || o->e_str_r >= RBO_NSTR) ? 1 : 0;
    out->delta_learnt = o->e_str_d >= RBO_NSTR ? 1 : 0;
}

${learning}""")

_LEARNING_DEF = """\
int ${p}_step_learning(state_t *s, offsets_t *o, ${grade}double t, real_t vx, real_t ay, real_t r,
                       real_t delta_f${more}, output_t *out, offsets_output_t *oo)
{
    offsets_output_t tmp;
    offsets_output_t *c = oo != 0 ? oo : &tmp;
    ${p}_offsets_step(o, t, vx, ay, r, delta_f, c);
    return rb_step(s, t, vx, c->ay, c->r, ${first}, out);
}
"""

#: ``_step_learning`` per first input of the step (:func:`offsets_parts`' ``inputs``): what its comment says, the
#: grade state it takes, the inputs after ``delta_f`` and what it gives the step as its first input
_LEARNING = {
    "delta_f": ("The learner, then ${p}_step on the corrected sample.", "", (), "c->delta_f"),
    "p": ("The learner (delta_f read by it only), then ${p}_step on the corrected sample with the roll rate p\n"
          " * (rad/s) as its first input.", "", ("p",), "p"),
    "grade": ("The learner (delta_f read by it only), then ${p}_roll_rate on the corrected yaw rate and ay, then\n"
              " * ${p}_step on the corrected sample with that roll rate as its first input.", "${p}_grade *g, ",
              ("p", "ax", "q"), "rbg_roll_rate(g, t, vx, c->ay, c->r, p, ax, q)"),
}


def _learning(inputs: str, prefix: str, real: str) -> tuple[str, str]:
    """``(declaration, definition)`` of ``_step_learning`` for ``inputs`` (:data:`_LEARNING`) of the module
    ``prefix`` whose real type is ``real``."""
    what, grade, more, first = (Template(x).substitute(p=prefix) if isinstance(x, str) else x
                                for x in _LEARNING[inputs])
    decl = Template(_LEARNING_DECL).substitute(p=prefix, real=real, what=what, grade=grade,
                                               more="".join(f", {real} {m}" for m in more))
    body = Template(_LEARNING_DEF).substitute(p=prefix, grade=grade, first=first,
                                              more="".join(f", real_t {m}" for m in more))
    return decl, body

#: the C constant of each kernel setting
_CONSTS = {"VSTOP": K.C_VSTOP, "TSTOP": K.C_TSTOP, "TAUSTOP": K.C_TAUSTOP, "NSTOP": K.C_NSTOP,
           "RSTOP": K.C_RSTOP, "TRAIL": K.C_TRAIL, "VSTR": K.C_VSTR, "AYSTR": K.C_AYSTR, "DSTR": K.C_DSTR,
           "RSTR": K.C_RSTR, "RDOT": K.C_RDOT, "DDOT": K.C_DDOT, "TSTR": K.C_TSTR, "TAUSTR": K.C_TAUSTR,
           "NSTR": K.C_NSTR, "L": K.C_L, "KUS": K.C_KUS, "TAUF": K.C_TAUF, "RMAX": K.C_RMAX,
           "DMAX": K.C_DMAX, "AYOFF": K.C_AYOFF, "GAP": K.C_GAP}


def offsets_parts(prefix: str, cfg: np.ndarray, float32: bool, inputs: str = "delta_f") -> tuple[str, str]:
    """``(header part, source part)`` of the learner with the kernel settings ``cfg``
    (:meth:`roadbank.estimators.offsets.OffsetSettings.cfg`) for the module ``prefix``; ``inputs``: what its
    ``_step_learning`` gives the step as its first input: ``"delta_f"`` (the corrected steering angle), ``"p"`` (a
    roll rate) or ``"grade"`` (a roll rate through the module's ``_roll_rate``, :mod:`.grade_c`)."""
    real = f"{prefix}_real"
    decl, body = _learning(inputs, prefix, real)
    header = _HEADER.substitute(p=prefix, real=real, vstop=f"{cfg[K.C_VSTOP]:g}", tstop=f"{cfg[K.C_TSTOP]:g}",
                                trail=f"{cfg[K.C_TRAIL]:g}", trail2=f"{2 * cfg[K.C_TRAIL]:g}",
                                ayoff=f"{cfg[K.C_AYOFF]:g}",
                                learning=decl)
    source = _SOURCE.substitute(p=prefix, learning=body,
                                **{k: real_literal(cfg[i], float32) for k, i in _CONSTS.items()})
    return header, source


def add_offsets(files: dict[str, str], prefix: str, cfg: np.ndarray, float32: bool,
                inputs: str = "delta_f") -> dict[str, str]:
    """The generated module ``files`` (:func:`roadbank.export.ccode.generate`) with the learner
    added to its header (before the closing guard), source (at the end) and README (``inputs`` as
    :func:`offsets_parts`'s)."""
    head, src = offsets_parts(prefix, cfg, float32, inputs)
    gyro = "" if inputs == "delta_f" else README_GYRO.format(
        p=prefix, more=", the grade state `&grade`, `ax` and `q`" if inputs == "grade" else "")
    return add_part(files, prefix, _fix_literals(head, float32), _fix_literals(src, float32),
                    README.format(p=prefix) + gyro, "the offset learner")


README = """
## Online sensor offsets

`{p}_step_learning(&state, &learner, t, vx, ay, r, delta_f, &out, &offsets)` runs the
offset learner (`{p}_offsets_init`, `{p}_offsets_step`) and then `{p}_step` on the corrected
sample: the yaw-rate offset is learnt at standstill (and, before any standstill, from straight
driving against the steering angle's kinematic yaw rate), the steering offset from straight
driving once the yaw-rate offset is learnt; the lateral accelerometer's offset is not learnt
(it reads like road bank), a known one is subtracted. `offsets.r_learnt` and
`offsets.delta_learnt` say whether each offset has enough evidence yet; `out.valid` is the
estimator's own flag. The same operations as roadbank's `with_online_offsets(...).step()`.
"""

README_GYRO = """
This module is the gyro-aided filter: `{p}_step_learning` also takes the roll rate `p` (rad/s){more}, after
`delta_f`; the learner reads `delta_f` (the steering angle), the filter the roll rate (with the yaw rate and `ay`
the learner corrected), as roadbank's `with_online_offsets(kinematic-gyro).step(t, vx, ay, r, delta_f, p=, ax=, q=)`.
"""
