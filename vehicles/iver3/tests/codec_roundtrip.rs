//! Property test: every Remote Helm sentence formats to a line that parses back to itself.

use frontseat_iver3::codec::{Ack, Compass, Oms, Osi, Sentence};
use proptest::prelude::*;

/// Numbers on the grid a sentence field prints exactly.
fn tenths(lo: i64, hi: i64) -> impl Strategy<Value = f64> {
    (lo..hi).prop_map(|k| k as f64 / 10.0)
}

fn field() -> impl Strategy<Value = String> {
    "[A-Za-z0-9.]{0,8}"
}

fn sentence() -> impl Strategy<Value = Sentence> {
    prop_oneof![
        (any::<bool>(), any::<bool>(), any::<bool>(), any::<bool>()).prop_map(
            |(gps, compass, state, power)| Sentence::Osd {
                gps,
                compass,
                state,
                power
            }
        ),
        (
            tenths(0, 3600),
            tenths(0, 10_000),
            tenths(0, 900),
            tenths(0, 200),
            0u32..=120
        )
            .prop_map(|(heading, depth, max_pitch, speed_kn, timeout_s)| {
                Sentence::Oms(Oms {
                    heading,
                    depth,
                    max_pitch,
                    speed_kn,
                    timeout_s,
                })
            }),
        "[A-Za-z0-9._]{0,12}".prop_map(|mission| Sentence::OmStart { mission }),
        Just(Sentence::OmStop),
        (
            (field(), "[NSPMmAW]", field()),
            (-90_000_000i64..90_000_000, -180_000_000i64..180_000_000),
            (
                tenths(0, 200),
                tenths(0, 10_000),
                tenths(0, 3600),
                tenths(0, 10_000)
            ),
            (field(), field(), field(), field(), field(), field()),
        )
            .prop_map(|((fm, mode, wp), (la, lo), (spd, alt, hdg, dep), s)| {
                Sentence::Osi(Box::new(Osi {
                    fin_motor: fm,
                    mode,
                    next_wp: wp,
                    lat: la as f64 / 1e6,
                    lon: lo as f64 / 1e6,
                    speed_kn: spd,
                    dist_to_next: s.0,
                    error: s.1,
                    altimeter_ft: alt,
                    park_time: s.2,
                    mag_declination: s.3,
                    mission: s.4,
                    remaining_time: s.5,
                    heading: hdg,
                    depth_ft: dep,
                }))
            }),
        (
            tenths(0, 3600),
            (-9000i64..9000),
            (-18000i64..18000),
            tenths(-400, 400),
            tenths(0, 10_000)
        )
            .prop_map(|(heading, p, r, temperature, depth_ft)| {
                Sentence::Compass(Compass {
                    heading,
                    pitch: p as f64 / 100.0,
                    roll: r as f64 / 100.0,
                    temperature,
                    depth_ft,
                })
            }),
        (any::<u32>(), 0u32..=1, any::<u32>()).prop_map(|(msg_type, status, err)| {
            Sentence::Ack(Ack {
                msg_type,
                status,
                err,
            })
        }),
    ]
}

proptest! {
    #[test]
    fn every_iver_sentence_round_trips(s in sentence()) {
        let line = s.to_line();
        prop_assert_eq!(Sentence::parse(&line).unwrap(), s);
    }
}
