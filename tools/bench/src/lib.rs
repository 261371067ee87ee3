//! `frontseat bench`: reproducible latency, throughput, capacity and footprint figures, printed
//! as one Markdown table (or JSON) with the machine and build profile in its header.
//!
//! Rows P1, P2, P6, M1, M2 run the real interface (and for M1, M2 the MOOS translation and a
//! MOOSDB) in this process against a scripted loopback frontseat (`frontseat`), P3 is the
//! simulator's own capacity bench, P4 and P5 run the `frontseat` binary as child processes
//! (`procs`). Z1–Z3 and T1 run `frontseat interface` as a child with its Zenoh gateway on (and for T1 a
//! second child exporting traces to a loopback OTLP sink), this process being the frontseat and
//! the Zenoh helm (`xproc`). G1 and G2 run the interface with its Goby3 gateway in this process
//! and a second Goby3 gateway as the helm's side, through the stand-in gobyd (`goby3`).
//! L0, L1 and L2 are the bench's own floors (a loopback line → a task wakes, → a blocked thread
//! wakes; a pseudo-terminal line → a task wakes) and every latency row is also given as a ratio
//! over the one its last hop has (`floor`). B1–D1 run each vehicle family's real driver against
//! its emulator over its own link (`vehicles`).
//! W1 runs the web scope in this process and reads its event stream over loopback (`web`).
//! R1 and R2 are the cost of the MCAP record: recording, and replay at full speed (`record`).
//! Figures are measured, never asserted: no test checks a timing.
//! `--rows` picks rows; `--against <exe>` compares this build with another over alternating runs
//! of both (`compare`), the way to tell whether a change made a path slower on a noisy machine.
//!
//! This crate is a library so that the binary stays thin: `frontseat bench` parses its flags and
//! calls [`run`] with its own executable's path, which the cross-process rows start as children
//! (a library cannot know which binary it is linked into).
#![forbid(unsafe_code)]

mod compare;
mod dds;
mod fleet;
mod floor;
mod frontseat;
mod goby3;
mod hops;
mod inproc;
mod procs;
mod record;
mod report;
mod sink;
mod vehicles;
mod web;
mod xproc;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde_json::json;

pub use fleet::{PUBLISHER_ENV, publisher_main};
pub use floor::{L4_PEER_ENV, l4_peer_main};
use report::{Figures, Machine, Row, fmt_count, fmt_duration};

/// What to run and how to print it.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Run in seconds, to prove the benchmark runs (CI); figures are rough.
    pub quick: bool,
    /// Print the results as JSON instead of the Markdown table.
    pub json: bool,
    /// The `frontseat` binary rows P4, P5, Z1–Z3 and T1 start as children.
    pub exe: PathBuf,
    /// Only these rows (and L0, which every ratio needs); all rows when empty.
    pub rows: Vec<String>,
    /// Instead of one table: an A/B of this build against that `frontseat` executable,
    /// `pairs` alternating runs of each (`compare`).
    pub against: Option<PathBuf>,
    pub pairs: usize,
}

/// Every row's id, in the order of the table.
pub const ROW_IDS: [&str; 39] = [
    "L0", "L1", "L2", "L3", "L4", "P1", "P2", "P3", "P4", "P5", "P6", "M1", "M2", "G1", "G2", "Z1",
    "Z2", "Z3", "T1", "C1", "C2", "C3", "W1", "R1", "R2", "F1", "F2", "B1", "B2", "I1", "I2", "S1",
    "S2", "A1", "A2", "U1", "U2", "D1", "D2",
];

/// Which rows a run measures. Rows measured together (P4/P5, M1/M2, G1/G2, Z1–Z3/T1, a vehicle
/// family's two) share their setup, so asking for one runs its group and the others are left
/// out of the table. A row's floor (`floor::floor_of`) is measured with it.
#[derive(Clone, Debug)]
pub struct Selection(Vec<&'static str>);

impl Selection {
    /// All rows when `ids` is empty; an unknown id is an error naming the known ones.
    pub fn parse(ids: &[String]) -> Result<Self, String> {
        if ids.is_empty() {
            return Ok(Self(ROW_IDS.to_vec()));
        }
        let mut picked = vec!["L0"];
        for id in ids {
            let id = id.trim().to_ascii_uppercase();
            match ROW_IDS.iter().find(|r| **r == id) {
                Some(r) if !picked.contains(r) => {
                    picked.push(r);
                    let floors = floor::floor_of(r)
                        .into_iter()
                        .chain(floor::path_floor_of(r).unwrap_or_default().iter().copied());
                    for f in floors {
                        if let Some(f) = ROW_IDS.iter().find(|x| **x == f)
                            && !picked.contains(f)
                        {
                            picked.push(f);
                        }
                    }
                }
                Some(_) => {}
                None => {
                    return Err(format!(
                        "unknown row `{id}`; rows are {}",
                        ROW_IDS.join(", ")
                    ));
                }
            }
        }
        Ok(Self(picked))
    }

    pub fn wants(&self, id: &str) -> bool {
        self.0.contains(&id)
    }

    fn any(&self, ids: &[&str]) -> bool {
        ids.iter().any(|id| self.wants(id))
    }
}

/// How long and how hard each row runs.
#[derive(Clone, Copy, Debug)]
struct Plan {
    inproc: inproc::Plan,
    goby3: goby3::Plan,
    xproc: xproc::Plan,
    dds: dds::Plan,
    web: web::Plan,
    record: record::Plan,
    fleet: fleet::Plan,
    vehicles: vehicles::Plan,
    capacity: (usize, f64, f64, Duration),
    start_runs: usize,
    settle: Duration,
    footprint_window: Duration,
}

impl Plan {
    fn full() -> Self {
        Self {
            inproc: inproc::Plan {
                p1_count: 10_000,
                p1_rate_hz: 500.0,
                p2_count: 10_000,
                p2_rate_hz: 500.0,
                p6_rate_hz: 10_000.0,
                p6_duration: Duration::from_secs(5),
                m1_count: 5_000,
                m1_rate_hz: 500.0,
                m2_count: 5_000,
                m2_rate_hz: 500.0,
            },
            goby3: goby3::Plan {
                g1_count: 5_000,
                g1_rate_hz: 500.0,
                g2_count: 5_000,
                g2_rate_hz: 500.0,
            },
            dds: dds::Plan {
                c1_count: 5_000,
                c1_rate_hz: 500.0,
                c2_count: 5_000,
                c2_rate_hz: 500.0,
                settle: Duration::from_secs(2),
                cpu_window: Duration::from_secs(10),
            },
            xproc: xproc::Plan {
                z1_count: 5_000,
                z1_rate_hz: 500.0,
                z2_count: 5_000,
                z2_rate_hz: 500.0,
                z3_rate_hz: 10_000.0,
                z3_duration: Duration::from_secs(5),
                settle: Duration::from_secs(2),
                cpu_window: Duration::from_secs(10),
            },
            web: web::Plan {
                count: 300,
                rate_hz: 10.0,
            },
            record: record::Plan {
                rate_hz: 10_000,
                window: Duration::from_secs(10),
            },
            fleet: fleet::Plan {
                f1_fleets: &[10, 50, 100],
                f1_window: Duration::from_secs(5),
                f2_vehicles: 1000,
                f2_window: Duration::from_secs(5),
            },
            vehicles: vehicles::Plan {
                nav_count: 500,
                cmd_count: 300,
                cmd_rate_hz: 20.0,
                cmd_wait: Duration::from_secs(2),
                warp: 5.0,
            },
            capacity: (100, 10.0, 100.0, Duration::from_secs(10)),
            start_runs: 20,
            settle: Duration::from_secs(2),
            footprint_window: Duration::from_secs(10),
        }
    }

    fn quick() -> Self {
        Self {
            inproc: inproc::Plan {
                p1_count: 200,
                p1_rate_hz: 1000.0,
                p2_count: 200,
                p2_rate_hz: 1000.0,
                p6_rate_hz: 10_000.0,
                p6_duration: Duration::from_millis(300),
                m1_count: 100,
                m1_rate_hz: 1000.0,
                m2_count: 100,
                m2_rate_hz: 1000.0,
            },
            goby3: goby3::Plan {
                g1_count: 100,
                g1_rate_hz: 1000.0,
                g2_count: 100,
                g2_rate_hz: 1000.0,
            },
            dds: dds::Plan {
                c1_count: 200,
                c1_rate_hz: 500.0,
                c2_count: 200,
                c2_rate_hz: 500.0,
                settle: Duration::from_millis(200),
                cpu_window: Duration::from_millis(500),
            },
            xproc: xproc::Plan {
                z1_count: 200,
                z1_rate_hz: 1000.0,
                z2_count: 200,
                z2_rate_hz: 1000.0,
                z3_rate_hz: 10_000.0,
                z3_duration: Duration::from_millis(300),
                settle: Duration::from_millis(200),
                cpu_window: Duration::from_millis(500),
            },
            web: web::Plan {
                count: 20,
                rate_hz: 10.0,
            },
            record: record::Plan {
                rate_hz: 10_000,
                window: Duration::from_millis(500),
            },
            fleet: fleet::Plan {
                f1_fleets: &[10],
                f1_window: Duration::from_millis(500),
                f2_vehicles: 100,
                f2_window: Duration::from_millis(500),
            },
            vehicles: vehicles::Plan {
                nav_count: 10,
                cmd_count: 5,
                cmd_rate_hz: 20.0,
                cmd_wait: Duration::from_secs(2),
                warp: 5.0,
            },
            capacity: (10, 10.0, 10.0, Duration::from_millis(500)),
            start_runs: 2,
            settle: Duration::from_millis(200),
            footprint_window: Duration::from_millis(500),
        }
    }
}

const P3: &str = "simulator capacity: vehicles × FREQ × WARP sustained";

async fn capacity(plan: &Plan) -> Row {
    let (vehicles, freq, warp, window) = plan.capacity;
    let r = frontseat_sim::capacity_bench(vehicles, freq, warp, window).await;
    let what = format!("{P3} ({vehicles} × {freq} × {warp})");
    if r.failed_vehicles == vehicles || r.window.is_zero() {
        return Row::failed("P3", what, "no vehicle started");
    }
    let pct = |v: f64| 100.0 * v / r.expected_nav_per_s.max(f64::MIN_POSITIVE);
    let cpu = r
        .cpu_percent
        .map(|c| format!("{c:.0} % of one core"))
        .unwrap_or_else(|| "CPU unknown".into());
    Row {
        id: "P3",
        what,
        figures: Figures::Result(format!(
            "{} NAV/s expected; ticks {:.2} %, sent {:.2} %, received {:.2} %; worst tick lateness {}; late {} skipped {} failed vehicles {}; {cpu}",
            fmt_count(r.expected_nav_per_s),
            pct(r.ticks_per_s),
            pct(r.sent_nav_per_s),
            pct(r.received_nav_per_s),
            fmt_duration(r.worst_lateness),
            r.late_ticks,
            r.skipped_ticks,
            r.failed_vehicles,
        )),
        detail: format!(
            "frontseat_sim::capacity_bench over {}, clients in the same process over loopback",
            fmt_duration(r.window)
        ),
        extra: json!({
            "vehicles": r.vehicles,
            "freq": r.freq,
            "warp": r.warp,
            "expected_nav_per_s": r.expected_nav_per_s,
            "ticks_per_s": r.ticks_per_s,
            "sent_nav_per_s": r.sent_nav_per_s,
            "received_nav_per_s": r.received_nav_per_s,
            "worst_lateness_us": r.worst_lateness.as_secs_f64() * 1e6,
            "late_ticks": r.late_ticks,
            "skipped_ticks": r.skipped_ticks,
            "failed_vehicles": r.failed_vehicles,
            "cpu_percent": r.cpu_percent,
        }),
    }
}

/// Runs every row one after the other and prints the table (or JSON) to stdout; exits 1 when a
/// row failed.
pub async fn run(args: BenchOptions) -> ExitCode {
    let sel = match Selection::parse(&args.rows) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("frontseat bench: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(other) = &args.against {
        let o = compare::CompareOptions {
            this: args.exe.clone(),
            other: other.clone(),
            pairs: args.pairs.max(1),
            rows: args.rows.clone(),
            sel: sel.clone(),
            quick: args.quick,
            json: args.json,
        };
        // The children are whole processes, waited for on a thread of their own.
        return tokio::task::spawn_blocking(move || compare::run(&o))
            .await
            .unwrap_or(ExitCode::from(1));
    }
    let plan = if args.quick {
        Plan::quick()
    } else {
        Plan::full()
    };
    let machine = Machine::detect();
    let started = Instant::now();
    // M1, M2, G1, G2 and W1 broken down by hop (`hops`), when the environment asks.
    if hops::install_if_asked() {
        eprintln!(
            "frontseat bench: {} set: M1, M2, G1, G2 and W1 are broken down by hop",
            hops::HOPS_ENV
        );
    }
    eprintln!(
        "frontseat bench{}: {} build on {} ({} cores); this takes {}",
        if args.quick { " --quick" } else { "" },
        machine.profile,
        machine.cpu,
        machine.cores,
        if args.quick {
            "a few seconds"
        } else if args.rows.is_empty() {
            "about three minutes"
        } else {
            "less for the rows picked"
        }
    );
    // One after the other: on a small machine the rows must not disturb each other.
    let l0 = floor::run(plan.inproc.p1_count, plan.inproc.p1_rate_hz).await;
    let mut rows = vec![l0];
    if sel.wants("L1") {
        rows.push(floor::run_l1(plan.inproc.p1_count, plan.inproc.p1_rate_hz).await);
    }
    if sel.wants("L2") {
        rows.push(floor::run_l2(plan.inproc.p1_count, plan.inproc.p1_rate_hz).await);
    }
    if sel.wants("L3") {
        rows.push(web::run_floor(plan.web).await);
    }
    if sel.wants("L4") {
        // L4's putting peer is a child: this executable, found next to `frontseat`.
        let bench_exe = args
            .exe
            .with_file_name(format!("frontseat-bench{}", std::env::consts::EXE_SUFFIX));
        rows.push(floor::run_l4(&bench_exe, plan.xproc.z1_count, plan.xproc.z1_rate_hz).await);
    }
    if sel.any(&["P1", "P2", "P6", "M1", "M2"]) {
        rows.extend(inproc::run(plan.inproc, &sel).await);
    }
    if sel.any(&["G1", "G2"]) {
        rows.extend(goby3::run(plan.goby3).await);
    }
    if sel.wants("P3") {
        rows.push(capacity(&plan).await);
    }
    if sel.any(&["P4", "P5"]) {
        let r = procs::run(
            &args.exe,
            plan.start_runs,
            plan.settle,
            plan.footprint_window,
        )
        .await;
        rows.extend(r);
    }
    if sel.any(&["Z1", "Z2", "Z3", "T1"]) {
        rows.extend(xproc::run(&args.exe, plan.xproc).await);
    }
    if sel.any(&["C1", "C2", "C3"]) {
        rows.extend(dds::run(&args.exe, plan.dds).await);
    }
    if sel.wants("W1") {
        rows.push(web::run(plan.web).await);
    }
    if sel.any(&["R1", "R2"]) {
        rows.extend(record::run(plan.record).await);
    }
    if sel.any(&["F1", "F2"]) {
        // The F1 publishers run in a child: this executable, found next to `frontseat`.
        let bench_exe = args
            .exe
            .with_file_name(format!("frontseat-bench{}", std::env::consts::EXE_SUFFIX));
        rows.extend(fleet::run(plan.fleet, &bench_exe, sel.wants("F1"), sel.wants("F2")).await);
    }
    if sel.any(&[
        "B1", "B2", "I1", "I2", "S1", "S2", "A1", "A2", "U1", "U2", "D1", "D2",
    ]) {
        rows.extend(vehicles::run(plan.vehicles, &sel).await);
    }
    rows.retain(|r| sel.wants(r.id));
    rows.sort_by_key(|r| ROW_IDS.iter().position(|id| *id == r.id));
    floor::add_ratios(&mut rows);
    let elapsed = started.elapsed();

    let out = if args.json {
        let v = report::json(&machine, args.quick, elapsed, &rows);
        serde_json::to_string_pretty(&v).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    } else {
        report::markdown(&machine, args.quick, elapsed, &rows)
    };
    let mut stdout = std::io::stdout().lock();
    if writeln!(stdout, "{out}").is_err() {
        return ExitCode::from(1);
    }
    if rows.iter().any(Row::is_failed) {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}
