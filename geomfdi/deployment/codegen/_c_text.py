"""The C99 text of a deployed residual monitor from its :class:`CodeSpec`.

A plain function of the spec record (no monitor object): :func:`c_source` gives the
header and the source that :func:`geomfdi.codegen.c` writes and that
``Monitor(backend="c")`` compiles.  The algorithm is the one of
:mod:`geomfdi.deployment.codegen._spec`; see the user guide, *Theory: residual
evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.deployment.codegen._spec import CodeSpec, signal_macros
from geomfdi.deployment.program import SAMPLE_LIMIT

__all__ = ["c_source"]


_PENDING = {"none": 0, "zero": 1, "steady": 2, "explicit": 3}


def _hex(x: float) -> str:
    return float(x).hex()


def _table(ctype: str, name: str, values: Any, fmt: Any = _hex) -> str:
    flat = list(np.asarray(values).ravel())
    if not flat:
        flat = [0]  # C has no zero-length arrays; never read
    body = ",\n    ".join(
        ", ".join(fmt(v) for v in flat[i : i + 4]) for i in range(0, len(flat), 4)
    )
    return f"static const {ctype} {name}[{len(flat)}] = {{\n    {body}\n}};\n"


def _alloc(n: int) -> int:
    return max(n, 1)


def _blocks(spec: CodeSpec) -> list[tuple[int, int, int, int]]:
    """Per generator ``(o, n, c0, nc)``: its states ``xi[o:o+n]`` and components
    ``c[c0:c0+nc]``.

    ``A`` and ``C`` are block diagonal (one block per generator, in row order): the
    generated code stores each generator's blocks as its own small dense tables and
    loops over them with constant bounds.
    """
    out = []
    o = 0
    comps = [sl for sl in spec.rows if sl is not None]
    for n, (c0, c1) in zip(spec.orders, comps, strict=True):
        out.append((o, n, c0, c1 - c0))
        o += n
    return out


def _block_tables(spec: CodeSpec, P: str) -> str:
    """``{P}_G<g>_AT, _CT``: generator ``g``'s blocks of ``A`` and ``C``, transposed
    (column by column), and ``{P}_BT``, ``{P}_DT``: the whole ``B`` and ``D`` transposed
    (:func:`_update_c` reads them column by column)."""
    parts = []
    for g, (o, n, c0, nc) in enumerate(_blocks(spec)):
        if n:
            parts.append(_table("double", f"{P}_G{g}_AT", spec.A[o : o + n, o : o + n].T))
            parts.append(_table("double", f"{P}_G{g}_CT", spec.C[c0 : c0 + nc, o : o + n].T))
    if spec.nw:
        parts.append(_table("double", f"{P}_BT", np.asarray(spec.B).T))
    parts.append(_table("double", f"{P}_DT", np.asarray(spec.D).T))
    return "".join(parts)


def _update_c(spec: CodeSpec, P: str) -> str:
    """``c = C xi + D z`` and ``xn = A xi + B z``.

    Each generator's blocks of ``A`` and ``C`` are its own small dense tables (the zeros
    outside the blocks are never read), then ``B z`` and ``D z`` for the whole bank.  The
    loops run over the columns outside and the rows inside, so that the compiler updates
    several rows with one vector instruction; every entry is still summed in the order of
    its dense row (the block's columns, then ``B`` or ``D``, from 0.0), so the results are
    bitwise those of a row-by-row dot product.
    """
    out = []
    for g, (o, n, c0, nc) in enumerate(_blocks(spec)):
        G = f"{P}_G{g}"
        states = f"states {o}..{o + n - 1}" if n else "no state"
        head = f"        /* generator {g}: {states}, components {c0}..{c0 + nc - 1} */"
        if not n:
            out.append(f"""{head}
        for (i = 0; i < {nc}; ++i) c[{c0} + i] = 0.0;""")
            continue
        out.append(f"""{head}
        x = s->xi + {o};
        for (i = 0; i < {nc}; ++i) c[{c0} + i] = 0.0;
        for (j = 0; j < {n}; ++j)
            for (i = 0; i < {nc}; ++i) c[{c0} + i] += {G}_CT[j * {nc} + i] * x[j];
        for (i = 0; i < {n}; ++i) xn[{o} + i] = 0.0;
        for (j = 0; j < {n}; ++j)
            for (i = 0; i < {n}; ++i) xn[{o} + i] += {G}_AT[j * {n} + i] * x[j];""")
    state_part = (
        f"\n            for (i = 0; i < {P}_NW; ++i) xn[i] += {P}_BT[j * {P}_NW + i] * z[j];"
        if spec.nw
        else ""
    )
    out.append(f"""        for (j = 0; j < NZ; ++j) {{ /* the inputs' part, every row at once */
            for (i = 0; i < NC; ++i) c[i] += {P}_DT[j * NC + i] * z[j];{state_part}
        }}
        for (i = 0; i < NC; ++i) /* an overflow: the sample is missing */
            ok &= c[i] - c[i] == 0.0;
        for (i = 0; i < {P}_NW; ++i) ok &= xn[i] - xn[i] == 0.0;""")
    return "\n".join(out)


def _decide_c(spec: CodeSpec, P: str, name: str) -> str:
    """``static int name_decide(const int *p)``: the decision for one pattern."""
    multi = ""
    if spec.multiple:
        multi = f"""
    for (i = 0; i < {P}_NR; ++i) cover[i] = 0;
    for (j = 0; j < {P}_NF; ++j) {{ /* columns inside the pattern: several faults at once */
        inside = 0;
        for (i = 0; i < {P}_NR; ++i)
            if ({P}_STRUCT[i * {P}_NF + j]) {{
                if (!p[i]) break;
                inside = 1;
            }}
        if (inside && i == {P}_NR)
            for (i = 0; i < {P}_NR; ++i) cover[i] |= {P}_STRUCT[i * {P}_NF + j];
    }}
    for (i = 0; i < {P}_NR; ++i)
        if (p[i] && !cover[i]) return {P}_UNEXPLAINED;
    return {P}_MULTIPLE;"""
    decl = f", inside, cover[{P}_NR]" if spec.multiple else ""
    tail = multi if spec.multiple else f"\n    return {P}_UNEXPLAINED;"
    return f"""static int {name}_decide(const int *p)
{{
    int i, j, any = 0, found = -1, ncand = 0, match{decl};
    for (i = 0; i < {P}_NR; ++i) any |= p[i];
    if (!any) return {P}_NO_ALARM;
    for (j = 0; j < {P}_NF; ++j) {{ /* the structure column equal to the pattern */
        match = 1;
        for (i = 0; i < {P}_NR; ++i)
            if ({P}_STRUCT[i * {P}_NF + j] != p[i]) match = 0;
        if (match) {{
            ncand += 1;
            found = j;
        }}
    }}
    if (ncand == 1) return found;
    if (ncand > 1) return {P}_AMBIGUOUS;{tail}
}}
"""


def _pattern_c(spec: CodeSpec, P: str, name: str) -> str:
    """The held pattern, its decision and the settling (end of ``name_step``)."""
    lines = []
    if spec.latch:
        quiet = ""
        if spec.reset:
            quiet = f"""
        if (held) {{
            s->quiet += 1;
            if (s->quiet >= {spec.reset}) {{ /* the episode ends */
                for (i = 0; i < {P}_NR; ++i) s->held[i] = 0;
                s->quiet = 0;
            }}
        }}"""
        if spec.reset:
            lines.append(f"    for (i = 0; i < {P}_NR; ++i) held |= s->held[i];")
        lines.append(f"""    if (any) {{ /* the pattern held over the alarm episode */
        for (i = 0; i < {P}_NR; ++i) s->held[i] = (unsigned char)(s->held[i] | alarms[i]);
        s->quiet = 0;
    }}{(" else {" + quiet + chr(10) + "    }") if quiet else " /* no reset: held to the end */"}
    for (i = 0; i < {P}_NR; ++i) pattern[i] = s->held[i];""")
    else:
        lines.append(f"    for (i = 0; i < {P}_NR; ++i) pattern[i] = alarms[i];")
    if spec.n > 1 and spec.multiple:
        lines.append(f"""    dec = {name}_decide(pattern);
    count = 1; /* settling: the same decision for k of the last n samples */
    for (j = 0; j < PN - 1; ++j) count += s->decisions[j] == dec;
    s->decisions[s->dpos] = dec;
    s->dpos = (s->dpos + 1) % (PN - 1);
    if ((dec >= 0 || dec == {P}_MULTIPLE) && count < PK) return {P}_UNEXPLAINED;
    return dec;""")
    else:
        lines.append(f"    return {name}_decide(pattern);")
    return "\n".join(lines)


def c_source(spec: CodeSpec, name: str) -> tuple[str, str]:
    """The texts of ``name.h`` and ``name.c`` for ``spec``."""
    from geomfdi import __version__

    P = name.upper()
    nw, q, m, nc, R, nf = spec.nw, spec.q, spec.m, spec.nc, spec.n_rows, spec.n_faults
    nz = q + m
    extra_decl = (", held = 0" if spec.latch and spec.reset else "") + (
        ", dec, count" if spec.n > 1 and spec.multiple else ""
    )
    if not spec.multiple:
        rule_text = "no persistence rule: isolation on the confirmed pattern of the sample;"
    elif spec.latch:
        end = f"ends after {spec.reset} quiet samples" if spec.reset else "never ends"
        rule_text = (
            f"isolation on the pattern held over the alarm episode ({end}),\n"
            f" * a decision kept when it held for {spec.k} of the last {spec.n} samples;"
        )
    else:
        rule_text = (
            "isolation on the confirmed pattern of the sample, a decision kept when it\n"
            f" * held for {spec.k} of the last {spec.n} samples;"
        )
    op_line = (
        ""
        if spec.z_op is None
        else f"\n    for (j = 0; j < NZ; ++j) z[j] -= {P}_ZOP[j]; /* physical -> deviation */"
    )
    x_decl = "\n    const double *x;" if nw else ""
    names = "".join(
        f"#define {P}_{ident} {i} /* {label} */\n"
        for (ident, i), label in zip(
            signal_macros(spec), [*spec.outputs, *spec.inputs, *spec.faults], strict=True
        )
    )
    if names:
        names = "/* indices of the outputs y, inputs u and faults (isolation results) */\n" + names
    if spec.z_op is not None:
        names += "/* y and u are physical values: the operating point is subtracted */\n"
    header = f"""/* {name}.h: residual monitor generated by geomfdi {__version__}.
 * Bank: {R} residuals, {nw} generator states, {q} outputs, {m} inputs, dt = {spec.dt!r}.
 * Decision: |r_i| > threshold_i, confirmed when {spec.k} of the last {spec.n} samples alarm;
 * {rule_text}
 * isolation returns the fault column, {P}_NO_ALARM, {P}_UNEXPLAINED, {P}_AMBIGUOUS
 * or {P}_MULTIPLE (several faults).  C99, static storage, no malloc. */
#ifndef {P}_H
#define {P}_H

#define {P}_NY {q}
#define {P}_NU {m}
#define {P}_NR {R}
#define {P}_NW {nw}
#define {P}_NF {nf}
#define {P}_NO_ALARM (-1)
#define {P}_UNEXPLAINED (-2)
#define {P}_AMBIGUOUS (-3)
#define {P}_MULTIPLE (-4)
{names}
typedef struct {{
    double xi[{_alloc(nw)}];
    unsigned char ring[{spec.n}][{R}];
    int count[{R}];
    int pos;
    unsigned char held[{R}];
    int quiet;
    int decisions[{max(spec.n - 1, 1)}];
    int dpos;
    int pending;
    long samples;
}} {name}_state;

void {name}_init({name}_state *s);
int {name}_step({name}_state *s, const double *y, const double *u, double *r, int *alarms);
void {name}_run({name}_state *s, long n, const double *Y, const double *U, double *R, int *A,
    int *I);
unsigned long {name}_state_size(void);

#endif
"""
    rows_code = []
    for i, sl in enumerate(spec.rows):
        if sl is None:
            rows_code.append(f"        r[{i}] = 0.0;")
        elif sl[1] - sl[0] == 1:
            rows_code.append(f"        r[{i}] = c[{sl[0]}];")
        else:
            terms = " + ".join(f"c[{k}] * c[{k}]" for k in range(sl[0], sl[1]))
            rows_code.append(f"        r[{i}] = sqrt({terms});")
    active = [1 if np.isfinite(v) else 0 for v in spec.thresholds]
    thr = [v if np.isfinite(v) else 0.0 for v in spec.thresholds]
    tables = "".join(
        [
            _block_tables(spec, P),
            _table("double", f"{P}_J", spec.J),
            _table("double", f"{P}_S", spec.S),
            _table("double", f"{P}_W0", spec.W0),
            _table("double", f"{P}_THR", thr),
            _table("int", f"{P}_ACTIVE", active, str),
            _table("int", f"{P}_STRUCT", spec.structure.astype(int), str),
            "" if spec.z_op is None else _table("double", f"{P}_ZOP", spec.z_op),
        ]
    )
    source = f"""/* {name}.c: residual monitor generated by geomfdi {__version__} (see {name}.h). */
#include <math.h>
#include "{name}.h"

#define NZ {nz}
#define NC {nc}
#define PN {spec.n}
#define PK {spec.k}
#define PENDING_INITIAL {_PENDING[spec.initial]}
#define PENDING_RESTART {_PENDING[spec.restart]}
#define SAMPLE_LIMIT {_hex(SAMPLE_LIMIT)} /* {SAMPLE_LIMIT:g}: larger samples are missing */

{tables}
void {name}_init({name}_state *s)
{{
    int i, j;
    for (i = 0; i < {_alloc(nw)}; ++i) s->xi[i] = 0.0;
    for (i = 0; i < PN; ++i)
        for (j = 0; j < {P}_NR; ++j) s->ring[i][j] = 0;
    for (j = 0; j < {P}_NR; ++j) {{
        s->count[j] = 0;
        s->held[j] = 0;
    }}
    for (i = 0; i < {max(spec.n - 1, 1)}; ++i) s->decisions[i] = {P}_NO_ALARM;
    s->pos = 0;
    s->quiet = 0;
    s->dpos = 0;
    s->pending = PENDING_INITIAL;
    s->samples = 0;
}}

static void {name}_start({name}_state *s, const double *z)
{{
    int i, j;
    double acc;
    for (i = 0; i < {P}_NW; ++i) {{
        acc = 0.0;
        if (s->pending == 2) {{
            for (j = 0; j < NZ; ++j) acc += {P}_S[i * NZ + j] * z[j];
        }} else {{
            for (j = 0; j < NZ; ++j) acc += {P}_J[i * NZ + j] * z[j];
            acc = (s->pending == 3 ? {P}_W0[i] : 0.0) - acc;
        }}
        s->xi[i] = acc;
    }}
    s->pending = 0;
}}

{_decide_c(spec, P, name)}
int {name}_step({name}_state *s, const double *y, const double *u, double *r, int *alarms)
{{
    double z[{_alloc(nz)}], c[{_alloc(nc)}], xn[{_alloc(nw)}];{x_decl}
    int raw[{P}_NR], pattern[{P}_NR];
    int i, j, ok = 1, any = 0{extra_decl};
    for (j = 0; j < {P}_NY; ++j) z[j] = y[j];
    for (j = 0; j < {P}_NU; ++j) z[{P}_NY + j] = u[j];{op_line}
    for (j = 0; j < NZ; ++j) /* nan, inf or out of range: a missing sample */
        if (!(fabs(z[j]) <= SAMPLE_LIMIT)) ok = 0;
    s->samples += 1;
    if (ok) {{
        if (s->pending) {name}_start(s, z);
{_update_c(spec, P)}
    }}
    if (!ok) {{ /* residuals nan, no raw alarm, restart at the next valid sample */
        for (i = 0; i < {P}_NR; ++i) {{
            r[i] = NAN;
            raw[i] = 0;
        }}
        s->pending = PENDING_RESTART;
    }} else {{
        for (i = 0; i < {P}_NW; ++i) s->xi[i] = xn[i];
{chr(10).join(rows_code)}
        for (i = 0; i < {P}_NR; ++i) raw[i] = {P}_ACTIVE[i] && fabs(r[i]) > {P}_THR[i];
    }}
    for (i = 0; i < {P}_NR; ++i) {{ /* k-of-n persistence */
        s->count[i] += raw[i] - (int)s->ring[s->pos][i];
        s->ring[s->pos][i] = (unsigned char)raw[i];
        alarms[i] = s->count[i] >= PK;
        any |= alarms[i];
    }}
    s->pos = (s->pos + 1) % PN;
{_pattern_c(spec, P, name)}
}}

void {name}_run({name}_state *s, long n, const double *Y, const double *U, double *R, int *A,
    int *I)
{{
    long k;
    for (k = 0; k < n; ++k)
        I[k] = {name}_step(s, Y + k * {P}_NY, U + k * {P}_NU, R + k * {P}_NR, A + k * {P}_NR);
}}

unsigned long {name}_state_size(void)
{{
    return (unsigned long)sizeof({name}_state);
}}
"""
    return header, source
