"""Expression class sets and their short names in the thesis tables."""

from __future__ import annotations

from aamcore.io.jaffe import JAFFE_CLASSES

SEVEN_CLASSES: tuple[str, ...] = tuple(JAFFE_CLASSES)
"""Neutral, happiness, sadness, surprise, anger, fear, disgust (table 9.3 order)."""

FIVE_CLASSES: tuple[str, ...] = ("NE", "HA", "SU", "FE", "DI")
"""The seven without sadness and anger (tables 9.6-9.8, 10.6-10.11)."""

SHORT_NAMES: dict[str, str] = {
    "NE": "Neut",
    "HA": "Happ",
    "SA": "Sad",
    "SU": "Surp",
    "AN": "Ang",
    "FE": "Fear",
    "DI": "Disg",
}


def short_name(code: str) -> str:
    """Table heading of a class code (``HA`` -> ``Happ``); unknown codes are kept."""
    return SHORT_NAMES.get(code, code)
