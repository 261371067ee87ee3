//! Goby3's frontseat interface state machine as a pure struct: no I/O, no clock of its own.
//!
//! The actor feeds it the helm state, the frontseat state and whether the frontseat provides data,
//! plus a monotonic "now" in simulated seconds since start; it returns the transitions taken. The
//! rules are Goby3's (`goby_frontseat_interface`), listed in `step`. One addition of ours: Goby3
//! never clears ERROR_FRONTSEAT_IGNORING_COMMANDS (and never raises it from the core); we raise it
//! after `ignoring_commands_after` consecutive refused commands while in COMMAND and clear it
//! (→ STANDBY, to climb back by the normal rules) after `ignoring_commands_holdoff`.

use std::time::Duration;

use crate::proto::goby::middleware::frontseat::protobuf::{
    FrontSeatError, FrontSeatState, HelmError, HelmState, InterfaceState, InterfaceStatus,
};

#[derive(Clone, Debug)]
pub struct StateMachineConfig {
    pub require_helm: bool,
    pub helm_running_timeout: Duration,
    pub frontseat_connected_timeout: Duration,
    pub ignoring_commands_after: u32,
    pub ignoring_commands_holdoff: Duration,
}

impl Default for StateMachineConfig {
    fn default() -> Self {
        Self {
            require_helm: true,
            helm_running_timeout: Duration::from_secs(10),
            frontseat_connected_timeout: Duration::from_secs(10),
            ignoring_commands_after: 3,
            ignoring_commands_holdoff: Duration::from_secs(10),
        }
    }
}

/// What the state machine looks at on each evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Inputs {
    pub helm: HelmState,
    pub frontseat: FrontSeatState,
    pub providing_data: bool,
}

impl Default for Inputs {
    fn default() -> Self {
        Self {
            helm: HelmState::HelmNotRunning,
            frontseat: FrontSeatState::FrontseatNotConnected,
            providing_data: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transition {
    pub from: InterfaceState,
    pub to: InterfaceState,
    pub helm_error: HelmError,
    pub frontseat_error: FrontSeatError,
    /// The rule that fired, for logs.
    pub rule: &'static str,
}

#[derive(Clone, Debug)]
pub struct StateMachine {
    cfg: StateMachineConfig,
    state: InterfaceState,
    helm_error: HelmError,
    fs_error: FrontSeatError,
    entered_at: Duration,
    refused_in_a_row: u32,
}

/// Goby3's words for a state, as shown in logs and systemd STATUS.
pub fn state_words(state: InterfaceState) -> &'static str {
    match state {
        InterfaceState::InterfaceStandby => "standby",
        InterfaceState::InterfaceListen => "running:listen",
        InterfaceState::InterfaceCommand => "running:command",
        InterfaceState::InterfaceHelmError => "error:helm",
        InterfaceState::InterfaceFsError => "error:fs",
    }
}

impl StateMachine {
    pub fn new(cfg: StateMachineConfig) -> Self {
        Self {
            cfg,
            state: InterfaceState::InterfaceStandby,
            helm_error: HelmError::ErrorHelmNone,
            fs_error: FrontSeatError::ErrorFrontseatNone,
            entered_at: Duration::ZERO,
            refused_in_a_row: 0,
        }
    }

    pub fn state(&self) -> InterfaceState {
        self.state
    }
    pub fn helm_error(&self) -> HelmError {
        self.helm_error
    }
    pub fn frontseat_error(&self) -> FrontSeatError {
        self.fs_error
    }

    /// InterfaceStatus exactly as Goby3 fills it: errors only when not NONE.
    pub fn status(&self, inputs: &Inputs) -> InterfaceStatus {
        let mut s = InterfaceStatus::default();
        s.set_state(self.state);
        s.set_frontseat_state(inputs.frontseat);
        s.set_helm_state(inputs.helm);
        s.frontseat_providing_data = Some(inputs.providing_data);
        if self.helm_error != HelmError::ErrorHelmNone {
            s.set_helm_error(self.helm_error);
        }
        if self.fs_error != FrontSeatError::ErrorFrontseatNone {
            s.set_frontseat_error(self.fs_error);
        }
        s
    }

    /// Feeds the outcome of a command the frontseat answered while we were in COMMAND.
    pub fn command_result(&mut self, successful: bool) {
        if successful {
            self.refused_in_a_row = 0;
        } else if self.state == InterfaceState::InterfaceCommand {
            self.refused_in_a_row += 1;
        }
    }

    /// Evaluates the rules until nothing changes (at most a few transitions: STANDBY → LISTEN →
    /// COMMAND can happen in one evaluation when everything is ready, instead of one per tick).
    pub fn step(&mut self, inputs: &Inputs, now: Duration) -> Vec<Transition> {
        let mut out = Vec::new();
        for _ in 0..4 {
            match self.step_once(inputs, now) {
                Some(t) => out.push(t),
                None => break,
            }
        }
        out
    }

    fn go(
        &mut self,
        to: InterfaceState,
        helm_error: HelmError,
        fs_error: FrontSeatError,
        now: Duration,
        rule: &'static str,
    ) -> Option<Transition> {
        let t = Transition {
            from: self.state,
            to,
            helm_error,
            frontseat_error: fs_error,
            rule,
        };
        self.state = to;
        self.helm_error = helm_error;
        self.fs_error = fs_error;
        self.entered_at = now;
        if to != InterfaceState::InterfaceCommand {
            self.refused_in_a_row = 0;
        }
        Some(t)
    }

    fn ok(&mut self, to: InterfaceState, now: Duration, rule: &'static str) -> Option<Transition> {
        self.go(
            to,
            HelmError::ErrorHelmNone,
            FrontSeatError::ErrorFrontseatNone,
            now,
            rule,
        )
    }

    fn step_once(&mut self, i: &Inputs, now: Duration) -> Option<Transition> {
        use InterfaceState::*;
        match self.state {
            InterfaceStandby => {
                if i.providing_data {
                    return self.ok(
                        InterfaceListen,
                        now,
                        "standby→listen: frontseat providing data",
                    );
                }
                self.check_errors(i, now)
            }
            InterfaceListen => {
                if i.frontseat == FrontSeatState::FrontseatAcceptingCommands
                    && (i.helm == HelmState::HelmDrive || !self.cfg.require_helm)
                {
                    return self.ok(
                        InterfaceCommand,
                        now,
                        "listen→command: frontseat accepting commands and helm driving",
                    );
                }
                self.check_errors(i, now)
            }
            InterfaceCommand => {
                if matches!(
                    i.frontseat,
                    FrontSeatState::FrontseatInControl | FrontSeatState::FrontseatIdle
                ) {
                    return self.ok(
                        InterfaceListen,
                        now,
                        "command→listen: frontseat in control or idle",
                    );
                }
                if self.cfg.ignoring_commands_after > 0
                    && self.refused_in_a_row >= self.cfg.ignoring_commands_after
                {
                    return self.go(
                        InterfaceFsError,
                        HelmError::ErrorHelmNone,
                        FrontSeatError::ErrorFrontseatIgnoringCommands,
                        now,
                        "fs error: frontseat refused consecutive commands",
                    );
                }
                self.check_errors(i, now)
            }
            InterfaceHelmError => {
                if i.helm == HelmState::HelmDrive {
                    return self.ok(InterfaceStandby, now, "helm error cleared: helm driving");
                }
                None
            }
            InterfaceFsError => {
                let cleared = match self.fs_error {
                    FrontSeatError::ErrorFrontseatNotConnected => {
                        i.frontseat != FrontSeatState::FrontseatNotConnected
                    }
                    FrontSeatError::ErrorFrontseatNotProvidingData => i.providing_data,
                    FrontSeatError::ErrorFrontseatIgnoringCommands => {
                        now.saturating_sub(self.entered_at) >= self.cfg.ignoring_commands_holdoff
                    }
                    FrontSeatError::ErrorFrontseatNone => true,
                };
                if cleared {
                    return self.ok(InterfaceStandby, now, "fs error cleared");
                }
                None
            }
        }
    }

    fn check_errors(&mut self, i: &Inputs, now: Duration) -> Option<Transition> {
        use InterfaceState::*;
        let fs_none = FrontSeatError::ErrorFrontseatNone;
        if i.helm == HelmState::HelmPark {
            return self.go(
                InterfaceHelmError,
                HelmError::ErrorHelmParked,
                fs_none,
                now,
                "helm error: helm parked",
            );
        }
        if self.cfg.require_helm
            && i.helm == HelmState::HelmNotRunning
            && (self.state == InterfaceCommand || now >= self.cfg.helm_running_timeout)
        {
            return self.go(
                InterfaceHelmError,
                HelmError::ErrorHelmNotRunning,
                fs_none,
                now,
                "helm error: helm not running",
            );
        }
        if i.frontseat == FrontSeatState::FrontseatNotConnected
            && (self.state != InterfaceStandby || now >= self.cfg.frontseat_connected_timeout)
        {
            return self.go(
                InterfaceFsError,
                HelmError::ErrorHelmNone,
                FrontSeatError::ErrorFrontseatNotConnected,
                now,
                "fs error: frontseat not connected",
            );
        }
        if !i.providing_data && self.state != InterfaceStandby {
            return self.go(
                InterfaceFsError,
                HelmError::ErrorHelmNone,
                FrontSeatError::ErrorFrontseatNotProvidingData,
                now,
                "fs error: frontseat not providing data",
            );
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use FrontSeatError as FE;
    use FrontSeatState as FS;
    use HelmError as HE;
    use HelmState as H;
    use InterfaceState as S;

    fn inputs(helm: H, frontseat: FS, providing_data: bool) -> Inputs {
        Inputs {
            helm,
            frontseat,
            providing_data,
        }
    }

    fn machine_in(state: S, helm_error: HE, fs_error: FE, require_helm: bool) -> StateMachine {
        let mut m = StateMachine::new(StateMachineConfig {
            require_helm,
            ..Default::default()
        });
        m.state = state;
        m.helm_error = helm_error;
        m.fs_error = fs_error;
        m
    }

    struct Row {
        rule: &'static str,
        from: (S, HE, FE),
        require_helm: bool,
        inputs: Inputs,
        now_s: u64,
        expect: (S, HE, FE),
    }

    const NONE: (HE, FE) = (HE::ErrorHelmNone, FE::ErrorFrontseatNone);

    fn rows() -> Vec<Row> {
        let st = |s| (s, NONE.0, NONE.1);
        vec![
            Row {
                rule: "standby stays while no data and before timeouts",
                from: st(S::InterfaceStandby),
                require_helm: true,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatNotConnected, false),
                now_s: 1,
                expect: st(S::InterfaceStandby),
            },
            Row {
                rule: "standby → listen when the frontseat provides data",
                from: st(S::InterfaceStandby),
                require_helm: true,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatIdle, true),
                now_s: 1,
                expect: st(S::InterfaceListen),
            },
            Row {
                rule: "standby → listen → command in one evaluation when all is ready",
                from: st(S::InterfaceStandby),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatAcceptingCommands, true),
                now_s: 1,
                expect: st(S::InterfaceCommand),
            },
            Row {
                rule: "listen → command when accepting commands and helm drive",
                from: st(S::InterfaceListen),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatAcceptingCommands, true),
                now_s: 1,
                expect: st(S::InterfaceCommand),
            },
            Row {
                rule: "listen stays when accepting but helm not running before its timeout",
                from: st(S::InterfaceListen),
                require_helm: true,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatAcceptingCommands, true),
                now_s: 5,
                expect: st(S::InterfaceListen),
            },
            Row {
                rule: "listen → command without helm when require_helm is false",
                from: st(S::InterfaceListen),
                require_helm: false,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatAcceptingCommands, true),
                now_s: 50,
                expect: st(S::InterfaceCommand),
            },
            Row {
                rule: "command → listen when the frontseat is in control",
                from: st(S::InterfaceCommand),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatInControl, true),
                now_s: 20,
                expect: st(S::InterfaceListen),
            },
            Row {
                rule: "command → listen when the frontseat is idle",
                from: st(S::InterfaceCommand),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatIdle, true),
                now_s: 20,
                expect: st(S::InterfaceListen),
            },
            Row {
                rule: "helm park → helm error parked",
                from: st(S::InterfaceCommand),
                require_helm: true,
                inputs: inputs(H::HelmPark, FS::FrontseatAcceptingCommands, true),
                now_s: 20,
                expect: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmParked,
                    FE::ErrorFrontseatNone,
                ),
            },
            Row {
                rule: "helm park is an error even without require_helm",
                from: st(S::InterfaceListen),
                require_helm: false,
                inputs: inputs(H::HelmPark, FS::FrontseatIdle, true),
                now_s: 20,
                expect: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmParked,
                    FE::ErrorFrontseatNone,
                ),
            },
            Row {
                rule: "helm not running in command → helm error at once",
                from: st(S::InterfaceCommand),
                require_helm: true,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatAcceptingCommands, true),
                now_s: 1,
                expect: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmNotRunning,
                    FE::ErrorFrontseatNone,
                ),
            },
            Row {
                rule: "helm not running after helm_running_timeout → helm error",
                from: st(S::InterfaceStandby),
                require_helm: true,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatIdle, false),
                now_s: 10,
                expect: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmNotRunning,
                    FE::ErrorFrontseatNone,
                ),
            },
            Row {
                rule: "helm not running is fine without require_helm",
                from: st(S::InterfaceStandby),
                require_helm: false,
                inputs: inputs(H::HelmNotRunning, FS::FrontseatIdle, false),
                now_s: 100,
                expect: st(S::InterfaceStandby),
            },
            Row {
                rule: "helm error clears to standby on drive",
                from: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmParked,
                    FE::ErrorFrontseatNone,
                ),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatNotConnected, false),
                now_s: 1,
                expect: st(S::InterfaceStandby),
            },
            Row {
                rule: "helm error stays while parked",
                from: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmParked,
                    FE::ErrorFrontseatNone,
                ),
                require_helm: true,
                inputs: inputs(H::HelmPark, FS::FrontseatAcceptingCommands, true),
                now_s: 1,
                expect: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmParked,
                    FE::ErrorFrontseatNone,
                ),
            },
            Row {
                rule: "not connected in standby after frontseat_connected_timeout → fs error",
                from: st(S::InterfaceStandby),
                require_helm: false,
                inputs: inputs(H::HelmDrive, FS::FrontseatNotConnected, false),
                now_s: 10,
                expect: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotConnected,
                ),
            },
            Row {
                rule: "not connected in standby before the timeout is no error",
                from: st(S::InterfaceStandby),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatNotConnected, false),
                now_s: 9,
                expect: st(S::InterfaceStandby),
            },
            Row {
                rule: "not connected outside standby → fs error at once",
                from: st(S::InterfaceCommand),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatNotConnected, false),
                now_s: 1,
                expect: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotConnected,
                ),
            },
            Row {
                rule: "not providing data outside standby → fs error",
                from: st(S::InterfaceListen),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatIdle, false),
                now_s: 1,
                expect: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotProvidingData,
                ),
            },
            Row {
                rule: "helm errors take precedence over frontseat errors",
                from: st(S::InterfaceCommand),
                require_helm: true,
                inputs: inputs(H::HelmPark, FS::FrontseatNotConnected, false),
                now_s: 1,
                expect: (
                    S::InterfaceHelmError,
                    HE::ErrorHelmParked,
                    FE::ErrorFrontseatNone,
                ),
            },
            Row {
                rule: "fs error not connected clears when connected",
                from: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotConnected,
                ),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatIdle, false),
                now_s: 30,
                expect: st(S::InterfaceStandby),
            },
            Row {
                rule: "fs error not connected stays while not connected",
                from: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotConnected,
                ),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatNotConnected, false),
                now_s: 30,
                expect: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotConnected,
                ),
            },
            Row {
                rule: "fs error not providing data clears when data flows (and climbs back)",
                from: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotProvidingData,
                ),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatAcceptingCommands, true),
                now_s: 30,
                expect: st(S::InterfaceCommand),
            },
            Row {
                rule: "fs error not providing data stays while no data even if connected",
                from: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotProvidingData,
                ),
                require_helm: true,
                inputs: inputs(H::HelmDrive, FS::FrontseatAcceptingCommands, false),
                now_s: 30,
                expect: (
                    S::InterfaceFsError,
                    HE::ErrorHelmNone,
                    FE::ErrorFrontseatNotProvidingData,
                ),
            },
        ]
    }

    #[test]
    fn goby3_rules_table() {
        for row in rows() {
            let mut m = machine_in(row.from.0, row.from.1, row.from.2, row.require_helm);
            m.step(&row.inputs, Duration::from_secs(row.now_s));
            assert_eq!(
                (m.state(), m.helm_error(), m.frontseat_error()),
                row.expect,
                "rule: {}",
                row.rule
            );
        }
    }

    #[test]
    fn ignoring_commands_is_raised_and_cleared_after_the_holdoff() {
        let mut m = machine_in(S::InterfaceCommand, NONE.0, NONE.1, true);
        let i = inputs(H::HelmDrive, FS::FrontseatAcceptingCommands, true);
        m.command_result(false);
        m.command_result(false);
        m.step(&i, Duration::from_secs(1));
        assert_eq!(m.state(), S::InterfaceCommand);
        m.command_result(false);
        m.step(&i, Duration::from_secs(2));
        assert_eq!(m.frontseat_error(), FE::ErrorFrontseatIgnoringCommands);
        m.step(&i, Duration::from_secs(11));
        assert_eq!(m.state(), S::InterfaceFsError, "still inside the holdoff");
        let t = m.step(&i, Duration::from_secs(12));
        assert_eq!(
            m.state(),
            S::InterfaceCommand,
            "cleared, then climbed back: {t:?}"
        );
        // A success in between resets the count.
        m.command_result(false);
        m.command_result(false);
        m.command_result(true);
        m.command_result(false);
        m.step(&i, Duration::from_secs(13));
        assert_eq!(m.state(), S::InterfaceCommand);
    }

    #[test]
    fn status_carries_errors_only_when_set() {
        let m = machine_in(S::InterfaceCommand, NONE.0, NONE.1, true);
        let s = m.status(&inputs(H::HelmDrive, FS::FrontseatAcceptingCommands, true));
        assert_eq!(s.helm_error, None);
        assert_eq!(s.frontseat_error, None);
        let m = machine_in(
            S::InterfaceFsError,
            HE::ErrorHelmNone,
            FE::ErrorFrontseatNotConnected,
            true,
        );
        let s = m.status(&inputs(H::HelmDrive, FS::FrontseatNotConnected, false));
        assert_eq!(s.frontseat_error(), FE::ErrorFrontseatNotConnected);
        assert_eq!(s.helm_error, None);
    }

    #[test]
    fn goby_words() {
        assert_eq!(state_words(S::InterfaceFsError), "error:fs");
        assert_eq!(state_words(S::InterfaceCommand), "running:command");
    }
}
