//! `frontseat bench --against <exe>`: an A/B of this build and another on the same machine, in one
//! run. The two builds' benches run as children, alternately (this, other, other, this, …, so
//! neither always goes first), and every latency row is summarised over the pairs: mean and median
//! of p50 and p99, and the change of this build against the other.
//!
//! Why alternate whole bench runs rather than compare two tables: this VM's wake-up latency drifts
//! by 10 % and more between minutes (BENCHMARKS.md, "The floor"), and a handful of runs made one
//! after the other once showed a +33 % that twelve interleaved pairs did not confirm.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

/// How the comparison runs.
#[derive(Clone, Debug)]
pub struct CompareOptions {
    /// This build's executable (the bench's own).
    pub this: PathBuf,
    /// The other build's `frontseat` executable.
    pub other: PathBuf,
    pub pairs: usize,
    /// Passed on to both children; empty = every row.
    pub rows: Vec<String>,
    /// The same rows, parsed: which rows the summary shows.
    pub sel: super::Selection,
    pub quick: bool,
    pub json: bool,
}

/// A child bench may take this long (a full table takes about three minutes).
const CHILD_LIMIT: Duration = Duration::from_secs(600);

/// At most this much of a child's output is kept (a full `--json` table is about 20 kB).
const OUTPUT_LIMIT: u64 = 4 << 20;

/// p50 and p99 (µs) of every latency row of one child's run, by row id.
type RunFigures = Vec<(String, f64, f64)>;

/// Runs the pairs and prints the summary; exits 1 when a child failed.
pub fn run(o: &CompareOptions) -> ExitCode {
    let mut this_runs = Vec::new();
    let mut other_runs = Vec::new();
    // The other build may predate `--rows`: then it runs its whole table and the rows not asked
    // for are left out of the summary.
    let mut other_knows_rows = !o.rows.is_empty();
    for pair in 0..o.pairs {
        let order = if pair % 2 == 0 {
            [true, false]
        } else {
            [false, true]
        };
        for this in order {
            let (exe, label) = if this {
                (&o.this, "this")
            } else {
                (&o.other, "other")
            };
            let rows = if this || other_knows_rows {
                &o.rows[..]
            } else {
                &[]
            };
            eprintln!(
                "frontseat bench --against: pair {}/{}, {label} build ({})",
                pair + 1,
                o.pairs,
                exe.display()
            );
            let mut result = child_run(exe, o.quick, rows);
            if !this && other_knows_rows && matches!(&result, Err(e) if e.contains("--rows")) {
                eprintln!(
                    "frontseat bench --against: the other build has no --rows; it runs every row"
                );
                other_knows_rows = false;
                result = child_run(exe, o.quick, &[]);
            }
            match result {
                Ok(figures) if this => this_runs.push(figures),
                Ok(figures) => other_runs.push(figures),
                Err(e) => {
                    eprintln!("frontseat bench --against: the {label} build's bench failed: {e}");
                    return ExitCode::from(1);
                }
            }
        }
    }
    let summary = summarise(&this_runs, &other_runs, &o.sel);
    if o.json {
        let v = json!({
            "this": o.this.display().to_string(),
            "other": o.other.display().to_string(),
            "pairs": o.pairs,
            "quick": o.quick,
            "rows": summary.iter().map(RowSummary::json).collect::<Vec<_>>(),
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&v).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
        );
    } else {
        println!("{}", markdown(o, &summary));
    }
    ExitCode::SUCCESS
}

/// One child bench with `--json`; p50 and p99 of every row that has them (the latency rows).
fn child_run(exe: &Path, quick: bool, rows: &[String]) -> Result<RunFigures, String> {
    let mut cmd = Command::new(exe);
    cmd.arg("bench").arg("--json");
    if quick {
        cmd.arg("--quick");
    }
    if !rows.is_empty() {
        cmd.arg("--rows").arg(rows.join(","));
    }
    let mut child = cmd
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))?;
    // Read both pipes while the child runs: a full pipe would stall it.
    let stdout = child.stdout.take();
    let stderr = child.stderr.take();
    let out = std::thread::spawn(move || read_all(stdout));
    let err = std::thread::spawn(move || read_all(stderr));
    let started = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if started.elapsed() > CHILD_LIMIT => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("did not finish within {CHILD_LIMIT:?}"));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(100)),
            Err(e) => return Err(format!("waiting for it: {e}")),
        }
    };
    let stdout = out.join().unwrap_or_default();
    let stderr = err.join().unwrap_or_default();
    let v: Value = match serde_json::from_str(&stdout) {
        Ok(v) => v,
        Err(e) => {
            let tail: String = stderr.lines().rev().take(5).collect::<Vec<_>>().join(" / ");
            return Err(format!("{status}, no JSON table ({e}): {tail}"));
        }
    };
    // A failed row makes the child exit 1 but the others still count; the failed one has no
    // figures and is left out.
    let rows = v["rows"].as_array().cloned().unwrap_or_default();
    Ok(rows
        .iter()
        .filter_map(|r| {
            let id = r["id"].as_str()?;
            let p50 = r["p50_us"].as_f64()?;
            let p99 = r["p99_us"].as_f64()?;
            Some((id.to_string(), p50, p99))
        })
        .collect())
}

fn read_all(pipe: Option<impl std::io::Read>) -> String {
    use std::io::Read as _;
    let mut s = String::new();
    if let Some(mut p) = pipe {
        let _ = (&mut p).take(OUTPUT_LIMIT).read_to_string(&mut s);
        // The rest is read and dropped: a child blocked on a full pipe would never exit.
        let _ = std::io::copy(&mut p, &mut std::io::sink());
    }
    s
}

/// Mean, median and standard deviation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    pub n: usize,
    pub mean: f64,
    pub median: f64,
    pub sd: f64,
}

impl Stats {
    pub fn of(v: &[f64]) -> Option<Self> {
        if v.is_empty() {
            return None;
        }
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            (s[n / 2 - 1] + s[n / 2]) / 2.0
        };
        let sd = if n > 1 {
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Some(Self {
            n,
            mean,
            median,
            sd,
        })
    }
}

/// One row over all pairs: [p50, p99] of this build and of the other.
#[derive(Clone, Debug)]
pub struct RowSummary {
    pub id: String,
    pub this: [Stats; 2],
    pub other: [Stats; 2],
}

/// Relative change of `this` against `other`, in percent.
fn change(this: f64, other: f64) -> f64 {
    100.0 * (this / other.max(1e-9) - 1.0)
}

impl RowSummary {
    fn json(&self) -> Value {
        let side = |s: &[Stats; 2]| {
            json!({
                "n": s[0].n,
                "p50_us": { "mean": s[0].mean, "median": s[0].median, "sd": s[0].sd },
                "p99_us": { "mean": s[1].mean, "median": s[1].median, "sd": s[1].sd },
            })
        };
        json!({
            "id": self.id,
            "this": side(&self.this),
            "other": side(&self.other),
            "p50_change_pct": {
                "mean": change(self.this[0].mean, self.other[0].mean),
                "median": change(self.this[0].median, self.other[0].median),
            },
            "p99_change_pct": {
                "mean": change(self.this[1].mean, self.other[1].mean),
                "median": change(self.this[1].median, self.other[1].median),
            },
        })
    }
}

/// Every latency row both builds measured that `sel` shows, in the table's order.
pub fn summarise(
    this: &[RunFigures],
    other: &[RunFigures],
    sel: &super::Selection,
) -> Vec<RowSummary> {
    let column = |runs: &[RunFigures], id: &str, p: usize| -> Vec<f64> {
        runs.iter()
            .flat_map(|r| r.iter().filter(|(i, ..)| i == id))
            .map(|(_, p50, p99)| if p == 0 { *p50 } else { *p99 })
            .collect()
    };
    super::ROW_IDS
        .iter()
        .filter(|id| sel.wants(id))
        .filter_map(|id| {
            let stats = |runs: &[RunFigures]| -> Option<[Stats; 2]> {
                Some([
                    Stats::of(&column(runs, id, 0))?,
                    Stats::of(&column(runs, id, 1))?,
                ])
            };
            Some(RowSummary {
                id: id.to_string(),
                this: stats(this)?,
                other: stats(other)?,
            })
        })
        .collect()
}

fn markdown(o: &CompareOptions, rows: &[RowSummary]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "A/B of `{}` (this) against `{}` (other): {} alternating pair(s){}. Figures are µs, mean / median over the runs; a change is this against other.\n",
        o.this.display(),
        o.other.display(),
        o.pairs,
        if o.quick { ", --quick" } else { "" }
    );
    let _ = writeln!(
        s,
        "| row | p50 this | p50 other | p50 change | p99 this | p99 other | p99 change |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let fig = |x: &Stats| format!("{:.0} / {:.0}", x.mean, x.median);
        let chg = |a: &Stats, b: &Stats| {
            format!(
                "{:+.1} % / {:+.1} %",
                change(a.mean, b.mean),
                change(a.median, b.median)
            )
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            r.id,
            fig(&r.this[0]),
            fig(&r.other[0]),
            chg(&r.this[0], &r.other[0]),
            fig(&r.this[1]),
            fig(&r.other[1]),
            chg(&r.this[1], &r.other[1]),
        );
    }
    let _ = write!(
        s,
        "\nA p50 changes by about one standard deviation between runs of the same build on this VM; with n pairs, a change under 2·sd/√n is not told apart from noise (sd per row in --json)."
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_odd_and_even_sets() {
        let s = Stats::of(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.n, s.mean, s.median), (3, 2.0, 2.0));
        assert!((s.sd - 1.0).abs() < 1e-12);
        let s = Stats::of(&[4.0, 1.0, 2.0, 3.0]).unwrap();
        assert_eq!(s.median, 2.5);
        assert_eq!(Stats::of(&[]), None);
    }

    #[test]
    fn summary_keeps_rows_both_sides_measured() {
        let run = |p1: f64| {
            vec![
                ("L0".to_string(), 50.0, 100.0),
                ("P1".to_string(), p1, 2.0 * p1),
                ("M1".to_string(), 200.0, 300.0),
            ]
        };
        let this = vec![run(110.0), run(90.0)];
        // One of the other build's runs has no M1 (a table without it).
        let mut other_run = run(100.0);
        other_run.retain(|(id, ..)| id != "M1");
        let other = vec![other_run, run(100.0)];
        let p1 = crate::Selection::parse(&["p1".to_string()]).unwrap();
        let s = summarise(&this, &other, &p1);
        let ids: Vec<&str> = s.iter().map(|r| r.id.as_str()).collect();
        assert_eq!(ids, ["L0", "P1"], "M1 was not asked for");
        let p1 = &s[1];
        assert_eq!(p1.this[0].mean, 100.0);
        assert_eq!(p1.other[0].n, 2);
        assert!(change(p1.this[0].mean, p1.other[0].mean).abs() < 1e-9);
        let all = summarise(&this, &other, &crate::Selection::parse(&[]).unwrap());
        let m1 = all.iter().find(|r| r.id == "M1").unwrap();
        assert_eq!((m1.this[0].n, m1.other[0].n), (2, 1));
    }
}
