"""The MAVLink 2 signing key file's format (pure): the 32-byte secret either raw or as 64 hex
characters (what MAVProxy's ``signing setup`` and QGroundControl export).

Read twice, with the same words: when the config is loaded (``helixd check`` refuses what
``helixd run`` would) and when the link opens (:mod:`helixd.link.wire.signing`).
"""

from __future__ import annotations

import string

KEY_LEN = 32


class SigningKeyError(ValueError):
    """The file's bytes are no signing key. The message is for humans."""


def parse_signing_key(data: bytes) -> bytes:
    """The 32-byte key in ``data``; :class:`SigningKeyError` saying what is allowed otherwise."""
    if len(data) == KEY_LEN:
        return data
    text = data.decode("ascii", errors="replace").strip()
    if len(text) == 2 * KEY_LEN and all(c in string.hexdigits for c in text):
        return bytes.fromhex(text)
    raise SigningKeyError(
        f"expected {KEY_LEN} raw bytes or {2 * KEY_LEN} hex characters, found {len(data)} bytes"
    )
