"""Compile an exported module: the strict C99 flags, a shared library with a small test
harness (for :mod:`ctypes`), and a stand-alone driver program (for sanitizer runs)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

#: warnings every exported module must compile without (``-Werror``)
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wshadow",
                "-Wconversion", "-Wdouble-promotion", "-Wstrict-prototypes", "-Wmissing-prototypes")
#: no fused multiply-add contraction: the same rounding as the Python kernels
FP_FLAGS = ("-ffp-contract=off",)
SANITIZE_FLAGS = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
                  "-g", "-O1")


class CompilerError(RuntimeError):
    """The C compiler is missing or rejected the code (message: command and compiler output)."""


def find_compiler() -> str:
    """The C compiler: ``$CC`` if set, else ``gcc`` or ``cc`` on PATH."""
    cc = os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc")
    if not cc:
        raise CompilerError("no C compiler found: install gcc or set CC")
    return cc


def compile_c(sources, output: Path, *, flags=(), shared: bool = False, include=()) -> Path:
    """Compile and link ``sources`` into ``output`` (executable, or shared library if ``shared``).

    Raises :class:`CompilerError` with the compiler's messages when it fails.
    """
    cmd = [find_compiler(), *STRICT_FLAGS, *FP_FLAGS, *flags]
    if shared:
        cmd += ["-shared", "-fPIC"]
    cmd += [f"-I{p}" for p in include]
    cmd += [str(s) for s in sources] + ["-o", str(output), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise CompilerError(f"compilation failed: {' '.join(cmd)}\n{proc.stderr.strip()}")
    return Path(output)


# ---------------------------------------------------------------------------
# harness: batch run, benchmark loop and a stand-alone driver around one module
# ---------------------------------------------------------------------------

_HARNESS = """\
/* test harness of {p} (roadbank.export.build); not part of the exported module */
#include <stddef.h>
#include "{p}.h"

size_t rbh_state_size(void);
void rbh_init(void *s);
int rbh_step(void *s, double t, double vx, double ay, double r, double d, double *out);
void rbh_run(void *s, long n, const double *t, const double *vx, const double *ay,
             const double *r, const double *d, int use_dt, double *out, unsigned char *valid);
double rbh_bench(long n, const {real} *t, const {real} *vx, const {real} *ay, const {real} *r,
                 const {real} *d, long reps);

size_t rbh_state_size(void) {{ return sizeof({p}_state); }}

void rbh_init(void *s) {{ {p}_init(({p}_state *)s); }}

int rbh_step(void *s, double t, double vx, double ay, double r, double d, double *out)
{{
    {p}_output o;
    int ok = {p}_step(({p}_state *)s, t, ({real})vx, ({real})ay, ({real})r, ({real})d, &o);
    out[0] = (double)o.w;
    out[1] = (double)o.theta;
    out[2] = (double)o.phi_b;
    out[3] = (double)o.phi;
    return ok;
}}

/* n samples through _step (use_dt = 0) or _step_dt with dt = t[k] - t[k-1] (use_dt = 1);
 * out: n x 4 (w, theta, phi_b, phi) */
void rbh_run(void *s, long n, const double *t, const double *vx, const double *ay,
             const double *r, const double *d, int use_dt, double *out, unsigned char *valid)
{{
    long k;
    {p}_output o;
    for (k = 0; k < n; ++k) {{
        int ok;
        if (use_dt) {{
            double dt = k > 0 ? t[k] - t[k - 1] : 0.0;
            ok = {p}_step_dt(({p}_state *)s, ({real})dt, ({real})vx[k], ({real})ay[k], ({real})r[k],
                             ({real})d[k], &o);
        }} else {{
            ok = {p}_step(({p}_state *)s, t[k], ({real})vx[k], ({real})ay[k], ({real})r[k],
                          ({real})d[k], &o);
        }}
        out[4 * k] = (double)o.w;
        out[4 * k + 1] = (double)o.theta;
        out[4 * k + 2] = (double)o.phi_b;
        out[4 * k + 3] = (double)o.phi;
        valid[k] = (unsigned char)ok;
    }}
}}

/* reps passes over n samples (inputs already in the module's type, time since the
 * previous sample in t); returns a checksum so that nothing is optimised away */
double rbh_bench(long n, const {real} *t, const {real} *vx, const {real} *ay, const {real} *r,
                 const {real} *d, long reps)
{{
    {p}_state s;
    {p}_output o;
    double acc = 0.0;
    long k;
    long j;
    for (j = 0; j < reps; ++j) {{
        {p}_init(&s);
        for (k = 0; k < n; ++k) {{
            acc += {p}_step_dt(&s, t[k], vx[k], ay[k], r[k], d[k], &o);
        }}
        acc += (double)o.phi_b;
    }}
    return acc;
}}

#if defined({P}_GRADE_CAP) || defined({P}_GRADE_OBSERVER)
#include <stdlib.h>
/* the grade-corrected roll rate of n samples (the module's {p}_roll_rate); 0 if no memory */
int rbh_roll_rates(long n, const double *t, const double *vx, const double *ay, const double *r,
                   const double *p, const double *ax, const double *q, double *out);

int rbh_roll_rates(long n, const double *t, const double *vx, const double *ay, const double *r,
                   const double *p, const double *ax, const double *q, double *out)
{{
    long k;
    {p}_grade *g = malloc(sizeof *g);
    if (g == NULL) {{
        return 0;
    }}
    {p}_grade_init(g);
    for (k = 0; k < n; ++k) {{
        out[k] = (double){p}_roll_rate(g, t[k], ({real})vx[k], ({real})ay[k], ({real})r[k], ({real})p[k],
                                        ({real})ax[k], ({real})q[k]);
    }}
    free(g);
    return 1;
}}
#endif
"""

_DRIVER = """\
/* stand-alone driver of {modules} (roadbank.export.build): reads n, then t, vx, ay, r, delta_f
 * (n doubles each) from argv[2]; writes w, theta, phi_b, phi (n doubles each) then valid
 * (n bytes) to argv[3]; argv[1] selects the module ({choices}) and "dt" in argv[4] the
 * step_dt entry point. Exit status 0 on success. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
{includes}

{functions}
int main(int argc, char **argv)
{{
    FILE *f;
    long n = 0;
    long k;
    double *in;
    double *out;
    unsigned char *valid;
    int use_dt = argc > 4 && strcmp(argv[4], "dt") == 0;
    int status = 1;
    if (argc < 4 || (f = fopen(argv[2], "rb")) == NULL) {{
        return 2;
    }}
    if (fread(&n, sizeof n, 1, f) != 1 || n <= 0) {{
        fclose(f);
        return 2;
    }}
    in = malloc((size_t)n * 5 * sizeof *in);
    out = malloc((size_t)n * 4 * sizeof *out);
    valid = malloc((size_t)n);
    if (in == NULL || out == NULL || valid == NULL || fread(in, sizeof *in, (size_t)n * 5, f) != (size_t)n * 5) {{
        fclose(f);
        free(in);
        free(out);
        free(valid);
        return 2;
    }}
    fclose(f);
    for (k = 0; k < n; ++k) {{
        valid[k] = 0;
    }}
{dispatch}
    if (status == 0 && (f = fopen(argv[3], "wb")) != NULL) {{
        if (fwrite(out, sizeof *out, (size_t)n * 4, f) != (size_t)n * 4
                || fwrite(valid, 1, (size_t)n, f) != (size_t)n) {{
            status = 3;
        }}
        fclose(f);
    }} else if (status == 0) {{
        status = 3;
    }}
    free(in);
    free(out);
    free(valid);
    return status;
}}
"""

_DRIVER_FN = """\
static void run_{ident}(long n, const double *in, double *out, unsigned char *valid, int use_dt)
{{
    {p}_state s;
    {p}_output o;
    long k;
    {p}_init(&s);
    for (k = 0; k < n; ++k) {{
        const double *t = in;
        int ok;
        if (use_dt) {{
            double dt = k > 0 ? t[k] - t[k - 1] : 0.0;
            ok = {p}_step_dt(&s, ({real})dt, ({real})in[n + k], ({real})in[2 * n + k],
                             ({real})in[3 * n + k], ({real})in[4 * n + k], &o);
        }} else {{
            ok = {p}_step(&s, t[k], ({real})in[n + k], ({real})in[2 * n + k], ({real})in[3 * n + k],
                          ({real})in[4 * n + k], &o);
        }}
        out[k] = (double)o.w;
        out[n + k] = (double)o.theta;
        out[2 * n + k] = (double)o.phi_b;
        out[3 * n + k] = (double)o.phi;
        valid[k] = (unsigned char)ok;
    }}
}}
"""


def harness_source(prefix: str) -> str:
    """C source of the ctypes harness of the module ``prefix`` (e.g. ``roadbank_pif_modified``)."""
    return _HARNESS.format(p=prefix, P=prefix.upper(), real=f"{prefix}_real")


def driver_source(prefixes: dict[str, str]) -> str:
    """C source of a driver program over several modules (``{selector: prefix}``)."""
    fns, disp = [], []
    for key, p in prefixes.items():
        ident = p.removeprefix("roadbank_")
        fns.append(_DRIVER_FN.format(p=p, ident=ident, real=f"{p}_real"))
        disp.append(f"    if (strcmp(argv[1], \"{key}\") == 0) {{\n"
                    f"        run_{ident}(n, in, out, valid, use_dt);\n        status = 0;\n    }}")
    return _DRIVER.format(modules=", ".join(prefixes.values()), choices=", ".join(prefixes),
                          includes="\n".join(f'#include "{p}.h"' for p in prefixes.values()),
                          functions="\n".join(fns), dispatch="\n".join(disp))


def build_driver(modules: dict[str, Path], output: Path, *, flags=SANITIZE_FLAGS) -> Path:
    """Link a driver program over exported modules ``{selector: path of the .c file}``.

    Several modules link into one program (their symbols are all prefixed).
    """
    output = Path(output)
    src = output.with_suffix(".driver.c")
    src.write_text(driver_source({k: Path(c).stem for k, c in modules.items()}))
    dirs = sorted({str(Path(c).parent) for c in modules.values()})
    # the driver itself is test code: strict too, but stdio and malloc are allowed there
    return compile_c([src, *modules.values()], output, flags=flags, include=dirs)


def object_report(source: Path, *, opt: str = "-O0") -> dict:
    """Compile ``source`` to an object and read what it needs and holds (for checks and docs).

    Returns a dict: ``sections`` ({name: bytes} from ``size -A``: .text, .rodata, .data,
    .bss, ...), ``undefined`` (external symbols it calls, set), ``mutable_symbols``
    (symbols in writable data: ``nm`` types b/B/d/D), ``stack`` ({function: (bytes,
    qualifier)} from ``-fstack-usage``; qualifier "static" = bounded at compile time)
    and ``calls`` (set of (caller, callee) from ``-fcallgraph-info``; no inlining at -O0).
    """
    source = Path(source)
    out = source.with_name(source.stem + f"{opt.replace('-', '_')}.o")
    compile_c([source], out, flags=(opt, "-c", "-fstack-usage", "-fcallgraph-info"))
    cmd_size = subprocess.run(["size", "-A", str(out)], capture_output=True, text=True, check=True)
    sections = {}
    for line in cmd_size.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sections[parts[0]] = int(parts[1])
    nm = subprocess.run(["nm", str(out)], capture_output=True, text=True, check=True).stdout
    undefined, mutable = set(), set()
    for line in nm.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == "U":
            undefined.add(parts[1])
        elif len(parts) == 3 and parts[1] in "bBdD":
            mutable.add(parts[2])
    stack = {}
    su = out.with_suffix(".su")
    for line in su.read_text().splitlines():
        loc, nbytes, qual = line.rsplit("\t", 2)
        stack[loc.rsplit(":", 1)[-1]] = (int(nbytes), qual)
    calls = set()
    edge = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
    for m in edge.finditer(out.with_suffix(".ci").read_text()):
        calls.add(tuple(name.rsplit(":", 1)[-1] for name in m.groups()))
    return {"sections": sections, "undefined": undefined, "mutable_symbols": mutable,
            "stack": stack, "calls": calls}
