//! The flags of `frontseat bench`, shared by the service binary (which parses them, so `--help`
//! and a bad flag read as ever) and the sibling executable `frontseat-bench` that runs them.

use clap::Args;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Run in seconds, to prove the benchmark runs (CI); figures are rough.
    #[arg(long)]
    pub quick: bool,
    /// Print the results as JSON instead of the Markdown table.
    #[arg(long)]
    pub json: bool,
    /// Only these rows, comma-separated (e.g. `--rows P1,P2,M1,M2` for an A/B of two builds).
    /// Floors: L0 (loopback line → a task wakes) always runs; L1 (→ a thread blocked in read(2)),
    /// L2 (a pseudo-terminal line → a task wakes), L3 (an SSE event → the client parses it) and
    /// L4 (a Zenoh put in another process → a subscriber here) run with the rows they are floors
    /// of;
    /// every latency row gives its ratio over its own floor. Vehicle families, each through its
    /// emulator: B1/B2 Bluefin (TCP), I1/I2 Iver3, S1/S2 Wave Glider SV2 (pty), A1/A2 ArduPilot
    /// Rover, U1/U2 ArduSub, D1/D2 DUNE (TCP); <F>1 navigation → node_status, <F>2 desired_course →
    /// the command read at the vehicle. Rows that share a setup run together (M1/M2, P4/P5, Z1–Z3/T1, a family's two);
    /// the table shows only the rows asked for.
    #[arg(long, value_delimiter = ',', value_name = "ROWS")]
    pub rows: Vec<String>,
    /// A/B against another build: runs this build's bench and that `frontseat` executable's
    /// alternately, `--pairs` times each, and prints mean and median p50/p99 of every latency
    /// row with the change (e.g. `--against /tmp/frontseat-old --rows P1,P2,M1,M2`). A build
    /// without `--rows` runs its whole table.
    #[arg(long, value_name = "EXE")]
    pub against: Option<std::path::PathBuf>,
    /// How many runs of each build `--against` makes.
    #[arg(long, default_value_t = 6, requires = "against")]
    pub pairs: usize,
}
