"""helixd — companion-computer daemon for the Helix-25 screw-propelled rover."""

from __future__ import annotations

from functools import cache

__all__ = ["__version__"]


@cache
def _version() -> str:
    # importlib.metadata pulls in email and socket: looked up only when asked, so the pure
    # layers (helixd.base, helixd.control) import without them (tests/test_layers.py).
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("helixd")
    except PackageNotFoundError:  # running from a source tree that was never installed
        return "0.0.0+unknown"


def __getattr__(name: str) -> str:
    """``helixd.__version__``, computed on first use (PEP 562)."""
    if name == "__version__":
        return _version()
    raise AttributeError(f"module 'helixd' has no attribute {name!r}")
