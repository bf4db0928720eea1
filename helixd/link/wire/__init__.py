"""helixd.link.wire: bytes to MAVLink messages and back (transports, framing, the codec,
signing, the .tlog, our HEARTBEAT, who else speaks with our system id)."""
