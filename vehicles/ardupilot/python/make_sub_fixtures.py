#!/usr/bin/env python3
"""Writes ../fixtures/pymavlink_sub_frames.hex: ArduSub's side of the Sub driver's fact tests,
encoded by pymavlink (the reference implementation), one frame per line as `NAME HEX`. The values
are the ones shared/protocol/ardupilot/ardusub.md records from ArduSub SITL (V4.7.0-dev,
BlueROV2 `vectored` frame): no raw bytes were captured there, so these frames carry its recorded
numbers and words, not its bytes. Re-run after changing it:
    python3 make_sub_fixtures.py"""
import os

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as apm  # noqa: E402

m = apm.MAVLink(None, srcSystem=1, srcComponent=1)
SUB = apm.MAV_TYPE_SUBMARINE
APM = apm.MAV_AUTOPILOT_ARDUPILOTMEGA

# ardusub.md: base_mode 0x51 when disarmed.
D = 0x51


def hb(base, mode, status):
    return m.heartbeat_encode(SUB, APM, base, mode, status)


frames = [
    # Boots in MANUAL 19, disarmed, standby (3).
    ("sub_hb_manual_disarmed", hb(D, 19, apm.MAV_STATE_STANDBY)),
    ("sub_hb_guided_disarmed", hb(D, 4, apm.MAV_STATE_STANDBY)),
    ("sub_hb_guided_armed", hb(D | 0x80, 4, apm.MAV_STATE_ACTIVE)),
    ("sub_hb_althold_armed", hb(D | 0x80, 2, apm.MAV_STATE_ACTIVE)),
    ("sub_hb_manual_armed", hb(D | 0x80, 19, apm.MAV_STATE_ACTIVE)),
    ("sub_hb_stabilize_armed", hb(D | 0x80, 0, apm.MAV_STATE_ACTIVE)),
    ("sub_hb_surface_armed", hb(D | 0x80, 9, apm.MAV_STATE_ACTIVE)),
    ("sub_hb_auto_armed", hb(D | 0x80, 3, apm.MAV_STATE_ACTIVE)),
    ("sub_hb_poshold_armed", hb(D | 0x80, 16, apm.MAV_STATE_ACTIVE)),
    # A failsafe flag (leak, GCS, pilot input) makes system_status 5 CRITICAL.
    ("sub_hb_guided_critical", hb(D | 0x80, 4, apm.MAV_STATE_CRITICAL)),
    # The GCS failsafe disarmed it; mode stayed GUIDED, status 5.
    ("sub_hb_guided_disarmed_critical", hb(D, 4, apm.MAV_STATE_CRITICAL)),
    # EKF with GPS (0x33f), and in constant-position mode after losing it (0xa7).
    ("sub_ekf_ready", m.ekf_status_report_encode(0x033F, 0.02, 0.01, 0.01, 0.02, 0.0)),
    ("sub_ekf_const_pos", m.ekf_status_report_encode(0x00A7, 0.5, 0.5, 0.1, 0.02, 0.0)),
    # A DVL's estimate: relative horizontal position (0x08), no absolute one.
    ("sub_ekf_dvl", m.ekf_status_report_encode(0x0001 | 0x0002 | 0x0004 | 0x0008 | 0x0020 | 0x0100, 0.02, 0.01, 0.01, 0.02, 0.0)),
    ("sub_gps_none", m.gps_raw_int_encode(0, 0, 0, 0, 0, 65535, 65535, 0, 0, 0)),
    # At LOCAL_POSITION_NED z 5.00: relative_alt -5037 mm, alt -5157 mm, VFR_HUD alt -5.16.
    ("sub_local_5m", m.local_position_ned_encode(41000, 3.0, 4.0, 5.0, 0.0, 0.5, 0.0)),
    ("sub_pos_5m", m.global_position_int_encode(41000, 423584560, -710875890, -5157, -5037, 0, 50, 0, 9000)),
    ("sub_vfr_5m", m.vfr_hud_encode(0.0, 0.5, 90, 0, -5.16, 0.0)),
    ("sub_pressure_5m", m.scaled_pressure_encode(41000, 1518.7, 0.0, 1500)),
    ("sub_attitude", m.attitude_encode(41000, 0.02, -0.05, 1.5707964, 0, 0, 0)),
    # Bad depths: NaN, 1e9 m, 200 m above the surface, and a pressure sensor that jumps.
    ("sub_local_nan", m.local_position_ned_encode(41200, 3.0, 4.0, float("nan"), 0.0, 0.5, 0.0)),
    ("sub_local_1e9", m.local_position_ned_encode(41200, 3.0, 4.0, 1e9, 0.0, 0.5, 0.0)),
    ("sub_local_above", m.local_position_ned_encode(41200, 3.0, 4.0, -200.0, 0.0, 0.5, 0.0)),
    ("sub_local_jump", m.local_position_ned_encode(41200, 3.0, 4.0, 45.0, 0.0, 0.5, 0.0)),
    ("sub_text_requires_position", m.statustext_encode(apm.MAV_SEVERITY_WARNING, b"Mode change failed: GUIDED requires position")),
    ("sub_text_gcs_lost", m.statustext_encode(apm.MAV_SEVERITY_CRITICAL, b"MYGCS: 255, heartbeat lost")),
    ("sub_text_gcs_cleared", m.statustext_encode(apm.MAV_SEVERITY_CRITICAL, b"GCS Failsafe Cleared")),
    ("sub_text_lost_manual", m.statustext_encode(apm.MAV_SEVERITY_CRITICAL, b"Lost manual control")),
    ("sub_text_leak", m.statustext_encode(apm.MAV_SEVERITY_CRITICAL, b"Leak Detected")),
    ("sub_ack_mode_failed", m.command_ack_encode(apm.MAV_CMD_DO_SET_MODE, apm.MAV_RESULT_FAILED)),
    ("sub_ack_mode_accepted", m.command_ack_encode(apm.MAV_CMD_DO_SET_MODE, apm.MAV_RESULT_ACCEPTED)),
]
here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "..", "fixtures", "pymavlink_sub_frames.hex"), "w") as f:
    f.write("# ArduSub-side MAVLink 2 frames (system 1, component 1) encoded by pymavlink 2.4.50\n")
    f.write("# (python/make_sub_fixtures.py) carrying the numbers and words shared/protocol/ardupilot/\n")
    f.write("# ardusub.md recorded on ArduSub SITL V4.7.0-dev (BlueROV2): modes, status, depth, failsafe texts.\n")
    for name, msg in frames:
        f.write("%s %s\n" % (name, msg.pack(m).hex()))
