"""Part programs (tests/data/gcode) parse to the paths they were written for; every error
names its line and word.

Tolerances: 1e-12 m on points and centres. The programs' numbers are exact decimals, and
a point is at most a few float operations from them (a unit factor, an incremental sum
over ≤ 15 blocks, an R arc's square root) on sizes ≤ 0.05 m: rounding is ≈1e-17 m each,
1e-12 m is far below it but six orders below a BLU (1e-6 m), so any wrong centre, side
or unit shows. Feeds: 1e-15 m/s (one division by 60 of an exact product).
"""

import math
from pathlib import Path as FilePath

import numpy as np
import pytest

from feedtune.machine.gcode import Event, ProgramError, parse_program
from feedtune.machine.path import Arc, Line

DATA = FilePath(__file__).parents[2] / "data" / "gcode"
MM, INCH = 1e-3, 0.0254
TOL = 1e-12


def read(name: str, **kw):
    return parse_program((DATA / name).read_text(), source=name, **kw)


def ends(program):
    return [(seg.start, seg.end) for seg in program.path.segments]


def assert_polyline(program, points, scale):
    """The path's segments run through ``points`` (program units) in order."""
    pts = np.array(points, dtype=float) * scale
    segs = program.path.segments
    assert len(segs) == len(pts) - 1
    for seg, a, b in zip(segs, pts[:-1], pts[1:]):
        np.testing.assert_allclose(seg.start, a, atol=TOL)
        np.testing.assert_allclose(seg.end, b, atol=TOL)


def test_pocket_absolute_mm():
    prog = read("pocket_mm_absolute.ngc")
    assert prog.units == "mm"
    assert_polyline(prog, [(0, 0, 0), (0, 0, 5), (0, 0, -1), (40, 0, -1), (40, 20, -1),
                           (0, 20, -1), (0, 0, -1), (5, 5, -1), (35, 5, -1), (35, 15, -1),
                           (5, 15, -1), (5, 5, -1), (5, 5, 5)], MM)
    segs = prog.path.segments
    # G0 from the start (0,0,0) to (0,0,5) is a rapid; the plunge at F120, then F600 modal
    assert segs[0].rapid and segs[-1].rapid
    assert segs[1].feed == pytest.approx(120 * MM / 60, abs=1e-15)
    assert all(s.feed == pytest.approx(600 * MM / 60, abs=1e-15) for s in segs[2:-1])
    assert [s.source_line for s in segs] == [4, *range(6, 17)]
    assert [e.word for e in prog.events] == ["M3", "M5", "M30"]
    assert [(s.line, s.word) for s in prog.skips] == [(5, "S12000")]


def test_pocket_incremental_inch():
    prog = read("pocket_inch_incremental.ngc")
    assert prog.units == "inch"
    z = 0.2 - 0.24
    assert_polyline(prog, [(0, 0, 0), (0, 0, 0.2), (0, 0, z), (1.6, 0, z), (1.6, 0.8, z),
                           (0, 0.8, z), (0, 0, z), (0.2, 0.2, z), (1.4, 0.2, z),
                           (1.4, 0.6, z), (0.2, 0.6, z), (0.2, 0.2, z), (0.2, 0.2, 0.2)],
                    INCH)
    assert prog.path.segments[3].feed == pytest.approx(24 * INCH / 60, abs=1e-15)


def test_arcs_by_r_and_by_ij():
    prog = read("arcs_r_and_ij.ngc")
    segs = prog.path.segments
    assert [type(s).__name__ for s in segs] == ["Line", "Arc", "Arc", "Arc", "Arc", "Arc"]
    upper, lower, long_arc, full, back = segs[1:]
    for arc in (upper, lower, full, back):
        np.testing.assert_allclose(arc.center, [0, 0, 0], atol=TOL)
        assert arc.radius == pytest.approx(10 * MM, abs=TOL)
    assert upper.ccw and upper.sweep == pytest.approx(math.pi, abs=1e-12)
    assert lower.ccw and lower.sweep == pytest.approx(math.pi, abs=1e-12)
    # R < 0: the long cw arc about (10, −10) mm, three quarters of a turn
    np.testing.assert_allclose(long_arc.center, [10 * MM, -10 * MM, 0], atol=TOL)
    assert not long_arc.ccw and long_arc.sweep == pytest.approx(-1.5 * math.pi, abs=1e-12)
    assert full.sweep == pytest.approx(-2 * math.pi, abs=1e-12)
    assert back.sweep == pytest.approx(math.pi / 2, abs=1e-12)
    # a point of each arc's middle lies on its circle (the path's own distance is ~0)
    for arc in segs[1:]:
        assert prog.path.distance(arc.point_at([arc.length / 2]))[0] < TOL
    assert [e.word for e in prog.events] == ["M2"]


def test_spiral_and_helix():
    prog = read("spiral_mm.ngc")
    arcs = prog.path.segments[1:]
    radii = [a.radius / MM for a in arcs]
    assert radii == pytest.approx([2, 3, 4, 5, 6, 7, 8], abs=1e-9)
    centres = [a.center[0] / MM for a in arcs]
    assert centres == pytest.approx([0, 1, 0, 1, 0, 1, 0], abs=1e-9)
    helix = arcs[-1]
    assert not helix.ccw and helix.sweep == pytest.approx(-2 * math.pi, abs=1e-12)
    assert helix.end[2] == pytest.approx(-2 * MM, abs=TOL)
    assert helix.length == pytest.approx(math.hypot(2 * math.pi * 8, 2) * MM, abs=TOL)


def test_incremental_arcs_inch_rounded_square():
    prog = read("incremental_arcs_inch.ngc")
    segs = prog.path.segments
    corners = [s for s in segs if isinstance(s, Arc)]
    assert len(corners) == 4
    expected_centres = [(1, 0.25), (1, 1.25), (0, 1.25), (0, 0.25)]
    for arc, c in zip(corners, expected_centres):
        np.testing.assert_allclose(arc.center[:2], np.array(c) * INCH, atol=TOL)
        assert arc.radius == pytest.approx(0.25 * INCH, abs=TOL)
        assert arc.sweep == pytest.approx(math.pi / 2, abs=1e-12)
    np.testing.assert_allclose(segs[-1].end, [0, 0, 0], atol=TOL)
    perimeter = (4 * 1 + 2 * math.pi * 0.25) * INCH
    assert prog.path.length == pytest.approx(perimeter, abs=TOL)


def test_modal_rules_and_block_order():
    prog = parse_program("N1 G21 G91 G1 X1 F60\nY1\nG90 X0\nF120 Y0\n", source="t")
    assert_polyline(prog, [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 0)], MM)
    feeds = [s.feed for s in prog.path.segments]
    assert feeds == pytest.approx([1e-3 / 1, 1e-3, 1e-3, 2e-3], abs=1e-15)  # F60 mm/min


def test_units_change_mid_program_and_given_units():
    prog = parse_program("G21 G1 X25.4 F100\nG20 X2\n", source="t")
    np.testing.assert_allclose(prog.path.segments[1].end, [2 * INCH, 0, 0], atol=TOL)
    assert prog.units == "mm"
    prog = parse_program("G1 X1 F10\n", source="t", units="inch")
    np.testing.assert_allclose(prog.path.segments[0].end, [INCH, 0, 0], atol=TOL)


def test_exact_stops_pauses_and_skips():
    prog = parse_program("G21 G1 X1 F100\nG9 X2\nG61 X3\nX4\nG64 X5\nM0\nX6\nG4 P0.5\n"
                         "G54\nX6\nM30\nX9\n", source="t")
    stops = [s.exact_stop for s in prog.path.segments]
    assert stops == [False, True, True, True, True, False]
    assert [(s.line, s.word) for s in prog.skips] == [
        (8, "G4P0.5"), (9, "G54"), (10, "G1"), (12, "X9")]
    assert Event(6, "M0") in prog.events


def test_comments_line_numbers_and_case():
    text = "%\nn5 g21 (a comment; with a semicolon, ünïcode) g1 x1 ( two ) y2 f100 ; rest\n%\n"
    prog = parse_program(text, source="t")
    np.testing.assert_allclose(prog.path.segments[0].end, [1 * MM, 2 * MM, 0], atol=TOL)


def test_arc_end_off_circle_within_rounding_is_accepted_on_one_circle():
    # I/J rounded to 3 decimals: the end lies 0.0014 mm off the start's circle
    prog = parse_program("G21 G0 X10 Y0\nG3 X0 Y10.001 I-10.0004 J0 F100\n", source="t")
    arc = prog.path.segments[1]
    r0 = np.hypot(*(arc.start - arc.center)[:2])
    r1 = np.hypot(*(arc.end - arc.center)[:2])
    assert abs(r1 - r0) < TOL
    # the centre moved by less than the rounding (0.002 mm)
    assert np.hypot(arc.center[0] + 0.0004 * MM, arc.center[1]) < 0.002 * MM


ERRORS = [
    ("G21 G1 X1 F100\nG18 X2\n", 2, "G18"),
    ("G21 G1 X1 F100\nG19\n", 2, "G19"),
    ("G21\nG41 D1 G1 X1 F100\n", 2, "G41"),
    ("G21\nG42 G1 X1 F100\n", 2, "G42"),
    ("G21 G1 X1 F100\nG81 X1 Y1 Z-1 R1\n", 2, "G81"),
    ("G21 G1 X1 F100\nG83 X1 Y1 Z-1 R1 Q1\n", 2, "G83"),
    ("G21 G90.1\n", 1, "G90.1"),
    ("G21\nG43 H1\n", 2, "G43"),
    ("G21\nG1 X1\n", 2, "G1"),                    # a feed move before any F
    ("G1 X1 F100\n", 1, "F100"),                  # no units
    ("G0 X1\n", 1, "G0"),                         # no units
    ("G21 X1\n", 1, "X1"),                        # no motion mode
    ("G21 G1 X1 F100 (open\n", 1, "("),
    ("G21 G1 X1 F100 (a (nested) one)\n", 1, "("),
    ("G21\n#1=5\n", 2, "#1=5"),
    ("G21\nG1 X[1+2] F100\n", 2, "X[1+2]"),
    ("G21\nO100 SUB\n", 2, "O100"),
    ("G21\nM98 P100\n", 2, "M98"),
    ("G21\nM100\n", 2, "M100"),
    ("G21\n/G1 X1 F100\n", 2, "/"),
    ("G21 G1 X1 F100\nG0 G1 X2\n", 2, "G1"),      # two motion words
    ("G21 G1 X1 X2 F100\n", 1, "X2"),             # a letter twice
    ("G21 G1 X1 F100\nA10\n", 2, "A10"),
    ("G21 G1 X1 F100\nG2 X3 Y0\n", 2, "G2"),      # arc without I/J or R
    ("G21 G1 X1 F100\nG2 X3 Y0 R0.5\n", 2, "R0.5"),  # radius below half the chord
    ("G21 G1 X1 F100\nG2 X1 Y0 R1\n", 2, "R1"),     # a full circle by R
    ("G21 G1 X1 F100\nG2 X3 I1 R1\n", 2, "R1"),
    ("G21 G1 X1 F100\nG3 X3 Y0.5 I1 J0\n", 2, "G3"),  # end off the circle
    ("G21 G1 X1 F100\nG2 X3 Y0 I1 K1\n", 2, "K1"),
    ("G21 G1 X1 I1 F100\n", 1, "I1"),
    ("G21 G1 X1 F0\n", 1, "F0"),
    ("G21 G1 X1 F100\nG92 X0\n", 2, "G92"),
    ("G21 G1 X1 F100\nG28\n", 2, "G28"),
    ("G21 G1 X1 F100\nG55\n", 2, "G55"),
    ("G21 G1 X1 F100\nG93\n", 2, "G93"),
    ("G21 G1 X1 F100\nG9\n", 2, "G9"),            # G9 without a move
    ("G21 G1 X1e3 F100\n", 1, "E3"),
    ("G21 G1 X1 F100\nX" + "9" * 8 + "\n", 2, "X" + "9" * 8),
    ("G21 G1 X1 N20 F100\n", 1, "N20"),
    ("G21 G1 X1 F100\nG3 X1 Y0 I0 J0\n", 2, "G3"),  # centre at the start
    ("G21 G1 X1 F100\nX2 P3\n", 2, "P3"),         # P without G4
    ("G21 G1 X1 F100\nG54.1 P2\n", 2, "G54.1"),
    ("G21 G1 X1 F100\nX2 )\n", 2, ")"),
    ("G21 G1 X1 F100\nX\u0661\u0660\n", 2, "\u0661"),  # Arabic-Indic digits ١٠
    ("G21 G1 X1 F100\nG2 X2 \u0131-1\n", 2, "\u0131"),    # dotless ı, upper() is I
]


@pytest.mark.parametrize("text, line, word", ERRORS, ids=[e[2] for e in ERRORS])
def test_error_names_line_and_word(text, line, word):
    with pytest.raises(ProgramError) as info:
        parse_program(text, source="part.ngc")
    assert (info.value.line, info.value.word) == (line, word)
    assert str(info.value).startswith(f"part.ngc:{line}: {word}: ")


def test_size_bounds():
    from feedtune.machine import gcode

    with pytest.raises(ProgramError, match="longer than"):
        parse_program("G21" + " " * gcode.MAX_LINE_CHARS, source="t")
    with pytest.raises(ProgramError, match="longer than"):
        parse_program("(" + "x" * gcode.MAX_PROGRAM_CHARS + ")", source="t")


def test_after_program_end_nothing_is_read():
    prog = parse_program("G21 G1 X1 F100\nM30\nG1 X2\n", source="t")
    assert len(prog.path.segments) == 1
    assert prog.skips[-1].line == 3


def test_zero_length_move_is_a_reported_skip_not_a_segment():
    prog = parse_program("G21 G1 X1 F100\nX1\n", source="t")
    assert len(prog.path.segments) == 1
    assert (prog.skips[0].line, prog.skips[0].word) == (2, "G1")
    assert isinstance(prog.path.segments[0], Line)


def test_full_circle_whose_end_is_off_its_start_by_float_rounding_keeps_its_centre():
    # incremental sums put the start at 0.015014000000000001 m, the absolute end at
    # 0.015014 m: a chord of 1e-18 m; the centre must stay start + (I, J) (hypothesis
    # found a projection onto that chord's bisector moving it by 0.25 mm)
    prog = parse_program("G21 G91 G1 Y0.470 F100\nY14.544\nG90 G3 Y15.014 I6.026 J-0.253\n",
                         source="t")
    arc = prog.path.segments[-1]
    start = prog.path.segments[-2].end
    np.testing.assert_allclose(arc.center[:2], start[:2] + [6.026e-3, -0.253e-3], atol=TOL)
    assert arc.sweep == pytest.approx(2 * math.pi, abs=1e-12)


def test_arc_end_within_rounding_of_its_start_is_a_full_circle_only_on_a_large_circle():
    # radius 10 mm, the end 0.001 mm off the start (a 3-decimal program's rounding): a
    # chord of 0.006° of the circle, so a full circle; a radius of 0.001 mm (the program's
    # resolution) turned by a quarter has a chord of 0.0014 mm, also within the rounding,
    # but 90° of its circle: the quarter arc as written (hypothesis found it read as a
    # full circle, 2π where π/2 was programmed)
    big = parse_program("G21 G90 G1 X10 F100\nG3 X10 Y0.001 I-10 J0\n", source="t")
    assert big.path.segments[-1].sweep == pytest.approx(2 * math.pi, abs=1e-12)
    small = parse_program("G21 G90 G1 Z0.001 F100\nG2 X-0.001 Y0.001 Z0 I0 J0.001\n",
                          source="t")
    arc = small.path.segments[-1]
    assert arc.sweep == pytest.approx(-math.pi / 2, abs=1e-9)
    np.testing.assert_allclose(arc.end, [-1e-6, 1e-6, 0], atol=TOL)
