"""Optional MAVLink 2 signing (``link.signing_key_file``).

The key file holds the 32-byte secret either raw or as 64 hex characters
(:mod:`helixd.mav.signing_key`; the config loader checks the file too). With a key, every
message we send is signed and unsigned or badly signed messages from the autopilot are rejected
(counted, never processed).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from helixd.mav.signing_key import SigningKeyError, parse_signing_key
from helixd.mav.url import LinkError

SIGNING_EPOCH_UNIX_S = 1_420_070_400  # MAVLink signing timestamps count from 2015-01-01
SIGNING_TICKS_PER_S = 100_000  # 10 µs units


def load_signing_key(path: Path) -> bytes:
    """Read the 32-byte key; LinkError naming the file and what is allowed otherwise."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise LinkError(f"signing key file {path}: cannot read it ({exc.strerror})") from None
    try:
        return parse_signing_key(data)
    except SigningKeyError as exc:
        raise LinkError(f"signing key file {path}: {exc}") from None


def signing_timestamp(now_unix_s: float) -> int:
    """MAVLink signing timestamp (10 µs ticks since 2015-01-01) for a wall-clock time."""
    return int(max(0.0, now_unix_s - SIGNING_EPOCH_UNIX_S) * SIGNING_TICKS_PER_S)


def enable_signing(mav: Any, key: bytes, link_id: int = 0) -> None:
    """Sign everything ``mav`` (a pymavlink MAVLink codec) sends; reject unsigned input."""
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = True
    mav.signing.allow_unsigned_callback = None
    mav.signing.link_id = link_id
    mav.signing.timestamp = signing_timestamp(time.time())
