"""What ``helixd serve`` would fly: the autopilot's mission, read again whenever it may have
changed and checked as ``helixd check`` checks a file (or the mission file the service was
given), with the autopilot's current item and fence kept for the flights."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import structlog

from helixd.base.clock import now_s
from helixd.link.connection import Autopilot, MavMsg
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.mav.url import LinkError
from helixd.mission.formats.items import GcsMission
from helixd.prepare.autopilot_mission import items_sha256
from helixd.serve.check import (
    CheckInputs,
    ReadyMission,
    Verdict,
    check_download,
    check_file,
)
from helixd.serve.options import ServeOptions

log = structlog.get_logger(__name__)

FLIGHT_PLAN_RECEIVED = "Flight plan received"  # ArduPilot, when an upload completes
MISSION_RETRY_S = 2.0  # a failed read is tried again this soon (s), not a whole poll later


class MissionWatch:
    """The mission and its verdict. The autopilot's is downloaded again when its count
    changes (MISSION_CURRENT.total), when an upload completes ("Flight plan received"), and
    every ``serve.mission_poll_s``; a failed read (a GCS uploading right now) is retried
    sooner. ``checked`` is the mission a start flies (None: nothing flyable)."""

    def __init__(self, opts: ServeOptions) -> None:
        self.opts = opts
        self.checked: ReadyMission | None = None
        self.fingerprint: str | None = None  # of the mission last read
        self.fence: GcsMission | None = None  # the autopilot's fence, as last downloaded
        self.autopilot_item = 0  # MISSION_CURRENT.seq: where the autopilot's AUTO runs from
        self.due = True  # read at the next chance
        self.read_error: str | None = None  # why the last read failed (None: it did not)
        # signs the autopilot's mission changed (a new count, "Flight plan received"), counted:
        # a flight compares it with the count it started at (its item numbers are its plan's)
        self.plan_changes = 0
        self._total: int | None = None
        self._next_poll_s = 0.0

    def on_message(self, msg: MavMsg, rx_s: float) -> None:
        """The link's reader: the autopilot's current item, and signs its mission changed."""
        kind = msg.get_type()
        if kind == "MISSION_CURRENT":
            self.autopilot_item = int(msg.seq)
            total = int(msg.total)
            if total != self._total:
                if self._total is not None:
                    log.info("autopilot_mission_count", total=total)
                    self.due = True
                    self.plan_changes += 1
                elif self.fingerprint is not None:
                    # the first count came after a read: an upload in between changed nothing
                    # it could compare with (autopilots count differently), so read once more
                    self.due = True
                self._total = total
        elif kind == "STATUSTEXT" and FLIGHT_PLAN_RECEIVED in str(msg.text):
            self.due = True
            self.plan_changes += 1

    def read_due(self, now_s: float) -> bool:
        return self.due or now_s >= self._next_poll_s

    async def read(self, ap: Autopilot, recheck: bool) -> Verdict | None:
        """Read the mission (and the autopilot's fence); its verdict when it changed, or when
        ``recheck`` asks for it again, else None (nothing new, or the read failed)."""
        self.due = False
        self.read_error = None
        poll_s = self.opts.cfg.serve.mission_poll_s
        self._next_poll_s = now_s() + poll_s
        if self.opts.mission_file is not None:
            return self._read_file(self.opts.mission_file)
        try:
            got = await ap.mission.download()
        except (MissionTransferError, LinkError) as exc:  # e.g. a GCS uploading right now
            log.info("serve_mission_read_failed", error=str(exc))
            self.read_error = str(exc)
            self._next_poll_s = now_s() + min(poll_s, MISSION_RETRY_S)
            return None
        fingerprint = items_sha256(got.mission, got.fence)
        if fingerprint == self.fingerprint and not recheck:
            return None
        self.fingerprint = fingerprint
        return self._checked(got.mission, got.fence, fingerprint)

    def _inputs(self) -> CheckInputs:
        o = self.opts
        return CheckInputs(o.cfg, o.config_path, o.mode, o.options, o.occupancy)

    def _checked(self, mission: tuple[Any, ...], fence: tuple[Any, ...], fp: str) -> Verdict:
        """``helixd check``'s checks of the downloaded mission."""
        verdict = check_download(mission, fence, fp, self._inputs())
        if verdict.fence is not None:
            self.fence = verdict.fence  # a flight to the autopilot's place plans around it
        self.checked = verdict.checked
        return verdict

    def _read_file(self, path: Path) -> Verdict | None:
        """The mission file (``serve.mission_file``, ``--mission``), checked as ``helixd run``
        checks it; its verdict when it changed."""
        fingerprint, verdict = check_file(path, self._inputs())
        if fingerprint == self.fingerprint and (verdict.checked is None or self.checked):
            return None
        self.fingerprint = fingerprint
        self.checked = verdict.checked
        return verdict


__all__ = ["FLIGHT_PLAN_RECEIVED", "MISSION_RETRY_S", "MissionWatch"]
