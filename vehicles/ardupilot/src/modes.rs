//! The autopilot's flight modes: ArduPilot Rover's and ArduSub's `custom_mode` numbers and names,
//! and the default frontseat reading of each (which ones hand the helm control, which ones are
//! the autopilot's own autonomy, which ones are a person's or a stop).

/// Which ArduPilot firmware the vehicle runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Firmware {
    #[default]
    Rover,
    Sub,
}

/// What a mode means for the backseat.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// A person, a stop or a hold: nobody is driving the mission.
    Idle,
    /// The autopilot drives by itself (AUTO, RTL, LOITER, a failsafe).
    InControl,
    /// GUIDED: the autopilot steers to targets the backseat sends.
    AcceptingCommands,
}

/// ArduPilot Rover mode numbers (Rover/mode.h).
pub mod rover {
    pub const MANUAL: u32 = 0;
    pub const ACRO: u32 = 1;
    pub const STEERING: u32 = 3;
    pub const HOLD: u32 = 4;
    pub const LOITER: u32 = 5;
    pub const FOLLOW: u32 = 6;
    pub const SIMPLE: u32 = 7;
    pub const DOCK: u32 = 8;
    pub const CIRCLE: u32 = 9;
    pub const AUTO: u32 = 10;
    pub const RTL: u32 = 11;
    pub const SMART_RTL: u32 = 12;
    pub const GUIDED: u32 = 15;
    pub const INITIALISING: u32 = 16;
}

/// ArduSub mode numbers (ArduSub/mode.h).
pub mod sub {
    pub const STABILIZE: u32 = 0;
    pub const ACRO: u32 = 1;
    pub const ALT_HOLD: u32 = 2;
    pub const AUTO: u32 = 3;
    pub const GUIDED: u32 = 4;
    pub const CIRCLE: u32 = 7;
    pub const SURFACE: u32 = 9;
    pub const POSHOLD: u32 = 16;
    pub const MANUAL: u32 = 19;
    pub const MOTOR_DETECT: u32 = 20;
    pub const SURFTRAK: u32 = 21;
}

impl Firmware {
    /// GUIDED: the mode in which the backseat's targets are followed.
    pub fn guided(self) -> u32 {
        match self {
            Firmware::Rover => rover::GUIDED,
            Firmware::Sub => sub::GUIDED,
        }
    }

    /// The stop-and-stay mode the command extension's HOLD asks for.
    pub fn hold(self) -> u32 {
        match self {
            Firmware::Rover => rover::HOLD,
            Firmware::Sub => sub::POSHOLD,
        }
    }

    /// The mode's name, for logs and reasons.
    pub fn mode_name(self, mode: u32) -> Option<&'static str> {
        Some(match (self, mode) {
            (Firmware::Rover, rover::MANUAL) => "MANUAL",
            (Firmware::Rover, rover::ACRO) => "ACRO",
            (Firmware::Rover, rover::STEERING) => "STEERING",
            (Firmware::Rover, rover::HOLD) => "HOLD",
            (Firmware::Rover, rover::LOITER) => "LOITER",
            (Firmware::Rover, rover::FOLLOW) => "FOLLOW",
            (Firmware::Rover, rover::SIMPLE) => "SIMPLE",
            (Firmware::Rover, rover::DOCK) => "DOCK",
            (Firmware::Rover, rover::CIRCLE) => "CIRCLE",
            (Firmware::Rover, rover::AUTO) => "AUTO",
            (Firmware::Rover, rover::RTL) => "RTL",
            (Firmware::Rover, rover::SMART_RTL) => "SMART_RTL",
            (Firmware::Rover, rover::GUIDED) => "GUIDED",
            (Firmware::Rover, rover::INITIALISING) => "INITIALISING",
            (Firmware::Sub, sub::STABILIZE) => "STABILIZE",
            (Firmware::Sub, sub::ACRO) => "ACRO",
            (Firmware::Sub, sub::ALT_HOLD) => "ALT_HOLD",
            (Firmware::Sub, sub::AUTO) => "AUTO",
            (Firmware::Sub, sub::GUIDED) => "GUIDED",
            (Firmware::Sub, sub::CIRCLE) => "CIRCLE",
            (Firmware::Sub, sub::SURFACE) => "SURFACE",
            (Firmware::Sub, sub::POSHOLD) => "POSHOLD",
            (Firmware::Sub, sub::MANUAL) => "MANUAL",
            (Firmware::Sub, sub::MOTOR_DETECT) => "MOTOR_DETECT",
            (Firmware::Sub, sub::SURFTRAK) => "SURFTRAK",
            _ => return None,
        })
    }

    /// The default reading of an armed vehicle's mode. A mode this table does not know is the
    /// autopilot doing something of its own: InControl, so the helm never commands into it.
    pub fn default_control(self, mode: u32) -> Control {
        use Control::*;
        match (self, mode) {
            (Firmware::Rover, rover::GUIDED) | (Firmware::Sub, sub::GUIDED) => AcceptingCommands,
            (
                Firmware::Rover,
                rover::MANUAL
                | rover::ACRO
                | rover::STEERING
                | rover::HOLD
                | rover::SIMPLE
                | rover::INITIALISING,
            ) => Idle,
            (
                Firmware::Sub,
                sub::STABILIZE
                | sub::ACRO
                | sub::ALT_HOLD
                | sub::POSHOLD
                | sub::MANUAL
                | sub::MOTOR_DETECT
                | sub::SURFTRAK,
            ) => Idle,
            _ => InControl,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The README's Rover mode numbers, one row each, with the reading the issue asks for.
    #[test]
    fn rover_modes_and_their_reading() {
        let rows = [
            (0, "MANUAL", Control::Idle),
            (4, "HOLD", Control::Idle),
            (5, "LOITER", Control::InControl),
            (10, "AUTO", Control::InControl),
            (11, "RTL", Control::InControl),
            (12, "SMART_RTL", Control::InControl),
            (15, "GUIDED", Control::AcceptingCommands),
            (16, "INITIALISING", Control::Idle),
        ];
        for (n, name, c) in rows {
            assert_eq!(Firmware::Rover.mode_name(n), Some(name));
            assert_eq!(Firmware::Rover.default_control(n), c, "{name}");
        }
        assert_eq!(Firmware::Rover.default_control(99), Control::InControl);
    }

    /// ardusub.md's mode numbers (ArduSub/mode.h:42-53), one row each, with their reading.
    #[test]
    fn sub_modes_and_their_reading() {
        let rows = [
            (0, "STABILIZE", Control::Idle),
            (1, "ACRO", Control::Idle),
            (2, "ALT_HOLD", Control::Idle),
            (3, "AUTO", Control::InControl),
            (4, "GUIDED", Control::AcceptingCommands),
            (7, "CIRCLE", Control::InControl),
            (9, "SURFACE", Control::InControl),
            (16, "POSHOLD", Control::Idle),
            (19, "MANUAL", Control::Idle),
            (20, "MOTOR_DETECT", Control::Idle),
            (21, "SURFTRAK", Control::Idle),
        ];
        for (n, name, c) in rows {
            assert_eq!(Firmware::Sub.mode_name(n), Some(name));
            assert_eq!(Firmware::Sub.default_control(n), c, "{name}");
        }
        for n in [5, 6, 15, 30] {
            assert_eq!(Firmware::Sub.mode_name(n), None, "{n}");
        }
        assert_eq!(Firmware::Sub.guided(), 4);
    }
}
