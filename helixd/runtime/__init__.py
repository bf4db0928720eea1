"""Flying: the daemon's phases, the flight loop, the host and the signals."""
