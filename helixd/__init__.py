"""helixd — companion-computer daemon for the Helix-25 screw-propelled rover."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("helixd")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
