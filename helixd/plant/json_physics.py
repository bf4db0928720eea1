"""The Helix plant as ArduPilot SITL's physics: the frames of SITL's JSON interface (pure).

ArduPilot SITL started with ``--model JSON`` takes its vehicle physics from another process
(``libraries/SITL/SIM_JSON.cpp``). Each physics step, lockstep:

* SITL sends one UDP datagram of servo outputs: little-endian ``uint16 magic, uint16
  frame_rate_hz, uint32 frame_count, uint16 pwm[16]`` (magic 18458) or ``pwm[32]`` (magic
  29569, on builds with 32 servo channels, SITL's);
* the physics answers with one JSON object, newline-framed: ``timestamp`` (s, the physics
  clock; SITL advances its own clock by the difference, which must be in (0, 0.1) s),
  ``imu.gyro`` (body FRD rad/s), ``imu.accel_body`` (body FRD m/s², specific force: gravity's
  reaction −9.80665 on z at rest), ``position`` (NED m from SITL's home), ``velocity`` (NED
  m/s) and ``attitude`` (roll, pitch, yaw rad; yaw clockwise from North).

ArduPilot's EKF3 fuses those with GPS and compass readings SITL simulates from the same
truth, so no pose noise is added here (the built-in simulator's noise stands in for exactly
that sensor model).

:class:`JsonPlant` steps :func:`helixd.plant.physics.step` — the same plant ``helixd sim`` flies
(eq. 1, motor lag, terrain traction and pits) — on the four scroll outputs of each frame. The
rover stays on flat ground: roll, pitch and vertical motion are zero. Frames: the plant's
state is NED with body x forward (ROLL axis) and y left (SCROLL axis), yaw rate CCW positive;
it is converted here, once, to SITL's FRD body frame (y right, z down, yaw rate clockwise).
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass

from helixd.plant import physics
from helixd.plant.ground import TerrainTraction
from helixd.plant.plant_config import PlantConfig
from helixd.plant.world import bathymetry_ne, media_ne

GRAVITY_MSS = 9.80665
MAGIC_16 = 18458  # servo_packet_16
MAGIC_32 = 29569  # servo_packet_32
_HEADER = struct.Struct("<HHI")
PACKET_16_BYTES = _HEADER.size + 2 * 16
PACKET_32_BYTES = _HEADER.size + 2 * 32
# SIM_JSON advances its clock only by a step in (0, 0.1) s; its frame rate follows ours
MIN_STEP_S = 1e-4
MAX_STEP_S = 0.05
DEFAULT_RATE_HZ = 400  # until SITL says its frame rate


class FrameError(ValueError):
    """A datagram that is not one of SITL's servo packets."""


@dataclass(frozen=True, slots=True)
class ServoFrame:
    """One servo packet: SITL's frame rate and count, and its outputs (µs, output n at n−1;
    0 = no pulses)."""

    frame_rate_hz: int
    frame_count: int
    pwm_us: tuple[int, ...]


def decode_servo_frame(data: bytes) -> ServoFrame:
    """A servo datagram → :class:`ServoFrame`; :class:`FrameError` for anything else (wrong
    size or magic): the UDP port is open to whatever is on the machine."""
    if len(data) not in (PACKET_16_BYTES, PACKET_32_BYTES):
        raise FrameError(
            f"{len(data)} bytes: a servo packet is {PACKET_16_BYTES} or {PACKET_32_BYTES}"
        )
    magic, rate_hz, count = _HEADER.unpack_from(data)
    channels = 16 if len(data) == PACKET_16_BYTES else 32
    expected = MAGIC_16 if channels == 16 else MAGIC_32
    if magic != expected:
        raise FrameError(f"magic {magic}, expected {expected} for {channels} channels")
    pwm = struct.unpack_from(f"<{channels}H", data, _HEADER.size)
    return ServoFrame(int(rate_hz), int(count), tuple(int(p) for p in pwm))


def encode_servo_frame(frame: ServoFrame) -> bytes:
    """The datagram SITL would send for ``frame`` (16 or 32 outputs); for tests and tools."""
    channels = len(frame.pwm_us)
    if channels not in (16, 32):
        raise FrameError(f"{channels} outputs: a servo packet has 16 or 32")
    magic = MAGIC_16 if channels == 16 else MAGIC_32
    return _HEADER.pack(magic, frame.frame_rate_hz, frame.frame_count) + struct.pack(
        f"<{channels}H", *frame.pwm_us
    )


@dataclass(frozen=True, slots=True)
class FdmReport:
    """What the physics tells SITL each frame (SITL's frames: NED world, FRD body)."""

    timestamp_s: float
    gyro_frd_radps: tuple[float, float, float]
    accel_frd_mss: tuple[float, float, float]
    position_ned_m: tuple[float, float, float]
    velocity_ned_mps: tuple[float, float, float]
    attitude_rad: tuple[float, float, float]  # roll, pitch, yaw (clockwise from North)
    # SIM_JSON's ``rng_1``: rangefinder 1's distance (m), the sonar's range to the pond's
    # bottom (SITL's rangefinder type 100 reads it); None: no field (no bathymetry). SIM_JSON
    # copies rng[0] into rangefinder 1 when bit 7 of the keys it received is set, which since
    # latitude/longitude/altitude joined its key table is ``attitude``'s (rng_1 is key 10):
    # sent every frame here, so rangefinder 1 follows rng_1 either way
    rangefinder_m: float | None = None

    def to_json_bytes(self) -> bytes:
        """One newline-framed JSON object. SIM_JSON parses the text between the last two
        newlines it holds, so the object is sent between two: parsed in the same frame."""
        body = {
            "timestamp": self.timestamp_s,
            "imu": {"gyro": list(self.gyro_frd_radps), "accel_body": list(self.accel_frd_mss)},
            "position": list(self.position_ned_m),
            "velocity": list(self.velocity_ned_mps),
            "attitude": list(self.attitude_rad),
        }
        if self.rangefinder_m is not None:
            body["rng_1"] = self.rangefinder_m
        return ("\n" + json.dumps(body, separators=(",", ":")) + "\n").encode("ascii")


def step_s_for(frame_rate_hz: int) -> float:
    """The physics step for SITL's frame rate (its ``rate_hz``), kept where SIM_JSON advances."""
    rate = frame_rate_hz if frame_rate_hz > 0 else DEFAULT_RATE_HZ
    return min(MAX_STEP_S, max(MIN_STEP_S, 1.0 / rate))


class JsonPlant:
    """The Helix plant stepped by SITL's servo frames (pure: no socket, no clock).

    ``step(frame)`` advances the plant by one SITL frame and returns the report to send back.
    A frame count lower than the last one is SITL restarting: the plant starts over at rest.
    With a media map in ``cfg`` (``media``, placed around ``origin_lat_deg``/``origin_lon_deg``,
    which must be SITL's ``--home``), each scroll meets the medium under it, as in ``helixd
    sim``; ``scroll_media`` says which.
    """

    def __init__(self, cfg: PlantConfig) -> None:
        self._cfg = cfg
        self._motor = cfg.motor_map()
        self._traction = cfg.traction()
        self._media = media_ne(cfg)
        self.scroll_media: tuple[str, ...] | None = None
        # the pond's bottom under the sonar (SITL's rangefinder 1, JSON ``rng_1``)
        self._bathy = bathymetry_ne(cfg)
        self._initial = cfg.start_state()
        self.restarts = 0
        self._reset()

    def _reset(self) -> None:
        self.state = self._initial
        self.time_s = 0.0
        self.frames = 0
        self._last_count: int | None = None
        self._last_v_ned = (0.0, 0.0)
        self._fractions: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    @property
    def scroll_fractions(self) -> tuple[float, float, float, float]:
        """The four scroll commands of the last frame (signed fractions of max RPM)."""
        return self._fractions

    def step(self, frame: ServoFrame) -> FdmReport:
        if self._last_count is not None and frame.frame_count < self._last_count:
            self.restarts += 1
            self._reset()
        self._last_count = frame.frame_count
        dt = step_s_for(frame.frame_rate_hz)
        pwm = list(frame.pwm_us) + [0] * max(0, 16 - len(frame.pwm_us))
        self._fractions = physics.scroll_fractions_from_pwm(
            pwm, self._cfg.scroll_output_channels, self._cfg.scroll_reversed, self._motor
        )
        self.state = physics.step(
            self.state,
            dt,
            self._fractions,
            self._cfg.vehicle,
            self._tractions(),
            self._cfg.motor_time_constant_s,
        )
        self.time_s += dt
        self.frames += 1
        return self._report(dt)

    def _tractions(self) -> TerrainTraction | tuple[TerrainTraction, ...]:
        """The ground under the whole rover, or under each scroll where a map says."""
        if self._media is None:
            return self._traction
        s = self.state
        where = physics.scroll_positions_ne(s.north_m, s.east_m, s.yaw_ned_rad, self._cfg.vehicle)
        media = tuple(self._media.medium_at(n, e) for n, e in where)
        self.scroll_media = tuple(m.value for m in media)
        return tuple(self._cfg.terrains.get(m) for m in media)

    def _report(self, dt: float) -> FdmReport:
        s = self.state
        v_n, v_e = s.v_north_mps, s.v_east_mps
        # acceleration in NED from the velocity change, rotated into the body: FRD x forward,
        # y right; the specific force adds gravity's reaction on z (−g, the accelerometer at rest)
        a_n = (v_n - self._last_v_ned[0]) / dt
        a_e = (v_e - self._last_v_ned[1]) / dt
        self._last_v_ned = (v_n, v_e)
        c, sn = math.cos(s.yaw_ned_rad), math.sin(s.yaw_ned_rad)
        a_fwd = a_n * c + a_e * sn
        a_right = -a_n * sn + a_e * c
        return FdmReport(
            timestamp_s=self.time_s,
            gyro_frd_radps=(0.0, 0.0, s.yaw_rate_ned_radps),
            accel_frd_mss=(a_fwd, a_right, -GRAVITY_MSS),
            position_ned_m=(s.north_m, s.east_m, 0.0),
            velocity_ned_mps=(v_n, v_e, 0.0),
            attitude_rad=(0.0, 0.0, s.yaw_ned_rad),
            rangefinder_m=self._range_m(),
        )

    def _range_m(self) -> float | None:
        """The sonar's range to the bottom under the rover (the water less the transducer's
        depth; 0 over dry ground: out of range low); None without a bathymetry."""
        if self._bathy is None:
            return None
        depth = self._bathy.depth_at(self.state.north_m, self.state.east_m)
        return 0.0 if depth is None else max(0.0, depth - self._cfg.sonar.offset_m)
