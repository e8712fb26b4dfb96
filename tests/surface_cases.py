"""Synthetic digitisations of known surfaces for the surface/IGES/toolpath tests and bench.

Each case samples cross-sections of an analytic surface, adds measurement noise along
z (seeded), and knows the exact surface so that a fitted surface can be compared with it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Case:
    name: str
    sections: list[np.ndarray]
    error_to_truth: Callable[[np.ndarray], np.ndarray]  # distance (or a bound of it) of points to the truth


def cylinder(noise_mm: float = 0.0, n_sections: int = 7, n_points: int = 14, radius: float = 20.0,
             sweep_deg: float = 120.0, length: float = 30.0, seed: int = 1) -> Case:
    """Sections are arcs of a cylinder of axis Y (z up): the exact shape of a rational curve."""
    rng = np.random.default_rng(seed)
    half = np.radians(sweep_deg) / 2
    secs = []
    for y in np.linspace(0.0, length, n_sections):
        a = np.linspace(-half, half, n_points)
        r = radius + rng.normal(0.0, noise_mm, n_points) if noise_mm else radius
        secs.append(np.c_[r * np.sin(a), np.full(n_points, y), r * np.cos(a)])

    def err(p):
        return np.abs(np.hypot(p[:, 0], p[:, 2]) - radius)

    return Case("cylinder", secs, err)


def _height_case(name, f, span, noise_mm, n_sections, n_points, seed) -> Case:
    rng = np.random.default_rng(seed)
    secs = []
    for y in np.linspace(-span, span, n_sections):
        x = np.linspace(-span, span, n_points)
        z = f(x, y) + (rng.normal(0.0, noise_mm, n_points) if noise_mm else 0.0)
        secs.append(np.c_[x, np.full(n_points, y), z])

    def err(p):  # vertical distance: an upper bound of the distance to the graph
        return np.abs(p[:, 2] - f(p[:, 0], p[:, 1]))

    return Case(name, secs, err)


def saddle(noise_mm: float = 0.0, n_sections: int = 9, n_points: int = 14, seed: int = 2) -> Case:
    return _height_case("saddle", lambda x, y: (x**2 - y**2) / 40.0, 10.0, noise_mm, n_sections, n_points, seed)


def bump(noise_mm: float = 0.0, n_sections: int = 11, n_points: int = 25, seed: int = 3) -> Case:
    return _height_case("bump", lambda x, y: 5.0 * np.exp(-(x**2 + y**2) / 40.0), 10.0, noise_mm,
                        n_sections, n_points, seed)


def csv_text(sections: list[np.ndarray]) -> str:
    rows = ["section,x,y,z"]
    for h, q in enumerate(sections, 1):
        rows += [f"{h},{float(x)!r},{float(y)!r},{float(z)!r}" for x, y, z in q]
    return "\n".join(rows) + "\n"


def geomdl_surface(b):
    """geomdl's rational surface from a pyiges entity 128 (its knots, weights and control
    points; pyiges's own to_geomdl drops the weights), knots scaled to [0, 1]."""
    from geomdl import NURBS

    n_u, n_v = b.k1 + 1, b.k2 + 1
    cp = b.control_points().reshape(n_v, n_u, 3).transpose(1, 0, 2)  # IGES: first index fastest
    w = np.asarray(b.weights).reshape(n_v, n_u).T
    g = NURBS.Surface()
    g.degree_u, g.degree_v = b.m1, b.m2
    g.ctrlpts_size_u, g.ctrlpts_size_v = n_u, n_v
    g.ctrlptsw = np.concatenate([cp * w[..., None], w[..., None]], axis=2).reshape(-1, 4).tolist()
    g.knotvector_u = list(b.knot1 / b.knot1[-1])
    g.knotvector_v = list(b.knot2 / b.knot2[-1])
    return g
