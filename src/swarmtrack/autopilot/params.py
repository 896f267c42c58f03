"""A simulated vehicle's parameters and MAVLink's parameter protocol, as PX4 serves them.

:data:`TABLE` is a small table of PX4 parameters with PX4 v1.14's defaults and types (``PARAM_DEFINE_FLOAT`` /
``PARAM_DEFINE_INT32`` in ``src/modules/commander/commander_params.c``, ``src/modules/mc_pos_control/
multicopter_*_params.c``, ``src/modules/navigator/*_params.c``, ``src/modules/simulation/battery_simulator/
battery_simulator_params.yaml``, ``src/lib/battery/module.yaml``): the ones the simulated vehicle flies by (read with
:meth:`Parameters.get`) and the ones its battery model reads (:mod:`~swarmtrack.autopilot.telemetry`).

:meth:`Parameters.handle` answers the protocol as PX4's ``MavlinkParametersManager`` does
(``src/modules/mavlink/mavlink_parameters.cpp``, PX4 main of 2025-2026):

- ``PARAM_REQUEST_LIST``: first ``_HASH_CHECK`` (index 65535 = −1, ``MAV_PARAM_TYPE_UINT32``, a CRC-32 of the names
  and values, which a ground station compares with its cache), then every parameter as ``PARAM_VALUE`` in index
  order (PX4 orders its parameters by name);
- ``PARAM_REQUEST_READ``: by index (``param_index >= 0``) or by name (``_HASH_CHECK`` gives the hash); an unknown
  one is not answered (PX4 logs ``unknown param`` on its own console);
- ``PARAM_SET``: of a known name with its declared type: set, answered with the new ``PARAM_VALUE`` (also on the
  vehicle's other links given as ``others``: PX4's other MAVLink instances send a changed value too,
  ``send_untransmitted``); of an unknown
  name, of another type, or of a type beyond ``MAV_PARAM_TYPE``: not answered, nothing set (PX4 logs ``unknown
  param`` / ``invalid param``; the client times out or sees the old value); ``_HASH_CHECK`` is ignored.

Values travel encoded as PX4 encodes them (``MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE``): an ``INT32`` value's
four bytes are copied into ``param_value``'s float (:func:`encode`, :func:`decode`), which is how MAVSDK reads a PX4
autopilot (``ParamValue::set_from_mavlink_param_value_bytewise``).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

INT32, REAL32, UINT32 = mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32, mavlink.MAV_PARAM_TYPE_UINT32
#: The name PX4 sends first in a list, carrying the hash of all values (``HASH_PARAM``).
HASH_CHECK = "_HASH_CHECK"


@dataclass(frozen=True)
class Param:
    """One parameter: its PX4 name, MAVLink type, PX4's default, unit and meaning."""

    name: str
    type: int
    default: float
    unit: str
    meaning: str


#: The parameters (PX4 v1.14 defaults; BAT1_N_CELLS is PX4 SITL's, set by its airframe ``rcS``).
TABLE: tuple[Param, ...] = (
    Param("BAT1_N_CELLS", INT32, 4, "", "battery cells in series (PX4 SITL's 4S)"),
    Param("BAT1_V_CHARGED", REAL32, 4.05, "V", "a full cell's voltage"),
    Param("BAT1_V_EMPTY", REAL32, 3.6, "V", "an empty cell's voltage"),
    Param("COM_DISARM_LAND", REAL32, 2.0, "s", "disarm this long after landing (<= 0: never)"),
    Param("COM_DISARM_PRFLT", REAL32, 10.0, "s", "disarm this long after arming without taking off (<= 0: never)"),
    Param("COM_OBL_RC_ACT", INT32, 0, "", "offboard loss action: 0 Position, 1 Altitude, 2 Manual, 3 Return, "
          "4 Land, 5 Hold, 6 Terminate, 7 Disarm"),
    Param("COM_OF_LOSS_T", REAL32, 1.0, "s", "setpoints older than this are an offboard loss"),
    Param("MIS_TAKEOFF_ALT", REAL32, 2.5, "m", "takeoff altitude above home"),
    Param("MPC_ACC_HOR", REAL32, 3.0, "m/s^2", "horizontal acceleration of the automatic modes"),
    Param("MPC_LAND_SPEED", REAL32, 0.7, "m/s", "landing descent rate"),
    Param("MPC_TILTMAX_AIR", REAL32, 45.0, "deg", "tilt limit"),
    Param("MPC_TKO_SPEED", REAL32, 1.5, "m/s", "takeoff climb rate"),
    Param("MPC_XY_CRUISE", REAL32, 5.0, "m/s", "horizontal speed of the automatic modes"),
    Param("MPC_XY_P", REAL32, 0.95, "1/s", "horizontal position gain"),
    Param("MPC_XY_VEL_MAX", REAL32, 12.0, "m/s", "horizontal velocity limit"),
    Param("MPC_XY_VEL_P_ACC", REAL32, 1.8, "1/s", "horizontal velocity gain (acceleration per m/s of error)"),
    Param("MPC_Z_P", REAL32, 1.0, "1/s", "vertical position gain"),
    Param("MPC_Z_VEL_MAX_DN", REAL32, 1.5, "m/s", "descent rate limit"),
    Param("MPC_Z_VEL_MAX_UP", REAL32, 3.0, "m/s", "climb rate limit"),
    Param("MPC_Z_VEL_P_ACC", REAL32, 4.0, "1/s", "vertical velocity gain"),
    Param("NAV_ACC_RAD", REAL32, 10.0, "m", "acceptance radius of a position (Return's arrival)"),
    Param("RTL_DESCEND_ALT", REAL32, 30.0, "m", "Return's descent altitude above home"),
    Param("RTL_LAND_DELAY", REAL32, 0.0, "s", "Return's hover above home before landing (-1: stay)"),
    Param("RTL_RETURN_ALT", REAL32, 60.0, "m", "Return's altitude above home"),
    Param("SIM_BAT_DRAIN", REAL32, 60.0, "s", "the simulated battery's time from full to empty while armed"),
    Param("SIM_BAT_MIN_PCT", REAL32, 50.0, "%", "the simulated battery never drops below this"),
)


def encode(value: float, type_: int) -> float:
    """``param_value`` of ``value`` of MAVLink type ``type_``, encoded bytewise as PX4 encodes it."""
    if type_ == REAL32:
        return float(value)
    fmt = "<I" if type_ == UINT32 else "<i"
    return struct.unpack("<f", struct.pack(fmt, int(value)))[0]


def decode(param_value: float, type_: int) -> float | int:
    """The value a bytewise-encoded ``param_value`` of MAVLink type ``type_`` carries."""
    if type_ == REAL32:
        return float(param_value)
    fmt = "<I" if type_ == UINT32 else "<i"
    return struct.unpack(fmt, struct.pack("<f", param_value))[0]


def _name(raw) -> str:
    """A ``param_id`` as text (pymavlink gives str or bytes; 16 characters without a NUL are allowed)."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", errors="replace")
    return raw.split("\x00", 1)[0][:16]


class Parameters:
    """One vehicle's parameters (:data:`TABLE`, with ``values`` overriding defaults by name) and their protocol."""

    def __init__(self, values: dict[str, float] | None = None):
        self._params = {p.name: p for p in sorted(TABLE, key=lambda p: p.name)}
        self._names = list(self._params)
        self._values: dict[str, float | int] = {}
        for p in self._params.values():
            self._values[p.name] = self._typed(p, p.default)
        for name, value in (values or {}).items():
            self.set(name, value)

    @staticmethod
    def _typed(p: Param, value: float) -> float | int:
        if p.type == INT32:
            return int(value)
        return struct.unpack("<f", struct.pack("<f", float(value)))[0]  # held as float32, as PX4 holds it

    def get(self, name: str) -> float | int:
        """The value of parameter ``name`` (KeyError for a name not in the table)."""
        return self._values[name]

    def set(self, name: str, value: float) -> None:
        """Set parameter ``name`` (KeyError for a name not in the table; INT32 values are truncated to int)."""
        self._values[name] = self._typed(self._params[name], value)

    def __contains__(self, name: str) -> bool:
        return name in self._params

    def __len__(self) -> int:
        return len(self._names)

    def hash(self) -> int:
        """The ``_HASH_CHECK`` value: a CRC-32 over each parameter's name and its 4 value bytes, in index order (as
        PX4's ``param_hash_check``; the same table and values give the same hash, a changed value another)."""
        crc = 0
        for name in self._names:
            p = self._params[name]
            raw = struct.pack("<i" if p.type == INT32 else "<f", self._values[name])
            crc = zlib.crc32(raw, zlib.crc32(name.encode(), crc))
        return crc

    def _send(self, mav, name: str) -> None:
        p = self._params[name]
        mav.param_value_send(name.encode(), encode(self._values[name], p.type), p.type, len(self._names),
                             self._names.index(name))

    def _send_hash(self, mav) -> None:
        mav.param_value_send(HASH_CHECK.encode(), encode(self.hash(), UINT32), UINT32, len(self._names), 65535)

    def handle(self, msg, mav, others=()) -> bool:
        """Answer ``msg`` if it is a parameter message for this autopilot (``mav.srcSystem``, ``mav.srcComponent``
        or ``MAV_COMP_ID_ALL``); replies go out through ``mav`` (the link ``msg`` came on), a changed value also
        through each of ``others`` (the vehicle's other links). Returns whether it was one (True also when PX4 would
        stay silent: an unknown name, a wrong type)."""
        kind = msg.get_type()
        if kind not in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET"):
            return False
        if msg.target_system != mav.srcSystem or msg.target_component not in (mav.srcComponent,
                                                                               mavlink.MAV_COMP_ID_ALL):
            return False
        if kind == "PARAM_REQUEST_LIST":
            self._send_hash(mav)
            for name in self._names:
                self._send(mav, name)
        elif kind == "PARAM_REQUEST_READ":
            self._read(msg, mav)
        else:
            self._set(msg, mav, others)
        return True

    def _read(self, msg, mav) -> None:
        if msg.param_index >= 0:
            if msg.param_index < len(self._names):
                self._send(mav, self._names[msg.param_index])
            return
        name = _name(msg.param_id)
        if name == HASH_CHECK:
            self._send_hash(mav)
        elif name in self._params:
            self._send(mav, name)

    def _set(self, msg, mav, others) -> None:
        name = _name(msg.param_id)
        p = self._params.get(name)
        if p is None or msg.param_type != p.type:  # PX4: "unknown param" / "invalid param", no answer
            return
        self._values[name] = self._typed(p, decode(msg.param_value, p.type))
        for link in (mav, *others):
            self._send(link, name)

    def table(self) -> list[tuple[str, str, float | int, float | int, str, str]]:
        """(name, type, default, value, unit, meaning) of every parameter, in index order (for docs and notes)."""
        kinds = {INT32: "INT32", REAL32: "REAL32"}
        return [(n, kinds[self._params[n].type], self._typed(self._params[n], self._params[n].default),
                 self._values[n], self._params[n].unit, self._params[n].meaning) for n in self._names]
