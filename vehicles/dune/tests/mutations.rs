//! A property test: imcpy's packets mutated at random (bit flips, cuts, splices, repeated
//! bytes), whole and split at random points, through the deframer, the decoder and the driver.
//! Nothing panics, nothing is buffered beyond the bound, every published fix is finite and inside
//! the globe, and the driver writes nothing that steers (it is never in COMMAND here: at most the
//! MANDONE + STOP that end a plan of ours it finds running).
//! Seed: `DUNE_MUTATION_SEED` (a number), else a fixed one; the seed is printed.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent, RecordingSink};
use frontseat_actors::link::LineWriter;
use frontseat_config::InterfaceConfig;
use frontseat_dune::imc::{self, Deframer, MAX_FRAME};
use frontseat_dune::{DuneDriver, Settings};

const FIXTURE: &str = include_str!("../fixtures/imcpy_packets.hex");

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn packets() -> Vec<Vec<u8>> {
    FIXTURE
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| l.split_once(' '))
        .map(|(_, h)| {
            (0..h.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&h[i..i + 2], 16).unwrap())
                .collect()
        })
        .collect()
}

#[test]
fn mutated_imcpy_packets_never_panic_and_never_steer() {
    let seed: u64 = std::env::var("DUNE_MUTATION_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5EED_D0E5);
    println!("DUNE_MUTATION_SEED={seed}");
    let mut rng = Rng(seed | 1);
    let base = packets();
    let mut cfg = InterfaceConfig::default();
    cfg.driver.dune.vehicle_imc_id = 0x00D1;
    let mut driver = DuneDriver::new(Settings::from_config(&cfg));
    let mut sink = RecordingSink::default();
    let (w, mut rx) = LineWriter::for_test();
    driver.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
    let mut deframer = Deframer::new();
    let mut now = Duration::ZERO;
    let mut frames = 0usize;
    for _ in 0..3000 {
        let mut stream = Vec::new();
        for _ in 0..1 + rng.below(4) {
            let mut p = base[rng.below(base.len())].clone();
            match rng.below(6) {
                0 => {
                    let i = rng.below(p.len());
                    p[i] ^= 1 << rng.below(8);
                }
                1 => p.truncate(rng.below(p.len())),
                2 => {
                    let i = rng.below(p.len());
                    let other = &base[rng.below(base.len())];
                    p.extend_from_slice(&other[..rng.below(other.len())]);
                    p.rotate_left(i);
                }
                3 => {
                    let b = (rng.next() & 0xFF) as u8;
                    p.extend(std::iter::repeat_n(b, rng.below(300)));
                }
                4 => {
                    // A random field value with a valid CRC: only the decoder's checks stand.
                    let n = p.len();
                    if n > 22 {
                        let i = 20 + rng.below(n - 22);
                        p[i] = (rng.next() & 0xFF) as u8;
                        let crc = imc::crc16(&p[..n - 2]).to_le_bytes();
                        p[n - 2..].copy_from_slice(&crc);
                    }
                }
                _ => {}
            }
            stream.extend(p);
        }
        let mut rest = &stream[..];
        while !rest.is_empty() {
            let cut = 1 + rng.below(rest.len());
            let (chunk, tail) = rest.split_at(cut);
            rest = tail;
            let mut out = Vec::new();
            deframer.feed(chunk, &mut |r| out.push(r));
            assert!(deframer.buffered() <= MAX_FRAME);
            for r in out {
                now += Duration::from_millis(10);
                let ev = match r {
                    Ok(f) => {
                        frames += 1;
                        DriverIoEvent::Frame(f)
                    }
                    Err(e) => DriverIoEvent::BadInput(e.to_string()),
                };
                driver.handle_io(ev, now, &mut sink);
            }
            driver.do_loop(now, &mut sink);
        }
    }
    for d in &sink.data {
        let g = &d.node_status.as_ref().unwrap().global_fix;
        assert!(g.lat.is_finite() && g.lat.abs() <= 90.0, "{g:?}");
        assert!(g.lon.is_finite() && g.lon.abs() <= 180.0, "{g:?}");
    }
    // Outside COMMAND the driver may only end a plan of ours it finds running (MANDONE, STOP).
    while let Ok(b) = rx.try_recv() {
        let (_, m) = imc::decode(&b).expect("the driver writes whole packets");
        assert!(ending_only(&m), "the driver wrote {m:?} outside COMMAND");
    }
    assert!(sink.responses.is_empty());
    assert!(frames > 1000, "only {frames} frames survived the mutations");
    println!(
        "{frames} frames, {} NodeStatus, counters {:?}",
        sink.data.len(),
        driver.counters
    );
}

fn ending_only(m: &imc::Message) -> bool {
    use frontseat_dune::imc::{Message, consts};
    match m {
        Message::Reference(r) => r.flags == consts::reference::MANDONE,
        Message::PlanControl(p) => p.op == consts::plan_control::STOP,
        _ => false,
    }
}
