"""helixd.link: the MAVLink I/O shell (transports, commands, streams, preflight).

The daemon codes against :class:`helixd.link.connection.Autopilot`; errors are
:class:`helixd.mav.url.LinkError` (and its ``LinkTimeout``),
:class:`helixd.link.services.command_client.CommandError` (and its ``CommandRejected`` /
``CommandTimeout``).

Here: the Autopilot facade, what the autopilot last told us (the vehicle state), its telemetry,
message rates, STATUSTEXT reassembly, the payload's readings. Below it, :mod:`helixd.link.wire`
(bytes to messages and back) and :mod:`helixd.link.services` (the autopilot's services:
commands, parameters, missions, FTP, the preflight checks).
"""
