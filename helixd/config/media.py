"""Media: the mode that follows the medium, and the ground the rover learns (``media``,
``ground``)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field

from helixd.config.fields import ConfigSection

# ---------------------------------------------------------------------------------------------
# Media: the mode follows the medium

ModeName = Literal["roll", "scroll", "omni"]


class MediaModesConfig(ConfigSection):
    """The motion mode each medium is flown in (docs/physics.md, the ground table): ROLL
    where rolling delivers most (hard 0.95, grass 0.9, sand 0.6 of v_x against 0.12, 0.25,
    0.12 scrolling), SCROLL where rolling delivers little and scrolling more (mud 0.3 vs 0.85,
    water 0.05 vs 0.62)."""

    hard: ModeName = Field("roll")
    """mode on hard ground (roll 0.95, scroll 0.12)"""
    grass: ModeName = Field("roll")
    """mode on grass (roll 0.9, scroll 0.25)"""
    sand: ModeName = Field("roll")
    """mode in sand (roll 0.6, scroll 0.12)"""
    mud: ModeName = Field("scroll")
    """mode in mud (roll 0.3, scroll 0.85)"""
    water: ModeName = Field("scroll")
    """mode in water (roll 0.05, scroll 0.62)"""


class MediaConfig(ConfigSection):
    """A media map and the mode that follows the medium (helixd.planning.media_modes)."""

    media_map: Path | None = Field(None)
    """media map (GeoJSON/KML, helixd.files.media) of where the rover goes; a mission's own
    media_map replaces it. None: the mission's one mode everywhere"""
    modes: MediaModesConfig | Literal["learned"] = Field(default_factory=MediaModesConfig)
    """the mode per medium; 'learned': per medium the mode the ground profile finds fastest
    (ground.objective), the defaults where it knows too little"""
    transition_margin_m: float = Field(1.0, ge=0.0, le=10.0)
    """where the mode changes at a boundary, the rover stops and turns in place this far on the
    firm side of it (the ROLL medium's), so all four scrolls bear on ground while it turns (m; the
    Helix-25 is about 1 m long)"""
    min_stretch_m: float = Field(5.0, ge=0.5, le=100.0)
    """a stretch shorter than this is flown in its neighbours' mode (never ROLL): two stops and
    turns in place cost more than rolling a few metres saves (m)"""
    detect: bool = Field(True)
    """notice ground the map does not show from the slip estimate and switch to the mode that works
    there (helixd.control.ground_check)"""
    detect_window_m: float = Field(1.5, gt=0.0, le=2.0)
    """distance commanded over which the delivered fraction is judged (m)"""
    detect_roll_fraction: float = Field(0.6, gt=0.0, lt=1.0)
    """in ROLL, delivered below this fraction of the commanded speed over the window: the ground is
    softer than the map says (hard 0.95, grass 0.9, mud 0.3)"""
    detect_scroll_fraction: float = Field(0.55, gt=0.0, lt=1.0)
    """scrolling because of the check, delivered below this fraction over the window: firm ground
    again, back to the planned mode (hard 0.12, mud 0.85)"""
    detect_hysteresis: float = Field(0.05, ge=0.0, le=0.3)
    """"firm again" needs the delivered fraction this far below detect_scroll_fraction (scrolling
    in water delivers about 0.6: no flip back in the water) (fraction)"""
    detect_min_change_m: float = Field(5.0, ge=0.0, le=50.0)
    """after the ground check changed the mode, the rover travels at least this far before it
    changes it again; where the media map has water or mud here or this far ahead it never goes
    back to roll (m)"""


class GroundConfig(ConfigSection):
    """The rover learns its ground (docs/physics.md, "Learning the ground"): after each run
    with a media map, what each medium delivered in each mode is fitted from flight.csv and
    merged into the ground profile, which ``media.modes: learned`` plans with."""

    learn: bool = Field(True)
    """merge each run with a media map into the profile"""
    profile_file: Path | None = Field(None)
    """the ground profile (YAML); None: ground-profile.yaml under recorder.run_root"""
    fade: float = Field(0.7, ge=0.0, le=1.0)
    """how much the profile's older evidence counts after one more run (1)"""
    min_taught_s: float = Field(5.0, gt=0.0, le=3600.0)
    """an axis taught for less than this in a medium and mode has no learned fraction: the defaults
    stand (s)"""
    objective: Literal["time", "energy"] = Field("time")
    """media.modes learned picks per medium the mode that is fastest (time) or spends the least
    energy per metre (energy)"""
