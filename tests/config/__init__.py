"""Tests of helixd.config: the sections of helixd.yaml."""
