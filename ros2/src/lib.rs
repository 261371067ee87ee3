//! The vehicle as a ROS 2 participant over DDS, with nothing from ROS installed: a helm-side
//! gateway of `frontseat interface` (`[ros2]`) that publishes the vehicle's navigation as
//! `nav_msgs/Odometry` and `sensor_msgs/NavSatFix`, Goby3's messages as `frontseat_msgs`, its
//! health on `/diagnostics`, and takes a ROS 2 helm's `desired_course`, `helm_state` and
//! `command_request` onto the bus, where they cross the interface's command gate like any helm's.
//! [`cdr`] is the wire layout, [`msgs`] the messages, [`types`] their ROS/DDS names and type
//! hashes, [`gateway`] the participant, its threads and checks. DDS: rustdds (pure Rust;
//! README.md says why). Nothing here can end the process or touch the vehicle link.
#![forbid(unsafe_code)]

pub mod cdr;
pub mod gateway;
pub mod msgs;
pub mod types;

pub use gateway::{Ros2Error, Ros2Gateway, Ros2Stats, start};
/// The DDS implementation, for tests and tools that talk to the gateway directly.
pub use rustdds;
