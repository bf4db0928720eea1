"""The simulator core without sockets: messages in, messages out, faults."""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import GCS_CONTACT_MESSAGE_IDS, MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
from helixd.mav.ftp_wire import FtpOp, FtpPayload, from_message, to_message
from helixd.sim.faults import FaultError, make_spec, parse_fault
from helixd.sim.ftp_server import FtpServer
from tests.support.simcore import command, incoming, make_core, of_type, run


def test_heartbeats_boot_16_then_0_on_every_link() -> None:
    core = make_core()
    out = run(core, 3.0)
    for link in (0, 1):
        modes = [int(m.custom_mode) for m in of_type(out, "HEARTBEAT", link)]
        assert modes[0] == 16 and modes[-1] == 0
        assert modes == sorted(modes, reverse=True)


def test_intervals_are_per_link() -> None:
    core = make_core()
    run(core, 2.0)
    assert command(core, 0, 511, 32, 25_000) == 0
    out = run(core, 2.0)
    fast = of_type(out, "LOCAL_POSITION_NED", 0)
    slow = of_type(out, "LOCAL_POSITION_NED", 1)
    assert 75 <= len(fast) <= 82
    assert 1 <= len(slow) <= 3


def test_no_position_before_ekf_origin() -> None:
    core = make_core(ekf_origin_delay_s=5.0)
    out = run(core, 4.0)
    assert not of_type(out, "LOCAL_POSITION_NED")
    out = run(core, 4.0)
    assert of_type(out, "LOCAL_POSITION_NED")
    assert len(of_type(out, "GPS_GLOBAL_ORIGIN", 0)) == 1


def test_commands_from_other_targets_are_not_for_us() -> None:
    core = make_core()
    run(core, 2.0)
    msg = mavlink.MAVLink_command_long_message(7, 1, 400, 0, 1, 21196, 0, 0, 0, 0, 0)
    core.handle(0, incoming(msg))
    assert not of_type(core.drain_outbox(), "COMMAND_ACK")
    assert not core.ap.armed


def test_link_drop_both_ways_on_one_link() -> None:
    core = make_core()
    run(core, 2.0)
    core.inject(make_spec("link_drop", {"duration_s": 1.0, "link": 0}))
    out = run(core, 0.9)
    assert not of_type(out, "HEARTBEAT", 0)
    assert of_type(out, "HEARTBEAT", 1)
    core.handle(
        0, incoming(mavlink.MAVLink_command_long_message(1, 1, 400, 0, 1, 21196, 0, 0, 0, 0, 0))
    )
    assert not core.ap.armed
    out = run(core, 1.2)
    assert of_type(out, "HEARTBEAT", 0)
    assert "link_drop" not in core.faults.active


def test_stale_pose_stops_position_but_not_heartbeat() -> None:
    core = make_core()
    run(core, 2.0)
    core.inject(make_spec("stale_pose", {"duration_s": 3.0}))
    out = run(core, 2.9)
    assert not of_type(out, "LOCAL_POSITION_NED")
    assert not of_type(out, "GLOBAL_POSITION_INT")
    assert of_type(out, "ATTITUDE")
    assert of_type(out, "HEARTBEAT")


def test_the_reboot_command_is_acked_then_the_autopilot_goes_silent_and_boots_again() -> None:
    """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1=1: COMMAND_ACK ACCEPTED on the wire first (the
    ACK was lost: reboot_after_replies extended a list drain_outbox had replaced), then no
    MAVLink for reboot_silent_s, then HEARTBEATs in the boot state (custom_mode 16)."""
    core = make_core()
    run(core, 3.0)
    assert command(core, 0, MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == 0  # ACCEPTED
    assert not run(core, core.config.reboot_silent_s - 0.1)
    beats = of_type(run(core, 0.4), "HEARTBEAT")
    assert beats and int(beats[0].custom_mode) == 16


def test_reboot_restarts_time_boot_ms_and_keeps_params() -> None:
    core = make_core()
    run(core, 3.0)
    core.params.set("FS_GCS_ENABLE", 1)
    before = core.ap.time_boot_ms(core.now_s)
    core.inject(make_spec("reboot", {"silent_s": 0.5}))
    out = run(core, 0.4)
    assert not out  # silent
    out = run(core, 0.4)
    beats = of_type(out, "HEARTBEAT")
    assert beats and all(int(m.custom_mode) == 16 for m in beats)
    assert core.ap.time_boot_ms(core.now_s) < before
    assert core.params.get("FS_GCS_ENABLE") == 1.0


def test_gps_jump_moves_the_estimate_not_the_rover() -> None:
    core = make_core()
    run(core, 2.0)
    core.inject(make_spec("gps_jump", {"distance_m": 10.0, "bearing_deg": 90.0}))
    run(core, 1.0)
    assert core.phys.east_m == pytest.approx(0.0, abs=1e-9)
    assert core.view.estimate.east_m == pytest.approx(10.0, abs=0.01)
    assert core.ekf_status().pos_horiz_variance > 0.8  # the EKF's glitch: above helixd's limit


def test_a_gps_jump_the_ekf_took_leaves_its_variance_low() -> None:
    core = make_core()
    run(core, 2.0)
    before = core.ekf_status().pos_horiz_variance
    core.inject(make_spec("gps_jump", {"distance_m": 30.0, "bearing_deg": 180.0, "variance": 0.0}))
    run(core, 0.2)
    assert core.view.estimate.north_m == pytest.approx(-30.0, abs=0.01)
    assert core.ekf_status().pos_horiz_variance == pytest.approx(before)
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(FaultError, match="variance"):
            make_spec("gps_jump", {"variance": bad})


def test_pilot_takeover_needs_a_switch_position_for_the_mode() -> None:
    core = make_core()
    run(core, 2.0)
    core.inject(make_spec("pilot_takeover", {}))  # default HOLD = MODE6 in the Helix setup
    run(core, 0.5)
    assert core.ap.mode == 4
    with pytest.raises(FaultError):
        core.inject(make_spec("pilot_takeover", {"mode": "GUIDED"}))


def test_ekf_unhealthy_reports_variances_over_threshold() -> None:
    core = make_core()
    run(core, 2.0)
    core.inject(make_spec("ekf_unhealthy", {"duration_s": 2.0}))
    out = run(core, 1.0)
    assert command(core, 0, 511, 193, 100_000) == 0
    out = run(core, 0.5)
    reports = of_type(out, "EKF_STATUS_REPORT", 0)
    assert reports and all(float(m.pos_horiz_variance) > 0.8 for m in reports)
    assert all(int(m.flags) & 16 == 0 for m in reports)  # no absolute horizontal position


def test_gps_raw_int_says_no_fix_before_the_first_fix_then_the_fix() -> None:
    # as ArduPilot (AP_GPS::send_mavlink_gps_raw sends whenever a GPS is configured): before
    # the fix (the EKF origin, here 1 s boot + 3 s) the report says no fix, no satellites, no
    # fix time
    core = make_core(ekf_origin_delay_s=3.0)
    run(core, 1.2)
    assert command(core, 0, 511, 24, 200_000) == 0  # GPS_RAW_INT at 5 Hz
    before = of_type(run(core, 2.6), "GPS_RAW_INT", 0)
    assert before and all(int(m.fix_type) == 1 for m in before)
    assert all(int(m.satellites_visible) == 0 and int(m.time_usec) == 0 for m in before)
    after = of_type(run(core, 1.0), "GPS_RAW_INT", 0)
    assert after and int(after[-1].fix_type) == 3 and int(after[-1].time_usec) > 0


def test_gps_loss_reports_no_fix_then_the_ekf_drops_its_position_after_dead_reckoning() -> None:
    # as ArduPilot SITL with SIM_GPS1_ENABLE 0: GPS_RAW_INT no fix, 0 satellites 0.4 s after
    # the loss; the EKF keeps a healthy horizontal position for 7.3 s on dead reckoning
    core = make_core()
    run(core, 5.0)
    assert command(core, 0, 511, 24, 200_000) == 0  # GPS_RAW_INT at 5 Hz
    core.inject(make_spec("gps_loss", {}))
    early = of_type(run(core, 0.35), "GPS_RAW_INT", 0)
    assert early and all(int(m.fix_type) == 3 for m in early)
    lost = of_type(run(core, 0.45), "GPS_RAW_INT", 0)
    assert lost and int(lost[-1].fix_type) == 1 and int(lost[-1].satellites_visible) == 0
    assert core.ekf_status().position_ok
    run(core, 6.4)
    assert core.ekf_status().position_ok  # 7.2 s: still dead-reckoning
    run(core, 0.2)
    assert not core.ekf_status().position_ok
    core.clear_fault("gps_loss")
    run(core, 0.5)
    assert core.ekf_status().position_ok
    assert int(of_type(run(core, 0.5), "GPS_RAW_INT", 0)[-1].fix_type) == 3


def test_gps_silent_stops_gps_raw_int_alone() -> None:
    # as ArduPilot with GPS1_TYPE 0 (or the stream turned off): no GPS_RAW_INT at all, every
    # other stream and the EKF go on
    core = make_core()
    run(core, 5.0)
    assert command(core, 0, 511, 24, 200_000) == 0  # GPS_RAW_INT at 5 Hz
    core.inject(make_spec("gps_silent", {}))
    window = run(core, 2.0)
    assert not of_type(window, "GPS_RAW_INT", 0)
    assert of_type(window, "LOCAL_POSITION_NED", 0) and of_type(window, "ATTITUDE", 0)
    assert core.ekf_status().position_ok
    core.clear_fault("gps_silent")
    assert of_type(run(core, 0.5), "GPS_RAW_INT", 0)


def test_gps_receiver_silent_repeats_the_last_fix_then_says_no_gps() -> None:
    # as ArduPilot when the receiver stops sending (SITL: SIM_GPS1_BYTELOS 100): GPS_RAW_INT
    # goes on with the last fix, its time frozen, for the driver's 4 s timeout, then no GPS
    core = make_core()
    run(core, 5.0)
    assert command(core, 0, 511, 24, 200_000) == 0
    before = of_type(run(core, 0.5), "GPS_RAW_INT", 0)
    assert len({int(m.time_usec) for m in before}) == len(before)  # a new fix each message
    core.inject(make_spec("gps_receiver_silent", {}))
    held = of_type(run(core, 3.9), "GPS_RAW_INT", 0)
    assert len(held) >= 15 and len({int(m.time_usec) for m in held}) == 1
    assert all(int(m.fix_type) == 3 and int(m.satellites_visible) == 12 for m in held)
    gone = of_type(run(core, 0.3), "GPS_RAW_INT", 0)
    assert gone and int(gone[-1].fix_type) == 0 and int(gone[-1].satellites_visible) == 0
    assert int(gone[-1].time_usec) == int(held[0].time_usec)
    assert core.ekf_status().position_ok  # dead-reckoning (7.3 s)
    run(core, 3.2)
    assert not core.ekf_status().position_ok
    core.clear_fault("gps_receiver_silent")
    assert int(of_type(run(core, 0.5), "GPS_RAW_INT", 0)[-1].fix_type) == 3


def test_scheduled_fault_fires_at_its_sim_time() -> None:
    core = make_core()
    spec, at_s = parse_fault("stall@3.5:duration_s=2")
    core.schedule(spec, at_s)
    run(core, 3.48)
    assert "stall" not in core.faults.active
    run(core, 0.04)
    assert "stall" in core.faults.active
    kinds = [e.kind for e in core.drain_events()]
    assert "fault" in kinds


def test_fault_specs_parse_and_reject_bad_input() -> None:
    spec, at_s = parse_fault("link_drop@12.5:duration_s=3,link=1")
    assert (spec.name, at_s, spec.kwargs["duration_s"], spec.kwargs["link"]) == (
        "link_drop",
        12.5,
        3.0,
        1,
    )
    assert parse_fault("pilot_takeover@1:mode=manual")[0].kwargs["mode"] == "MANUAL"
    for bad in ("nosuch@1", "stall", "stall@x", "stall@1:speed=2", "stall@1:duration_s=0"):
        with pytest.raises(FaultError):
            parse_fault(bad)


def test_yaw_reported_clockwise_from_north() -> None:
    core = make_core(initial_yaw_ned_rad=math.radians(30.0))
    run(core, 2.0)
    assert command(core, 0, 511, 30, 100_000) == 0
    att = of_type(run(core, 0.5), "ATTITUDE", 0)
    assert att and float(att[-1].yaw) == pytest.approx(math.radians(30.0), abs=1e-6)


def test_gcs_contact_counts_heartbeat_override_and_manual_control_from_the_gcs_id_only() -> None:
    """GCS_Common.cpp: handle_heartbeat / handle_rc_channels_override / handle_manual_control
    refresh sysid_myggcs_seen only for GCS::sysid_is_gcs senders (MANUAL_CONTROL also needs
    target = our sysid)."""
    core = make_core()
    run(core, 2.0)
    ap = core.ap
    hb = mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)
    core.handle(0, incoming(hb, sysid=255))  # ArduPilot's default GCS id is not ours
    assert ap.gcs_last_seen_s is None
    manual = mavlink.MAVLink_manual_control_message(2, 0, 0, 500, 0, 0)
    core.handle(0, incoming(manual))  # aimed at system 2: not us
    assert ap.gcs_last_seen_s is None
    manual = mavlink.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0)
    core.handle(0, incoming(manual))
    assert ap.gcs_last_seen_s == core.now_s
    run(core, 0.5)
    core.handle(1, incoming(hb))
    assert ap.gcs_last_seen_s == core.now_s


def test_only_heartbeat_override_and_manual_control_are_gcs_contact() -> None:
    """GCS_Common.cpp: sysid_mygcs_seen has three callers (handle_heartbeat of any MAV_TYPE,
    handle_rc_channels_override, handle_manual_control); what a read-only tool sends from the
    GCS id — commands, parameter, mission and stream requests, SET_MODE — is no contact."""
    core = make_core()
    run(core, 2.0)
    ap = core.ap
    others = [
        mavlink.MAVLink_command_long_message(1, 1, 512, 0, 33, 0, 0, 0, 0, 0, 0),
        mavlink.MAVLink_command_int_message(1, 1, 0, 512, 0, 0, 33, 0, 0, 0, 0, 0, 0),
        mavlink.MAVLink_param_request_read_message(1, 1, b"FS_GCS_ENABLE", -1),
        mavlink.MAVLink_param_request_list_message(1, 1),
        mavlink.MAVLink_mission_request_list_message(1, 1, 0),
        mavlink.MAVLink_request_data_stream_message(1, 1, 0, 4, 1),
        mavlink.MAVLink_set_mode_message(1, 1, 0),
        mavlink.MAVLink_statustext_message(6, b"hello", 0, 0),
    ]
    for msg in others:
        core.handle(0, incoming(msg))
        core.drain_outbox()
    assert ap.gcs_last_seen_s is None
    contact = {
        0: mavlink.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3),  # onboard controller: counts
        70: mavlink.MAVLink_rc_channels_override_message(1, 1, *([65535] * 8), *([0] * 10)),
        69: mavlink.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0),
    }
    assert set(contact) == GCS_CONTACT_MESSAGE_IDS
    for msg in contact.values():
        run(core, 0.2)
        core.handle(1, incoming(msg))
        assert ap.gcs_last_seen_s == core.now_s, msg.get_type()


def test_home_position_is_announced_once_when_home_is_set_and_not_before() -> None:
    """AP_AHRS::set_home sends HOME_POSITION (and the origin) to every link; before home is
    set a REQUEST_MESSAGE for it is accepted and answered with nothing."""
    core = make_core(ekf_origin_delay_s=2.0)
    out = run(core, 2.0)
    assert command(core, 0, 512, 242) == 0  # MAV_CMD_REQUEST_MESSAGE HOME_POSITION
    assert not of_type(out + core.drain_outbox(), "HOME_POSITION")
    out = run(core, 2.0)
    homes = of_type(out, "HOME_POSITION")
    assert sorted(lk for lk, m in out if m.get_type() == "HOME_POSITION") == [0, 1]
    assert int(homes[0].latitude) == round(core.config.origin_lat_deg * 1e7)
    texts = [str(m.text) for m in of_type(out, "STATUSTEXT")]
    assert any(t.startswith("Set HOME to 53.523250 -113.526320") for t in texts)
    assert command(core, 1, 512, 242) == 0


def test_ftp_requests_are_answered_to_their_sender_on_their_link(tmp_path: Path) -> None:
    (tmp_path / "scripts").mkdir()
    with FtpServer(tmp_path) as srv:
        core = make_core(ftp=srv)
        run(core, 2.0)
        listing = FtpPayload.request(FtpOp.ListDirectory, 7, 1, data=b"scripts")
        core.handle(1, incoming(to_message(listing, 1, 1), sysid=250, compid=190))
        replies = of_type(core.drain_outbox(), "FILE_TRANSFER_PROTOCOL")
        assert len(replies) == 1
        reply = replies[0]
        assert (int(reply.target_system), int(reply.target_component)) == (250, 190)
        got = FtpPayload.unpack(from_message(reply))
        assert (got.opcode, got.req_opcode, got.seq_number) == (
            FtpOp.Nack,  # an empty directory: EndOfFile
            FtpOp.ListDirectory,
            8,
        )
        core.handle(1, incoming(to_message(listing, 1, 1), sysid=250, compid=190))  # repeated
        assert [lk for lk, _ in core.drain_outbox()] == [1]  # the kept reply, to link 1 only
        core.handle(0, incoming(to_message(listing, 5, 1)))  # for another vehicle
        assert of_type(core.drain_outbox(), "FILE_TRANSFER_PROTOCOL") == []


def test_without_an_ftp_server_ftp_goes_unanswered() -> None:
    core = make_core()
    run(core, 2.0)
    listing = FtpPayload.request(FtpOp.ListDirectory, 0, 1, data=b"/")
    core.handle(0, incoming(to_message(listing, 1, 1)))
    assert of_type(core.drain_outbox(), "FILE_TRANSFER_PROTOCOL") == []
