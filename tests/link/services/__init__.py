"""Tests of helixd.link.services: the autopilot's services over the link."""
