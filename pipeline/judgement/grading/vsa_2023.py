"""Swiss VSA 2023 single-defect classes (Einzelzustand EZ0, the worst, to EZ4), as a table of thresholds.

Source: the VSA 2023 condition-classification thresholds as collected in
../shared/EN13508-2-notes.md section 2.5 (from sewer-studio
``docs/vsa-zustandsklassifizierung-2023-schwellen.md`` [V]). Each line of
that table's "mechanics" column is one or more ``Band`` rows here; a list of
four thresholds "a/b/c/d" reads ">= a -> EZ0, >= b -> EZ1, >= c -> EZ2,
>= d -> EZ3", and below the last threshold the defect is EZ4. Aspects:
D tightness, S stability, B operation; the single class of a defect is its
worst aspect.

Deliberately left out, because the notes do not say which classes their
thresholds give: BBA B roots ("30/20/10", three values for five classes)
and the classes of the BBC characterisations A and B (the notes give C and
Z only). Those observations are reported as ungraded with that reason.
Rigid and flexible pipes (BAA S) are told apart by the header's material
(``FLEXIBLE_MATERIALS``); DN is the header's height [mm].
"""

from __future__ import annotations

from pipeline.judgement.grading.scheme import Band, Scheme

__all__ = ["SCHEME", "FLEXIBLE_MATERIALS"]

FLEXIBLE_MATERIALS = frozenset({"pe", "pe-hd", "hdpe", "pp", "pvc", "pvc-u", "gfk", "grp", "polyethylene",
                                "polypropylene", "steel", "stainless steel", "plastic", "polyester resin"})


def _bands(code: str, chars: str, aspect: str, thresholds: tuple[float, ...], unit: str, **kw) -> tuple[Band, ...]:
    return (Band(code, chars, aspect, tuple(zip(thresholds, range(len(thresholds)))), unit, **kw),)


SCHEME = Scheme(
    name="VSA 2023",
    key="vsa-2023",
    classes=("EZ0", "EZ1", "EZ2", "EZ3", "EZ4"),
    source="VSA 2023 single-defect classification, thresholds per ../shared/EN13508-2-notes.md 2.5",
    bands=(
        *_bands("BAA", "AB", "S", (7, 4, 3, 1), "%", material="rigid"),
        *_bands("BAA", "AB", "S", (15, 10, 6, 2), "%", material="flexible"),
        *_bands("BAA", "AB", "B", (50, 40, 25, 10), "%"),
        *_bands("BAB", "BC", "S", (8, 5, 3, 1), "mm"),
        *_bands("BAJ", "A", "D", (70, 50, 30, 20), "mm", dn_max_mm=400),
        *_bands("BAJ", "A", "D", (80, 60, 40, 20), "mm", dn_above_mm=400),
        *_bands("BAJ", "B", "D", (30, 20, 15, 10), "mm"),
        *_bands("BAJ", "C", "D", (12, 9, 7, 5), "deg", dn_max_mm=200),
        *_bands("BAJ", "C", "D", (6, 4, 3, 2), "deg", dn_above_mm=200),
        *_bands("BAG", "*", "B", (50, 30, 20, 10), "%", dn_max_mm=250),
        *_bands("BAG", "*", "B", (80, 60, 40, 10), "%", dn_above_mm=250),
        *_bands("BBB", "*", "B", (30, 20, 10, 5), "%"),
        *_bands("BBC", "CZ", "B", (50, 40, 25, 10), "%"),
        Band("BDD", "*", "B", ((50, 2), (10, 3)), "%"),
        Band("BAE", "*", "S", ((100, 2),), "mm"),
    ),
    not_graded={
        "BBA": "the VSA 2023 root thresholds in the notes (30/20/10 %) do not say their classes",
        "BCA": "a connection is an inventory record, not a defect",
        "BCD": "a node, not a defect", "BCE": "a node, not a defect", "BDA": "a photograph, not a defect",
        "BDB": "a remark, not a defect", "BDC": "the survey's end, not a defect",
    },
    flexible_materials=FLEXIBLE_MATERIALS,
)
