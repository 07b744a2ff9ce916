"""Part programs: the common milling subset of RS274/NGC G-code, parsed into a :class:`Path`.

``parse_program(text: str, *, source: str, units=None, rapid_feed=0.1, start=(0, 0, 0))
-> Program`` (``.path: Path``, ``.skips``, ``.units``, ``.events``).

What is read
------------
- motion, modal group 1: G0 (rapid), G1 (line), G2/G3 (clockwise/counter-clockwise arc
  in the XY plane, z linear along the arc: a helix), G80 (cancel a canned cycle: no-op);
- G17 (XY plane; G18/G19 are errors); G20/G21 (inch/mm; every length becomes metres);
  G90/G91 (absolute/incremental X Y Z); G91.1 (I J incremental from the arc's start,
  the default; G90.1 is an error); G94 (feed per minute, the default; G93/G95 are errors);
  G40 and G49 (compensation off: accepted, nothing to cancel);
- arcs by I/J (centre = start + (I, J)) or by R (|R| the radius; R > 0 the arc of at most
  180°, R < 0 the longer one; a full circle needs I/J);
- F: feed per minute in the program's unit, → m/s; modal; a G1/G2/G3 before any F is an
  error;
- G9 (exact stop at the end of this block) and G61/G64 (exact-stop mode on/off);
- comments ``( … )`` (not nested) and ``; …``, line numbers ``N…``, ``%`` delimiters;
- M0 M1 M2 M3 M4 M5 M6 M7 M8 M9 M30 M48 M49 M60: recorded in ``events``, never moves;
  M0/M1/M60 (pauses) stop the tool at the end of the last move; nothing after M2/M30 is
  read (a skip names the first line not read).

Modal rules: motion mode, units, distance mode, path mode and feed are modal; the words of
a block take effect in the RS274 order (feed, units, distance mode, then the motion), so
``G21 G91 G1 X1 F100`` is read as one block. Two words of one modal group, or one letter
twice, in a block are errors. Axis words with no motion mode in effect are an error. A
program that moves before it has said G20 or G21 is an error unless the caller gives
``units``.

What is skipped (listed in ``Program.skips``, never silently): G4 dwell (the path has
no dwell time), G54 (the work offset is taken as zero), S and T words (spindle speed and
tool number do not move the tool), zero-length moves, the text after M2/M30.

Everything else is an error (:class:`ProgramError`, naming the line and the word): G18,
G19, cutter compensation G41/G42, tool length offsets G43, canned cycles G73/G76/G81–G89,
G90.1, G93/G95, work offsets G55–G59 and G92, G28/G30 homing, G53, G10, G61.1, polar
and scaling modes, subroutines (O, M98/M99), parameters and expressions (#, [ ]),
block delete ``/``, axis words A B C U V W, words D H L P Q E, any other M code.

Untrusted input: the text is read, never executed; nothing names a file; at most
``MAX_PROGRAM_CHARS`` characters and ``MAX_LINE_CHARS`` per line; outside comments
only ASCII; numbers are plain decimals (no exponents), within ``MAX_COORDINATE``
program units.

Library choice (see docs/design.md, "Part programs"): pygcode 0.2.1 (last release 2017)
and nc-gcode-interpreter 0.1.9 (Sinumerik dialect; polars and pyarrow) both read G41 and G81
without complaint and produce a wrong path; gcodeparser 0.3.0 drops the words after a
``( )`` comment and has no modal groups. This module is our own.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from feedtune.machine.path import Arc, Line, Path

#: longest program read [characters]
MAX_PROGRAM_CHARS = 16_000_000
#: longest line [characters] (RS274/NGC interpreters allow 256)
MAX_LINE_CHARS = 4096
#: largest |number| in a program [program units]
MAX_COORDINATE = 1e6
#: metres per program unit
UNIT_METRES = {"mm": 1e-3, "inch": 0.0254}
#: how far the end of an I/J arc may lie off the start's circle [program units]: 0.002 mm,
#: 0.0002 inch (a 3-decimal mm or 4-decimal inch program's rounding of end and centre)
ARC_RADIUS_TOLERANCE = {"mm": 0.002, "inch": 0.0002}
#: an I/J arc whose end is within ``ARC_RADIUS_TOLERANCE`` of its start is a full circle
#: only if that chord also subtends less than 1° (chord/radius < 2 sin 0.5°); otherwise
#: (a circle of a few resolution steps) it is the short arc as written
FULL_CIRCLE_CHORD = 2 * math.sin(math.radians(0.5))

_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)
_MOTION = {0: "G0", 10: "G1", 20: "G2", 30: "G3"}
#: modal groups of the G codes read (value ×10 → group)
_GROUPS = {0: "motion", 10: "motion", 20: "motion", 30: "motion", 800: "motion",
           170: "plane", 200: "units", 210: "units", 900: "distance", 910: "distance",
           911: "arc distance", 940: "feed mode", 400: "cutter compensation",
           490: "tool length", 610: "path mode", 640: "path mode",
           40: "non-modal", 90: "non-modal", 540: "coordinate system"}
_UNSUPPORTED_G = {
    180: "the XZ plane (only G17)", 190: "the YZ plane (only G17)",
    410: "cutter compensation", 411: "cutter compensation", 420: "cutter compensation",
    421: "cutter compensation", 430: "tool length offset", 431: "tool length offset",
    432: "tool length offset", 901: "absolute arc centres (G90.1)",
    930: "inverse-time feed", 950: "feed per revolution", 611: "exact path mode",
    920: "coordinate offset", 921: "coordinate offset", 922: "coordinate offset",
    923: "coordinate offset", 280: "homing move", 281: "homing move", 300: "homing move",
    301: "homing move", 530: "machine coordinates", 100: "data setting (G10)",
    150: "polar coordinates", 160: "polar coordinates", 500: "scaling", 510: "scaling",
    680: "coordinate rotation", 690: "coordinate rotation",
}
_CANNED = {730, 760, *range(810, 900, 10)}
_EVENT_M = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 30, 48, 49, 60}
_PAUSE_M = {0, 1, 60}


class ProgramError(ValueError):
    """A part program that cannot be read into a path: ``line`` (1-based) and ``word``."""

    def __init__(self, source: str, line: int, word: str, message: str):
        self.source, self.line, self.word = source, line, word
        super().__init__(f"{source}:{line}: {word}: {message}")


@dataclass(frozen=True)
class Skip:
    """Something in the program that does not become path: where, which word, and why."""

    line: int
    word: str
    reason: str


@dataclass(frozen=True)
class Event:
    """An M code that does not move the tool (spindle, coolant, tool change, stop, end)."""

    line: int
    word: str


@dataclass(frozen=True, eq=False)
class Program:
    """A parsed part program.

    Attributes
    ----------
    source : str
        Where the text came from (for messages only; never opened).
    path : Path
        The programmed moves in metres, feeds in m/s, rapids flagged.
    units : str
        "mm" or "inch": the units of the program's first move (a program without moves:
        the units last in effect, "mm" if it never said).
    skips : tuple of Skip
        What was read but does not become path.
    events : tuple of Event
        The M codes, in order.
    """

    source: str
    path: Path
    units: str
    skips: tuple[Skip, ...]
    events: tuple[Event, ...]


def _code(value: float) -> int:
    """A G/M number ×10 as an integer (G91.1 → 911), or -1 when it has more decimals."""
    scaled = round(value * 10)
    return scaled if abs(value * 10 - scaled) < 1e-9 else -1


def _name(letter: str, code: int) -> str:
    return f"{letter}{code // 10}" + (f".{code % 10}" if code % 10 else "")


_COMMENT = re.compile(r"\([^()]*\)|;.*|[()]")
_LINE = re.compile(r"(?:[A-Z][+-]?(?:\d+\.?\d*|\.\d+))*", re.ASCII)


def _strip_comments(raw: str, fail) -> str:
    """The line without comments and blanks (RS274 ignores spaces), upper case."""

    def drop(m: re.Match) -> str:
        text = m.group(0)
        if text == "(":
            rest = raw[m.end():]
            fail("(", "nested comment" if ")" in rest and "(" in rest.split(")")[0]
                 else "comment not closed on its line")
        if text == ")":
            fail(")", "')' without '('")
        return ""

    if "(" in raw or ")" in raw or ";" in raw:
        raw = _COMMENT.sub(drop, raw)
    if not raw.isascii():
        # before upper(): "ı".upper() is "I", and \d would take other scripts' digits
        bad = next(ch for ch in raw if not ch.isascii())
        fail(bad, "a character outside ASCII (only comments may hold one)")
    return "".join(raw.split()).upper()


def _words(text: str, fail) -> list[tuple[str, float, str]]:
    """(letter, value, as written) for every word of a comment-free line."""
    if _LINE.fullmatch(text):
        matches = _WORD.finditer(text)
    else:
        matches = []
        pos = 0
        while pos < len(text):
            m = _WORD.match(text, pos)
            if m is None:
                bad = re.match(r".[^A-Z]*", text[pos:]).group(0)[:24]
                what = ("parameters and expressions are not read" if bad[0] in "#[]="
                        else "block delete is not read" if bad[0] == "/"
                        else "not a word (a letter and a plain decimal number)")
                fail(bad, what)
            matches.append(m)
            if m.group(1) == "O":
                break  # refused below, before the text that follows it
            pos = m.end()
    words = []
    for m in matches:
        if m.group(1) == "O":
            fail(m.group(0), "subroutines and program numbers (O words) are not read")
        value = float(m.group(2))
        if not abs(value) <= MAX_COORDINATE:
            fail(m.group(0), f"|value| above {MAX_COORDINATE:g}")
        words.append((m.group(1), value, m.group(0)))
    return words


def parse_program(text: str, *, source: str, units: str | None = None,
                  rapid_feed: float = 0.1, start=(0.0, 0.0, 0.0)) -> Program:
    """Read a part program into a path.

    Parameters
    ----------
    text : str
        The program (untrusted; at most ``MAX_PROGRAM_CHARS`` characters).
    source : str
        A name for messages (a file name); never opened.
    units : {"mm", "inch"} or None
        Units in effect before the program's own G20/G21; None: the program must say
        G20 or G21 before its first move.
    rapid_feed : float
        Feed of G0 moves [m/s] (the machine's rapid traverse rate).
    start : sequence of 3 floats
        Tool position [m] when the program starts.

    Returns
    -------
    Program

    Raises
    ------
    ProgramError
        For anything the module docstring lists as an error, naming line and word.
    """
    if len(text) > MAX_PROGRAM_CHARS:
        raise ProgramError(source, 0, "program", f"longer than {MAX_PROGRAM_CHARS} characters")
    if units is not None and units not in UNIT_METRES:
        raise ValueError(f"units must be 'mm' or 'inch', got {units!r}")
    if not (math.isfinite(rapid_feed) and rapid_feed > 0):
        raise ValueError(f"rapid_feed must be a positive speed [m/s], got {rapid_feed!r}")
    position = tuple(float(v) for v in np.asarray(start, dtype=float).reshape(3))
    unit = units
    first_units = None
    absolute = True
    motion: int | None = None
    feed: float | None = None  # m/s
    exact_mode = False
    segments: list[Line | Arc] = []
    skips: list[Skip] = []
    events: list[Event] = []
    ended = False

    for number, raw in enumerate(text.splitlines(), start=1):
        def fail(word: str, message: str, number=number):
            raise ProgramError(source, number, word, message)

        if len(raw) > MAX_LINE_CHARS:
            fail("line", f"longer than {MAX_LINE_CHARS} characters")
        line = _strip_comments(raw, fail)
        if not line or line == "%":
            continue
        if ended:
            skips.append(Skip(number, line[:12], "after the program end (M2/M30): not read"))
            break
        words = _words(line, fail)
        if words and words[0][0] == "N":
            words = words[1:]
        seen: dict[str, str] = {}
        groups: dict[str, str] = {}
        gcodes: list[int] = []
        mcodes: list[int] = []
        axes: dict[str, float] = {}
        for letter, value, written in words:
            if letter == "G":
                code = _code(value)
                if code in _CANNED:
                    fail(written, "canned cycles are not read")
                if code in _UNSUPPORTED_G:
                    fail(written, f"{_UNSUPPORTED_G[code]} is not read")
                if code not in _GROUPS:
                    fail(written, "G code not read")
                group = _GROUPS[code]
                if group in groups:
                    fail(written, f"a second {group} word in one block ({groups[group]})")
                groups[group] = written
                gcodes.append(code)
                continue
            if letter == "M":
                code = _code(value)
                if code % 10 or code // 10 not in _EVENT_M:
                    fail(written, "M code not read (subroutines, macros and "
                                  "machine-specific M codes are not supported)")
                mcodes.append(code // 10)
                continue
            if letter == "N":
                fail(written, "a line number must be the first word")
            if letter in seen:
                fail(written, f"{letter} given twice in one block ({seen[letter]})")
            seen[letter] = written
            if letter in "XYZIJRF":
                axes[letter] = value
            elif letter in "ST":
                skips.append(Skip(number, written, "spindle speed and tool number do not "
                                                  "move the tool"))
            elif letter == "K":
                fail(written, "K is an arc centre offset of G18/G19: only G17 is read")
            elif letter != "P":  # P: a G4 dwell's time, checked below
                fail(written, "word not read")

        # non-motion modal words, in the RS274 order of execution
        feed_value = axes.pop("F", None)
        if 200 in gcodes or 210 in gcodes:
            unit = "inch" if 200 in gcodes else "mm"
        if feed_value is not None:
            if unit is None:
                fail(seen["F"], "a feed before G20/G21: its unit is unknown")
            if feed_value <= 0:
                fail(seen["F"], "feed must be positive")
            feed = feed_value * UNIT_METRES[unit] / 60.0
        if 40 in gcodes:
            skips.append(Skip(number, groups["non-modal"] + seen.get("P", ""),
                              "dwell: the path has no dwell time"))
        elif "P" in seen:
            fail(seen["P"], "word not read")
        if 540 in gcodes:
            skips.append(Skip(number, groups["coordinate system"],
                              "work offset taken as zero"))
        if 900 in gcodes or 910 in gcodes:
            absolute = 900 in gcodes
        if 610 in gcodes or 640 in gcodes:
            exact_mode = 610 in gcodes
        block_motion = next((c for c in gcodes if _GROUPS[c] == "motion"), None)
        if block_motion is not None:
            motion = None if block_motion == 800 else block_motion
        exact_block = 90 in gcodes

        moves = {k: v for k, v in axes.items() if k in "XYZIJR"}
        if moves:
            if motion is None:
                fail(next(seen[k] for k in "XYZIJR" if k in moves),
                     "axis words with no motion mode (G0/G1/G2/G3) in effect")
            if unit is None:
                fail(_MOTION[motion], "a move before G20/G21: its unit is unknown")
            first_units = first_units or unit
            scale = UNIT_METRES[unit]
            target = tuple(position[axis] if k not in moves
                           else moves[k] * scale + (0.0 if absolute else position[axis])
                           for axis, k in enumerate("XYZ"))
            name = _MOTION[motion]
            if motion in (0, 10):
                for k in "IJR":
                    if k in moves:
                        fail(seen[k], f"{k} has no meaning in {name}")
            if motion == 0:
                speed = rapid_feed
            else:
                if feed is None:
                    fail(name, "a feed move before any F")
                speed = feed
            stop = exact_block or exact_mode
            if motion in (0, 10):
                if target == position:
                    skips.append(Skip(number, name, "zero-length move"))
                else:
                    segments.append(Line(position, target, speed, rapid=motion == 0,
                                         source_line=number, exact_stop=stop))
            else:
                chord = math.hypot(target[0] - position[0], target[1] - position[1])
                radius = math.hypot(moves.get("I", 0.0), moves.get("J", 0.0)) * scale
                if "R" not in moves and chord <= ARC_RADIUS_TOLERANCE[unit] * scale \
                        and chord <= FULL_CIRCLE_CHORD * radius:
                    # a full circle whose end is off its start by rounding (an absolute end
                    # after incremental sums): the end is the start, or the arc's sweep
                    # would be the tiny angle between them. A chord that is short only
                    # because the circle is (a radius near the program's resolution) is
                    # an arc as written, as LinuxCNC reads it
                    target = (position[0], position[1], target[2])
                center = _arc_centre(position, target, moves, seen, motion == 30, unit, fail)
                try:
                    segments.append(Arc(position, target, center, ccw=motion == 30, feed=speed,
                                        source_line=number, exact_stop=stop))
                except ValueError as exc:
                    fail(name, str(exc))
            position = target
        elif exact_block:
            fail(groups["non-modal"], "G9 without a move")

        for m in mcodes:
            events.append(Event(number, f"M{m}"))
            if m in _PAUSE_M and segments:
                segments[-1] = _with_stop(segments[-1])
            if m in (2, 30):
                ended = True

    if first_units is None:
        first_units = unit or "mm"
    return Program(source=source, path=Path(tuple(segments)), units=first_units,
                   skips=tuple(skips), events=tuple(events))


def _with_stop(seg: Line | Arc) -> Line | Arc:
    if isinstance(seg, Line):
        return Line(seg.start, seg.end, seg.feed, rapid=seg.rapid,
                    source_line=seg.source_line, exact_stop=True)
    return Arc(seg.start, seg.end, seg.center, ccw=seg.ccw, feed=seg.feed,
               source_line=seg.source_line, exact_stop=True)


def _arc_centre(start: tuple, end: tuple, moves: dict, seen: dict, ccw: bool,
                unit: str, fail) -> tuple[float, float, float]:
    """The arc's centre [m] from I/J (incremental from the start) or R.

    With I/J the end may lie off the start's circle by ``ARC_RADIUS_TOLERANCE`` (program
    rounding); the centre is then moved to the nearest point of the chord's perpendicular
    bisector when that is at most the same tolerance away, so that start and end share
    one circle.
    """
    scale = UNIT_METRES[unit]
    tolerance = ARC_RADIUS_TOLERANCE[unit] * scale
    name = "G3" if ccw else "G2"
    dx, dy = end[0] - start[0], end[1] - start[1]
    half = 0.5 * math.hypot(dx, dy)
    mx, my = 0.5 * (start[0] + end[0]), 0.5 * (start[1] + end[1])
    if "R" in moves:
        if "I" in moves or "J" in moves:
            fail(seen["R"], "an arc takes R or I/J, not both")
        radius = moves["R"] * scale
        if half == 0:
            fail(seen["R"], "a full circle cannot be given by R (use I/J)")
        if abs(radius) < half:
            if half - abs(radius) > tolerance:
                fail(seen["R"], f"radius {abs(radius):.6g} m is less than half the chord "
                                f"{half:.6g} m")
            radius = math.copysign(half, radius)
        h = math.sqrt(max(radius * radius - half * half, 0.0))
        # the short arc (R > 0) turns about a centre on its own side of the chord: left
        # of start → end for G3, right for G2; R < 0 takes the other side
        side = (1.0 if ccw else -1.0) * (1.0 if radius > 0 else -1.0)
        k = side * h / (2 * half)
        return (mx - k * dy, my + k * dx, 0.0)
    if "I" not in moves and "J" not in moves:
        fail(name, "an arc needs I/J or R")
    cx = start[0] + moves.get("I", 0.0) * scale
    cy = start[1] + moves.get("J", 0.0) * scale
    r0 = math.hypot(start[0] - cx, start[1] - cy)
    r1 = math.hypot(end[0] - cx, end[1] - cy)
    if r0 == 0:
        fail(name, "arc centre at its start point")
    if abs(r1 - r0) > tolerance:
        fail(name, f"end is {r1:.9g} m from the centre, start {r0:.9g} m: not one circle")
    if half > 0 and r1 != r0:
        # onto the chord's perpendicular bisector, if that moves the centre within the
        # rounding; a chord far shorter than the radius (a full circle whose end is off
        # its start by float rounding) would send it far, so it stays, and the arc's
        # own check (radii within 1e-9 m + 1e-6 R) decides
        ux, uy = dx / (2 * half), dy / (2 * half)
        shift = (cx - mx) * ux + (cy - my) * uy
        if abs(shift) <= tolerance:
            cx, cy = cx - ux * shift, cy - uy * shift
    return (cx, cy, 0.0)
