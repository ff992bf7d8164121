"""The VSA-KEK INTERLIS 2 models as pipegauge reads and writes them: names, the attributes behind the log's
columns, the attributes' order, the codes VSA writes otherwise than EN 13508-2, and a transfer's objects.
The condition classes (Einzelschadenklasse) are the VSA 2023 grading scheme's (pipeline.judgement.grading).

Models ``VSA_KEK_2019_LV95`` and ``VSA_KEK_2020_1_LV95`` (docs/formats.md says which attribute maps to which
field, and what differs between the two). ``MODELS`` is the one place their names are written
(tests/test_architecture.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pipeline.judgement.grading.vsa_2023 import SCHEME as VSA_2023

__all__ = ["ILI_NS", "MODELS", "VERSION_OF", "FPS", "QUANTITY_RANGE", "ANMERKUNG_CHARS", "EINZELSCHADENKLASSEN",
           "GRADING_SCHEME", "FIELD_NAMES", "SECTION_FIELDS", "ATTRIBUTE_ORDER", "ROLES_AFTER", "split_code", "vsa_code",
           "TransferObject", "Transfer"]

ILI_NS = "http://www.interlis.ch/INTERLIS2.3"
MODELS = {"2019": ("VSA_KEK_2019_LV95", "20.01.2021"), "2020": ("VSA_KEK_2020_1_LV95", "30.10.2023")}
VERSION_OF = {name: version for version, (name, _) in MODELS.items()}     # model name -> key of MODELS
FPS = 25                            # Videozaehlerstand hh:mm:ss:ff counts frames 0..24 (VSA_KEK model)
QUANTITY_RANGE = (0, 100000)        # Quantifizierung1/2: the model's integer range [mm or %]
ANMERKUNG_CHARS = 100              # Kanalschaden.Anmerkung is TEXT*100 (other texts are cut at their own length)
# Einzelschadenklasse: the models' enumeration is VSA's single-defect classes ("unbekannt" aside), the classes of
# the scheme pipegauge grades by; they are written once, in the scheme
EINZELSCHADENKLASSEN = VSA_2023.classes
GRADING_SCHEME = VSA_2023.key       # the scheme whose grade a transfer carries as Einzelschadenklasse
# VSA-KEK characterises codes that EN 13508-2 (pipeline/domain/codes.py) does not: the VSA code stands for the EN one
_VSA_ALIASES = {"BAGA": ("BAG", "", "")}
_EN_ALIASES = {v: k for k, v in _VSA_ALIASES.items()}
# the Kanalschaden attribute behind each log column, for the messages
FIELD_NAMES = {"distance_m": "Distanz", "code": "KanalSchadencode", "char1": "KanalSchadencode (characterisation 1)",
               "char2": "KanalSchadencode (characterisation 2)", "q1": "Quantifizierung1", "q2": "Quantifizierung2",
               "q1_unit": "Quantifizierung1", "q2_unit": "Quantifizierung2", "clock_from": "SchadenlageAnfang",
               "clock_to": "SchadenlageEnde", "at_joint": "Verbindung", "continuous": "Streckenschaden",
               "video_time": "Videozaehlerstand", "remark": "Anmerkung"}
# header.json's fields a transfer does not hold: package.json's "section" gives them (docs/formats.md)
SECTION_FIELDS = ("direction", "shape", "height_mm", "width_mm", "height_tolerance_mm", "material",
                  "pipe_unit_length_m", "site", "longitudinal_reference")

# each class's attributes and roles in the models' order, the order the writer writes them in
ATTRIBUTE_ORDER = {
    "Untersuchung": ("Art", "Ausfuehrender", "Bemerkung", "Bezeichnung", "Datengrundlage", "Dauer", "Detaildaten",
                     "Ergebnis", "Grund", "Kosten", "Status", "Zeitpunkt", "bisPunktBezeichnung", "Erfassungsart",
                     "Fahrzeug", "Geraet", "Inspizierte_Laenge", "Videonummer", "vonPunktBezeichnung", "Witterung"),
    "Kanalschaden": ("Anmerkung", "Ansichtsparameter", "Einzelschadenklasse", "Streckenschaden", "Verbindung",
                     "Videozaehlerstand", "UntersuchungRef", "Distanz", "KanalSchadencode", "Quantifizierung1",
                     "Quantifizierung2", "SchadenlageAnfang", "SchadenlageEnde"),
    "Datentraeger": ("Art", "Bemerkung", "Bezeichnung", "Pfad", "Standort"),
    "Datei": ("Art", "Bemerkung", "Bezeichnung", "Klasse", "Objekt", "Relativpfad", "DatentraegerRef"),
}
ROLES_AFTER = {"Untersuchung": ("AbwasserbauwerkRef", "Ausfuehrende_FirmaRef", "HaltungspunktRef")}


def split_code(text: str) -> tuple[str, str, str]:
    """A VSA KanalSchadencode as EN 13508-2 main code and characterisations: BCADA -> (BCA, D, A)."""
    text = text.strip().upper()
    if text in _VSA_ALIASES:
        return _VSA_ALIASES[text]
    return text[:3], text[3:4], text[4:]


def vsa_code(code: str, char1: str, char2: str) -> str:
    """The VSA KanalSchadencode of an EN observation: BCA D A -> BCADA."""
    return _EN_ALIASES.get((code, char1, char2), f"{code}{char1}{char2}")


@dataclass
class TransferObject:
    """One object of a transfer as delivered: its class (without model and topic), TID and attributes as text."""

    cls: str
    tid: str
    line: int
    attrs: dict[str, str] = field(default_factory=dict)            # attribute -> text ("" for an empty element)
    refs: dict[str, tuple[str, str | None]] = field(default_factory=dict)   # role -> (REF, BID)
    meta: dict[str, str] = field(default_factory=dict)             # 2019's Metaattribute structure

    def where(self, path) -> str:
        return f"{path} line {self.line}, {self.cls} TID {self.tid}"


@dataclass
class Transfer:
    """A whole transfer file: model, basket and objects in file order."""

    path: Path
    model: str
    version: str          # "2019" | "2020"
    bid: str
    objects: list[TransferObject]

    def of(self, cls: str) -> list[TransferObject]:
        return [o for o in self.objects if o.cls == cls]
