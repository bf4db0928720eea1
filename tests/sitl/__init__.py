"""Opt-in tests against real ArduPilot Rover SITL (``HELIXD_SITL_BIN``); see README.md here."""
