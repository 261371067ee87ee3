//! What the interface is told once, at its start: [`InterfaceSettings`] resolved from the config
//! and the selected driver's word (its acknowledgement budget, its raw framing), the command
//! timeout that follows from them, and the DriverActor's node in the supervision tree (its
//! restart policy).

use std::time::Duration;

use frontseat_config::{InterfaceConfig, RestartPolicy};

use crate::command_gate::Limits;
use crate::nav_gate::NavLimits;
use crate::proto::goby::middleware::frontseat::protobuf::VehicleType;
use crate::raw_gate::RawPolicy;
use crate::state_machine::StateMachineConfig;
use crate::supervisor::{Node, Policy, Side};

/// Everything the interface needs, resolved from the config once.
#[derive(Clone, Debug)]
pub struct InterfaceSettings {
    pub name: String,
    pub vehicle_type: VehicleType,
    pub origin: (f64, f64),
    pub sm: StateMachineConfig,
    /// helm_state not heard for this long (sim time) = helm not running; zero = never.
    pub helm_state_timeout: Duration,
    pub status_period: Duration,
    pub exit_on_error: bool,
    pub warp: f64,
    pub restart_initial: Duration,
    pub restart_max: Duration,
    pub max_restarts: u32,
    pub restart_window: Duration,
    pub queue_capacity: usize,
    /// A command with response_requested that the frontseat has not answered in this long
    /// (sim time) gets a failed CommandResponse.
    pub command_timeout: Duration,
    pub driver_name: String,
    pub limits: Limits,
    /// Physical bounds of navigation from the frontseat (`[limits.navigation]`).
    pub nav_limits: NavLimits,
    /// Who may use raw_send_request and what one may carry (`[raw_send]`).
    pub raw: RawPolicy,
    /// `[chaos] enabled`: the interface and each driver open a fault port (crate::chaos).
    pub fault_ports: bool,
}

impl InterfaceSettings {
    /// The settings of `cfg` for a driver the config alone describes: no acknowledgement budget
    /// beyond the interface's own, and raw requests checked as lines (frames for a plugin).
    /// [`Self::for_driver`] gives the selected driver's word on both.
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let secs = |s: f64| Duration::from_secs_f64(s.max(0.0));
        Self {
            name: cfg.name.clone(),
            vehicle_type: VehicleType::try_from(cfg.r#type.proto_value())
                .unwrap_or(VehicleType::Auv),
            origin: (cfg.origin.lat, cfg.origin.lon),
            sm: StateMachineConfig {
                require_helm: cfg.require_helm,
                helm_running_timeout: secs(cfg.helm_running_timeout),
                frontseat_connected_timeout: secs(cfg.frontseat_connected_timeout),
                ..Default::default()
            },
            helm_state_timeout: secs(cfg.helm_state_timeout),
            status_period: secs(cfg.status_period),
            exit_on_error: cfg.exit_on_error,
            warp: cfg.sim_warp_factor,
            restart_initial: Duration::from_millis(cfg.supervision.restart_initial_delay_ms),
            restart_max: Duration::from_millis(cfg.supervision.restart_max_delay_ms),
            max_restarts: cfg.supervision.max_restarts,
            restart_window: secs(cfg.supervision.restart_window_s),
            queue_capacity: cfg.bus.queue_capacity.max(1),
            command_timeout: command_timeout(Duration::ZERO),
            driver_name: cfg.driver.name.clone(),
            limits: Limits::from(&cfg.limits),
            nav_limits: NavLimits::from(&cfg.limits.navigation),
            raw: RawPolicy::from_config(
                cfg,
                if cfg.driver.library.is_some() {
                    crate::raw_gate::RawFraming::Frames
                } else {
                    crate::raw_gate::RawFraming::Lines
                },
            ),
            fault_ports: cfg.chaos.enabled,
        }
    }

    /// With what the selected driver says of its vehicle: how long it may take to answer a
    /// command, and how its wire delimits a raw request.
    pub fn for_driver(mut self, driver: &crate::drivers::SelectedDriver) -> Self {
        self.command_timeout = command_timeout(driver.ack_budget);
        self.raw.framing = driver.raw_framing;
        self
    }

    /// The DriverActor's restart policy (`[supervision]`): restarted however it ends (a panic, a
    /// kill, a stop nobody asked for), after `restart_initial` doubling to `restart_max`; more
    /// than `max_restarts` within `restart_window` and its supervisor gives up.
    pub fn driver_policy(&self) -> Policy {
        Policy {
            side: Side::Vehicle,
            restart: RestartPolicy::Always,
            max_restarts: self.max_restarts,
            window: self.restart_window,
            backoff_initial: self.restart_initial,
            backoff_max: self.restart_max,
        }
    }
}

/// Our own answer to a command waits at least this long for the driver's.
const MIN_COMMAND_TIMEOUT: Duration = Duration::from_secs(5);

/// How long the interface waits before answering a command itself (failed): past the selected
/// driver's own acknowledgement budget (`ack_budget`: Bluefin's nmea_resend_attempts ×
/// nmea_resend_interval, the serial vehicles' link ack_timeout; the driver's word,
/// [`crate::drivers::BuiltIn::ack_budget`]), plus a second, so the driver's real answer (a
/// Bluefin "pending", then its ack) is the one the helm gets, as in Goby3, which forwards every
/// driver answer and never answers on its own (frontseat_interface.cpp:205-208).
pub fn command_timeout(ack_budget: Duration) -> Duration {
    ack_budget
        .saturating_add(Duration::from_secs(1))
        .max(MIN_COMMAND_TIMEOUT)
}

/// The interface's one supervised child, as its supervisor starts it and the tree shows it.
pub fn driver_node(settings: &InterfaceSettings) -> Node {
    Node::new(
        "DriverActor",
        settings.driver_policy(),
        "[supervision] (restart_initial_delay_ms, restart_max_delay_ms, max_restarts, restart_window_s); down = frontseat not connected",
    )
}
