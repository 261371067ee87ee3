//! A vehicle's extension groups (`interface_yaml/vehicles/`) through the interface: toward the
//! vehicle gated by their kind (command, mode, data) on their Goby3 base fields and re-joined with
//! the vehicle's own fields; toward the helms their node_status through the navigation gate.

use std::sync::Arc;

use crate::bus::Envelope;
use crate::extensions::{Encoded, Kind as ExtensionKind, Spec as ExtensionSpec};
use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, InterfaceData, InterfaceState, NodeStatus,
};

use super::state::FsiState;

/// A vehicle extension the interface could not handle: our own bus encoded it (or our driver
/// did), so this is a bug, not vehicle input; logged all the same at a bounded rate (a line at
/// the 1st, 2nd, 4th, … drop).
fn extension_dropped(type_name: &str, why: &str) {
    static DROPPED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = DROPPED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
    if n.is_power_of_two() {
        tracing::warn!(
            target: super::LOG_TARGET,
            type_name,
            dropped_total = n,
            "vehicle extension dropped: {why}"
        );
    }
}

impl FsiState {
    /// A vehicle extension from a helm (`interface_yaml/vehicles/`), gated by its kind: a
    /// command as command_request, a mode request in listen or command, data as
    /// data_to_frontseat; what passes goes to the driver whole, tagged with its type.
    pub(super) fn handle_extension_to_frontseat(&mut self, env: Envelope<Encoded>) {
        let spec = env.msg.spec;
        // The lane's fence rides on to the driver with what passes (crate::setpoint_lane).
        let held = env.held();
        let passed = match spec.kind {
            ExtensionKind::Command => self.gate_extended(env),
            ExtensionKind::Mode => self.gate_mode_command(env),
            ExtensionKind::Data => {
                if self.listen_or_command() {
                    let meta = env.meta();
                    Some((env.msg.bytes.clone(), meta))
                } else {
                    self.counters.data_gated += 1;
                    tracing::debug!(
                        target: super::LOG_TARGET,
                        group = spec.group,
                        "{} data_to_frontseat dropped: not in listen or command",
                        spec.vehicle
                    );
                    None
                }
            }
            // Toward the helms: the interface publishes these, it never receives them.
            ExtensionKind::Navigation | ExtensionKind::NavigationCopy => None,
        };
        if let Some((bytes, meta)) = passed {
            let ext = crate::driver::DriverExtension {
                type_name: Some(spec.type_name.to_string()),
                value: Some(bytes),
                vehicle: Some(spec.vehicle.to_string()),
            };
            self.ports
                .publish_extension_to_frontseat_held(Arc::new(ext), meta, held);
        }
    }

    /// A vehicle-extended CommandRequest (Bluefin's field 1000, Iver3's 1001): the same gate,
    /// pending table and refusals as [`Self::handle_command`]; the request to forward whole
    /// (vehicle fields included, course made safe) to the driver, or None when it was refused.
    pub(super) fn gate_extended(
        &mut self,
        env: Envelope<Encoded>,
    ) -> Option<(Vec<u8>, crate::bus::PublishMeta)> {
        let base = self.extension_base(&env)?;
        self.gate_extended_base(env, base)
    }

    /// [`Self::gate_extended`] with the base already decoded from the mirror.
    pub(super) fn gate_extended_base(
        &mut self,
        env: Envelope<Encoded>,
        base: CommandRequest,
    ) -> Option<(Vec<u8>, crate::bus::PublishMeta)> {
        let state = self.sm.state();
        if !self.shutting_down && state == InterfaceState::InterfaceCommand {
            let spec = env.msg.spec;
            let mirror = env.msg.bytes.clone();
            // Its desired_course crosses the same safety envelope as any other setpoint.
            let checked = self.through_envelope(Envelope::rewrap(env, base))?;
            let joined = self.rejoin_or_log(spec, &*checked.msg, &mirror)?;
            if base.response_requested() {
                self.pending
                    .insert(base.request_id, self.now() + self.s.command_timeout);
            }
            return Some((joined, checked.meta()));
        }
        self.refuse_gated(&base, "command");
        None
    }

    /// A vehicle mode/arming request (the ArduPilot extension): GUIDED is how COMMAND is
    /// reached, so it passes in listen as well as command; a course riding along still needs
    /// command and the safety envelope, as everywhere.
    pub(super) fn gate_mode_command(
        &mut self,
        env: Envelope<Encoded>,
    ) -> Option<(Vec<u8>, crate::bus::PublishMeta)> {
        let base = self.extension_base(&env)?;
        if self.sm.state() == InterfaceState::InterfaceCommand || base.desired_course.is_some() {
            return self.gate_extended_base(env, base);
        }
        if self.listen_or_command() {
            if base.response_requested() {
                self.pending
                    .insert(base.request_id, self.now() + self.s.command_timeout);
            }
            let meta = env.meta();
            return Some((env.msg.bytes.clone(), meta));
        }
        self.refuse_gated(&base, "listen or command");
        None
    }

    /// The Goby3 CommandRequest inside a vehicle's command mirror (same field numbers). The
    /// bytes were encoded from a typed message on our own bus, so a failure is a bug: logged.
    pub(super) fn extension_base(&self, env: &Envelope<Encoded>) -> Option<CommandRequest> {
        match <CommandRequest as prost::Message>::decode(env.msg.bytes.as_slice()) {
            Ok(base) => Some(base),
            Err(e) => {
                extension_dropped(env.msg.spec.type_name, &e.to_string());
                None
            }
        }
    }

    /// The gated base re-joined with the vehicle's own fields of `mirror`.
    pub(super) fn rejoin_or_log<B: prost::Message>(
        &self,
        spec: &ExtensionSpec,
        base: &B,
        mirror: &[u8],
    ) -> Option<Vec<u8>> {
        match crate::extension::rejoin(base, mirror, spec.base_fields) {
            Ok(b) => Some(b),
            Err(e) => {
                extension_dropped(spec.type_name, &e.to_string());
                None
            }
        }
    }

    /// A vehicle extension's node_status through the navigation gate: completed when fit for a
    /// helm, removed otherwise (`count`: whether its refusals count, or are counted elsewhere).
    pub(super) fn gate_extension_nav(&mut self, ns: &mut Option<NodeStatus>, count: bool) {
        if let Some(n) = ns.as_mut() {
            if self.nav_fit_for_helm(n, count) {
                self.compute_missing(n);
            } else {
                *ns = None;
            }
        }
    }

    /// A driver's extended data (its type one of `interface_yaml/vehicles/`' groups toward the
    /// helms): its node_status crosses the navigation gate (counted unless the kind says it is a
    /// copy of navigation counted on data_from_frontseat), then it goes out on its group.
    pub(super) fn handle_extension_data(&mut self, env: Envelope<crate::driver::DriverExtension>) {
        let meta = env.meta();
        let Some(spec) = crate::extensions::to_helm(env.msg.type_name()) else {
            extension_dropped(
                env.msg.type_name(),
                "no vehicle group toward the helms has this type",
            );
            return;
        };
        let mirror = env.msg.value();
        let mut base = match <InterfaceData as prost::Message>::decode(mirror) {
            Ok(b) => b,
            Err(e) => return extension_dropped(spec.type_name, &e.to_string()),
        };
        self.gate_extension_nav(
            &mut base.node_status,
            spec.kind == ExtensionKind::Navigation,
        );
        let Some(joined) = self.rejoin_or_log(spec, &base, mirror) else {
            return;
        };
        if let Err(e) = self.ports.publish_encoded(spec.group, &joined, meta) {
            extension_dropped(spec.type_name, &e.to_string());
        }
    }
}
