//! `[driver]`: which frontseat driver runs, and the config's one list of vehicles. Each built-in
//! vehicle's section is written in its own folder (`vehicles/<vehicle>/config.rs`, implementing
//! [`DriverSection`]); the list in `lib.rs` (`driver_sections!`, a line per vehicle) makes from it
//! the section's module, its `DriverConfig` field (doc comment = schema description), the
//! driver's name constant, `BUILT_IN_DRIVERS`, the defaults, the validation and the link the
//! start-up log names. Nothing else in the config names a vehicle but the default driver.

use crate::FieldError;
use crate::check::{Checker, at};

/// What the config needs of a vehicle's section beyond its serde shape.
pub(crate) trait DriverSection {
    /// Whether the section is validated when another driver is selected. Sections whose
    /// required fields have no sensible default (a serial port, a Remote Helm version) say no.
    const CHECKED_WHEN_NOT_SELECTED: bool;
    fn check(&self, prefix: &str, c: &mut Checker);
    /// Where this vehicle's driver talks to its vehicle, for the start-up log line.
    fn vehicle_link(&self) -> String;
}

/// Expands the list of vehicles (see `lib.rs`) into the `[driver]` section. Each entry: the
/// field's doc comment, `name: "path/to/config.rs" => Type, CONST;` where `name` is both the
/// driver's name and its section's key.
macro_rules! driver_sections {
    ($( $(#[doc = $doc:literal])* $field:ident: $path:literal => $ty:ident, $name:ident; )*) => {
        $(
            #[path = $path]
            mod $field;
            pub use $field::*;
        )*

        /// Which frontseat driver to run and its settings.
        #[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
        #[serde(deny_unknown_fields, default)]
        pub struct DriverConfig {
            /// Built-in driver to run when no library is given: "basic_simulator", "bluefin", "iver3",
            /// "waveglider_sv2", "ardupilot" or "dune".
            pub name: String,
            /// Path to a driver plugin (shared library) to load instead of a built-in driver;
            /// FRONTSEAT_DRIVER_LIBRARY in the environment does the same.
            #[serde(skip_serializing_if = "Option::is_none")]
            #[schemars(example = &"/usr/local/lib/frontseat/libmy_driver.so")]
            pub library: Option<String>,
            $( $(#[doc = $doc])* pub $field: $ty, )*
        }

        $(
            #[doc = concat!("Name of the built-in driver `", stringify!($field), "`.")]
            pub const $name: &str = stringify!($field);
        )*

        /// Every built-in driver.
        pub const BUILT_IN_DRIVERS: &[&str] = &[$($name),*];

        impl Default for DriverConfig {
            fn default() -> Self {
                Self {
                    name: BASIC_SIMULATOR.into(),
                    library: None,
                    $( $field: $ty::default(), )*
                }
            }
        }

        impl DriverConfig {
            /// The selected built-in driver's link (None: a plugin, or an unknown name).
            fn selected_link(&self) -> Option<String> {
                if self.library.is_some() {
                    return None;
                }
                match self.name.as_str() {
                    $( $name => Some($crate::drivers::DriverSection::vehicle_link(&self.$field)), )*
                    _ => None,
                }
            }

            fn check_sections(&self, prefix: &str, c: &mut $crate::check::Checker) {
                use $crate::drivers::DriverSection as _;
                $(
                    if <$ty as $crate::drivers::DriverSection>::CHECKED_WHEN_NOT_SELECTED
                        || (self.library.is_none() && self.name == $name)
                    {
                        self.$field.check(&$crate::check::at(prefix, stringify!($field)), c);
                    }
                )*
            }
        }
    };
}

impl crate::DriverConfig {
    /// Where the selected driver talks to its vehicle, for the start-up log line: an operator
    /// reading the journal must see the link that is actually in use, not the basic
    /// simulator's default address when another driver runs.
    pub fn vehicle_link(&self) -> String {
        match (&self.library, self.selected_link()) {
            (Some(lib), _) => format!("plugin {lib}"),
            (None, Some(link)) => link,
            // Refused by validation; the default driver's link is what would have been used.
            (None, None) => self.basic_simulator.vehicle_link(),
        }
    }

    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        match &self.library {
            Some(lib) => c.non_empty(&at(prefix, "library"), lib),
            None if !crate::BUILT_IN_DRIVERS.contains(&self.name.as_str()) => {
                c.push(FieldError::new(
                    at(prefix, "name"),
                    format!("{:?}", self.name),
                    format!(
                        "unknown built-in driver; the built-ins are {:?} (or set library)",
                        crate::BUILT_IN_DRIVERS
                    ),
                ))
            }
            None => {}
        }
        self.check_sections(prefix, c);
    }
}
