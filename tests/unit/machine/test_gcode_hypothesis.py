"""Random part programs round-trip through a writer written for the tests; R arcs keep
their invariants; arbitrary text is a Program or a ProgramError, never another exception.

Programs live on a grid of 0.001 program units (exact decimals), at most 60 units from
the origin, so every coordinate and centre is a few float operations from an exact
number: 1e-12 m is far above that rounding (≈1e-15 m at 1.5 m) and a million times below
a BLU; an R arc's centre takes a square root of a difference, so its points are checked
at 1e-9 m against its own radius (cancellation in r² − (c/2)² of numbers ≈ 1e-3 m²).
"""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from feedtune.machine.gcode import ProgramError, parse_program
from feedtune.machine.path import Arc

TOL = 1e-12
SCALE = {"mm": 1e-3, "inch": 0.0254}
GRID = st.integers(-60_000, 60_000)  # thousandths of a program unit


@st.composite
def moves(draw):
    """A list of (kind, data) in thousandths: ("G0"/"G1", (x, y, z)) or
    ("G2"/"G3", (i, j, quarter turns 1–4, z))."""
    out = []
    pos = (0, 0, 0)
    for _ in range(draw(st.integers(1, 12))):
        kind = draw(st.sampled_from(["G0", "G1", "G1", "G2", "G3"]))
        if kind in ("G0", "G1"):
            target = (draw(GRID), draw(GRID), draw(st.integers(-5000, 5000)))
            if target == pos:
                continue
            out.append((kind, target))
            pos = target
        else:
            i, j = draw(st.integers(-20_000, 20_000)), draw(st.integers(-20_000, 20_000))
            if i == 0 and j == 0:
                continue
            quarters = draw(st.integers(1, 4))
            z = draw(st.integers(-5000, 5000))
            cx, cy = pos[0] + i, pos[1] + j
            rx, ry = pos[0] - cx, pos[1] - cy
            for _ in range(quarters):  # rotate (rx, ry) by ±90°, exactly on the grid
                rx, ry = (-ry, rx) if kind == "G3" else (ry, -rx)
            target = (cx + rx, cy + ry, z)
            out.append((kind, (i, j, quarters, z, target)))
            pos = target
    return out


def number(k: int) -> str:
    return f"{k / 1000:.3f}"


def write(program, units, data) -> str:
    """A writer for the tests: the moves as G-code, formatted as ``data`` draws."""
    lines = ["%", f"({units} program written by the test writer)",
             "G21" if units == "mm" else "G20", "G17"]
    pos = (0, 0, 0)
    absolute = None
    feed_given = False
    for n, (kind, move) in enumerate(program, start=1):
        want_abs = data.draw(st.booleans())
        words = []
        if data.draw(st.booleans()):
            words.append(f"N{10 * n}")
        if want_abs != absolute:
            words.append("G90" if want_abs else "G91")
            absolute = want_abs
        words.append(data.draw(st.sampled_from([kind, kind.replace("G", "G0")])))
        target = move if kind in ("G0", "G1") else move[4]
        for axis, value, old in zip("XYZ", target, pos):
            if value != old or data.draw(st.booleans()):
                words.append(axis + number(value if absolute else value - old))
        if kind in ("G2", "G3"):
            words += [f"I{number(move[0])}", f"J{number(move[1])}"]
        if kind != "G0" and (not feed_given or data.draw(st.booleans())):
            words.append("F" + str(data.draw(st.integers(1, 5000))))
            feed_given = True
        text = data.draw(st.sampled_from([" ", "", "  "])).join(words)
        if data.draw(st.booleans()):
            text = text.lower()
        comment = data.draw(st.sampled_from(["", " (move)", " ; move", "(a)"]))
        lines.append(text + comment)
        pos = target
    lines += ["M30", "%"]
    return "\n".join(lines) + "\n"


@settings(max_examples=150, deadline=None)
@given(program=moves(), units=st.sampled_from(["mm", "inch"]), data=st.data())
def test_written_programs_parse_to_their_moves(program, units, data):
    text = write(program, units, data)
    parsed = parse_program(text, source="random.ngc")
    s = SCALE[units] / 1000
    segs = parsed.path.segments
    assert len(segs) == len(program)
    pos = np.zeros(3)
    for seg, (kind, move) in zip(segs, program):
        np.testing.assert_allclose(seg.start, pos, atol=TOL)
        if kind in ("G0", "G1"):
            assert seg.rapid == (kind == "G0")
            target = np.array(move, dtype=float) * s
        else:
            i, j, quarters, z, end = move
            assert isinstance(seg, Arc) and seg.ccw == (kind == "G3")
            np.testing.assert_allclose(seg.center[:2], pos[:2] + np.array([i, j]) * s, atol=TOL)
            expected = quarters * math.pi / 2 * (1 if kind == "G3" else -1)
            assert math.isclose(seg.sweep, expected, abs_tol=1e-9)
            target = np.array(end, dtype=float) * s
        np.testing.assert_allclose(seg.end, target, atol=TOL)
        pos = target
    assert parsed.units == units


@settings(max_examples=200, deadline=None)
@given(start=st.tuples(GRID, GRID), end=st.tuples(GRID, GRID),
       factor=st.floats(1.0, 5.0), long=st.booleans(), ccw=st.booleans())
def test_r_arcs_keep_their_invariants(start, end, factor, long, ccw):
    chord = math.dist(start, end)
    if chord == 0:
        return
    radius = round(factor * chord / 2) + 1  # thousandths, at least half the chord
    r_word = ("-" if long else "") + number(radius)
    text = (f"G21 G90 G0 X{number(start[0])} Y{number(start[1])}\n"
            f"{'G3' if ccw else 'G2'} X{number(end[0])} Y{number(end[1])} R{r_word} F100\n")
    arc = parse_program(text, source="r.ngc").path.segments[-1]
    r = radius * 1e-6
    for p in (arc.start, arc.end, arc.point_at([arc.length / 3])[0]):
        assert abs(math.dist(p[:2], arc.center[:2]) - r) < 1e-9
    assert arc.ccw == ccw
    half_turn = math.pi
    if long:
        assert abs(arc.sweep) >= half_turn - 1e-6
    else:
        assert abs(arc.sweep) <= half_turn + 1e-6


ALPHABET = "GMXYZIJKRFNSTOP0123456789.-+ ()%;#[]/\n"


@settings(max_examples=400, deadline=None)
@given(st.text(alphabet=ALPHABET, max_size=120))
def test_any_text_is_a_program_or_a_program_error(text):
    try:
        program = parse_program("G21\n" + text, source="fuzz")
    except ProgramError as exc:
        assert exc.line >= 1 and exc.word
        return
    for seg in program.path.segments:
        assert np.all(np.isfinite(seg.start)) and np.all(np.isfinite(seg.end))
