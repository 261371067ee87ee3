#!/usr/bin/env python3
"""A backseat written with pymavlink (the reference MAVLink implementation, from PyPI) against
`frontseat sim --vehicle ardusub`, doing what ardusub.md's SITL runs did: see a Sub booting in
MANUAL, set GUIDED and arm, dive and steer with 0x09C0 LOCAL_NED targets at 5 Hz (depth read from
LOCAL_POSITION_NED.z), see GLOBAL_INT's yaw ignored and an acceleration-bearing target dropped,
and see a failsafe disarm it when its heartbeats and MANUAL_CONTROL stop.
Usage: pymavlink_sub_backseat.py HOST:PORT WARP. Prints one line per check; exits 0 when all pass."""
import math
import os
import sys
import time

os.environ["MAVLINK20"] = "1"
os.environ["MAVLINK_DIALECT"] = "ardupilotmega"
from pymavlink import mavutil  # noqa: E402

mav = mavutil.mavlink
WARP = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
DEADLINE = time.monotonic() + 120


def fail(why):
    print("FAIL:", why, flush=True)
    sys.exit(1)


conn = mavutil.mavlink_connection("tcp:" + sys.argv[1], source_system=255, source_component=191)
state = {"hb_at": 0.0, "mc_at": 0.0, "feed_hb": True, "local": None, "att": None, "hb": None}


def pump(seconds, each=None):
    """Reads for `seconds` of sim time, feeding HEARTBEAT 1 Hz and neutral MANUAL_CONTROL 2 Hz."""
    end = time.monotonic() + seconds / WARP
    while time.monotonic() < end:
        if time.monotonic() > DEADLINE:
            fail("out of time")
        now = time.monotonic()
        if state["feed_hb"] and now - state["hb_at"] >= 1.0 / WARP:
            conn.mav.heartbeat_send(mav.MAV_TYPE_ONBOARD_CONTROLLER, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            state["hb_at"] = now
        if state["feed_hb"] and now - state["mc_at"] >= 0.5 / WARP:
            conn.mav.manual_control_send(conn.target_system, 0, 0, 500, 0, 0)
            state["mc_at"] = now
        if each:
            each()
        m = conn.recv_match(blocking=True, timeout=0.02 / WARP)
        while m is not None:
            t = m.get_type()
            if t == "LOCAL_POSITION_NED":
                state["local"] = m
            elif t == "ATTITUDE":
                state["att"] = m
            elif t == "HEARTBEAT" and m.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA:
                state["hb"] = m
            elif t == "STATUSTEXT":
                state.setdefault("texts", []).append(m.text)
            m = conn.recv_match(blocking=False)


def command(cmd, p1=0, p2=0):
    conn.mav.command_long_send(conn.target_system, conn.target_component, cmd, 0, p1, p2, 0, 0, 0, 0, 0)
    end = time.monotonic() + 5
    while time.monotonic() < end:
        a = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5)
        if a is not None and a.command == cmd:
            return a.result
    fail("no COMMAND_ACK for %d" % cmd)


def heading():
    return math.degrees(state["att"].yaw) % 360.0


def herr(want):
    d = (heading() - want) % 360.0
    return min(d, 360.0 - d)


hb = conn.wait_heartbeat(timeout=10)
if hb is None:
    fail("no HEARTBEAT")
if hb.autopilot != mav.MAV_AUTOPILOT_ARDUPILOTMEGA or hb.type != mav.MAV_TYPE_SUBMARINE:
    fail("not an ArduSub: autopilot %d type %d" % (hb.autopilot, hb.type))
if hb.custom_mode != 19:
    fail("did not boot in MANUAL 19: %d" % hb.custom_mode)
print("ok heartbeat: ArduSub submarine in MANUAL 19, system", conn.target_system, flush=True)

for msg_id in (mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mav.MAVLINK_MSG_ID_ATTITUDE,
               mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT):
    if command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 200000) != mav.MAV_RESULT_ACCEPTED:
        fail("SET_MESSAGE_INTERVAL %d refused" % msg_id)
pump(6.0)
if command(mav.MAV_CMD_DO_SET_MODE, 1, 4) != mav.MAV_RESULT_ACCEPTED:
    fail("GUIDED refused")
if command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) != mav.MAV_RESULT_ACCEPTED:
    fail("arming refused")


def armed_guided():
    hb = state["hb"]
    return hb is not None and bool(hb.base_mode & 0x80) and hb.custom_mode == 4


# The HEARTBEAT that announces the change comes within one sim second; on a loaded machine the
# emulator's clock lags the wall, so wait for it (up to 10 sim seconds) instead of exactly one.
for _ in range(50):
    if armed_guided():
        break
    pump(0.2)
if not armed_guided():
    fail("not armed in GUIDED: %r" % state["hb"])
print("ok GUIDED 4 and armed", flush=True)

# The recommended target: 0x09C0 LOCAL_NED, x/y the latest position, z depth, velocity along
# the heading, yaw; 5 Hz.
last = {"t": 0.0}


def posvel():
    now = time.monotonic()
    if now - last["t"] < 0.2 / WARP or state["local"] is None:
        return
    last["t"] = now
    lp = state["local"]
    h = math.radians(90.0)
    conn.mav.set_position_target_local_ned_send(
        0, conn.target_system, conn.target_component, mav.MAV_FRAME_LOCAL_NED, 0x09C0,
        lp.x, lp.y, 5.0, 0.5 * math.cos(h), 0.5 * math.sin(h), 0, 0, 0, 0, h, 0)


pump(25.0, posvel)
lp = state["local"]
if abs(lp.z - 5.0) > 0.3 or herr(90.0) > 5.0 or abs(math.hypot(lp.vx, lp.vy) - 0.5) > 0.05:
    fail("not at 5 m / 90 deg / 0.5 m/s: z %.2f heading %.1f speed %.2f" % (lp.z, heading(), math.hypot(lp.vx, lp.vy)))
print("ok dived and steering: z %.2f m, heading %.1f, %.2f m/s" % (lp.z, heading(), math.hypot(lp.vx, lp.vy)), flush=True)

# A non-ignored acceleration drops the whole message: asking 180 deg with 0x0800 changes nothing.
def accel_target():
    now = time.monotonic()
    if now - last["t"] < 0.2 / WARP:
        return
    last["t"] = now
    conn.mav.set_position_target_local_ned_send(
        0, conn.target_system, conn.target_component, mav.MAV_FRAME_LOCAL_NED, 0x0800,
        0, 0, 8.0, -0.5, 0, 0, 0, 0, 0, math.pi, 0)


pump(5.0, accel_target)
if herr(90.0) > 5.0 or abs(state["local"].z - 5.0) > 0.3:
    fail("an acceleration-bearing target was followed: heading %.1f z %.2f" % (heading(), state["local"].z))
print("ok acceleration target dropped", flush=True)

# GLOBAL_INT in GUIDED: alt = -depth followed, yaw ignored (heading stays 90).
def global_target():
    now = time.monotonic()
    if now - last["t"] < 0.2 / WARP:
        return
    last["t"] = now
    conn.mav.set_position_target_global_int_send(
        0, conn.target_system, conn.target_component, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0x09C0,
        0, 0, -3.0, 0.5, 0, 0, 0, 0, 0, math.radians(270.0), 0)


pump(10.0, global_target)
if herr(90.0) > 5.0 or abs(state["local"].z - 3.0) > 0.3:
    fail("GLOBAL_INT: heading %.1f z %.2f" % (heading(), state["local"].z))
print("ok GLOBAL_INT yaw ignored, depth followed", flush=True)

# The failsafes: stop our heartbeats and pilot input; the pilot-input failsafe (3 s, before the
# GCS one's 5 s) disarms: "Lost manual control".
state["feed_hb"] = False
pump(8.0)
if state["hb"].base_mode & 0x80:
    fail("still armed 8 s after our heartbeats and MANUAL_CONTROL stopped")
lost = [t for t in state.get("texts", []) if "lost" in t.lower()]
if not lost:
    fail("no failsafe text: %r" % state.get("texts"))
print("ok failsafe disarmed:", lost[0], flush=True)
print("PASS", flush=True)
