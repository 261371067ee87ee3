//! Rows R1 and R2, the cost of the record (`frontseat-record`): R1 publishes node_status at a
//! fixed rate on a bus with and without the recorder and charges the difference in process CPU
//! to the recorder, with the bytes it wrote and what it dropped; R2 replays that file at
//! `--speed max` into a subscriber and gives messages/s and the factor over real time.

use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::ports::BenchVehiclePorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_record::recorder::{RecordMeta, Recorder, RecorderOptions};
use frontseat_record::replay::{ReplayOptions, Speed, replay};
use serde_json::json;

use crate::inproc::node_status_channel;
use crate::report::{Figures, Row, fmt_count};

#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub rate_hz: u32,
    pub window: Duration,
}

const R1: &str = "recording: node_status at RATE msg/s to MCAP (zstd), recorder's CPU";
const R2: &str = "replay at --speed max into a subscriber";

/// Publishes `rate` node_status per second for `window`, in 10 ms batches; returns the process
/// CPU time spent and the wall time taken.
async fn publish_paced(bus: &Bus, plan: Plan) -> (Option<Duration>, Duration) {
    let per_tick = (plan.rate_hz / 100).max(1);
    let ticks = (plan.window.as_millis() / 10).max(1) as u64;
    let mut iv = tokio::time::interval(Duration::from_millis(10));
    iv.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Burst);
    let pid = std::process::id();
    let vehicle = BenchVehiclePorts::new(bus);
    let cpu0 = crate::procs::cpu_time(pid);
    let t0 = Instant::now();
    let mut n = 0u32;
    for _ in 0..ticks {
        iv.tick().await;
        for _ in 0..per_tick {
            n = n.wrapping_add(1);
            let mut m = NodeStatus {
                time: f64::from(n) / f64::from(plan.rate_hz),
                name: Some("bench".into()),
                ..Default::default()
            };
            m.global_fix.lat = 42.0 + f64::from(n % 1000) * 1e-6;
            m.global_fix.lon = -71.0;
            m.pose.heading = Some(f64::from(n % 360));
            vehicle.publish_node_status(m);
        }
    }
    let wall = t0.elapsed();
    let cpu = cpu0
        .zip(crate::procs::cpu_time(pid))
        .map(|(a, b)| b.saturating_sub(a));
    (cpu, wall)
}

pub async fn run(plan: Plan) -> Vec<Row> {
    let what = R1.replace("RATE", &fmt_count(f64::from(plan.rate_hz)));
    let path = std::env::temp_dir().join(format!("frontseat-bench-{}.mcap", std::process::id()));
    // Without the recorder: what publishing alone costs (a subscriber keeps the bus busy the
    // same way the recorder's subscription does, minus the recording).
    let base_bus = Bus::new();
    let (_s, mut rx) = node_status_channel(&base_bus, "bench", 1 << 20);
    let drain = tokio::spawn(async move { while rx.recv().await.is_some() {} });
    let (base_cpu, base_wall) = publish_paced(&base_bus, plan).await;
    drop(base_bus);
    drain.abort();

    let bus = Bus::new();
    let rec = match Recorder::start(&bus, RecorderOptions::file(&path), RecordMeta::default()) {
        Ok(r) => r,
        Err(e) => {
            return vec![
                Row::failed("R1", what, e.to_string()),
                Row::failed("R2", R2, "no recording"),
            ];
        }
    };
    let (cpu, wall) = publish_paced(&bus, plan).await;
    // The close (last chunk, summary) is part of the recorder's cost.
    let cpu0 = crate::procs::cpu_time(std::process::id());
    let stats = tokio::task::spawn_blocking(move || rec.stop())
        .await
        .unwrap_or_default();
    let close_cpu = cpu0
        .zip(crate::procs::cpu_time(std::process::id()))
        .map(|(a, b)| b.saturating_sub(a));
    let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let pct = |c: Duration, w: Duration| 100.0 * c.as_secs_f64() / w.as_secs_f64().max(1e-9);
    let r1 = match (cpu, base_cpu, close_cpu) {
        (Some(c), Some(b), Some(cl)) => {
            let with = pct(c + cl, wall);
            let without = pct(b, base_wall);
            let recorder = (with - without).max(0.0);
            Row {
                id: "R1",
                what,
                figures: Figures::Result(format!(
                    "recorder ≈ {recorder:.1} % of one core ({with:.1} % with, {without:.1} % without); {} msg/s written, {} B/s on disk, drops {}",
                    fmt_count(stats.written as f64 / wall.as_secs_f64().max(1e-9)),
                    fmt_count(bytes as f64 / wall.as_secs_f64().max(1e-9)),
                    stats.dropped(),
                )),
                detail: format!(
                    "{} messages over {:.1} s in 10 ms batches; process CPU from /proc (10 ms ticks), with minus without the recorder",
                    stats.received,
                    wall.as_secs_f64()
                ),
                extra: json!({
                    "rate_hz": plan.rate_hz,
                    "recorder_cpu_percent": recorder,
                    "cpu_percent_with": with,
                    "cpu_percent_without": without,
                    "written": stats.written,
                    "dropped": stats.dropped(),
                    "bytes": bytes,
                }),
            }
        }
        _ => Row::failed("R1", what, "CPU unknown (/proc/self/stat unreadable)"),
    };

    let bus = Bus::new();
    let (_s, mut rx) = node_status_channel(&bus, "helm", 1 << 22);
    let opts = ReplayOptions {
        speed: Speed::Max,
        ..Default::default()
    };
    let cpu0 = crate::procs::cpu_time(std::process::id());
    let t0 = Instant::now();
    let r = replay(&bus, &path, &opts).await;
    let took = t0.elapsed();
    // On a loaded machine the wall time includes time the replay waited for a core; the
    // process CPU time says what the replay itself costs.
    let replay_cpu = cpu0
        .zip(crate::procs::cpu_time(std::process::id()))
        .map(|(a, b)| b.saturating_sub(a));
    let mut got = 0u64;
    while rx.try_recv().is_ok() {
        got += 1;
    }
    let _ = std::fs::remove_file(&path);
    let r2 = match r {
        Ok(s) if s.published > 0 => {
            let speedup = wall.as_secs_f64() / took.as_secs_f64().max(1e-9);
            let per_cpu = replay_cpu.map(|c| s.published as f64 / c.as_secs_f64().max(1e-9));
            let cpu_text = match (replay_cpu, per_cpu) {
                (Some(c), Some(r)) => format!(
                    "; {:.2} s of process CPU over {:.2} s of wall time ({} msg per CPU-second, {:.0}× real time per CPU-second)",
                    c.as_secs_f64(),
                    took.as_secs_f64(),
                    fmt_count(r),
                    wall.as_secs_f64() / c.as_secs_f64().max(1e-9)
                ),
                _ => String::new(),
            };
            Row {
                id: "R2",
                what: R2.into(),
                figures: Figures::Result(format!(
                    "{} msg/s, {speedup:.0}× real time; {got} of {} received",
                    fmt_count(s.published as f64 / took.as_secs_f64().max(1e-9)),
                    s.published
                )),
                detail: format!(
                    "R1's file read back, decoded and published onto a bus with one subscriber{cpu_text}"
                ),
                extra: json!({
                    "published": s.published,
                    "received": got,
                    "msg_per_s": s.published as f64 / took.as_secs_f64().max(1e-9),
                    "times_real_time": speedup,
                    "cpu_s": replay_cpu.map(|c| c.as_secs_f64()),
                    "msg_per_cpu_s": per_cpu,
                }),
            }
        }
        Ok(_) => Row::failed("R2", R2, "nothing replayed"),
        Err(e) => Row::failed("R2", R2, e.to_string()),
    };
    vec![r1, r2]
}
