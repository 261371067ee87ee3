//! OpenCPN's autopilot output read back (shared facts §5): RMB, RMC, APB and XTE, sent about once
//! a second while a route or "Navigate To Here" is active. What the helm needs is the active
//! leg: destination, bearing from the present position to it (true), range, cross-track error
//! and the arrival flag (RMB 13 / APB 6 = `A`, sent for one cycle before the next leg). A
//! magnetic APB (`UseMagAPB=1`) is not used: the bearing comes from RMB, which is always true.

use crate::nmea::{self, NmeaError, Sentence};

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AutopilotError {
    #[error(transparent)]
    Nmea(#[from] NmeaError),
    #[error("{kind} field {field} `{value}` is not valid")]
    Field {
        kind: &'static str,
        field: usize,
        value: String,
    },
    #[error("{0} has too few fields")]
    Short(&'static str),
    #[error("{0} status is V (void): OpenCPN has no valid fix or leg")]
    Void(&'static str),
    #[error("APB bearings are magnetic; the true bearing of RMB is used instead")]
    Magnetic,
}

/// One leg as a sentence tells it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Leg {
    pub origin_id: Option<String>,
    pub destination_id: String,
    pub destination: Option<(f64, f64)>,
    /// Degrees true, from the present position to the destination.
    pub bearing: f64,
    pub range_nm: Option<f64>,
    /// Negative: steer left.
    pub cross_track_nm: Option<f64>,
    pub arrived: bool,
}

/// What one sentence said.
#[derive(Debug, Clone, PartialEq)]
pub enum Said {
    /// RMB or APB: the active leg.
    Leg(Leg),
    /// XTE: the cross-track error alone.
    CrossTrack(f64),
    /// RMC: OpenCPN's own-ship fix (the one it steers from).
    Fix { lat: f64, lon: f64 },
    /// Another sentence (OpenCPN's multiplexer echoes inputs when no filter is set).
    Other,
}

fn field<'a>(s: &Sentence<'a>, i: usize, kind: &'static str) -> Result<&'a str, AutopilotError> {
    s.fields.get(i).copied().ok_or(AutopilotError::Short(kind))
}

fn number(s: &Sentence<'_>, i: usize, kind: &'static str) -> Result<f64, AutopilotError> {
    let v = field(s, i, kind)?;
    v.parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| AutopilotError::Field {
            kind,
            field: i + 1,
            value: v.chars().take(16).collect(),
        })
}

fn bearing(s: &Sentence<'_>, i: usize, kind: &'static str) -> Result<f64, AutopilotError> {
    let b = number(s, i, kind)?;
    if (0.0..=360.0).contains(&b) {
        Ok(b.rem_euclid(360.0))
    } else {
        Err(AutopilotError::Field {
            kind,
            field: i + 1,
            value: b.to_string(),
        })
    }
}

fn signed_xte(s: &Sentence<'_>, i: usize, kind: &'static str) -> Result<f64, AutopilotError> {
    let x = number(s, i, kind)?.abs();
    match field(s, i + 1, kind)? {
        "L" => Ok(-x),
        "R" | "" => Ok(x),
        v => Err(AutopilotError::Field {
            kind,
            field: i + 2,
            value: v.chars().take(4).collect(),
        }),
    }
}

/// `DDMM.mmm` (or `DDDMM.mmm`) and a hemisphere as decimal degrees.
fn angle(s: &Sentence<'_>, i: usize, kind: &'static str, max: f64) -> Result<f64, AutopilotError> {
    let raw = number(s, i, kind)?;
    let deg = (raw / 100.0).trunc();
    let v = deg + (raw - deg * 100.0) / 60.0;
    let sign = match field(s, i + 1, kind)? {
        "N" | "E" => 1.0,
        "S" | "W" => -1.0,
        v => {
            return Err(AutopilotError::Field {
                kind,
                field: i + 2,
                value: v.chars().take(4).collect(),
            });
        }
    };
    if !(0.0..=max).contains(&v) {
        return Err(AutopilotError::Field {
            kind,
            field: i + 1,
            value: raw.to_string(),
        });
    }
    Ok(sign * v)
}

fn id(v: &str) -> String {
    v.chars().take(32).collect()
}

/// Reads one line of OpenCPN's output; the checksum is required.
pub fn read(line: &str) -> Result<Said, AutopilotError> {
    let s = nmea::parse(line)?;
    match s.kind {
        "RMB" => {
            const K: &str = "RMB";
            if field(&s, 0, K)? != "A" {
                return Err(AutopilotError::Void(K));
            }
            let origin = field(&s, 3, K)?;
            Ok(Said::Leg(Leg {
                origin_id: (!origin.is_empty()).then(|| id(origin)),
                destination_id: id(field(&s, 4, K)?),
                destination: Some((angle(&s, 5, K, 90.0)?, angle(&s, 7, K, 180.0)?)),
                bearing: bearing(&s, 10, K)?,
                range_nm: Some(number(&s, 9, K)?.abs()),
                cross_track_nm: signed_xte(&s, 1, K).ok(),
                arrived: field(&s, 12, K)? == "A",
            }))
        }
        "APB" => {
            const K: &str = "APB";
            if field(&s, 0, K)? != "A" || field(&s, 1, K)? != "A" {
                return Err(AutopilotError::Void(K));
            }
            if field(&s, 11, K)? != "T" {
                return Err(AutopilotError::Magnetic);
            }
            Ok(Said::Leg(Leg {
                origin_id: None,
                destination_id: id(field(&s, 9, K)?),
                destination: None,
                bearing: bearing(&s, 10, K)?,
                range_nm: None,
                cross_track_nm: signed_xte(&s, 2, K).ok(),
                arrived: field(&s, 5, K)? == "A",
            }))
        }
        "XTE" => {
            const K: &str = "XTE";
            if field(&s, 0, K)? != "A" || field(&s, 1, K)? != "A" {
                return Err(AutopilotError::Void(K));
            }
            Ok(Said::CrossTrack(signed_xte(&s, 2, K)?))
        }
        "RMC" => {
            const K: &str = "RMC";
            if field(&s, 1, K)? != "A" {
                return Err(AutopilotError::Void(K));
            }
            Ok(Said::Fix {
                lat: angle(&s, 2, K, 90.0)?,
                lon: angle(&s, 4, K, 180.0)?,
            })
        }
        _ => Ok(Said::Other),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn captured_sentences_read() {
        let Said::Leg(l) =
            read("$ECRMB,A,0.004,L,WPA,WPB,4221.600,N,07105.100,W,0.014,19.026,23.846,A,A*7B")
                .unwrap()
        else {
            panic!()
        };
        assert_eq!(l.origin_id.as_deref(), Some("WPA"));
        assert_eq!(l.destination_id, "WPB");
        assert!(l.arrived);
        assert!((l.bearing - 19.026).abs() < 1e-9);
        let (lat, lon) = l.destination.unwrap();
        assert!((lat - 42.36).abs() < 1e-9 && (lon + 71.085).abs() < 1e-9);
        assert_eq!(l.cross_track_nm, Some(-0.004));
        let Said::Leg(l) =
            read("$ECRMB,A,0.000,R,,WPA,4221.300,N,07105.400,W,0.011,36.464,0.000,A,A*15").unwrap()
        else {
            panic!()
        };
        assert_eq!(l.origin_id, None);
        let Said::Leg(a) =
            read("$ECAPB,A,A,0.004,L,N,A,V,36.463,T,WPB,19.026,T,19.026,T*61").unwrap()
        else {
            panic!()
        };
        assert!(a.arrived && a.destination_id == "WPB");
        assert_eq!(
            read("$ECXTE,A,A,0.004,L,N*4B").unwrap(),
            Said::CrossTrack(-0.004)
        );
        // OpenCPN's 13-field RMC (one empty field too many when variation is unknown).
        assert!(matches!(
            read("$ECRMC,070716.00,A,4221.291,N,07105.402,W,0.000,0.000,281126,,,,A*72").unwrap(),
            Said::Fix { .. }
        ));
    }

    #[test]
    fn bad_input_is_refused_not_panicked() {
        assert!(matches!(
            read("$ECXTE,A,A,0.004,L,N*4C"),
            Err(AutopilotError::Nmea(_))
        ));
        let rmb = nmea::frame(
            '$',
            "ECRMB,A,0.0,R,,WPA,4221.300,N,07105.400,W,0.011,999,0.0,V,A",
        );
        assert!(matches!(read(&rmb), Err(AutopilotError::Field { .. })));
        let void = nmea::frame(
            '$',
            "ECRMB,V,0.0,R,,WPA,4221.300,N,07105.400,W,0.011,10,0.0,V,N",
        );
        assert_eq!(read(&void), Err(AutopilotError::Void("RMB")));
        let short = nmea::frame('$', "ECAPB,A,A");
        assert_eq!(read(&short), Err(AutopilotError::Short("APB")));
        let mag = nmea::frame(
            '$',
            "ECAPB,A,A,0.004,L,N,V,V,36.463,M,WPB,19.026,M,19.026,M",
        );
        assert_eq!(read(&mag), Err(AutopilotError::Magnetic));
        assert_eq!(read(&nmea::frame('$', "GPGGA,1")).unwrap(), Said::Other);
    }
}
