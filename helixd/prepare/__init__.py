"""Preparing a flight: the mission, the config, the route and the media checked and built
into a :class:`helixd.prepare.planned.Flight` before anything is sent (nothing here touches
the link; :func:`helixd.prepare.builder.prepare_flight` is the one entry)."""
