"""A full card mid-flight on the simulator: the flight goes on and completes (exit 0), one
WARNING reaches the console's events and the ground station's feed, and summary.json is
written and says from when the record is missing."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import helixd.runtime.daemon
from helixd.base.exitcodes import ExitCode
from helixd.mav.constants import MAV_SEVERITY_WARNING
from helixd.recorder.retention import check_free_space
from helixd.recorder.rundir import RESERVE_FILE, RunRecorder
from helixd.report.gcs_feed import GcsFeed
from tests.support.full_disk import FullAfter
from tests.support.simulated import simulated_flight

pytestmark = [pytest.mark.integration, pytest.mark.usefixtures("reset_logging")]

CARD_BYTES = 60_000  # flight.csv fills the card after ~180 rows (~4 s of flight)


def test_card_full_mid_flight(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real_create = RunRecorder.create

    def create(*args: Any, **kwargs: Any) -> RunRecorder:
        return real_create(*args, **{**kwargs, "opener": FullAfter(CARD_BYTES)})

    said: list[tuple[str, int]] = []
    real_say = GcsFeed.say

    def say(self: GcsFeed, text: str, severity: int) -> None:
        said.append((text, severity))
        real_say(self, text, severity)

    def low_space(path: Path, estimated_s: float | None) -> str | None:
        def disk_usage(_: Path) -> tuple[int, int, int]:
            return (10**9, 10**9 - 1_000_000, 1_000_000)  # 1 MB free: below one flight

        return check_free_space(path, estimated_s, disk_usage=disk_usage)

    monkeypatch.setattr(helixd.runtime.daemon, "check_free_space", low_space)
    monkeypatch.setattr(RunRecorder, "create", create)
    monkeypatch.setattr(GcsFeed, "say", say)
    flown = simulated_flight(tmp_path, "square")  # events.jsonl as the CLI has it
    outcome = flown.outcome
    assert outcome.exit_code is ExitCode.OK, outcome.messages
    assert outcome.run_dir is not None
    summary = json.loads((outcome.run_dir / "summary.json").read_text())
    assert summary["completed"] is True and summary["waypoints_reached"] == 4
    assert summary["record_cut_files"] == ["flight.csv"]
    assert 0.0 < summary["record_cut_at_s"] < summary["duration_s"]
    assert not (outcome.run_dir / RESERVE_FILE).exists()
    events = [json.loads(ln) for ln in (outcome.run_dir / "events.jsonl").read_text().splitlines()]
    cuts = [e for e in events if e["event"] == "record_cut"]
    assert len(cuts) == 1 and cuts[0]["level"] == "warning" and cuts[0]["file"] == "flight.csv"
    lines = flown.log.splitlines()
    # preflight warned of the low space (console and GCS); the cut is the one warning after
    assert sum("event=disk_space_low " in ln for ln in lines) == 1
    assert any(m.startswith("warning: low disk space") for m in outcome.messages)
    assert ("low disk space for the flight record", MAV_SEVERITY_WARNING) in said
    flying = next(i for i, ln in enumerate(lines) if "phase=fly" in ln)
    warned = [ln for ln in lines[flying:] if "level=warning" in ln]
    assert len(warned) == 1 and "event=record_cut " in warned[0], warned
    warnings = [t for t, sev in said if sev == MAV_SEVERITY_WARNING and "record cut" in t]
    assert len(warnings) == 1, said
    last = outcome.messages[-1]
    assert last.startswith("helixd: RESULT ok") and "record cut at" in last
    assert last.endswith("exit 0")
