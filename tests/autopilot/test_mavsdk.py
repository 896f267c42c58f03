"""The simulated PX4 vehicle driven by a real client: MAVSDK-Python 4.x (``mavsdk``, the native binding of MAVSDK's C++
core; its asyncio API) against one :class:`~swarmtrack.autopilot.solo.SoloVehicle` on loopback UDP, as a companion
program would fly a PX4 SITL instance. One vehicle and one connected system for the module (it starts landed and
disarmed); each flight test first sets up the state it starts from (landed, or airborne in Hold), so that pytest-xdist
may run other modules' tests between them (and set the module's vehicle up again).

Each MAVSDK call is awaited with its own timeout (:func:`run`, :func:`until`); the vehicle's thread and sockets and
MAVSDK's instance are closed by the fixture. Tolerances, stated where asserted, are the simulated vehicle's:
PX4's position/velocity cascade around a point mass at 50 Hz, seen through float32 MAVLink fields at the telemetry
rates of PX4's onboard link.
"""

from __future__ import annotations

import asyncio
import math
import socket
import time
from dataclasses import dataclass, field

import pytest
from mavsdk import LogLevel, log_subscribe, log_unsubscribe
from mavsdk.asyncio import Autopilot, ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.info import InfoAsync, InfoError, Version
from mavsdk.asyncio.plugins.mission import MissionAsync, MissionItem, MissionPlan
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
from mavsdk.asyncio.plugins.offboard import AccelerationNed, OffboardAsync, VelocityNedYaw
from mavsdk.asyncio.plugins.param import ParamAsync, ParamError
from mavsdk.asyncio.plugins.telemetry import FlightMode, LandedState, TelemetryAsync

from swarmtrack.autopilot.geodesy import PX4_SITL
from swarmtrack.autopilot.params import INT32, TABLE
from swarmtrack.autopilot.solo import SoloVehicle
from swarmtrack.autopilot.telemetry import UID_BASE

# one worker runs these in file order, beside nothing real-time of its own: the live group's worker
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("live-2")]  # with the live tests of autopilots, not under them

TAKEOFF_ALT = 2.5  # MIS_TAKEOFF_ALT's default (m above home)


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(coro, timeout: float):
    """Await ``coro`` within ``timeout`` s on a loop of its own (MAVSDK's asyncio calls run its blocking C calls in
    the loop's executor)."""
    return asyncio.run(asyncio.wait_for(coro, timeout))


async def count(subscribe, seconds: float) -> int:
    """How many updates the MAVSDK subscription ``subscribe()`` gives in ``seconds``."""
    stream, n = subscribe(), 0
    deadline = time.monotonic() + seconds
    try:
        while (left := deadline - time.monotonic()) > 0:
            try:
                await asyncio.wait_for(stream.__anext__(), left)
            except TimeoutError:
                break
            n += 1
    finally:
        await stream.aclose()
    return n


async def until(get, ok, timeout: float, what: str, period: float = 0.05):
    """Poll ``await get()`` until ``ok(value)``; AssertionError naming ``what`` and the last value after
    ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while True:
        value = await get()
        if ok(value):
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"{what}: not within {timeout:g} s; last {value}")
        await asyncio.sleep(period)


async def speed_factor(info, timeout: float = 3.0) -> float:
    """MAVSDK's estimate of the simulation's speed, once it has seen enough ``ATTITUDE`` messages (before: an error,
    then NaN)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            factor = await info.get_speed_factor()
        except InfoError:
            factor = math.nan
        if math.isfinite(factor) or time.monotonic() > deadline:
            return factor
        await asyncio.sleep(0.1)


async def landed(drone) -> None:
    """The vehicle on the ground and disarmed (landed first if it flies): each flight test sets up the state it starts
    from, as pytest may run another module's tests between them and set the module's vehicle up again."""
    t = drone.telemetry
    if await t.in_air():
        await drone.action.land()
        await until(t.landed_state, lambda s: s == LandedState.ON_GROUND, 10.0, "landed")
    if await t.armed():
        await drone.action.disarm()
        await until(t.armed, lambda armed: not armed, 5.0, "disarmed")


async def airborne(drone) -> None:
    """The vehicle armed and in Hold at the takeoff altitude (armed and taken off if it is on the ground)."""
    t = drone.telemetry
    if not await t.in_air():
        if not await t.armed():
            await drone.action.arm()
        await drone.action.takeoff()
        await until(t.position, lambda p: abs(p.relative_altitude_m - TAKEOFF_ALT) < 0.15, 10.0, "climb")
    if await t.flight_mode() != FlightMode.HOLD:
        await drone.action.hold()
        await until(t.flight_mode, lambda m: m == FlightMode.HOLD, 2.0, "Hold")


@dataclass
class Drone:
    sdk: Mavsdk
    solo: SoloVehicle
    system: object
    logs: list = field(default_factory=list)
    expected: list = field(default_factory=list)  # what MAVSDK logged because a test asked for an error

    def __post_init__(self):
        s = self.system
        self.telemetry, self.info, self.param = TelemetryAsync(s), InfoAsync(s), ParamAsync(s)
        self.mission, self.mission_raw = MissionAsync(s), MissionRawAsync(s)
        self.action, self.offboard = ActionAsync(s), OffboardAsync(s)


@pytest.fixture(scope="module")
def drone():
    logs: list[tuple[str, str]] = []
    log_subscribe(lambda level, msg, file, line: (level < LogLevel.WARN or logs.append((level.name, msg))) or True)
    port = _free_port()
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        run(sdk.add_any_connection(f"udpin://127.0.0.1:{port}"), 5.0)
        with SoloVehicle(port=port, local_port=_free_port(), gcs_local_port=_free_port()) as solo:
            system = run(sdk.first_autopilot(10.0), 15.0)
            assert system is not None, "MAVSDK found no autopilot within 10 s"
            yield Drone(sdk, solo, system, logs)
    finally:
        sdk.destroy()
        log_unsubscribe()


# -- connecting, telemetry, info ---------------------------------------------------------------------------------------

def test_connects_to_a_px4_autopilot(drone):
    async def go():
        assert await drone.system.has_autopilot() and await drone.system.is_connected()
        assert await drone.system.autopilot_type() == Autopilot.PX4
        assert await drone.system.get_system_id() == 1
    run(go(), 5.0)


def test_telemetry_on_the_ground(drone):
    t = drone.telemetry

    async def go():
        pos = await until(t.position, lambda p: math.isfinite(p.latitude_deg), 5.0, "GLOBAL_POSITION_INT")
        assert pos.latitude_deg == pytest.approx(PX4_SITL.lat, abs=1e-7)  # at the origin: PX4 SITL's start
        assert pos.longitude_deg == pytest.approx(PX4_SITL.lon, abs=1e-7)
        assert pos.absolute_altitude_m == pytest.approx(PX4_SITL.alt, abs=0.01)
        assert pos.relative_altitude_m == pytest.approx(0.0, abs=0.01)
        att = await until(t.attitude_euler, lambda a: math.isfinite(a.roll_deg), 5.0, "ATTITUDE")
        assert abs(att.roll_deg) < 0.1 and abs(att.pitch_deg) < 0.1
        assert await t.flight_mode() == FlightMode.POSCTL
        assert await t.armed() is False
        assert await until(t.landed_state, lambda s: s == LandedState.ON_GROUND, 5.0, "EXTENDED_SYS_STATE")
        # PX4 has a home before arming (MAVSDK's examples wait for it): HOME_POSITION at 0.5 Hz or on request
        health = await until(t.health, lambda h: h.is_global_position_ok and h.is_home_position_ok, 5.0,
                             "SYS_STATUS and HOME_POSITION")
        home = await t.home()
        assert (home.latitude_deg, home.longitude_deg) == (pytest.approx(PX4_SITL.lat, abs=1e-7),
                                                           pytest.approx(PX4_SITL.lon, abs=1e-7))
        assert health.is_local_position_ok and health.is_armable and health.is_gyrometer_calibration_ok
        assert health.is_accelerometer_calibration_ok and health.is_magnetometer_calibration_ok
        battery = await until(t.battery, lambda b: b.remaining_percent > 0, 5.0, "BATTERY_STATUS")
        assert battery.remaining_percent == 100.0 and battery.voltage_v == pytest.approx(4 * 4.05, abs=0.01)
        pv = await t.position_velocity_ned()
        assert abs(pv.position.north_m) < 0.01 and abs(pv.velocity.north_m_s) < 0.01
    run(go(), 20.0)


def test_set_rate_changes_a_streams_rate(drone):
    """telemetry.set_rate_attitude_euler is SET_MESSAGE_INTERVAL for ATTITUDE: 5 Hz counted over 2 s (at most 12; a
    busy machine can only make fewer come, so the lower bounds are loose), then 0 Hz restores the onboard link's
    default (PX4's 100 Hz, here the vehicle's 50 Hz steps: at least 25 in 1 s)."""
    t = drone.telemetry

    async def go():
        await t.set_rate_attitude_euler(5.0)
        await asyncio.sleep(0.3)
        assert 4 <= await count(t.subscribe_attitude_euler, 2.0) <= 12
        await t.set_rate_attitude_euler(0.0)
        await asyncio.sleep(0.3)
        assert await count(t.subscribe_attitude_euler, 1.0) >= 25
    run(go(), 15.0)


def test_a_ground_station_on_the_gcs_link_gets_px4s_normal_rates(drone):
    """A second MAVSDK instance, a ground station sending to the vehicle's GCS port (PX4 SITL's 18570 + i), claims the
    link and gets its streams at PX4's "normal" rates, beside the companion's "onboard" ones: ATTITUDE 15 Hz (at most
    34 in 2 s; onboard at least 25 in 1 s, the vehicle's 50 Hz steps capping PX4's 100 Hz), LOCAL_POSITION_NED 1 Hz
    (1 to 3 in 2 s), GPS_RAW_INT 5 Hz (at most 12 in 2 s); and a parameter the companion changed is the GCS's value
    too. A busy machine can only make fewer come: the upper bounds are tight, the lower ones loose."""
    gcs = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        async def go():
            await gcs.add_any_connection(f"udpout://127.0.0.1:{drone.solo.vehicle.gcs_link.port}")
            system = await gcs.first_autopilot(10.0)
            assert system is not None and await system.get_system_id() == 1
            t = TelemetryAsync(system)
            await asyncio.sleep(1.0)
            assert 12 <= await count(t.subscribe_attitude_euler, 2.0) <= 34
            assert 1 <= await count(t.subscribe_position_velocity_ned, 2.0) <= 3
            assert 4 <= await count(t.subscribe_raw_gps, 2.0) <= 12
            assert await count(drone.telemetry.subscribe_attitude_euler, 1.0) >= 25
            await drone.param.set_param_float("RTL_RETURN_ALT", 30.0)
            assert await ParamAsync(system).get_param_float("RTL_RETURN_ALT") == 30.0
            await drone.param.set_param_float("RTL_RETURN_ALT", 60.0)
        run(go(), 30.0)
    finally:
        gcs.destroy()


def test_info_version_identification_product(drone):
    async def go():
        version = await drone.info.get_version()
        assert (version.flight_sw_major, version.flight_sw_minor, version.flight_sw_patch) == (1, 14, 0)
        assert version.flight_sw_version_type == Version.FlightSoftwareVersionType.RELEASE
        ident = await drone.info.get_identification()
        assert ident.legacy_uid == UID_BASE  # system 1
        assert ident.hardware_uid == (b"swarmtrack".ljust(17, b"\0") + bytes([1])).hex()
        product = await drone.info.get_product()
        assert product.vendor_id == 0 and product.product_id == 0
        # MAVSDK's estimate of the simulation's speed from ATTITUDE's time_boot_ms: the vehicle runs in real time
        assert await speed_factor(drone.info) == pytest.approx(1.0, abs=0.2)
    run(go(), 10.0)


# -- parameters --------------------------------------------------------------------------------------------------------

def test_param_get_and_set_an_int(drone):
    async def go():
        assert await drone.param.get_param_int("COM_OBL_RC_ACT") == 0
        await drone.param.set_param_int("COM_OBL_RC_ACT", 5)
        assert await drone.param.get_param_int("COM_OBL_RC_ACT") == 5
        assert drone.solo.vehicle.params.get("COM_OBL_RC_ACT") == 5  # the vehicle flies by it
        await drone.param.set_param_int("COM_OBL_RC_ACT", 0)
    run(go(), 15.0)


def test_param_get_and_set_a_float(drone):
    async def go():
        assert await drone.param.get_param_float("COM_OF_LOSS_T") == 1.0
        await drone.param.set_param_float("MPC_XY_VEL_MAX", 7.5)
        assert await drone.param.get_param_float("MPC_XY_VEL_MAX") == 7.5
        assert drone.solo.vehicle.params.get("MPC_XY_VEL_MAX") == 7.5
        await drone.param.set_param_float("MPC_XY_VEL_MAX", 12.0)
    run(go(), 15.0)


def test_param_get_all(drone):
    async def go():
        every = await drone.param.get_all_params()
        ints = {p.name: p.value for p in every.int_params}
        floats = {p.name: p.value for p in every.float_params}
        assert set(ints) == {p.name for p in TABLE if p.type == INT32}
        assert set(floats) == {p.name for p in TABLE if p.type != INT32}
        assert ints["BAT1_N_CELLS"] == 4 and floats["RTL_RETURN_ALT"] == 60.0
    run(go(), 15.0)


def test_param_of_an_unknown_name_is_an_error(drone):
    async def go():
        with pytest.raises(ParamError):  # PX4 does not answer an unknown name: MAVSDK retries, then times out
            await drone.param.get_param_float("NO_SUCH_PARAM")
    before = len(drone.logs)
    run(go(), 15.0)
    drone.expected.extend(drone.logs[before:])  # MAVSDK's "Retrying failed"


# -- missions ----------------------------------------------------------------------------------------------------------

def _waypoint(lat: float, lon: float, alt: float) -> MissionItem:
    nan = float("nan")
    return MissionItem(lat, lon, alt, 5.0, True, nan, nan, MissionItem.CameraAction.NONE, nan, nan, nan, nan, nan,
                       MissionItem.VehicleAction.NONE)


def test_mission_download_empty_upload_download_clear(drone):
    plan = [_waypoint(47.3980, 8.5460, 10.0), _waypoint(47.3985, 8.5450, 15.0)]

    async def go():
        assert (await drone.mission.download_mission()).mission_items == []
        await drone.mission.upload_mission(MissionPlan(plan))
        back = (await drone.mission.download_mission()).mission_items
        assert [(i.latitude_deg, i.longitude_deg, i.relative_altitude_m) for i in back] == [
            (pytest.approx(w.latitude_deg, abs=1e-7), pytest.approx(w.longitude_deg, abs=1e-7), w.relative_altitude_m)
            for w in plan]
        raw = await drone.mission_raw.download_mission()
        assert len(raw) >= len(plan) and len(drone.solo.vehicle.missions.items[0]) == len(raw)  # stored, not flown
        await drone.mission.clear_mission()
        assert (await drone.mission.download_mission()).mission_items == []
        assert await drone.telemetry.flight_mode() == FlightMode.POSCTL
    run(go(), 30.0)


# -- flying: arm, take off, hold, offboard, land (each from the state it sets up) --------------------------------------

def test_arm_sets_home(drone):
    t = drone.telemetry

    async def go():
        await landed(drone)
        await drone.action.arm()
        assert await until(t.armed, bool, 2.0, "armed")
        await until(t.health, lambda h: h.is_home_position_ok, 5.0, "HOME_POSITION")
        home = await t.home()
        assert home.latitude_deg == pytest.approx(PX4_SITL.lat, abs=1e-6)
        assert home.longitude_deg == pytest.approx(PX4_SITL.lon, abs=1e-6)
    run(go(), 30.0)


def test_takeoff_reaches_the_takeoff_altitude_and_holds(drone):
    t = drone.telemetry

    async def go():
        await landed(drone)
        await drone.action.arm()
        await drone.action.takeoff()
        # within 0.15 m of MIS_TAKEOFF_ALT (2.5 m at MPC_TKO_SPEED 1.5 m/s), then PX4's Hold
        pos = await until(t.position, lambda p: abs(p.relative_altitude_m - TAKEOFF_ALT) < 0.15, 10.0, "climb")
        assert await until(t.flight_mode, lambda m: m == FlightMode.HOLD, 5.0, "Hold after takeoff")
        assert await t.in_air() and await until(t.landed_state, lambda s: s == LandedState.IN_AIR, 2.0, "in air")
        assert abs(pos.relative_altitude_m - drone.solo.altitude) < 0.3
        # FLIGHT_INFORMATION (MAVSDK asks for it at 1 Hz with SET_MESSAGE_INTERVAL): armed before it took off
        stream = drone.info.subscribe_flight_information()
        try:
            flight = await asyncio.wait_for(stream.__anext__(), 3.0)
        finally:
            await stream.aclose()
        assert flight.duration_since_arming_ms > flight.duration_since_takeoff_ms > 0
    run(go(), 40.0)


def test_hold_keeps_the_position(drone):
    t = drone.telemetry

    async def go():
        await airborne(drone)
        await drone.action.hold()
        assert await until(t.flight_mode, lambda m: m == FlightMode.HOLD, 2.0, "Hold")
        a = (await t.position_velocity_ned()).position
        await asyncio.sleep(2.0)
        b = (await t.position_velocity_ned()).position
        assert math.dist((a.north_m, a.east_m, a.down_m), (b.north_m, b.east_m, b.down_m)) < 0.2
    run(go(), 30.0)


def test_offboard_velocity_setpoints_are_flown(drone):
    t = drone.telemetry

    async def go():
        await airborne(drone)
        await drone.offboard.set_velocity_ned(VelocityNedYaw(1.0, 0.5, 0.0, 0.0))
        await drone.offboard.start()
        assert await until(t.flight_mode, lambda m: m == FlightMode.OFFBOARD, 2.0, "Offboard")
        await asyncio.sleep(3.0)  # PX4's velocity loop (MPC_XY_VEL_P_ACC 1.8/s) settles within ~2 s
        a = await t.position_velocity_ned()
        ta = time.monotonic()
        # the velocity commanded, within 0.1 m/s; the altitude kept within 0.2 m
        assert a.velocity.north_m_s == pytest.approx(1.0, abs=0.1)
        assert a.velocity.east_m_s == pytest.approx(0.5, abs=0.1)
        assert abs(a.velocity.down_m_s) < 0.1 and abs(-a.position.down_m - TAKEOFF_ALT) < 0.2
        await asyncio.sleep(1.0)
        b = await t.position_velocity_ned()
        dt = time.monotonic() - ta
        # ... and it moves by it: (1.0, 0.5) m/s × the time between the samples, within 0.15 m (each sample is up to
        # one 50 Hz step old, plus the loopback and MAVSDK's callback thread)
        assert b.position.north_m - a.position.north_m == pytest.approx(1.0 * dt, abs=0.15)
        assert b.position.east_m - a.position.east_m == pytest.approx(0.5 * dt, abs=0.15)
    run(go(), 35.0)


def test_offboard_acceleration_setpoints_are_flown(drone):
    t = drone.telemetry

    async def go():
        await airborne(drone)
        await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 0.0))
        await drone.offboard.start()
        await until(t.position_velocity_ned, lambda pv: math.hypot(pv.velocity.north_m_s, pv.velocity.east_m_s) < 0.05,
                    5.0, "stopped")
        a = await t.position_velocity_ned()
        t0 = time.monotonic()
        await drone.offboard.set_acceleration_ned(AccelerationNed(0.5, -0.25, 0.0))
        assert await t.flight_mode() == FlightMode.OFFBOARD
        await asyncio.sleep(2.0)
        b = await t.position_velocity_ned()
        dt = time.monotonic() - t0
        # the velocity grew by the acceleration × the time, within 0.2 m/s (the 50 Hz steps and the samples' timing)
        assert b.velocity.north_m_s - a.velocity.north_m_s == pytest.approx(0.5 * dt, abs=0.2)
        assert b.velocity.east_m_s - a.velocity.east_m_s == pytest.approx(-0.25 * dt, abs=0.2)
        assert abs(-b.position.down_m - TAKEOFF_ALT) < 0.3
        await drone.offboard.stop()  # MAVSDK switches to Hold
        assert await until(t.flight_mode, lambda m: m == FlightMode.HOLD, 2.0, "Hold after offboard")
    run(go(), 35.0)


def test_land_lands_and_disarms(drone):
    t = drone.telemetry

    async def go():
        await airborne(drone)
        await drone.action.land()
        assert await until(t.flight_mode, lambda m: m == FlightMode.LAND, 2.0, "Land")
        # down at MPC_LAND_SPEED 0.7 m/s (about 4 s), disarmed COM_DISARM_LAND 2 s after touching down
        assert await until(t.landed_state, lambda s: s == LandedState.ON_GROUND, 10.0, "landed")
        assert not await until(t.armed, lambda armed: not armed, 5.0, "disarmed")
        assert abs((await t.position()).relative_altitude_m) < 0.1
    run(go(), 40.0)


def test_mavsdk_logged_no_error(drone):
    """No protocol trouble on MAVSDK's side (a retry that failed, an unknown GPS fix type, a mission transfer
    error), except what the unknown-parameter test asked for."""
    assert [m for m in drone.logs if m[0] == "ERROR" and m not in drone.expected] == []
