"""The pipe materials a section header may name (EN 13508-2 ACD), as delivered in English, German or by code.

A material outside this table is still read (the header keeps it), but the
inspection records a problem naming it: the grading schemes tell rigid from
flexible pipes by the material (``pipeline.judgement.grading``), and a name
they do not know is graded as a rigid pipe.
"""

from __future__ import annotations

__all__ = ["KNOWN_MATERIALS", "material_problem"]

KNOWN_MATERIALS = frozenset({
    # rigid
    "concrete", "reinforced concrete", "prestressed concrete", "sprayed concrete", "beton", "stahlbeton", "rcp",
    "vitrified clay", "clay", "stoneware", "steinzeug", "vc", "brick", "brickwork", "masonry", "mauerwerk",
    "cast iron", "grey cast iron", "ductile iron", "guss", "asbestos cement", "fibre cement", "fiber cement",
    "faserzement", "stone", "polymer concrete", "polymerbeton",
    # the words the exchange formats' material codes map to (pipeline/formats/isybau/codes.py, dwa_m150.py...)
    "concrete segments", "in-situ concrete", "steel fibre concrete", "polymer-modified concrete", "cement mortar",
    "polyester resin concrete", "porosit", "iron or steel",
    # flexible (as the grading schemes list them)
    "plastic", "pe", "pe-hd", "hdpe", "pp", "pvc", "pvc-u", "upvc", "gfk", "grp", "polyethylene", "polypropylene",
    "steel", "stahl", "stainless steel", "polyester resin",
    # EN 13508-2's own words for what is not known
    "unknown", "other",
})


def material_problem(material: str) -> str | None:
    """Why a header's material is one pipegauge does not know, or None."""
    if material.strip().lower() in KNOWN_MATERIALS:
        return None
    return (f"field 'material': {material[:60]!r} is not a pipe material pipegauge knows (e.g. concrete, vitrified "
            "clay, PVC, PE; docs/formats.md): the grades treat the pipe as rigid; write the material's name")
