//! LSTS DUNE vehicles (OceanScan LAUVs and the research vehicles built on DUNE) as a frontseat,
//! over IMC. Read top to bottom: [`imc`] (the wire: header, CRC, the messages a frontseat needs,
//! a bounded deframer), [`infer`] (what a backseat concludes from what the vehicle says, and what
//! it sends for a course — pure functions), [`driver`] (the state, the I/O and the glue to the
//! runtime's driver trait), [`emulator`] (a DUNE LAUV's BackSeat TCP face on the simulator's
//! vehicle model). See README.md.

#![forbid(unsafe_code)]

pub mod imc;
