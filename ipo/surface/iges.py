"""IGES 5.3 export of rational B-spline surfaces (entity 128) and curves (entity 126), and a
minimal reader of such files (001 §4: the surface goes to CAM through IGES).

Fixed 80-column records: columns 1–72 data, 73 the section letter (S, G, D, P, T),
74–80 the sequence number. Each entity has two directory (D) lines; its parameter (P)
lines carry data in columns 1–64 and the entity's D pointer in 65–72. Reals are written
with the shortest repr that reads back to the same double, so the round trip is exact.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ipo.errors import IGES, IpoError
from ipo.surface.evaluation import RationalSurface

P_DATA_COLS = 64


class IgesError(IpoError):
    """A file this reader cannot take, or a surface the writer cannot put in one (code E-IPO-IGES);
    the message names the line."""

    def __init__(self, message: str):
        super().__init__(IGES, message)


@dataclass(frozen=True, slots=True, eq=False)
class RationalCurve:
    """Entity 126: degree, clamped knots, weights (n,), control points (n, 3)."""

    degree: int
    knots: np.ndarray
    weights: np.ndarray
    points: np.ndarray


def real(x: float) -> str:
    """An IGES real: always with a decimal point, exponent as E."""
    s = repr(float(x))
    if "e" in s:
        mant, exp = s.split("e")
        return (mant if "." in mant else mant + ".") + "E" + exp
    return s


def _hollerith(text: str) -> str:
    return f"{len(text)}H{text}"


def _records(tokens: list[str], width: int) -> list[str]:
    """Pack parameter tokens (each already followed by its delimiter) into lines of <= width."""
    lines, cur = [], ""
    for tok in tokens:
        if len(tok) > width:
            raise IgesError(f"IGES parameter too long for a record: {tok[:20]}...")
        if len(cur) + len(tok) > width:
            lines.append(cur)
            cur = ""
        cur += tok
    if cur:
        lines.append(cur)
    return lines


def _delimited(values: list[str]) -> list[str]:
    return [v + "," for v in values[:-1]] + [values[-1] + ";"]


def surface_params(s: RationalSurface) -> list[str]:
    n_u, n_v = s.weights.shape
    polynomial = int(np.all(s.weights == s.weights.flat[0]))
    head = ["128", str(n_u - 1), str(n_v - 1), str(s.degree_u), str(s.degree_v), "0", "0", str(polynomial), "0", "0"]
    # IGES orders the net with the first index fastest: W(0,0), W(1,0), ..., W(K1,0), W(0,1), ...
    w = s.weights.T.ravel()
    p = s.points.transpose(1, 0, 2).reshape(-1, 3)
    (u0, u1), (v0, v1) = s.u_range, s.v_range
    return (head + [real(k) for k in s.knots_u] + [real(k) for k in s.knots_v] + [real(x) for x in w]
            + [real(x) for x in p.ravel()] + [real(u0), real(u1), real(v0), real(v1)])


def curve_params(c: RationalCurve) -> list[str]:
    n = len(c.weights)
    centred = c.points - c.points.mean(axis=0)
    normal = np.linalg.svd(centred)[2][-1] if n >= 3 else np.zeros(3)
    planar = int(n >= 3 and np.abs(centred @ normal).max() <= 1e-9 * max(np.ptp(c.points, axis=0).max(), 1e-300))
    polynomial = int(np.all(c.weights == c.weights[0]))
    head = ["126", str(n - 1), str(c.degree), str(planar), "0", str(polynomial), "0"]
    norm = normal if planar else np.zeros(3)
    return (head + [real(k) for k in c.knots] + [real(x) for x in c.weights] + [real(x) for x in c.points.ravel()]
            + [real(c.knots[c.degree]), real(c.knots[-c.degree - 1])] + [real(x) for x in norm])


def _line(data: str, letter: str, seq: int) -> str:
    if len(data) > 72:
        raise ValueError("IGES record data longer than 72 columns")
    return f"{data:<72}{letter}{seq:7d}"


def iges_text(surfaces: list[RationalSurface], curves: list[RationalCurve] = (), *,
              description: str = "vcnc surface", file_name: str = "surface.igs") -> str:
    """The whole file as text: CRLF-free 80-column lines."""
    stamp = time.strftime("%Y%m%d.%H%M%S", time.gmtime())
    span = max([float(np.abs(s.points).max()) for s in surfaces] + [float(np.abs(c.points).max()) for c in curves]
               + [1.0])
    g_values = [_hollerith(","), _hollerith(";"), _hollerith(description), _hollerith(file_name),
                _hollerith("vcnc"), _hollerith("vcnc ipo.iges"), "32", "38", "6", "308", "15",
                _hollerith(description), "1.", "2", _hollerith("MM"), "1", "0.01", _hollerith(stamp),
                "1.E-06", real(span), _hollerith("vcnc"), _hollerith("vcnc"), "11", "0", _hollerith(stamp)]
    s_lines = [_line(description, "S", 1)]
    g_lines = [_line(rec, "G", i) for i, rec in enumerate(_records(_delimited(g_values), 72), 1)]
    entities = [(128, surface_params(s)) for s in surfaces] + [(126, curve_params(c)) for c in curves]
    d_lines, p_lines = [], []
    for k, (etype, params) in enumerate(entities):
        de = 2 * k + 1
        recs = _records(_delimited(params), P_DATA_COLS)
        first_p = len(p_lines) + 1
        for rec in recs:
            p_lines.append(_line(f"{rec:<{P_DATA_COLS}}{de:8d}", "P", len(p_lines) + 1))
        d1 = f"{etype:8d}{first_p:8d}{0:8d}{1:8d}{0:8d}{0:8d}{0:8d}{0:8d}{'00000000':>8}"
        d2 = f"{etype:8d}{0:8d}{0:8d}{len(recs):8d}{0:8d}{'':8}{'':8}{'SURFACE' if etype == 128 else 'CURVE':>8}{0:8d}"
        d_lines += [_line(d1, "D", de), _line(d2, "D", de + 1)]
    t = f"S{len(s_lines):7d}G{len(g_lines):7d}D{len(d_lines):7d}P{len(p_lines):7d}"
    return "\n".join(s_lines + g_lines + d_lines + p_lines + [_line(t, "T", 1)]) + "\n"


def write_iges(path: str | Path, surfaces: list[RationalSurface], curves: list[RationalCurve] = (), *,
               description: str = "vcnc surface") -> None:
    Path(path).write_text(iges_text(surfaces, curves, description=description, file_name=Path(path).name),
                          encoding="ascii")


def _number(tok: str, where: str) -> float:
    try:
        return float(tok.strip().upper().replace("D", "E"))
    except ValueError:
        raise IgesError(f"{where}: '{tok.strip()}' is not a number") from None


def _parse_surface(tokens: list[str], where: str) -> RationalSurface:
    f = [_number(t, where) for t in tokens]
    k1, k2, m1, m2 = (int(x) for x in f[1:5])
    if f[8] or f[9]:
        raise IgesError(f"{where}: periodic surfaces are not supported")
    n_u, n_v = k1 + 1, k2 + 1
    need = 10 + (n_u + m1 + 1) + (n_v + m2 + 1) + 4 * n_u * n_v + 4
    if len(f) < need:
        raise IgesError(f"{where}: entity 128 has {len(f)} parameters, expected {need}")
    i = 10
    ku = np.array(f[i:i + n_u + m1 + 1]); i += n_u + m1 + 1
    kv = np.array(f[i:i + n_v + m2 + 1]); i += n_v + m2 + 1
    w = np.array(f[i:i + n_u * n_v]).reshape(n_v, n_u).T; i += n_u * n_v
    p = np.array(f[i:i + 3 * n_u * n_v]).reshape(n_v, n_u, 3).transpose(1, 0, 2); i += 3 * n_u * n_v
    u0, u1, v0, v1 = f[i:i + 4]
    surf = RationalSurface(m1, m2, ku, kv, w, p)
    if not (np.allclose((u0, u1), surf.u_range) and np.allclose((v0, v1), surf.v_range)):
        raise IgesError(f"{where}: a parameter sub-range (U {u0}..{u1}, V {v0}..{v1}) is not supported")
    return surf


def read_surfaces(path: str | Path) -> list[RationalSurface]:
    """Every entity 128 of an IGES file with the default delimiters (',' and ';')."""
    path = Path(path)
    sections: dict[str, list[tuple[int, str]]] = {c: [] for c in "SGDPT"}
    for n, raw in enumerate(path.read_text(encoding="ascii", errors="replace").splitlines(), 1):
        if not raw.strip():
            continue
        if len(raw) < 73 or raw[72] not in sections:
            raise IgesError(f"{path}:{n}: not an 80-column IGES record (column 73 must be S, G, D, P or T)")
        sections[raw[72]].append((n, raw[:72]))
    if not sections["G"]:
        raise IgesError(f"{path}: no global section")
    g = "".join(d for _, d in sections["G"])
    if not g.startswith("1H,,1H;"):
        raise IgesError(f"{path}: only the default delimiters ',' and ';' are supported")
    p_lines = [d for _, d in sections["P"]]
    out = []
    d = sections["D"]
    for k in range(0, len(d) - 1, 2):
        line, d1 = d[k]
        if int(d1[:8]) != 128:
            continue
        first, count = int(d1[8:16]), int(d[k + 1][1][24:32])
        where = f"{path}:{line}"
        if first < 1 or first + count - 1 > len(p_lines):
            raise IgesError(f"{where}: parameter pointer {first}+{count} outside the P section")
        text = "".join(pl[:P_DATA_COLS] for pl in p_lines[first - 1:first - 1 + count]).strip()
        if not text.endswith(";"):
            raise IgesError(f"{where}: entity 128's parameters do not end with ';'")
        out.append(_parse_surface(text[:-1].split(","), where))
    if not out:
        raise IgesError(f"{path}: no rational B-spline surface (entity 128)")
    return out
