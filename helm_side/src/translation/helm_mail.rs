//! The helm's mail, read: the DESIRED_* variables pHelmIvP posts, buffered per packet into one
//! DesiredCourse (triggered by DESIRED_SPEED, as Goby3 does), and IVPHELM_STATE mapped onto a
//! HelmState. Pure; the data path feeds it the MOOS client's mail.

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{DesiredCourse, HelmState};

/// One DESIRED_* variable pHelmIvP posts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesiredVar {
    Speed,
    Heading,
    Depth,
    Pitch,
    Roll,
    ZRate,
    Altitude,
}

impl DesiredVar {
    pub const ALL: [DesiredVar; 7] = [
        DesiredVar::Speed,
        DesiredVar::Heading,
        DesiredVar::Depth,
        DesiredVar::Pitch,
        DesiredVar::Roll,
        DesiredVar::ZRate,
        DesiredVar::Altitude,
    ];

    pub fn key(self) -> &'static str {
        match self {
            DesiredVar::Speed => "DESIRED_SPEED",
            DesiredVar::Heading => "DESIRED_HEADING",
            DesiredVar::Depth => "DESIRED_DEPTH",
            DesiredVar::Pitch => "DESIRED_PITCH",
            DesiredVar::Roll => "DESIRED_ROLL",
            DesiredVar::ZRate => "DESIRED_Z_RATE",
            DesiredVar::Altitude => "DESIRED_ALTITUDE",
        }
    }

    pub fn from_key(key: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|v| v.key() == key)
    }
}

/// The MOOS variable carrying the helm's state.
pub const IVPHELM_STATE: &str = "IVPHELM_STATE";

/// The DESIRED_* values received since the last course, as Goby3 buffers them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DesiredBuffer {
    /// The DESIRED_SPEED of the packet being read (value, MOOS time): the trigger.
    speed: Option<(f64, f64)>,
    heading: Option<f64>,
    depth: Option<f64>,
    pitch: Option<f64>,
    roll: Option<f64>,
    z_rate: Option<f64>,
    altitude: Option<f64>,
}

impl DesiredBuffer {
    /// Takes one DESIRED_* value posted at MOOS time `time`; the last value of a variable wins.
    /// Nothing is published yet: Goby3 buffers the whole mail of one packet before
    /// DESIRED_SPEED triggers the course, so a course carries the heading pHelmIvP posted in the
    /// same iteration (it posts DEPTH, SPEED, HEADING, in that order, in one packet).
    pub fn on_value(&mut self, var: DesiredVar, value: f64, time: f64) {
        let slot = match var {
            DesiredVar::Speed => {
                self.speed = Some((value, time));
                return;
            }
            DesiredVar::Heading => &mut self.heading,
            DesiredVar::Depth => &mut self.depth,
            DesiredVar::Pitch => &mut self.pitch,
            DesiredVar::Roll => &mut self.roll,
            DesiredVar::ZRate => &mut self.z_rate,
            DesiredVar::Altitude => &mut self.altitude,
        };
        *slot = Some(value);
    }

    /// The end of one packet's mail: if it carried a DESIRED_SPEED, the DesiredCourse to publish
    /// (the speed's time, the speed, and every other value buffered since the last course, each
    /// used once). A value that arrives without a speed waits for the next one.
    pub fn on_packet_end(&mut self) -> Option<DesiredCourse> {
        let (speed, time) = self.speed.take()?;
        Some(DesiredCourse {
            time,
            speed: Some(speed),
            heading: self.heading.take(),
            depth: self.depth.take(),
            pitch: self.pitch.take(),
            roll: self.roll.take(),
            z_rate: self.z_rate.take(),
            altitude: self.altitude.take(),
        })
    }
}

/// IVPHELM_STATE, trimmed and case-insensitive: "drive" → DRIVE, "park" → PARK, anything else
/// (STANDBY, DISABLED, MALCONFIG, DRIVE+, ...) → NOT_RUNNING, as Goby3 maps it.
pub fn parse_helm_state(value: &str) -> HelmState {
    let v = value.trim();
    if v.eq_ignore_ascii_case("drive") {
        HelmState::HelmDrive
    } else if v.eq_ignore_ascii_case("park") {
        HelmState::HelmPark
    } else {
        HelmState::HelmNotRunning
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helm_state_is_trimmed_and_case_insensitive() {
        assert_eq!(parse_helm_state("DRIVE"), HelmState::HelmDrive);
        assert_eq!(parse_helm_state("  drive\n"), HelmState::HelmDrive);
        assert_eq!(parse_helm_state("Park"), HelmState::HelmPark);
        assert_eq!(parse_helm_state("\tPARK "), HelmState::HelmPark);
        for other in [
            "",
            "STANDBY",
            "DISABLED",
            "MALCONFIG",
            "DRIVE+",
            "PARK+",
            "driv",
        ] {
            assert_eq!(
                parse_helm_state(other),
                HelmState::HelmNotRunning,
                "{other}"
            );
        }
    }

    #[test]
    fn a_packet_is_one_helm_iteration() {
        let mut b = DesiredBuffer::default();
        // pHelmIvP's order within one packet: DEPTH, SPEED, HEADING.
        b.on_value(DesiredVar::Depth, 5.0, 10.0);
        b.on_value(DesiredVar::Speed, 1.5, 10.25);
        b.on_value(DesiredVar::Heading, 90.0, 10.26);
        let c = b.on_packet_end().unwrap();
        assert_eq!(
            (c.time, c.speed, c.heading, c.depth),
            (10.25, Some(1.5), Some(90.0), Some(5.0)),
            "the heading of the same iteration, though it came after the speed"
        );
        // A packet without DESIRED_SPEED publishes nothing; its values wait for the speed.
        b.on_value(DesiredVar::Heading, 91.0, 10.5);
        assert_eq!(b.on_packet_end(), None);
        b.on_value(DesiredVar::Speed, 1.6, 10.75);
        let c = b.on_packet_end().unwrap();
        assert_eq!((c.speed, c.heading), (Some(1.6), Some(91.0)));
        // Each value was used once: a speed-only packet gives a course without a heading
        // (the command gate keeps the last commanded heading for it).
        b.on_value(DesiredVar::Speed, 0.0, 11.0);
        assert_eq!(
            b.on_packet_end(),
            Some(DesiredCourse {
                time: 11.0,
                speed: Some(0.0),
                ..Default::default()
            })
        );
        assert_eq!(b.on_packet_end(), None, "one course per trigger");
    }

    #[test]
    fn every_desired_variable_is_buffered_and_the_last_value_wins() {
        let mut b = DesiredBuffer::default();
        for (i, v) in DesiredVar::ALL.iter().enumerate() {
            b.on_value(*v, 100.0 + i as f64, 1.0);
        }
        b.on_value(DesiredVar::Heading, 7.0, 1.0);
        b.on_value(DesiredVar::Speed, 2.0, 3.0);
        let c = b.on_packet_end().unwrap();
        assert_eq!(
            c,
            DesiredCourse {
                time: 3.0,
                speed: Some(2.0),
                heading: Some(7.0),
                depth: Some(102.0),
                pitch: Some(103.0),
                roll: Some(104.0),
                z_rate: Some(105.0),
                altitude: Some(106.0),
            }
        );
        assert_eq!(b, DesiredBuffer::default());
    }

    #[test]
    fn desired_keys_round_trip_and_others_are_not_desired() {
        for v in DesiredVar::ALL {
            assert_eq!(DesiredVar::from_key(v.key()), Some(v));
        }
        assert_eq!(DesiredVar::from_key("DESIRED_THRUST"), None);
        assert_eq!(DesiredVar::from_key("desired_speed"), None);
    }
}
