"""``media.modes: learned``: per medium the mode the profile makes fastest (or cheapest),
the default where it knows too little."""

from __future__ import annotations

from helixd.base.media import Medium
from helixd.base.plan import MotionMode
from helixd.config.media import MediaConfig
from helixd.planning.media_modes import config_modes, delivered, learned_modes

ROLL, SCROLL = MotionMode.ROLL, MotionMode.SCROLL
DEFAULTS = config_modes(MediaConfig())  # media.modes as the config ships it


def pick(
    fractions: dict[tuple[Medium, str], float],
    energy: dict[tuple[Medium, MotionMode], float] | None = None,
    objective: str = "time",
) -> dict[Medium, MotionMode]:
    return learned_modes(
        DEFAULTS,
        lambda m, a: fractions.get((m, a)),
        lambda m, k: (energy or {}).get((m, k)),
        max_gain=2.0,
        stuck_fraction=0.15,
        objective=objective,
    )


def test_the_faster_mode_wins_where_both_are_known() -> None:
    got = pick(
        {
            (Medium.HARD, "roll"): 0.95,
            (Medium.HARD, "scroll"): 0.12,
            (Medium.MUD, "roll"): 0.7,  # a site whose mud rolls better than it scrolls
            (Medium.MUD, "scroll"): 0.3,
            (Medium.WATER, "roll"): 0.05,
        }
    )
    assert got[Medium.HARD] is ROLL
    assert got[Medium.MUD] is ROLL  # learnt: against the default SCROLL
    assert got[Medium.WATER] is SCROLL  # scroll axis unknown: the default
    assert got[Medium.GRASS] is DEFAULTS[Medium.GRASS]


def test_feed_forward_ties_go_to_the_larger_fraction_and_a_stall_is_not_amplified() -> None:
    assert delivered(0.6, 2.0, 0.15) == 1.0 and delivered(0.12, 2.0, 0.15) == 0.12
    got = pick({(Medium.SAND, "roll"): 0.55, (Medium.SAND, "scroll"): 0.9})
    assert got[Medium.SAND] is SCROLL  # both reach the command with the 2x feed-forward


def test_energy_objective_picks_the_cheaper_metre() -> None:
    fractions = {(Medium.MUD, "roll"): 0.9, (Medium.MUD, "scroll"): 0.8}
    energy = {(Medium.MUD, ROLL): 300.0, (Medium.MUD, SCROLL): 200.0}
    assert pick(fractions, energy, "time")[Medium.MUD] is ROLL
    assert pick(fractions, energy, "energy")[Medium.MUD] is SCROLL
    assert pick(fractions, {(Medium.MUD, ROLL): 100.0}, "energy")[Medium.MUD] is SCROLL  # default
