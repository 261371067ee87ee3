#!/usr/bin/env python3
"""Writes ../fixtures/pymavlink_vehicle_frames.hex: the vehicle side of the driver's fact tests,
encoded by pymavlink (the reference implementation), one frame per line as `NAME HEX`, so the
Rust codec and driver are checked against bytes they did not produce. Re-run after changing it:
    python3 make_fixtures.py"""
import os

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as apm  # noqa: E402

m = apm.MAVLink(None, srcSystem=1, srcComponent=1)
m.robust_parsing = True
A = apm.MAV_MODE_FLAG_SAFETY_ARMED | apm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
C = apm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
frames = [
    ("hb_manual_disarmed", m.heartbeat_encode(apm.MAV_TYPE_SURFACE_BOAT, apm.MAV_AUTOPILOT_ARDUPILOTMEGA, C, 0, apm.MAV_STATE_STANDBY)),
    ("hb_guided_armed", m.heartbeat_encode(apm.MAV_TYPE_SURFACE_BOAT, apm.MAV_AUTOPILOT_ARDUPILOTMEGA, A, 15, apm.MAV_STATE_ACTIVE)),
    ("hb_auto_armed", m.heartbeat_encode(apm.MAV_TYPE_SURFACE_BOAT, apm.MAV_AUTOPILOT_ARDUPILOTMEGA, A, 10, apm.MAV_STATE_ACTIVE)),
    ("hb_hold_armed", m.heartbeat_encode(apm.MAV_TYPE_SURFACE_BOAT, apm.MAV_AUTOPILOT_ARDUPILOTMEGA, A, 4, apm.MAV_STATE_STANDBY)),
    ("hb_hold_failsafe", m.heartbeat_encode(apm.MAV_TYPE_SURFACE_BOAT, apm.MAV_AUTOPILOT_ARDUPILOTMEGA, A, 4, apm.MAV_STATE_CRITICAL)),
    ("hb_gcs", m.heartbeat_encode(apm.MAV_TYPE_GCS, apm.MAV_AUTOPILOT_INVALID, 0, 0, apm.MAV_STATE_ACTIVE)),
    ("ekf_ready", m.ekf_status_report_encode(0x033F, 0.02, 0.01, 0.01, 0.02, 0.0)),
    ("ekf_backup", m.ekf_status_report_encode(0x00A7, 0.5, 0.5, 0.1, 0.02, 0.0)),
    ("gps_3d", m.gps_raw_int_encode(0, 3, 423584560, -710875890, 0, 121, 200, 150, 9000, 10)),
    ("gps_nofix", m.gps_raw_int_encode(0, 1, 0, 0, 0, 9999, 9999, 0, 0, 0)),
    ("pos_boston", m.global_position_int_encode(1000, 423584560, -710875890, 0, -2500, 0, 150, 0, 9000)),
    ("pos_zero", m.global_position_int_encode(1000, 0, 0, 0, 0, 0, 0, 0, 65535)),
    ("pos_out_of_range", m.global_position_int_encode(1000, 950000000, -710875890, 0, 0, 0, 0, 0, 0)),
    ("attitude", m.attitude_encode(1000, 0.05, -0.1, 1.5707964, 0, 0, 0)),
    ("text_acc_ignore", m.statustext_encode(apm.MAV_SEVERITY_WARNING, b"Ignoring GLOBAL_INT target; set ACC_IGNORE in mask")),
    ("text_timeout", m.statustext_encode(apm.MAV_SEVERITY_INFO, b"target not received last 3secs, stopping")),
    ("text_prearm", m.statustext_encode(apm.MAV_SEVERITY_CRITICAL, b"PreArm: Hardware safety switch")),
    ("ack_mode_accepted", m.command_ack_encode(apm.MAV_CMD_DO_SET_MODE, apm.MAV_RESULT_ACCEPTED)),
    ("ack_arm_failed", m.command_ack_encode(apm.MAV_CMD_COMPONENT_ARM_DISARM, apm.MAV_RESULT_FAILED)),
    ("ack_arm_accepted", m.command_ack_encode(apm.MAV_CMD_COMPONENT_ARM_DISARM, apm.MAV_RESULT_ACCEPTED)),
]
here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "..", "fixtures", "pymavlink_vehicle_frames.hex"), "w") as f:
    f.write("# Vehicle-side MAVLink 2 frames (system 1, component 1) encoded by pymavlink 2.4.50\n")
    f.write("# (python/make_fixtures.py): ArduPilot Rover's messages as the README's facts need them.\n")
    for name, msg in frames:
        f.write("%s %s\n" % (name, msg.pack(m).hex()))
