"""The Helix plant as ArduPilot SITL's JSON physics: SITL's servo frames in, FDM reports out."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium
from helixd.files.bathymetry import Bathymetry
from helixd.plant import physics
from helixd.plant.ground import Terrain
from helixd.plant.json_physics import (
    GRAVITY_MSS,
    MAGIC_16,
    MAGIC_32,
    PACKET_16_BYTES,
    PACKET_32_BYTES,
    FrameError,
    JsonPlant,
    ServoFrame,
    decode_servo_frame,
    encode_servo_frame,
    step_s_for,
)
from helixd.plant.physics import MotorMap
from helixd.plant.plant_config import PlantConfig
from helixd.plant.sonar import SonarModel
from helixd.plant.state import PhysicsState

RATE_HZ = 400
NEUTRAL = 1500


def frame(count: int, scrolls_us: tuple[int, int, int, int], channels: int = 16) -> ServoFrame:
    pwm = list(scrolls_us) + [0] * (channels - 4)
    return ServoFrame(RATE_HZ, count, tuple(pwm))


def drive(plant: JsonPlant, scrolls_us: tuple[int, int, int, int], seconds: float, start: int = 0):
    report = None
    for k in range(int(seconds * RATE_HZ)):
        report = plant.step(frame(start + k, scrolls_us))
    assert report is not None
    return report


# -- the servo packet -------------------------------------------------------------------------


@pytest.mark.parametrize(("channels", "size", "magic"), [(16, 40, MAGIC_16), (32, 72, MAGIC_32)])
def test_servo_packet_round_trip(channels: int, size: int, magic: int) -> None:
    sent = ServoFrame(1200, 77, tuple(1000 + i for i in range(channels)))
    data = encode_servo_frame(sent)
    assert len(data) == size
    assert int.from_bytes(data[:2], "little") == magic
    assert decode_servo_frame(data) == sent


def test_a_packet_of_the_wrong_size_or_magic_is_refused() -> None:
    good = encode_servo_frame(frame(1, (NEUTRAL,) * 4))
    with pytest.raises(FrameError, match="41 bytes"):
        decode_servo_frame(good + b"\0")
    with pytest.raises(FrameError, match="magic"):
        decode_servo_frame(b"\x00\x00" + good[2:])
    sixteen_with_32_magic = MAGIC_32.to_bytes(2, "little") + good[2:]
    with pytest.raises(FrameError, match="expected 18458"):
        decode_servo_frame(sixteen_with_32_magic)


@settings(max_examples=300)
@given(st.binary(max_size=100))
def test_any_datagram_decodes_or_is_refused_by_name(data: bytes) -> None:
    try:
        got = decode_servo_frame(data)
    except FrameError:
        return
    assert len(data) in (PACKET_16_BYTES, PACKET_32_BYTES)
    assert len(got.pwm_us) in (16, 32)


def test_step_follows_sitls_frame_rate_within_what_sim_json_accepts() -> None:
    assert step_s_for(400) == pytest.approx(0.0025)
    assert step_s_for(0) > 0  # before SITL says its rate
    assert step_s_for(1) <= 0.05  # SIM_JSON ignores steps of 0.1 s and more
    assert step_s_for(65535) >= 1e-4


# -- the plant --------------------------------------------------------------------------------


def test_at_neutral_the_rover_rests_and_the_accelerometer_reads_gravity() -> None:
    plant = JsonPlant(PlantConfig())
    report = drive(plant, (NEUTRAL,) * 4, 1.0)
    assert report.timestamp_s == pytest.approx(1.0)
    assert report.position_ned_m == (0.0, 0.0, 0.0)
    assert report.velocity_ned_mps == (0.0, 0.0, 0.0)
    assert report.gyro_frd_radps == (0.0, 0.0, 0.0)
    assert report.accel_frd_mss == pytest.approx((0.0, 0.0, -GRAVITY_MSS))


def test_roll_drives_forward_north_when_facing_north() -> None:
    # eq. 2 with v_y = v_θ = 0: ω1 = ω2 = −ω3 = −ω4
    plant = JsonPlant(PlantConfig())
    first = plant.step(frame(0, (1800, 1800, 1200, 1200)))
    assert first.accel_frd_mss[0] > 0.1  # the scrolls spin up: forward acceleration
    report = drive(plant, (1800, 1800, 1200, 1200), 3.0, start=1)
    north, east, _ = report.position_ned_m
    assert north > 1.0
    assert abs(east) < 1e-6
    assert report.velocity_ned_mps[0] > 0.3
    assert report.attitude_rad == pytest.approx((0.0, 0.0, 0.0))


def test_scroll_drives_along_the_scrolls_to_the_left() -> None:
    # eq. 2 with v_x = v_θ = 0 and v_y > 0 (left): ω1 = −ω2 = −ω3 = ω4; facing north, left is west
    plant = JsonPlant(PlantConfig())
    report = drive(plant, (1800, 1200, 1200, 1800), 3.0)
    north, east, _ = report.position_ned_m
    assert east < -0.3
    assert abs(north) < 1e-6
    # hard ground passes less of the scroll axis than of the roll axis (the traction table)
    roll = drive(JsonPlant(PlantConfig()), (1800, 1800, 1200, 1200), 3.0)
    assert abs(east) < roll.position_ned_m[0]


def test_counter_clockwise_yaw_is_a_negative_ned_yaw_rate() -> None:
    plant = JsonPlant(PlantConfig())
    report = drive(plant, (1700,) * 4, 1.0)  # all four forward: v_θ > 0, CCW
    assert report.gyro_frd_radps[2] < -0.1
    assert report.attitude_rad[2] < -0.1
    assert report.position_ned_m[:2] == pytest.approx((0.0, 0.0), abs=1e-9)


def test_the_same_physics_as_the_built_in_simulator() -> None:
    cfg = PlantConfig(terrain=Terrain.MUD)
    plant = JsonPlant(cfg)
    scrolls = (1700, 1400, 1300, 1650)
    drive(plant, scrolls, 2.0)
    state = PhysicsState()
    motor = MotorMap()
    fractions = physics.scroll_fractions_from_pwm(
        list(scrolls) + [0] * 12, (1, 2, 3, 4), (False,) * 4, motor
    )
    for _ in range(2 * RATE_HZ):
        state = physics.step(
            state, 1.0 / RATE_HZ, fractions, cfg.vehicle, cfg.traction(), cfg.motor_time_constant_s
        )
    assert plant.state == state


def test_a_frame_count_going_back_is_sitl_restarting() -> None:
    plant = JsonPlant(PlantConfig())
    drive(plant, (1800, 1800, 1200, 1200), 1.0)
    assert plant.state.north_m > 0.05
    report = plant.step(frame(0, (NEUTRAL,) * 4))
    assert plant.restarts == 1
    assert report.timestamp_s == pytest.approx(1.0 / RATE_HZ)
    assert report.position_ned_m == (0.0, 0.0, 0.0)


def test_no_pulses_stop_the_motors() -> None:
    plant = JsonPlant(PlantConfig())
    report = drive(plant, (0, 0, 0, 0), 1.0)
    assert report.position_ned_m == (0.0, 0.0, 0.0)


def test_the_report_is_one_json_object_between_two_newlines() -> None:
    plant = JsonPlant(PlantConfig())
    data = plant.step(frame(0, (1800, 1800, 1200, 1200))).to_json_bytes()
    assert data.startswith(b"\n") and data.endswith(b"\n") and data.count(b"\n") == 2
    body = json.loads(data)
    assert set(body) == {"timestamp", "imu", "position", "velocity", "attitude"}
    assert set(body["imu"]) == {"gyro", "accel_body"}
    values = [body["timestamp"], *body["imu"]["gyro"], *body["imu"]["accel_body"]]
    values += body["position"] + body["velocity"] + body["attitude"]
    assert all(math.isfinite(v) for v in values)


# -- with a media map and a bathymetry ------------------------------------------------------


def test_with_a_media_map_each_scroll_meets_the_medium_under_it() -> None:
    # water all round the start: rolling gives next to nothing, scrolling propels
    pond = MediaMap(
        MediaFrame.LOCAL_NED,
        (MediaArea(Medium.WATER, ((-50.0, -50.0), (-50.0, 50.0), (50.0, 50.0), (50.0, -50.0))),),
    )
    cfg = PlantConfig(media=pond)
    roll = drive(JsonPlant(cfg), (1800, 1800, 1200, 1200), 3.0)
    plant = JsonPlant(cfg)
    scroll = drive(plant, (1800, 1200, 1200, 1800), 3.0)
    on_land = drive(JsonPlant(PlantConfig()), (1800, 1800, 1200, 1200), 3.0)
    assert plant.scroll_media == ("water",) * 4
    assert roll.position_ned_m[0] < 0.1 * on_land.position_ned_m[0]
    assert abs(scroll.position_ned_m[1]) > 3 * roll.position_ned_m[0]


def test_with_a_bathymetry_the_sonar_range_goes_to_sitls_rangefinder_1() -> None:
    """SIM_JSON reads ``rng_1`` into rangefinder 1 (SITL's RNGFND1_TYPE 100): the water under
    the rover less the transducer's depth, 0 over dry ground."""
    cfg = PlantConfig()
    lat0, lon0 = cfg.origin_lat_deg, cfg.origin_lon_deg
    bottom = Bathymetry.model_validate(
        {
            "format": "helixd-bathymetry/1",
            "south_west": {"lat_deg": lat0 - 1e-4, "lon_deg": lon0 - 1e-4},
            "cell_m": 5.0,
            "depth_m": [[2.0] * 6, [2.0] * 6, [2.0] * 6, [2.0] * 6, [None] * 6],
        }
    )
    plant = JsonPlant(
        cfg.model_copy(update={"bathymetry": bottom, "sonar": SonarModel(offset_m=0.25)})
    )
    body = json.loads(plant.step(frame(0, (1500, 1500, 1500, 1500))).to_json_bytes())
    assert body["rng_1"] == pytest.approx(1.75)
    north = drive(plant, (1800, 1800, 1200, 1200), 40.0, start=1).position_ned_m[0]
    assert north > 12.0  # rolled north, past the last wet row
    assert json.loads(plant.step(frame(10**7, (1500,) * 4)).to_json_bytes())["rng_1"] == 0.0
    assert "rng_1" not in json.loads(JsonPlant(cfg).step(frame(0, (1500,) * 4)).to_json_bytes())
