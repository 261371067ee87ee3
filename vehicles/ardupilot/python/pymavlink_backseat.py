#!/usr/bin/env python3
"""A backseat written with pymavlink (the reference MAVLink implementation, from PyPI) against
`frontseat sim --vehicle ardupilot`: it must see an ArduPilot boat, set GUIDED, arm, see the
mode, steer it with a 0x09C7 target and see a mask without ACC_IGNORE refused in words.
Usage: pymavlink_backseat.py HOST:PORT. Prints one line per check; exits 0 when all pass."""
import math
import os
import sys
import time

os.environ["MAVLINK20"] = "1"
os.environ["MAVLINK_DIALECT"] = "ardupilotmega"
from pymavlink import mavutil  # noqa: E402

mav = mavutil.mavlink
DEADLINE = time.monotonic() + 60


def fail(why):
    print("FAIL:", why, flush=True)
    sys.exit(1)


def recv(kind, cond=lambda m: True, within=10.0):
    end = min(time.monotonic() + within, DEADLINE)
    while time.monotonic() < end:
        m = conn.recv_match(type=kind, blocking=True, timeout=0.5)
        if m is not None and cond(m):
            return m
    fail("no %s matching within %.0f s" % (kind, within))


def ack_of(cmd):
    a = recv("COMMAND_ACK", lambda m: m.command == cmd)
    return a.result


conn = mavutil.mavlink_connection("tcp:" + sys.argv[1], source_system=255, source_component=190)
hb = conn.wait_heartbeat(timeout=10)
if hb is None:
    fail("no HEARTBEAT")
if hb.autopilot != mav.MAV_AUTOPILOT_ARDUPILOTMEGA or hb.type != mav.MAV_TYPE_SURFACE_BOAT:
    fail("not an ArduPilot boat: autopilot %d type %d" % (hb.autopilot, hb.type))
print("ok heartbeat: ArduPilot surface boat, system", conn.target_system, flush=True)

# Wait out INITIALISING: pymavlink names the mode from Rover's table.
recv("HEARTBEAT", lambda m: mavutil.mode_string_v10(m) == "MANUAL")
print("ok mode MANUAL after init", flush=True)

# Ask for positions (SET_MESSAGE_INTERVAL, µs) and for the EKF report.
for msg_id, hz in ((mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 10), (mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 2)):
    conn.mav.command_long_send(conn.target_system, conn.target_component,
                               mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, 1e6 / hz, 0, 0, 0, 0, 0)
    if ack_of(mav.MAV_CMD_SET_MESSAGE_INTERVAL) != mav.MAV_RESULT_ACCEPTED:
        fail("SET_MESSAGE_INTERVAL refused")
recv("EKF_STATUS_REPORT", lambda m: m.flags & 0x033F == 0x033F, within=20)
pos = recv("GLOBAL_POSITION_INT", lambda m: m.lat != 0)
print("ok EKF ready; position %.6f %.6f" % (pos.lat * 1e-7, pos.lon * 1e-7), flush=True)

conn.set_mode_apm("GUIDED")
if ack_of(mav.MAV_CMD_DO_SET_MODE) != mav.MAV_RESULT_ACCEPTED:
    fail("GUIDED refused")
conn.arducopter_arm()
if ack_of(mav.MAV_CMD_COMPONENT_ARM_DISARM) != mav.MAV_RESULT_ACCEPTED:
    fail("arming refused")
recv("HEARTBEAT", lambda m: mavutil.mode_string_v10(m) == "GUIDED"
     and m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
print("ok GUIDED and armed, as pymavlink reads the HEARTBEAT", flush=True)

# Heading 90 at 2 m/s by velocity + yaw (0x09C7), re-sent at 5 Hz; the boat turns east.
def target(mask, yaw):
    conn.mav.set_position_target_global_int_send(
        0, conn.target_system, conn.target_component, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mask, 0, 0, 0, 2.0, 0, 0, 0, 0, 0, yaw, 0)

end = time.monotonic() + 20
while True:
    target(0x09C7, math.pi / 2)
    m = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=0.2)
    if m is not None and abs(m.hdg / 100.0 - 90.0) < 1.0 and math.hypot(m.vx, m.vy) > 150:
        print("ok steering: heading %.1f, %.2f m/s" % (m.hdg / 100.0, math.hypot(m.vx, m.vy) / 100), flush=True)
        break
    if time.monotonic() > end:
        fail("did not turn to 90 deg at speed")

target(0x0907, 0.0)
t = recv("STATUSTEXT", lambda m: "ACC_IGNORE" in m.text)
print("ok refused mask in words:", t.text, flush=True)
print("PASS", flush=True)
