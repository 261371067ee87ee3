//! OpenCPN (or any NMEA 0183 chart plotter) beside frontseat, both directions:
//! - out: vehicles as AIS class B targets ([`ais`] encodes, [`feed`] keeps the targets and
//!   reports them, [`transport`] sends by UDP and a TCP server; [`lone`] is one interface's own);
//! - in: OpenCPN's autopilot sentences ([`autopilot`] reads APB/RMB/XTE/RMC) as one vehicle's
//!   helm ([`helm`]), through the generated ports like any helm.
//!
//! [`nmea`] frames and checks sentences. Facts (field layouts, OpenCPN's behaviour) are cited
//! from the shared OpenCPN protocol notes; README.md says which crates were considered.
#![forbid(unsafe_code)]

pub mod ais;
pub mod autopilot;
pub mod feed;
pub mod helm;
pub mod lone;
pub mod nmea;
pub mod transport;
