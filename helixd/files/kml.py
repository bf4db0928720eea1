"""KML's hostile-input edge, shared by the readers of KML files (media maps, survey areas):
DOCTYPE and entity declarations are refused before parsing, so no entity expansion can
happen; tags are read without their namespace."""

from __future__ import annotations

import xml.etree.ElementTree as ET

__all__ = ["KmlRefused", "kml_root", "local_name"]


class KmlRefused(ValueError):
    """The text cannot be read as KML; the message names ``src`` and why."""


def kml_root(text: str, src: str) -> ET.Element:
    """The root element of the KML ``text`` (read from ``src``); raises :class:`KmlRefused`."""
    head = text[:4096].upper()
    if "<!DOCTYPE" in head or "<!ENTITY" in text.upper():
        raise KmlRefused(f"{src}: DOCTYPE/ENTITY declarations are not allowed in a KML file")
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise KmlRefused(f"{src}: not valid XML: {exc}") from None


def local_name(tag: str) -> str:
    """``{namespace}Placemark`` → ``Placemark``."""
    return tag.rsplit("}", 1)[-1]
