"""Error codes of the interpreter, and the exception a block check raises.

Every diagnostic prints as `file:line:col: error[CODE]: message` (ipr.entities.Diagnostic).
The codes are stable: tests and users may match on them. docs/gcode-errors.md has the
same table with examples.

| code                 | meaning                                                                  |
|----------------------|--------------------------------------------------------------------------|
| E-SYNTAX             | the line does not follow the grammar (ipr/gcode.lark)                    |
| E-GCODE-UNSUPPORTED  | a G-code vcnc does not implement (G41, G93, G28, G81, ...)               |
| E-MCODE-UNSUPPORTED  | an M-code vcnc does not implement                                        |
| E-WORD-REPEATED      | a letter other than G or M appears twice in one block                    |
| E-MODAL-GROUP        | two codes of one modal group in one block                                |
| E-AXIS-CONFLICT      | two codes in one block both want the axis words (G92 with a motion)      |
| E-WORD-UNUSED        | a word no code of the block uses (I with G1, H without G43, ...)         |
| E-WORD-MISSING       | a code lacks a word it needs (G4 without P, G5.2 with X but no Y, ...)   |
| E-VALUE              | a word's value is out of range (negative F, non-integer T, P turns, ...) |
| E-NO-MOTION-MODE     | axis words while no motion mode is active (after G80)                    |
| E-FEED-ZERO          | a feed move (G1, G2, G3, NURBS) while the feed rate is zero              |
| E-G53                | G53 without G0/G1, or in G91                                             |
| E-PARAM              | a parameter number out of range, or an unset named parameter read        |
| E-EXPR               | an expression has no value (division by zero, SQRT of a negative, ...)   |
| E-EXPR-TOO-DEEP      | an expression nested more than 100 levels (brackets, operators, signs)   |
| E-OWORD              | an O-word line that is malformed or out of place (endsub without sub,    |
|                      | else without if, a loop or if never closed, M99 ending the main program) |
| E-SUB-NOT-FOUND      | a call (o<name> call, M98 P) to a subroutine found in no file            |
| E-LOOP-LIMIT         | loops ran more iterations than the limit (default 10,000,000)            |
| E-CALL-DEPTH         | subroutine calls nested deeper than the limit (default 9, as rs274)      |
| E-ARC-FORMAT         | an arc with both R and I/J/K, neither, or an offset of the wrong plane   |
| E-ARC-RADIUS         | the arc end point is off the circle through the start point              |
| E-ARC-R-FULL         | a radius-format arc whose end is its start (a full circle needs I/J/K)   |
| E-ARC-R-SMALL        | the radius is smaller than half the distance from start to end           |
| E-NURBS-ORDER        | NURBS order (P for G6.2, L for G5.2) outside 2..6                        |
| E-NURBS-WEIGHT       | a NURBS weight (R for G6.2, P for G5.2) that is not > 0                  |
| E-NURBS-START        | the first control point is not the current position (within 0.001 mm)   |
| E-NURBS-KNOT-COUNT   | knots != control points + order                                          |
| E-NURBS-KNOT-ORDER   | a knot smaller than the one before                                       |
| E-NURBS-KNOT-CLAMP   | the first or the last `order` knots are not all equal, or an end value  |
|                      | is repeated more than `order` times                                      |
| E-NURBS-KNOT-MULT    | an interior knot repeated `order` times or more                          |
| E-NURBS-POINTS       | fewer control points than the order                                      |
| E-NURBS-BLOCK        | a block inside a NURBS group that is not a control-point or knot block   |
| E-NURBS-INCOMPLETE   | a NURBS group that ends (G0..G3, G5.3 missing, end of file) unfinished   |
| E-AXIS-ABSENT        | an axis word (A, B, C, U, V, W) of an axis the machine does not have     |
| E-CYCLE              | a canned cycle lacks R/Z/Q/P, has R below Z, L0, Q <= 0, or runs in G93 |
|                      | or under cutter compensation                                             |
| E-SPINDLE            | a cycle needs the spindle turning (G86, G88) or turning the right way    |
|                      | (G84 clockwise, G74 counter-clockwise)                                   |
| E-OFFSET             | G10 without L/P or with an L/P out of range; G28.1/G30.1 with axis words |
| E-FEED-MODE          | G93 move without F; G95 with spindle speed zero                          |
| E-MCODE-USER         | M100..M199 that the machine file does not name                           |
| E-COMP               | cutter compensation: no tool radius, not G17, an entry move or arc not    |
|                      | longer than the radius, a tool larger than an arc, a gouge in a concave  |
|                      | corner, an arc right after G40, G10/G28/G30/G53/G92 while it is on      |
| E-DIALECT            | a line of another kind than G-code: grbl's `$` sender commands            |

Warnings and notices (severity "warning"/"notice", never stop a program):

| code                 | meaning                                                                  |
|----------------------|--------------------------------------------------------------------------|
| E-POLAR              | @/^ (polar coordinates) with X or Y, outside G17, with G53 or a code that |
|                      | takes axis words, with NURBS/splines, or at the origin where undefined   |
| W-TOOL-UNKNOWN       | G43 H or M6 T names a tool missing from the tool table: zero offset      |
| N-Q-IGNORED          | the Q word of LinuxCNC's G6.2 (its output method) is ignored             |
| N-RECORDED           | a code the virtual machine records but does not act on (M19 orient,      |
|                      | M48..M53 override switches, M62..M68 I/O, G96 surface speed, dialect     |
|                      | bookkeeping M-codes such as Haas M31)                                    |
| N-KNOCK-ON           | errors suppressed because they follow from an earlier refused block      |
"""
from __future__ import annotations

CODES = (
    "E-SYNTAX", "E-GCODE-UNSUPPORTED", "E-MCODE-UNSUPPORTED",
    "E-WORD-REPEATED", "E-MODAL-GROUP", "E-AXIS-CONFLICT", "E-WORD-UNUSED", "E-WORD-MISSING",
    "E-VALUE", "E-NO-MOTION-MODE", "E-FEED-ZERO", "E-G53", "E-PARAM", "E-EXPR",
    "E-EXPR-TOO-DEEP", "E-OWORD", "E-SUB-NOT-FOUND", "E-LOOP-LIMIT", "E-CALL-DEPTH",
    "E-ARC-FORMAT", "E-ARC-RADIUS", "E-ARC-R-FULL", "E-ARC-R-SMALL",
    "E-NURBS-ORDER", "E-NURBS-WEIGHT", "E-NURBS-START", "E-NURBS-KNOT-COUNT",
    "E-NURBS-KNOT-ORDER", "E-NURBS-KNOT-CLAMP", "E-NURBS-KNOT-MULT", "E-NURBS-POINTS",
    "E-NURBS-BLOCK", "E-NURBS-INCOMPLETE",
    "E-AXIS-ABSENT", "E-CYCLE", "E-SPINDLE", "E-OFFSET", "E-FEED-MODE", "E-MCODE-USER", "E-DIALECT", "E-COMP",
    "E-POLAR",
    "W-TOOL-UNKNOWN", "N-Q-IGNORED", "N-RECORDED", "N-KNOCK-ON",
)


class BlockError(Exception):
    """A block is wrong. `word` is the index (in Block.words) of the offending word, or
    None for the block as a whole (column 1); `col` overrides it when known; `line`
    overrides the block's own line (an incomplete NURBS group names its first line)."""

    def __init__(self, code: str, message: str, word: int | None = None, *,
                 col: int | None = None, line: int | None = None):
        assert code in CODES, code
        super().__init__(message)
        self.code = code
        self.message = message
        self.word = word
        self.col = col
        self.line = line


def code_name(letter: str, value: float) -> str:
    """'G41', 'G6.2', 'M30': a code as a machinist writes it."""
    text = f"{value:.4f}".rstrip("0").rstrip(".")
    return f"{letter}{text}"
