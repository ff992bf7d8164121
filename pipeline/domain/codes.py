"""EN 13508-2 observation codes: characterisations, quantification units, and what pipegauge measures.

Source: EN 13508-2:2003+A1:2011 clause 8 as summarised in ../shared/DESIGN.md
section 4 and the coding notes beside it (RIONED, VSA-KEK 2020, DWA/ISYBAU
tables). The standard is a paid document: where a utility's catalogue
differs, this table is the one place to change.

Each quantification says its unit and, when pipegauge measures it from the
two points marked in the image, its *method* (a key of
``pipeline.measurement.methods.METHODS``):

* ``length``: distance between two wall points [mm] (break length; the
  width of a crack whose shape does not say the width's direction);
* ``around``: extent around the pipe between two wall points, in the
  cross-section (a longitudinal crack's width, a connection's height) [mm];
* ``axial``: distance along the pipe axis between two wall points
  (longitudinal joint displacement, a circumferential crack's width, a
  connection's width) [mm];
* ``step``: from a wall point to a point displaced off the wall in the same
  cross-section (radial joint displacement) [mm];
* ``deformation``: reduction of the vertical (char. A) or horizontal (B)
  dimension, % of the pipe's dimension;
* ``intrusion``: intruding connection, from the wall to the tip, % of the
  pipe height;
* ``water_level``: the water line's chord, % of the vertical dimension;
* ``deposit_area``: the deposit surface's chord, % of the cross-sectional area.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

__all__ = ["Quantification", "Code", "CODES", "UNITS", "code_spec", "quantification", "plain_description"]

UNITS = ("mm", "%", "deg", "count")
ANY = "*"


@dataclass(frozen=True)
class Quantification:
    """What a quantification of a code means: its unit and how it is measured in the image."""

    unit: str
    meaning: str
    method: str | None = None
    by_char2: Mapping[str, str] = field(default_factory=dict)   # characterisation 2 -> method, where it says the direction

    def method_for(self, char2: str = "") -> str | None:
        """The method for an observation with characterisation 2 ``char2`` (a crack's shape says its width's direction)."""
        return self.by_char2.get(char2, self.method)


@dataclass(frozen=True)
class Code:
    """One main code of EN 13508-2.

    char1, char2 : allowed characterisation letters -> meaning (empty: none is coded)
    q1, q2 : quantification per characterisation 1 (key ``"*"`` for any)
    continuous : whether it may be coded as a continuous defect (S/F markers)
    char1_optional : characterisation 1 may be left empty (a national catalogue adds letters EN 13508-2 lacks)
    changes_geometry : the record changes the header's profile or pipe units from its distance on (VSA-KEK AEC, AEF)
    """

    code: str
    name: str
    char1: Mapping[str, str] = field(default_factory=dict)
    char2: Mapping[str, str] = field(default_factory=dict)
    q1: Mapping[str, Quantification] = field(default_factory=dict)
    q2: Mapping[str, Quantification] = field(default_factory=dict)
    continuous: bool = True
    char1_optional: bool = False
    changes_geometry: bool = False

    def quantification(self, which: str, char1: str) -> Quantification | None:
        """The quantification ``"Q1"`` or ``"Q2"`` for a characterisation 1, or None when the code has none."""
        table = self.q1 if which == "Q1" else self.q2
        return table.get(char1, table.get(ANY))


def _q(unit: str, meaning: str, method: str | None = None, by_char2: Mapping[str, str] | None = None) -> Quantification:
    return Quantification(unit, meaning, method, MappingProxyType(dict(by_char2 or {})))


# A longitudinal crack's width runs around the pipe, a circumferential crack's along it; the other shapes do not say.
_CRACK_WIDTH = {"A": "around", "B": "axial"}


_AREA = _q("%", "reduction of the cross-sectional area")
_CRACK_CHARS = {"A": "surface crack", "B": "crack", "C": "open crack"}
# Characterisation texts from ../shared/EN13508-2-notes.md, section 2.2 (DWA/ISYBAU tables, VSA-KEK 2020); a
# letter the code allows whose text the notes do not give maps to "" and is left out of the description.
_SURFACE = {"A": "increased roughness", "B": "spalling", "C": "aggregate visible", "D": "aggregate projecting",
            "E": "aggregate missing", "F": "reinforcement visible", "G": "reinforcement projecting",
            "H": "reinforcement corroded", "I": "missing wall", "J": "corrosion products", "K": "bulge", "Z": "other"}
_CRACK_SHAPES = {"A": "longitudinal", "B": "circumferential", "C": "complex", "D": "spiral", "E": "star"}

_TABLE: tuple[Code, ...] = (
    Code("BAA", "deformation", {"A": "vertical", "B": "horizontal"},
         q1={ANY: _q("%", "change of the dimension in the characterised direction", "deformation")}),
    Code("BAB", "crack", _CRACK_CHARS, _CRACK_SHAPES,
         q1={"B": _q("mm", "crack width", "length", _CRACK_WIDTH), "C": _q("mm", "crack width", "length", _CRACK_WIDTH)}),
    Code("BAC", "break or collapse", {"A": "break", "B": "missing pieces", "C": "collapse"},
         q1={ANY: _q("mm", "length of the break", "length")}),
    Code("BAD", "defective brickwork", {"A": "displaced bricks", "B": "missing bricks", "C": "dropped invert", "D": "collapsed"},
         q1={"C": _q("mm", "drop of the invert")}),
    Code("BAE", "missing mortar", q1={ANY: _q("mm", "depth of the missing mortar")}),
    Code("BAF", "surface damage", _SURFACE, {"A": "mechanical", "B": "chemical", "C": "chemical above the water line",
                                          "D": "chemical at the water line", "E": "chemical below the water line",
                                          "Z": "other cause"}),
    Code("BAG", "intruding connection", q1={ANY: _q("%", "intrusion, % of the pipe height", "intrusion")},
         continuous=False),
    Code("BAH", "defective connection", {"A": "position incorrect", "B": "protrudes partly", "C": "incomplete",
                                     "D": "damaged", "E": "blocked", "Z": "other"}, continuous=False),
    Code("BAI", "intruding sealing material", {"A": "sealing ring", "Z": "other"},
         {"A": "intruding", "B": "hanging above the axis", "C": "hanging below the axis", "D": "broken"},
         q1={"Z": _AREA}, continuous=False),
    Code("BAJ", "displaced joint", {"A": "longitudinal", "B": "radial", "C": "angular"},
         q1={"A": _q("mm", "longitudinal displacement (gap)", "axial"),
             "B": _q("mm", "radial displacement (step)", "step"),
             "C": _q("deg", "angular displacement")}, continuous=False),
    Code("BAK", "lining defect", {"A": "detached", "B": "discoloured", "C": "defective end", "D": "wrinkled",
                              "E": "blistered", "F": "service cut defective", "G": "", "Z": "other"}),
    Code("BAL", "defective repair", {"A": "wall missing", "B": "hole", "C": "failed patch", "D": "", "Z": "other"}),
    Code("BAM", "weld failure", {"A": "longitudinal", "B": "circumferential", "C": "spiral"}),
    Code("BAN", "porous pipe"),
    Code("BAO", "soil visible through defect", continuous=False),
    Code("BAP", "void visible through defect", continuous=False),
    Code("BBA", "roots", {"A": "tap root", "B": "fine roots", "C": "complex roots"}, q1={ANY: _AREA}),
    Code("BBB", "attached deposits", {"A": "encrustation", "B": "grease", "C": "fouling", "Z": "other"}, q1={ANY: _AREA}),
    Code("BBC", "settled deposits", {"A": "fine (sand)", "B": "coarse (gravel)", "C": "hard or compacted", "Z": "other"},
         q1={ANY: _q("%", "reduction of the cross-sectional area", "deposit_area")}),
    Code("BBD", "ingress of soil", {"A": "sand", "B": "peat", "C": "fine material", "D": "coarse material", "Z": "other"},
         q1={ANY: _AREA}),
    Code("BBE", "other obstacles", {**{c: "" for c in "ABCDEFGH"}, "Z": "other"}, q1={ANY: _AREA}),
    Code("BBF", "infiltration", {"A": "seeping", "B": "dripping", "C": "running", "D": "gushing"}),
    Code("BBG", "exfiltration"),
    Code("BBH", "vermin", {"A": "rat", "B": "cockroach", "Z": "other"}, {"A": "in pipe", "B": "in connection", "C": "in joint", "Z": "other"},
         q1={ANY: _q("count", "number of animals")}, continuous=False),
    Code("BCA", "connection", {"A": "fitting", "B": "junction", **{c: "" for c in "CDEFG"}, "Z": "other"},
         {"A": "open", "B": "closed"},
         q1={ANY: _q("mm", "height of the opening (around the pipe)", "around")},
         q2={ANY: _q("mm", "width of the opening (along the pipe)", "axial")}, continuous=False),
    Code("BCB", "point repair", {"A": "pipe replaced", **{c: "" for c in "BCDEFGHI"}, "Z": "other"}),
    Code("BCC", "curvature", {"A": "left", "B": "right"}, {"A": "up", "B": "down"},
         q1={ANY: _q("deg", "angle of the bend")}),
    Code("BCD", "start node", continuous=False),
    Code("BCE", "finish node", continuous=False),
    Code("BDA", "general photograph", continuous=False),
    # VSA-KEK codes the kind of a general remark (BDBA start of the survey ... BDBM); EN 13508-2 has none
    Code("BDB", "general remark", {c: "" for c in "ABCDEFGHIJKLM"}, continuous=False,
         char1_optional=True),
    Code("BDC", "survey abandoned", {"A": "obstruction", "B": "water level too high", "C": "equipment failure",
                                 "Z": "other reason"}, continuous=False),
    Code("BDD", "water level", {"A": "clear", "B": "discontinued", "C": "turbid", "D": "coloured", "E": "turbid and coloured"},
         q1={ANY: _q("%", "water level, % of the vertical dimension", "water_level")}),
    Code("BDE", "flow from incoming pipe", {**{c: "" for c in "ABCDE"}, "Y": "misconnection"},
         q1={ANY: _q("%", "flow, % of the incoming pipe's height")},
         continuous=False),
    Code("BDF", "atmosphere", {"A": "oxygen deficiency", "B": "hydrogen sulphide", "C": "methane", "Z": "other"}),
    Code("BDG", "loss of vision", {"A": "camera under water", "B": "silt", "C": "steam", "Z": "other"}),
)

# Swiss VSA-KEK in-line header changes (EN13508-2-notes 2.4, seen in the TEKSI transfer): X, then the new profile
# or material letter of the VSA catalogue; AEF gives the new pipe unit length. Q1 units are VSA's usage as read in
# that transfer (AEC 300 for a 300 mm profile, AEF 2000 for 2 m units) [uncertain: not in EN 13508-2].
_TABLE += (
    Code("AEC", "change of profile (VSA-KEK)", {"X": ""}, {c: "" for c in "ABCDEFGH"},
         q1={ANY: _q("mm", "height of the new profile")}, continuous=False, changes_geometry=True),
    Code("AED", "change of material (VSA-KEK)", {"X": ""}, {c: "" for c in "ABCDEFGHIJKLMNOPQRSTUVWX"},
         continuous=False),
    Code("AEF", "new pipe unit length (VSA-KEK)", q1={ANY: _q("mm", "length of the new pipe units")}, continuous=False,
         changes_geometry=True),
)

CODES: Mapping[str, Code] = MappingProxyType({c.code: c for c in _TABLE})


def code_spec(code: str) -> Code | None:
    """The table entry of a main code (upper case), or None when the code is unknown."""
    return CODES.get(code)


def plain_description(code: str, char1: str | None = None, char2: str | None = None) -> str:
    """An observation in EN 13508-2 words: BAB B A -> 'crack, longitudinal', BCA A A -> 'connection, fitting, open'.

    A characterisation that names the defect itself replaces the code's name (BAB C: 'open crack'); one whose
    text the table lacks is left out.
    """
    spec = CODES.get(code)
    if spec is None:
        return f"unknown code {code}"
    first = spec.char1.get(char1 or "")
    parts = [first if first and spec.name in first else spec.name]
    if first and spec.name not in first:
        parts.append(first)
    second = spec.char2.get(char2 or "")
    if second:
        parts.append(second)
    return ", ".join(parts)


def quantification(code: str, which: str, char1: str) -> Quantification | None:
    """The quantification Q1/Q2 of ``code`` with characterisation 1 ``char1``, or None."""
    spec = CODES.get(code)
    return spec.quantification(which, char1) if spec else None
