"""Reporting a flight: the operator's terminal lines, the ground station's STATUSTEXT and
NAMED_VALUE_FLOAT feed, and the service's notifications."""
