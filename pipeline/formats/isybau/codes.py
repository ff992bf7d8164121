"""ISYBAU's names and coded values (the reference lists, ``1302-referenzlisten.xsd``), each mapped to pipegauge's.

One table per coded element. A value a table does not hold is a problem of its section, named with its element
and the fix, never a guess (``pipeline.formats.isybau.read``). docs/formats.md shows these tables.
"""

from __future__ import annotations

__all__ = ["FORMAT_NAME", "NAMESPACES", "VERSIONS", "ANLAGENTYP", "KIND_OF", "DIRECTIONS", "PROFILES", "MATERIALS",
           "EN13508_CODING", "CONTINUOUS", "FPS_RANGE"]

FORMAT_NAME = "isybau-xml"

# The namespace of the root element Identifikation, by format version's year.
NAMESPACES = {
    "2006": "http://www.ofd-hannover.la/Identifikation",
    "2013": "http://www.ofd-hannover.la/Identifikation",
    "2017": "http://www.bfr-abwasser.de",
}
VERSIONS = tuple(NAMESPACES)

# Anlagentyp: the kind of inspected object.
ANLAGENTYP = {"1": "Haltung", "2": "Anschlussleitung", "3": "Schacht", "4": "Bauwerk"}
KIND_OF = {"1": "pipe", "2": "lateral", "3": "manhole"}            # Bauwerk (4): read, said, not a log

# Inspektionsrichtung: O "von oben, in Fliessrichtung", U "von unten, gegen Fliessrichtung".
DIRECTIONS = {"O": "downstream", "U": "upstream"}

# Profilart: the cross-sections pipegauge measures (pipeline.maths.profiles.SHAPES). Egg with H/B other than 3/2
# (6), mouth, rectangular... are read, their sections measured only when delivery.json gives a shape.
PROFILES = {"0": "circular", "1": "egg"}
PROFILE_NAMES = {"0": "Kreisprofil", "1": "Eiprofil (H/B=3/2)", "2": "Maulprofil (H/B=1,66/2)",
                 "3": "Rechteckprofil (geschlossen)", "4": "Kreisprofil (doppelwandig)", "5": "Rechteckprofil (offen)",
                 "6": "Eiprofil (H/B ungleich 3/2)", "7": "Maulprofil (H/B ungleich 1,66/2)", "8": "Trapezprofil",
                 "9": "Doppeltrapezprofil", "10": "U-foermig", "11": "Bogenfoermig", "12": "oval",
                 "13": "andere Profilart"}

# Material: ISYBAU's code -> pipegauge's word (the grading's rigid/flexible split reads these words).
MATERIALS = {
    "AZ": "asbestos cement", "B": "concrete", "BS": "concrete segments", "CNS": "stainless steel",
    "EIS": "iron or steel", "FZ": "fibre cement", "GFK": "grp", "GG": "grey cast iron", "GGG": "ductile iron",
    "KST": "plastic", "MA": "masonry", "OB": "in-situ concrete", "P": "porosit", "PC": "polymer concrete",
    "PCC": "polymer-modified concrete", "PE": "pe", "PEHD": "pe-hd", "PH": "polyester resin",
    "PHB": "polyester resin concrete", "PP": "pp", "PVC": "pvc", "PVCU": "pvc-u", "SFB": "steel fibre concrete",
    "SPB": "prestressed concrete", "SB": "reinforced concrete", "ST": "steel", "STZ": "vitrified clay",
    "SZB": "sprayed concrete", "ZG": "brickwork",
}
# Codes that name no one material: the grading cannot tell rigid from flexible, so they are a problem of the
# section (the material then comes from delivery.json), as DWA-M 150's W, Z and MIX are.
NO_MATERIAL = {"W": "nicht identifizierter Werkstoff", "MIX": "unterschiedliche Werkstoffe",
               "BOD": "unbefestigt, anstehender Boden", "RAS": "Rasen", "PFL": "Pflaster"}

# Kodiersystem of an Auftrag: which codes its RZustand use. EN 13508-2 (2003 or 2011, with or without national
# rules) is what pipegauge's code table holds; ISYBAU 1996/2001 and "other" codings are refused row by row.
EN13508_CODING = {"1", "2", "3", "7", "8", "9", "10"}
CODING_NAMES = {"4": "ISYBAU 2001", "5": "ISYBAU 1996", "6": "another coding system"}

# Streckenschaden: A start, B end (EN 13508-2), E end (older codings), C a change of quantification or position,
# G over the object's whole length, R over one pipe unit.
CONTINUOUS = {"A": "S", "B": "F", "E": "F"}

FPS_RANGE = (1, 120)             # a film's Frame/fps pipegauge accepts [1/s]
