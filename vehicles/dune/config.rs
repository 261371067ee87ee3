//! `[driver.dune]`: an LSTS DUNE vehicle (an OceanScan LAUV, or any DUNE system) over IMC on its
//! BackSeat TCP server — where it is, our IMC id and the vehicle's, the entity whose health
//! gates navigation, the FollowReference maneuver's rates and timeouts, and how the vehicle is
//! controlled (only the FollowReference path; direct control is refused here, see the README).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// How the helm's course reaches a DUNE vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DuneControl {
    /// A one-maneuver plan (PlanControl START + FollowReference), then a Reference per period
    /// toward a point ahead on the commanded heading: the path DUNE supports on AUVs, with the
    /// maneuver's timeout as a watchdog.
    #[default]
    FollowReference,
    /// ControlLoops + DesiredHeading/Speed/Z. Refused by DUNE's supervisor on AUV configs, no
    /// watchdog, and a scope_ref trap: not implemented, refused by validation.
    Direct,
}

/// The DUNE driver (IMC 5.4 over the vehicle's BackSeat TCP server).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DuneConfig {
    /// Host of the vehicle's DUNE (its BackSeat TCP server; on the vehicle's own computer,
    /// 127.0.0.1).
    pub address: String,
    /// Port of the BackSeat TCP server (6006 on LAUV configs, `Transports.TCP.Server/BackSeat`).
    pub port: u16,
    /// Our IMC id (the header's src of everything we send, and FollowReference's control_src).
    /// CCU ids live in 0x4000-0x5FFF; default 0x4F0A = 20234.
    pub own_imc_id: u16,
    /// The vehicle's IMC id (lauv-simulator-1: 0x00D1 = 209). 0 = the src of the first
    /// VehicleState heard, as LSTS's own backseat does. Everything we send goes to exactly this
    /// id (DUNE drops dst 0xFFFF); state and navigation from another src are counted and ignored.
    pub vehicle_imc_id: u16,
    /// The entity whose EntityState ERROR or FAILURE stops navigation from reaching the helm
    /// (names come from the vehicle's EntityInfo/EntityList). Empty: none.
    pub navigation_entity: String,
    /// The plan id of our one-maneuver plan (how the vehicle's plan state is recognised as ours).
    pub plan_id: String,
    /// How the helm's course reaches the vehicle: "follow_reference" (the default; the only one
    /// implemented).
    pub control: DuneControl,
    /// References are sent at this rate while the helm commands. Unit: Hz, 0.2 to 10.
    #[schemars(range(min = 0.2, max = 10.0))]
    pub reference_rate: f64,
    /// FollowReference's timeout: the vehicle ends the maneuver (SERVICE, thrust off) when no
    /// Reference came for this long — the watchdog if the backseat dies. Unit: s, at least three
    /// reference periods, at most 600.
    pub maneuver_timeout: f64,
    /// The point each Reference aims at: this far ahead of the vehicle on the commanded heading.
    /// Unit: m, 50 to 1000 (the vehicle loiters within 15 m of the point).
    #[schemars(range(min = 50.0, max = 1000.0))]
    pub lookahead_m: f64,
    /// References stop when the helm has not renewed its course for this long (the vehicle's own
    /// timeout then ends the maneuver). Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub course_timeout: f64,
    /// The vehicle is NOT_CONNECTED after this long without a VehicleState (DUNE sends 2 Hz).
    /// Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub vehicle_state_timeout: f64,
    /// Navigation is not provided after this long without a usable EstimatedState (20 Hz).
    /// Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub navigation_timeout: f64,
    /// Reconnect delay after a lost link; doubles up to reconnect_max_ms. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_initial_ms: u64,
    /// Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_max_ms: u64,
}

impl Default for DuneConfig {
    fn default() -> Self {
        Self {
            address: "127.0.0.1".into(),
            port: 6006,
            own_imc_id: 0x4F0A,
            vehicle_imc_id: 0,
            navigation_entity: "Navigation".into(),
            plan_id: "frontseat".into(),
            control: DuneControl::FollowReference,
            reference_rate: 1.0,
            maneuver_timeout: 10.0,
            lookahead_m: 300.0,
            course_timeout: 3.0,
            vehicle_state_timeout: 3.0,
            navigation_timeout: 1.0,
            reconnect_initial_ms: 100,
            reconnect_max_ms: 5000,
        }
    }
}

impl crate::drivers::DriverSection for DuneConfig {
    const CHECKED_WHEN_NOT_SELECTED: bool = false;

    fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_empty(&at(prefix, "address"), &self.address);
        c.port(&at(prefix, "port"), self.port);
        for (name, id) in [
            ("own_imc_id", self.own_imc_id),
            ("vehicle_imc_id", self.vehicle_imc_id),
        ] {
            // 0xFFFF = null, 0xFFF0 = broadcast: neither names one system.
            if id == 0xFFFF || id == 0xFFF0 || (name == "own_imc_id" && id == 0) {
                c.push(FieldError::new(
                    at(prefix, name),
                    id.to_string(),
                    if name == "own_imc_id" {
                        "not one system's IMC id (0, 0xFFF0 and 0xFFFF are special)"
                    } else {
                        "not one system's IMC id (0xFFF0 and 0xFFFF are special; 0 = learn it)"
                    },
                ));
            }
        }
        if self.own_imc_id == self.vehicle_imc_id {
            c.push(FieldError::new(
                at(prefix, "own_imc_id"),
                self.own_imc_id.to_string(),
                "must differ from vehicle_imc_id",
            ));
        }
        c.non_empty(&at(prefix, "plan_id"), &self.plan_id);
        if self.control == DuneControl::Direct {
            c.push(FieldError::new(
                at(prefix, "control"),
                "\"direct\"",
                "direct control (ControlLoops + Desired*) is not implemented: DUNE refuses it on \
                 AUVs and it has no watchdog; use \"follow_reference\"",
            ));
        }
        c.within(
            &at(prefix, "reference_rate"),
            self.reference_rate,
            0.2,
            10.0,
        );
        if c.finite(&at(prefix, "maneuver_timeout"), self.maneuver_timeout) {
            let min = 3.0 / self.reference_rate.clamp(0.2, 10.0);
            c.within(
                &at(prefix, "maneuver_timeout"),
                self.maneuver_timeout,
                min,
                600.0,
            );
        }
        c.within(&at(prefix, "lookahead_m"), self.lookahead_m, 50.0, 1000.0);
        c.positive(&at(prefix, "course_timeout"), self.course_timeout);
        c.positive(
            &at(prefix, "vehicle_state_timeout"),
            self.vehicle_state_timeout,
        );
        c.positive(&at(prefix, "navigation_timeout"), self.navigation_timeout);
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
        format!("imc tcp {}:{}", self.address, self.port)
    }
}
