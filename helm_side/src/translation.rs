//! FrontSeatTranslation: the bridge between our bus and a MOOSDB where pHelmIvP runs, as Goby3's
//! `goby::moos::FrontSeatTranslation`. node_status goes out as NAV_* (each one posted exactly
//! once), DESIRED_* come back as DesiredCourse (triggered by DESIRED_SPEED), IVPHELM_STATE as
//! HelmStateReport; our own health (MOOSDB link, helm in DRIVE, DESIRED_* freshness) goes out on
//! `frontseat::translation::status`. The translation never posts IVPHELM_STATE (a foreign
//! IVPHELM_STATE makes pHelmIvP disable itself).
//!
//! It runs as one tokio task, not a ractor actor: the MOOS client already delivers its events on
//! an mpsc channel from its own task and reconnects by itself, so an actor would need a pump task
//! in front of its mailbox (one more hop on the latency path) and there is nothing a supervisor
//! restart could repair. The conversions are pure functions, tested on their own.
//!
//! Its parts: `nav` turns a node_status into NAV_* posts, `helm_mail` turns the helm's mail
//! into a DesiredCourse or a HelmState, `health` keeps the TranslationStatus, `config` makes
//! the MOOS client's configuration, `task` runs the data path, `actor` supervises it.

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_helm_side::translation";

mod actor;
mod config;
mod health;
mod helm_mail;
mod nav;
mod task;

pub use actor::{
    TranslationActor, TranslationActorState, TranslationArgs, TranslationMsg, TranslationObserver,
    child_spec,
};
pub use config::client_config;
pub use health::Health;
pub use helm_mail::{DesiredBuffer, DesiredVar, IVPHELM_STATE, parse_helm_state};
pub use nav::{NavValue, format_g15, nav_posts, yaw_from_heading};
pub use task::{
    STATUS_PERIOD, TranslationCounters, TranslationError, TranslationHandle, TranslationWatch,
    spawn, spawn_with_faults,
};
