"""G2/G3 against analytic circles: centre and radius formats, every plane, full circle,
helix, turns, G90.1, G20 and the end-point tolerance."""
from __future__ import annotations

import math

import pytest

import ipr
from ipr.entities import Arc, GCodeError

# plane word, G-code of the plane, (first, second, normal) axis letters, offset letters
PLANES = {
    "XY": ("G17", "XYZ", "IJK"),
    "ZX": ("G18", "ZXY", "KIJ"),
    "YZ": ("G19", "YZX", "JKI"),
}
AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


def _point(plane: str, a: float, b: float, n: float) -> tuple[float, float, float]:
    letters = PLANES[plane][1]
    p = [0.0, 0.0, 0.0]
    for letter, v in zip(letters, (a, b, n)):
        p[AXIS_INDEX[letter]] = v
    return tuple(p)


def _words(plane: str, a: float, b: float, n: float | None = None) -> str:
    letters = PLANES[plane][1]
    out = f"{letters[0]}{a:.6f} {letters[1]}{b:.6f}"
    return out if n is None else out + f" {letters[2]}{n:.6f}"


def _arc(text: str) -> Arc:
    arcs = [e for e in ipr.parse_text(text).entities if isinstance(e, Arc)]
    assert len(arcs) == 1
    return arcs[0]


@pytest.mark.parametrize("plane", list(PLANES))
@pytest.mark.parametrize("ccw", [False, True])
@pytest.mark.parametrize("theta0,theta1", [(0.3, 1.9), (2.0, -2.5), (-1.0, 2.8)])
def test_centre_format_matches_the_analytic_circle(plane, ccw, theta0, theta1):
    ca, cb, r = 3.0, -2.0, 7.5
    s = (ca + r * math.cos(theta0), cb + r * math.sin(theta0))
    e = (ca + r * math.cos(theta1), cb + r * math.sin(theta1))
    g_plane, _, offs = PLANES[plane]
    text = (f"G21 G90 {g_plane} F600\nG0 {_words(plane, *s, 1.0)}\n"
            f"{'G3' if ccw else 'G2'} {_words(plane, *e)} {offs[0]}{ca - s[0]:.6f} {offs[1]}{cb - s[1]:.6f}\n")
    arc = _arc(text)
    assert arc.plane == plane and arc.ccw is ccw
    assert arc.center == pytest.approx(_point(plane, ca, cb, 1.0), abs=2e-6)
    assert arc.end == pytest.approx(_point(plane, *e, 1.0), abs=2e-6)
    assert arc.radius_mm == pytest.approx(r, abs=1e-6)
    sweep = (theta1 - theta0) % (2 * math.pi)
    expected = sweep if ccw else sweep - 2 * math.pi
    assert arc.sweep_rad == pytest.approx(expected, abs=1e-6)
    assert arc.feed_mm_s == pytest.approx(10.0)


@pytest.mark.parametrize("plane", list(PLANES))
@pytest.mark.parametrize("ccw", [False, True])
@pytest.mark.parametrize("sweep_abs", [0.7, 2.5, 4.0, 5.9])
def test_radius_format_short_and_long_arcs(plane, ccw, sweep_abs):
    """Positive R gives the arc of at most 180 degrees, negative R the longer one."""
    ca, cb, r, theta0 = -1.0, 4.0, 5.0, 0.4
    theta1 = theta0 + (sweep_abs if ccw else -sweep_abs)
    s = (ca + r * math.cos(theta0), cb + r * math.sin(theta0))
    e = (ca + r * math.cos(theta1), cb + r * math.sin(theta1))
    radius = r if sweep_abs <= math.pi else -r
    g_plane = PLANES[plane][0]
    text = (f"G21 G90 {g_plane} F600\nG0 {_words(plane, *s, 0.0)}\n"
            f"{'G3' if ccw else 'G2'} {_words(plane, *e)} R{radius:.6f}\n")
    arc = _arc(text)
    assert arc.center == pytest.approx(_point(plane, ca, cb, 0.0), abs=1e-5)
    assert abs(arc.sweep_rad) == pytest.approx(sweep_abs, abs=1e-5)
    assert (arc.sweep_rad > 0) is ccw


def test_g18_positive_sense_follows_rs274ngc():
    """G18: counter-clockwise turns from +Z towards +X (RS274NGC, looking along -Y)."""
    arc = _arc("G18 F60\nG0 X0 Z10\nG3 X10 Z0 I0 K-10\n")
    assert arc.ccw and arc.sweep_rad == pytest.approx(math.pi / 2)
    arc = _arc("G18 F60\nG0 X0 Z10\nG2 X10 Z0 I0 K-10\n")
    assert arc.sweep_rad == pytest.approx(-3 * math.pi / 2)


@pytest.mark.parametrize("plane", list(PLANES))
def test_full_circle_in_centre_format(plane):
    g_plane, _, offs = PLANES[plane]
    arc = _arc(f"{g_plane} F600\nG0 {_words(plane, 2.0, 0.0, 0.0)}\nG2 {offs[0]}-2\n")
    assert arc.start == arc.end
    assert arc.center == pytest.approx(_point(plane, 0.0, 0.0, 0.0))
    assert arc.sweep_rad == pytest.approx(-2 * math.pi)
    arc = _arc(f"{g_plane} F600\nG0 {_words(plane, 2.0, 0.0, 0.0)}\nG3 {_words(plane, 2.0, 0.0)} {offs[0]}-2\n")
    assert arc.sweep_rad == pytest.approx(2 * math.pi)


@pytest.mark.parametrize("plane", list(PLANES))
def test_helix_and_turns(plane):
    """The normal axis moves linearly; P3 adds two full turns; the centre stays in the start's plane."""
    g_plane, letters, offs = PLANES[plane]
    arc = _arc(f"{g_plane} F600\nG0 {_words(plane, 5.0, 0.0, 1.0)}\n"
               f"G3 {_words(plane, 0.0, 5.0, -4.0)} {offs[0]}-5 {offs[1]}0 P3\n")
    assert arc.turns == 2
    assert arc.start == pytest.approx(_point(plane, 5.0, 0.0, 1.0))
    assert arc.end == pytest.approx(_point(plane, 0.0, 5.0, -4.0))
    assert arc.center == pytest.approx(_point(plane, 0.0, 0.0, 1.0))
    assert arc.sweep_rad == pytest.approx(math.pi / 2 + 4 * math.pi)


def test_absolute_arc_centre_g90_1_with_work_offset():
    setup = ipr.Setup(work_offsets_mm={"G55": (100.0, 50.0, 0.0)})
    prog = ipr.parse_text("G55 F600\nG0 X10 Y0\nG90.1 G3 X0 Y10 I0 J0\nG91.1 G3 X-10 Y0 I0 J-10\n",
                          setup=setup)
    a1, a2 = [e for e in prog.entities if isinstance(e, Arc)]
    assert a1.center == pytest.approx((100.0, 50.0, 0.0))
    assert a2.center == pytest.approx((100.0, 50.0, 0.0))
    assert a2.sweep_rad == pytest.approx(math.pi / 2)


def test_inch_arc_is_converted_to_mm():
    arc = _arc("G20\nF10\nG0 X1 Y0\nG3 X0 Y1 I-1 J0\n")
    assert arc.start == pytest.approx((25.4, 0.0, 0.0))
    assert arc.end == pytest.approx((0.0, 25.4, 0.0))
    assert arc.radius_mm == pytest.approx(25.4)
    assert arc.feed_mm_s == pytest.approx(10 * 25.4 / 60)
    arc = _arc("G20 F10\nG0 X1 Y0\nG3 X0 Y1 R1\n")
    assert arc.center == pytest.approx((0.0, 0.0, 0.0), abs=2e-6)


@pytest.mark.parametrize("radius,off_mm,ok,moved", [
    (1.0, 0.0019, True, False), (1.0, 0.0021, True, True),        # 0.002 mm keeps the centre
    (10.0, 0.0099, True, False), (10.0, 0.0101, True, True),      # 0.1 % of the radius above it
    (1.0, 0.028, True, True), (1.0, 0.0285, False, None),          # LinuxCNC: 0.0283 mm ...
    (50.0, 0.049, True, False), (50.0, 0.051, False, None),         # ... or 0.1 % of r
    (5000.0, 2.8, True, False), (5000.0, 2.9, False, None),         # ... up to 2.83 mm
])
def test_end_point_tolerance(radius, off_mm, ok, moved):
    """End point off the circle by `off_mm` (radially) on a quarter arc: rs274's limits; beyond
    max(0.002 mm, 0.1 % r) the centre moves so that the circle passes through both ends."""
    end_r = radius + off_mm
    text = f"F60\nG0 X{radius:.6f} Y0\nG3 X0 Y{end_r:.6f} I{-radius:.6f} J0\n"
    if ok:
        arc = _arc(text)
        r0 = math.dist(arc.start[:2], arc.center[:2])
        assert math.dist(arc.end[:2], arc.center[:2]) == pytest.approx(r0, abs=1e-9 if moved else off_mm * 1.001)
        assert (arc.center[:2] != (0.0, 0.0)) == moved
        assert math.dist(arc.center[:2], (0.0, 0.0)) <= 2 * off_mm
    else:
        with pytest.raises(GCodeError) as info:
            ipr.parse_text(text)
        assert info.value.diagnostics[0].code == "E-ARC-RADIUS"


def test_inch_tolerance():
    """0.0002 inch keeps the centre; rs274's 0.00283 inch is the limit."""
    assert _arc("G20 F6\nG0 X0.1 Y0\nG3 X0 Y0.10019 I-0.1 J0\n").center == (0.0, 0.0, 0.0)
    assert _arc("G20 F6\nG0 X1 Y0\nG3 X0 Y1.0028 I-1 J0\n").center != (0.0, 0.0, 0.0)
    with pytest.raises(GCodeError):
        ipr.parse_text("G20 F6\nG0 X1 Y0\nG3 X0 Y1.0029 I-1 J0\n")


def test_nearly_full_circle_off_the_circle_is_refused():
    with pytest.raises(GCodeError) as info:
        ipr.parse_text("G21 G0 X10 Y0\nG2 X10.025 Y0 I-5 J0 F100\n")
    assert "spiral" in info.value.diagnostics[0].message


def test_semicircle_radius_slightly_too_small_is_accepted():
    arc = _arc("F60\nG0 X0 Y0\nG2 X10 Y0 R4.9995\n")
    assert arc.center == pytest.approx((5.0, 0.0, 0.0), abs=1e-3)
