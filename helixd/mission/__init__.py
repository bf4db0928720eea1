"""Missions: file model, validation and resolution into a plan."""
