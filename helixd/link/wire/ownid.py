"""Who else speaks with helixd's system id (pure bookkeeping, judged by preflight).

ArduPilot counts *every* sender whose system id is the GCS id (``GCS::sysid_is_gcs``) as the
ground station: its HEARTBEATs (``GCS_MAVLINK::handle_heartbeat``), RC_CHANNELS_OVERRIDE and
MANUAL_CONTROL all refresh ``sysid_myggcs_seen``, which is what the GCS failsafe watches, and
its overrides are obeyed like ours. A ground station or a second helixd on our id therefore
hides a dead helixd from the failsafe and fights its overrides. ArduPilot forwards HEARTBEATs
and broadcast messages between its links (``MAVLink_routing::check_and_forward``), so such a
sender on another link of the autopilot still shows up on ours.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["OwnIdSender", "OwnIdSenders"]

MAV_TYPE_NAMES = {6: "GCS", 18: "onboard controller", 1: "fixed wing", 10: "ground rover"}


@dataclass(slots=True)
class OwnIdSender:
    compid: int
    messages: int = 0
    last_type: str = ""
    mav_type: int | None = None  # from its HEARTBEAT, if it sent one

    def describe(self, own_compid: int) -> str:
        what = f"component {self.compid}: {self.messages} message(s), last {self.last_type}"
        if self.mav_type is not None:
            name = MAV_TYPE_NAMES.get(self.mav_type, str(self.mav_type))
            what += f", HEARTBEAT type {name}"
        if self.compid == own_compid:
            what += " (helixd's own component id too: a second helixd, or our messages echoed)"
        return what


class OwnIdSenders:
    """Messages received with srcSystem == our own system id, per component."""

    def __init__(self) -> None:
        self.by_compid: dict[int, OwnIdSender] = {}

    def note(self, compid: int, msg_type: str, mav_type: int | None) -> bool:
        """Record one message; True if this component was not seen before."""
        sender = self.by_compid.get(compid)
        new = sender is None
        if sender is None:
            sender = self.by_compid[compid] = OwnIdSender(compid)
        sender.messages += 1
        sender.last_type = msg_type
        if mav_type is not None:
            sender.mav_type = mav_type
        return new

    def __bool__(self) -> bool:
        return bool(self.by_compid)

    def describe(self, own_compid: int) -> str:
        return "; ".join(s.describe(own_compid) for _, s in sorted(self.by_compid.items()))
