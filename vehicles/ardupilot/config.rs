//! `[driver.ardupilot]`: an ArduPilot vehicle (Rover with a boat frame, or Sub) over MAVLink —
//! the link address in the `mavlink` crate's syntax, which vehicle it is talking to, the stream
//! rates to ask for, the mode table, the GUIDED target re-send rate, and the switch that lets a
//! helm ask for mode changes and arming (off: the interface never touches either by default).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};
use crate::state_name::FrontSeatStateName;

/// A MAVLink link, written as the `mavlink` crate writes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MavlinkAddress {
    /// `tcpout:HOST:PORT`: connect to the vehicle (SITL serves 5760).
    TcpOut { host: String, port: u16 },
    /// `udpin:ADDR:PORT`: listen; answer whoever sent last (BlueOS/mavlink-router push here).
    UdpIn { host: String, port: u16 },
    /// `udpout:HOST:PORT`: send to the vehicle from an ephemeral port.
    UdpOut { host: String, port: u16 },
    /// `serial:PATH:BAUD`.
    Serial { path: String, baud: u32 },
}

fn host_port(rest: &str) -> Result<(String, u16), String> {
    let (host, port) = rest
        .rsplit_once(':')
        .ok_or_else(|| "expected HOST:PORT".to_string())?;
    let port: u16 = port.parse().map_err(|_| format!("bad port {port:?}"))?;
    if host.is_empty() {
        return Err("empty host".into());
    }
    Ok((host.trim_matches(['[', ']']).to_string(), port))
}

impl MavlinkAddress {
    pub fn parse(s: &str) -> Result<Self, String> {
        let (kind, rest) = s
            .split_once(':')
            .ok_or_else(|| "expected KIND:… (tcpout, udpin, udpout, serial)".to_string())?;
        match kind {
            "tcpout" => {
                let (host, port) = host_port(rest)?;
                if port == 0 {
                    return Err("port 0".into());
                }
                Ok(Self::TcpOut { host, port })
            }
            "udpin" => {
                let (host, port) = host_port(rest)?;
                Ok(Self::UdpIn { host, port })
            }
            "udpout" => {
                let (host, port) = host_port(rest)?;
                if port == 0 {
                    return Err("port 0".into());
                }
                Ok(Self::UdpOut { host, port })
            }
            "serial" => {
                let (path, baud) = rest
                    .rsplit_once(':')
                    .ok_or_else(|| "expected serial:PATH:BAUD".to_string())?;
                let baud: u32 = baud.parse().map_err(|_| format!("bad baud {baud:?}"))?;
                if path.is_empty() || baud == 0 {
                    return Err("expected serial:PATH:BAUD with a path and a baud > 0".into());
                }
                Ok(Self::Serial {
                    path: path.into(),
                    baud,
                })
            }
            "tcpin" => Err(
                "tcpin is not supported: the vehicle (or SITL) is the server; use tcpout".into(),
            ),
            other => Err(format!(
                "unknown link kind {other:?} (tcpout, udpin, udpout, serial)"
            )),
        }
    }
}

/// Which ArduPilot firmware the vehicle runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ArdupilotVehicle {
    /// ArduPilot Rover (a boat frame: BlueBoat and most research boats).
    #[default]
    Rover,
    /// ArduSub (BlueROV2): GUIDED with LOCAL_NED position + velocity + yaw targets (depth is
    /// their z), or ALT_HOLD with `alt_hold_accepts_commands`.
    Sub,
}

/// The frontseat state an armed vehicle is in for one mode number.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ArdupilotModeAssignment {
    /// The `custom_mode` number (Rover: GUIDED 15, HOLD 4, …; Sub: GUIDED 4, …).
    pub mode: u32,
    /// The frontseat state while armed in that mode.
    pub state: FrontSeatStateName,
}

/// Stream rates asked for with MAV_CMD_SET_MESSAGE_INTERVAL at every (re)connection. Unit: Hz;
/// 0 leaves that message at the vehicle's own rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ArdupilotStreamRates {
    /// GLOBAL_POSITION_INT (position, velocity, heading). Unit: Hz, 0 to 50.
    pub global_position_int: f64,
    /// ATTITUDE (roll, pitch, yaw). Unit: Hz, 0 to 50.
    pub attitude: f64,
    /// VFR_HUD (ground speed, heading). Unit: Hz, 0 to 50.
    pub vfr_hud: f64,
    /// SYS_STATUS (sensor health, battery). Unit: Hz, 0 to 50.
    pub sys_status: f64,
    /// GPS_RAW_INT (fix type). Unit: Hz, 0 to 50.
    pub gps_raw_int: f64,
    /// EKF_STATUS_REPORT (estimate readiness). Unit: Hz, 0 to 50.
    pub ekf_status_report: f64,
    /// LOCAL_POSITION_NED (Sub only: depth is its z, and GUIDED targets carry its x, y).
    /// Unit: Hz, 0 to 50.
    pub local_position_ned: f64,
}

impl Default for ArdupilotStreamRates {
    fn default() -> Self {
        Self {
            global_position_int: 5.0,
            attitude: 5.0,
            vfr_hud: 2.0,
            sys_status: 1.0,
            gps_raw_int: 1.0,
            ekf_status_report: 1.0,
            local_position_ned: 5.0,
        }
    }
}

/// The ArduPilot driver (MAVLink 2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ArdupilotConfig {
    /// Link in the `mavlink` crate's syntax: `tcpout:127.0.0.1:5760`, `udpin:0.0.0.0:14550`,
    /// `udpout:192.168.2.2:14550`, `serial:/dev/ttyUSB0:57600`.
    pub address: String,
    /// "rover" or "sub".
    pub vehicle: ArdupilotVehicle,
    /// The vehicle's MAVLink system id; 0 = the first autopilot heard.
    pub system_id: u8,
    /// The autopilot's component id; 0 = the first heard (usually 1).
    pub component_id: u8,
    /// Our own system id: 255 as in the setup checked against SITL (pymavlink's default; also
    /// ArduPilot's MAV_GCS_SYSID, should FS_GCS_ENABLE be turned on).
    pub own_system_id: u8,
    /// Our component id (MAV_COMP_ID_ONBOARD_COMPUTER = 191).
    pub own_component_id: u8,
    /// The vehicle is NOT_CONNECTED after this long without its HEARTBEAT. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub heartbeat_timeout: f64,
    /// The GUIDED target is re-sent at this rate while the helm commands (Rover drops a target
    /// 3 s after the last one). Unit: Hz, 1 to 50.
    #[schemars(range(min = 1.0, max = 50.0))]
    pub resend_rate: f64,
    /// The driver stops re-sending a course the helm has not renewed for this long, so the
    /// vehicle's own 3 s timeout stops it. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub course_timeout: f64,
    /// A course asking for a response is answered after this long without a refusal
    /// (STATUSTEXT) or a mode change, since ArduPilot never acknowledges targets. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub target_verdict_after: f64,
    /// Stream rates to ask for.
    pub stream_rates: ArdupilotStreamRates,
    /// Overrides of the default mode table (for an armed vehicle; disarmed is always idle).
    pub modes: Vec<ArdupilotModeAssignment>,
    /// Sub: send a neutral MANUAL_CONTROL (x, y, r 0, z 500, buttons 0) twice a second while
    /// the link is up and the vehicle heard, to feed ArduSub's pilot-input failsafe
    /// (FS_PILOT_INPUT, default: disarm 3 s after the last pilot input; a BlueROV2 has no RC).
    /// Only from `own_system_id` = the vehicle's MAV_GCS_SYSID (255) does it count. Off by
    /// default: a topside joystick (QGroundControl, BlueOS) on that sysid sends its own, and ours
    /// would fight it. If frontseat stops, the vehicle's failsafe acts.
    pub pilot_input_keepalive: bool,
    /// Sub: an armed Sub in ALT_HOLD (no position estimate needed) accepts the helm's course:
    /// depth by a z-only SET_POSITION_TARGET_GLOBAL_INT, heading by SET_ATTITUDE_TARGET,
    /// forward thrust by MANUAL_CONTROL x. Off: ALT_HOLD is the pilot's depth hold (idle).
    /// On, navigation needs no horizontal position: lat/lon are what the vehicle reports (its
    /// EKF origin or last estimate).
    pub alt_hold_accepts_commands: bool,
    /// Sub in ALT_HOLD: MANUAL_CONTROL x per m/s of desired speed (open-loop thrust: ArduSub's
    /// SITL made 0.49–0.53 m/s at x = 500 with JS_GAIN 0.5). Unit: 1/(m/s), 1 to 10000.
    #[schemars(range(min = 1.0, max = 10000.0))]
    pub alt_hold_thrust_per_mps: f64,
    /// Accept the ArduPilot CommandRequest extension (GUIDED, HOLD, arm, disarm) from the bus.
    /// Off: such requests are refused and the vehicle's mode and arming are left to its pilot.
    pub allow_mode_commands: bool,
    /// Reopen delay after a lost link; doubles up to reconnect_max_ms. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_initial_ms: u64,
    /// Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_max_ms: u64,
    /// A mode or arming command unanswered by COMMAND_ACK this long fails. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub ack_timeout: f64,
}

impl Default for ArdupilotConfig {
    fn default() -> Self {
        Self {
            address: "tcpout:127.0.0.1:5760".into(),
            vehicle: ArdupilotVehicle::Rover,
            system_id: 0,
            component_id: 0,
            own_system_id: 255,
            own_component_id: 191,
            heartbeat_timeout: 3.0,
            resend_rate: 5.0,
            course_timeout: 2.0,
            target_verdict_after: 0.5,
            stream_rates: ArdupilotStreamRates::default(),
            modes: Vec::new(),
            allow_mode_commands: false,
            pilot_input_keepalive: false,
            alt_hold_accepts_commands: false,
            alt_hold_thrust_per_mps: 1000.0,
            reconnect_initial_ms: 100,
            reconnect_max_ms: 5000,
            ack_timeout: 3.0,
        }
    }
}

impl crate::drivers::DriverSection for ArdupilotConfig {
    const CHECKED_WHEN_NOT_SELECTED: bool = false;

    fn check(&self, prefix: &str, c: &mut Checker) {
        if let Err(why) = MavlinkAddress::parse(&self.address) {
            c.push(FieldError::new(at(prefix, "address"), &self.address, why));
        }
        c.positive(&at(prefix, "heartbeat_timeout"), self.heartbeat_timeout);
        c.within(&at(prefix, "resend_rate"), self.resend_rate, 1.0, 50.0);
        c.positive(&at(prefix, "course_timeout"), self.course_timeout);
        c.positive(
            &at(prefix, "target_verdict_after"),
            self.target_verdict_after,
        );
        c.positive(&at(prefix, "ack_timeout"), self.ack_timeout);
        c.within(
            &at(prefix, "alt_hold_thrust_per_mps"),
            self.alt_hold_thrust_per_mps,
            1.0,
            10000.0,
        );
        let r = &self.stream_rates;
        let sp = at(prefix, "stream_rates");
        for (name, v) in [
            ("global_position_int", r.global_position_int),
            ("attitude", r.attitude),
            ("vfr_hud", r.vfr_hud),
            ("sys_status", r.sys_status),
            ("gps_raw_int", r.gps_raw_int),
            ("ekf_status_report", r.ekf_status_report),
            ("local_position_ned", r.local_position_ned),
        ] {
            c.within(&at(&sp, name), v, 0.0, 50.0);
        }
        let initial = at(prefix, "reconnect_initial_ms");
        let max = at(prefix, "reconnect_max_ms");
        c.at_least(&initial, self.reconnect_initial_ms, 1);
        c.at_least(&max, self.reconnect_max_ms, 1);
        c.ordered(
            &initial,
            self.reconnect_initial_ms,
            &max,
            self.reconnect_max_ms,
        );
    }

    fn vehicle_link(&self) -> String {
        format!("mavlink {}", self.address)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_in_the_mavlink_crates_syntax() {
        let rows: [(&str, Result<MavlinkAddress, ()>); 8] = [
            (
                "tcpout:127.0.0.1:5760",
                Ok(MavlinkAddress::TcpOut {
                    host: "127.0.0.1".into(),
                    port: 5760,
                }),
            ),
            (
                "udpin:0.0.0.0:14550",
                Ok(MavlinkAddress::UdpIn {
                    host: "0.0.0.0".into(),
                    port: 14550,
                }),
            ),
            (
                "udpout:127.0.0.1:14550",
                Ok(MavlinkAddress::UdpOut {
                    host: "127.0.0.1".into(),
                    port: 14550,
                }),
            ),
            (
                "serial:/dev/ttyUSB0:57600",
                Ok(MavlinkAddress::Serial {
                    path: "/dev/ttyUSB0".into(),
                    baud: 57600,
                }),
            ),
            ("tcpin:0.0.0.0:5760", Err(())),
            ("tcpout:127.0.0.1", Err(())),
            ("serial:/dev/ttyUSB0:fast", Err(())),
            ("http://x", Err(())),
        ];
        for (s, want) in rows {
            assert_eq!(MavlinkAddress::parse(s).map_err(|_| ()), want, "{s}");
        }
    }
}
