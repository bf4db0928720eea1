"""The dependency-free base layer: plain geometry, angles, frames and plan/mode types.

Standard library only (no pydantic, YAML, numpy, asyncio or sockets), and nothing from the
rest of helixd: the control core, the mission loader, the simulator and the I/O shell all
build on it without building on each other. ``tests/test_layers.py`` holds it to that.
"""
