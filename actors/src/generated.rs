//! The interface compiler's output (codegen/, run by build.rs from `interface_yaml/`): `proto` (the
//! prost messages), `groups` (one typed constant per group), `extensions` (each vehicle's
//! extension groups and how they are gated, from `interface_yaml/vehicles/`), `ports` (per actor: its publish
//! methods and its inbox), the gateway's type-erased helpers for interprocess groups, and
//! `RESOLVED_INTERFACES_YAML`. Edit the yaml or the .proto files and rebuild; never this output.

// The generated wiring is clippy-clean; only prost's `proto` module allows lints, inside the file.
mod out {
    include!(concat!(env!("OUT_DIR"), "/frontseat_interfaces.rs"));
}

pub use out::{
    EncodedEnvelope, EncodedError, RESOLVED_INTERFACES_YAML, extensions, groups,
    interprocess_publish_encoded, interprocess_subscribe_encoded, ports, proto, subscribe_encoded,
};
