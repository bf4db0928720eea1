"""The rover learns its ground (on the simulated clock): a site whose mud rolls better than it
scrolls (unlike the built-in table), flown once scrolling the mud (the default policy) and once
rolling it (the mission's own media_modes); after each run the profile holds what each medium
delivered in each mode, summary.json its own ground, and ``media.modes: learned`` then picks
ROLL for the mud; ``helixd ground RUN… --media`` finds the same from the runs alone."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaFrame, MediaMap, Medium
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.plant.ground import TerrainTable
from helixd.prepare.ground_learning import learned_policy_modes
from helixd.recorder.ground_profile import read_profile
from helixd.recorder.rows import read_flight_columns
from tests.integration.test_amphibious_flight import band, geojson
from tests.support.cli import run_main
from tests.support.simulated import simulated_flights

pytestmark = pytest.mark.integration

MUD_ROLL, MUD_SCROLL = 0.7, 0.3  # the site's truth (the table: 0.3 and 0.85)


def test_the_profile_learns_per_medium_and_mode_and_the_learned_policy_uses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    helixd_map = geojson(tmp_path / "site.geojson", ("mud", 10.0, 40.0))
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.MUD, 10.0, 40.0),), Medium.HARD)
    truth = TerrainTable.model_validate(
        {"mud": {"roll_efficiency": MUD_ROLL, "scroll_efficiency": MUD_SCROLL}}
    )
    profile = tmp_path / "state" / "ground-profile.yaml"
    legs = []
    # out across the mud and back: one simulator, the second leg starts where the first ended
    for name, modes, north in (("scrolled", None, 50.0), ("rolled", {"mud": "roll"}, 0.0)):
        data = {"name": name, "mode": "roll", "frame": "local_ned", "media_map": str(helixd_map),
                "waypoints": [{"north": north, "east": 0.0}]}  # fmt: skip
        if modes:
            data["media_modes"] = modes
        path = tmp_path / f"{name}.yaml"
        path.write_text(json.dumps(data), encoding="utf-8")
        legs.append((path, None))
    cfg = {"ground": {"profile_file": str(profile)}, "media": {"detect": False}}
    flown = simulated_flights(tmp_path, legs, cfg, media=world, terrains=truth, noise="low", seed=5)
    for f in flown:
        assert f.code == ExitCode.OK, f.log[-3000:]
        assert "event=ground_learned" in f.log
    got = read_profile(profile)
    mud_scroll = got.cells[(Medium.MUD, MotionMode.SCROLL)]
    mud_roll = got.cells[(Medium.MUD, MotionMode.ROLL)]
    print(f"mud: scroll {mud_scroll.scroll.fraction:.3f}, roll {mud_roll.roll.fraction:.3f}")
    assert mud_scroll.scroll.fraction == pytest.approx(MUD_SCROLL, abs=0.03)
    assert mud_roll.roll.fraction == pytest.approx(MUD_ROLL, abs=0.05)
    assert got.cells[(Medium.HARD, MotionMode.ROLL)].roll.fraction == pytest.approx(0.95, abs=0.05)
    assert len(mud_scroll.runs) == 1 and len(got.cells[(Medium.HARD, MotionMode.ROLL)].runs) == 2
    runs = sorted((tmp_path / "runs").glob("*-*"))  # scrolled, then rolled
    c = read_flight_columns(runs[0] / "flight.csv")  # a medium per sample, from the map
    assert set(c["medium"]) == {"hard", "mud"}
    assert set(c["motion_mode"][c["medium"] == "mud"]) == {"scroll"}
    summary = json.loads((runs[0] / "summary.json").read_text())
    assert summary["ground"]["mud/scroll"]["fractions"]["scroll"] == pytest.approx(
        MUD_SCROLL, abs=0.03
    )
    learned = HelixdConfig.model_validate(
        {"ground": {"profile_file": str(profile)}, "media": {"modes": "learned"}}
    )
    modes = learned_policy_modes(learned)
    assert modes[Medium.MUD] is MotionMode.ROLL  # the site's mud: against the default SCROLL
    assert modes[Medium.HARD] is MotionMode.ROLL
    assert modes[Medium.WATER] is MotionMode.SCROLL  # never flown: the default
    code, out, err = run_main(["ground", *map(str, runs), "--media", str(helixd_map)], capsys)
    assert code == 0, err
    assert "mud    roll    (by the profile)" in out
    assert "water  scroll  (the default: too little learnt)" in out
