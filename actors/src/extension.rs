//! Vehicle extensions on the wire: a vehicle's mirror message is its Goby3 base message (the same
//! field numbers) plus the vehicle's own fields, so the interface gates any vehicle's extension by
//! decoding the base from the mirror's bytes, and re-joins the gated base with the vehicle's
//! fields without knowing their types. Which groups are extensions, and how each is gated, is
//! generated from `interface_yaml/vehicles/` (`crate::extensions`). Pure; bounded by the input.

use prost::Message;

/// Why a mirror's bytes could not be split.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SplitError {
    #[error("truncated field at byte {0}")]
    Truncated(usize),
    #[error("invalid field key at byte {0}")]
    BadKey(usize),
    #[error("unsupported wire type {wire_type} (field {field}) at byte {at}")]
    WireType {
        wire_type: u8,
        field: u32,
        at: usize,
    },
}

/// The encoded fields of `bytes` whose numbers are not in `base_fields`: the vehicle's own part
/// of a mirror message, byte for byte. Groups (wire types 3 and 4, not used by proto3 nor by any
/// Goby3 frontseat message) are refused rather than guessed.
pub fn vehicle_fields(bytes: &[u8], base_fields: &[u32]) -> Result<Vec<u8>, SplitError> {
    let mut out = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let start = at;
        let key = read_varint(bytes, &mut at).ok_or(SplitError::BadKey(start))?;
        let field = u32::try_from(key >> 3).map_err(|_| SplitError::BadKey(start))?;
        if field == 0 {
            return Err(SplitError::BadKey(start));
        }
        let wire_type = (key & 7) as u8;
        let len = match wire_type {
            0 => {
                read_varint(bytes, &mut at).ok_or(SplitError::Truncated(start))?;
                0
            }
            1 => 8,
            2 => {
                let n = read_varint(bytes, &mut at).ok_or(SplitError::Truncated(start))?;
                usize::try_from(n).map_err(|_| SplitError::Truncated(start))?
            }
            5 => 4,
            _ => {
                return Err(SplitError::WireType {
                    wire_type,
                    field,
                    at: start,
                });
            }
        };
        at = at
            .checked_add(len)
            .filter(|end| *end <= bytes.len())
            .ok_or(SplitError::Truncated(start))?;
        if !base_fields.contains(&field) {
            out.extend_from_slice(&bytes[start..at]);
        }
    }
    Ok(out)
}

fn read_varint(bytes: &[u8], at: &mut usize) -> Option<u64> {
    let mut value = 0u64;
    for shift in (0..64).step_by(7) {
        let b = *bytes.get(*at)?;
        *at += 1;
        value |= u64::from(b & 0x7f) << shift;
        if b & 0x80 == 0 {
            return Some(value);
        }
    }
    None
}

/// The mirror whose base part is `base` (as the gate left it) and whose vehicle part is that of
/// `mirror`: `base`'s encoding followed by the vehicle's fields (protobuf fields may come in any
/// order), so a course the safety envelope changed replaces the helm's, never merges with it.
pub fn rejoin<B: Message>(
    base: &B,
    mirror: &[u8],
    base_fields: &[u32],
) -> Result<Vec<u8>, SplitError> {
    let vehicle = vehicle_fields(mirror, base_fields)?;
    let mut out = base.encode_to_vec();
    out.extend_from_slice(&vehicle);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::frontseat::protobuf::{bluefin, iver};
    use crate::proto::goby::middleware::frontseat::protobuf::{
        BluefinExtraCommands, CommandRequest, DesiredCourse, InterfaceData, IverExtraCommands,
        IverState, NodeStatus, bluefin_extra_commands, iver_extra_commands,
    };

    const COMMAND_BASE: &[u32] = &[1, 10, 11, 20];

    fn bluefin_request() -> bluefin::CommandRequest {
        bluefin::CommandRequest {
            desired_course: Some(DesiredCourse {
                time: 1.0,
                heading: Some(90.0),
                speed: Some(9.0),
                depth: Some(300.0),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(7),
            cancel_request_id: None,
            bluefin_command: Some(BluefinExtraCommands {
                command: Some(bluefin_extra_commands::BluefinCommand::BuoyancyAdjust as i32),
                ..Default::default()
            }),
        }
    }

    #[test]
    fn a_gated_course_replaces_the_helms_and_the_vehicle_part_survives() {
        let helm = bluefin_request();
        let bytes = helm.encode_to_vec();
        let mut base = CommandRequest::decode(bytes.as_slice()).unwrap();
        // What the safety envelope does: a course outside the limits is clamped; depth dropped.
        base.desired_course = Some(DesiredCourse {
            time: 1.0,
            heading: Some(90.0),
            speed: Some(2.0),
            ..Default::default()
        });
        let joined = rejoin(&base, &bytes, COMMAND_BASE).unwrap();
        let back = bluefin::CommandRequest::decode(joined.as_slice()).unwrap();
        assert_eq!(back.desired_course, base.desired_course);
        assert_eq!(
            back.desired_course.unwrap().depth,
            None,
            "merged, not replaced"
        );
        assert_eq!(back.bluefin_command, helm.bluefin_command);
        assert_eq!(back.request_id, Some(7));
    }

    #[test]
    fn no_vehicle_field_leaves_only_the_base() {
        let helm = iver::CommandRequest {
            request_id: Some(3),
            ..Default::default()
        };
        let bytes = helm.encode_to_vec();
        assert!(vehicle_fields(&bytes, COMMAND_BASE).unwrap().is_empty());
        let with = iver::CommandRequest {
            iver_command: Some(IverExtraCommands {
                command: Some(iver_extra_commands::IverCommand::StartMission as i32),
                mission: Some("survey.mis".into()),
            }),
            ..helm
        };
        let fields = vehicle_fields(&with.encode_to_vec(), COMMAND_BASE).unwrap();
        let only = iver::CommandRequest::decode(fields.as_slice()).unwrap();
        assert_eq!(only.iver_command, with.iver_command);
        assert_eq!(only.request_id, None);
    }

    #[test]
    fn navigation_is_replaced_and_the_vehicle_state_kept() {
        let data = iver::InterfaceData {
            node_status: Some(NodeStatus {
                name: Some("helm-said".into()),
                ..Default::default()
            }),
            iver_state: Some(IverState { mode: Some(3) }),
            ..Default::default()
        };
        let bytes = data.encode_to_vec();
        let gated = InterfaceData::default();
        let joined = rejoin(&gated, &bytes, &[1, 2, 3]).unwrap();
        let back = iver::InterfaceData::decode(joined.as_slice()).unwrap();
        assert_eq!(back.node_status, None);
        assert_eq!(back.iver_state, data.iver_state);
    }

    #[test]
    fn bad_bytes_are_typed_errors() {
        assert_eq!(vehicle_fields(&[0x0a], &[]), Err(SplitError::Truncated(0)));
        assert_eq!(
            vehicle_fields(&[0x0a, 5, 1], &[]),
            Err(SplitError::Truncated(0))
        );
        assert_eq!(vehicle_fields(&[0x00], &[]), Err(SplitError::BadKey(0)));
        assert_eq!(vehicle_fields(&[0xff; 11], &[]), Err(SplitError::BadKey(0)));
        assert!(matches!(
            vehicle_fields(&[0x0b], &[]),
            Err(SplitError::WireType { wire_type: 3, .. })
        ));
        // A fixed64 that ends early, a varint that never ends.
        assert_eq!(
            vehicle_fields(&[0x09, 1, 2], &[]),
            Err(SplitError::Truncated(0))
        );
        assert_eq!(
            vehicle_fields(&[0x08, 0x80], &[]),
            Err(SplitError::Truncated(0))
        );
    }

    #[test]
    fn arbitrary_bytes_never_panic_and_never_grow() {
        // A small deterministic generator (seeds 1..=4): the split is bounded by its input.
        for seed in 1u64..=4 {
            let mut x = seed;
            for len in 0..200usize {
                let bytes: Vec<u8> = (0..len)
                    .map(|_| {
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        x as u8
                    })
                    .collect();
                if let Ok(v) = vehicle_fields(&bytes, &[1]) {
                    assert!(v.len() <= bytes.len());
                }
            }
        }
    }
}
