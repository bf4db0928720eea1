"""Link tests against a real MAVLink peer on 127.0.0.1 (tests/link/peer.py)."""
