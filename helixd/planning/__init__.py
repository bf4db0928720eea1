"""Paths around what is in the way: maps, keep-out shapes, grid A*, line-of-sight legs."""
