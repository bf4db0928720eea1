"""helixd.link: the MAVLink I/O shell (transports, commands, streams, preflight).

The daemon codes against :class:`helixd.link.connection.Autopilot`; errors are
:class:`helixd.mav.url.LinkError` (and its ``LinkTimeout``),
:class:`helixd.link.services.command_client.CommandError` (and its ``CommandRejected`` / ``CommandTimeout``).
"""
