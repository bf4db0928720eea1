"""helixd.link: the MAVLink I/O shell (transports, commands, streams, preflight).

The daemon codes against :class:`helixd.link.connection.Autopilot`; errors are
:class:`LinkError` (and its :class:`LinkTimeout`), :class:`CommandError` (and its
:class:`CommandRejected` / :class:`CommandTimeout`).
"""

from helixd.link.commands import CommandError, CommandRejected, CommandTimeout
from helixd.link.connection import Autopilot
from helixd.mav.url import LinkError, LinkTimeout, LinkUrl, parse_link_url

__all__ = [
    "Autopilot",
    "CommandError",
    "CommandRejected",
    "CommandTimeout",
    "LinkError",
    "LinkTimeout",
    "LinkUrl",
    "parse_link_url",
]
