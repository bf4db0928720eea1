"""Tests of helixd.link.wire: bytes to messages and back."""
