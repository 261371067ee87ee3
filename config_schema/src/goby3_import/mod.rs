//! Goby3 `.pb.cfg` files as they are: a goby_frontseat_interface or goby_moos_gateway
//! configuration (protobuf text format) read with Goby3's own field names and types, and turned
//! into the equivalent TOML, one comment per field saying where it came from.
//!
//! The text is parsed against descriptors of Goby3's config messages (proto/goby3/, compiled by
//! build.rs), so a misspelt field or a wrong enum name is an error as it is in Goby3. Every field
//! the file sets is then either mapped to a TOML setting, or named in a note: ignored (a Goby3
//! feature with no counterpart that cannot change what reaches the vehicle, e.g. the ncurses log
//! GUI) or refused (a setting we cannot honour and must not pretend to). Nothing is dropped
//! silently: a field no rule takes becomes an "ignored" note by name.
//!
//! Running a .pb.cfg is importing it and loading the TOML text, so what `--import-goby3` prints
//! is exactly what runs.

mod ledger;
mod placeholder;
mod text;

use crate::{ConfigError, FieldError};
use ledger::Import;
pub use ledger::Note;
pub use placeholder::BANNER;
use prost_reflect::Value;
pub use text::{GATEWAY_MESSAGE, INTERFACE_MESSAGE, PARSE_ERROR_PREFIX, parse_text};

/// A .pb.cfg turned into TOML: the text (it loads as the equivalent config) and the fields that
/// have no setting of ours, named.
#[derive(Debug, Clone)]
pub struct Imported {
    pub toml: String,
    /// Set in the file, ignored here (no effect on what reaches the vehicle or the helm).
    pub ignored: Vec<Note>,
}

impl Imported {
    /// The ignored fields as warning lines (`--check` prints them, the service logs them).
    pub fn warnings(&self) -> Vec<String> {
        self.ignored
            .iter()
            .map(|n| format!("Goby3 field {} = {} ignored: {}", n.path, n.value, n.why))
            .collect()
    }
}

/// Whether `file` names a Goby3 protobuf-text config (`*.pb.cfg`, as Goby3's examples and
/// launch files name them) rather than TOML.
pub fn is_goby3_file(file: &str) -> bool {
    file.ends_with(".pb.cfg")
}

/// Goby3's driver library names (`FRONTSEAT_DRIVER_LIBRARY=libgoby_frontseat_bluefin.so.30`, as
/// a Goby3 unit file sets it) → our built-in driver of that vehicle. A path, a missing `lib`
/// prefix and any `.so[.N…]` suffix are accepted; None for any other library (a plugin of ours).
pub fn goby3_driver_for_library(library: &str) -> Option<&'static str> {
    let file = library.rsplit('/').next().unwrap_or(library);
    let file = file.strip_prefix("lib").unwrap_or(file);
    let stem = file.split(".so").next().unwrap_or(file);
    match stem {
        "goby_frontseat_basic_simulator" => Some(crate::BASIC_SIMULATOR),
        "goby_frontseat_bluefin" => Some(crate::BLUEFIN),
        "goby_frontseat_iver" => Some(crate::IVER3),
        "goby_frontseat_waveglider_sv2" => Some(crate::WAVEGLIDER_SV2),
        _ => None,
    }
}

const GLOG: &str = "Goby3's glog logger: our logs go to stderr through tracing (journald under \
                    systemd; RUST_LOG=debug for more)";
const ZMQ_TUNING: &str = "ZeroMQ tuning of Goby3's portal; ours has its own bounded queues";
const BLUEFIN_EXT: &str = "[goby.middleware.frontseat.protobuf.bluefin_config]";
const BASIC_EXT: &str = "[goby.middleware.frontseat.protobuf.basic_simulator_config]";
const IVER_EXT: &str = "[goby.middleware.frontseat.protobuf.iver_config]";
const SV2_EXT: &str = "[goby.middleware.frontseat.protobuf.waveglider_sv2_config]";
const MOOS_HELM_EXT: &str = "[goby.moos.protobuf.moos_helm]";

/// `app { }` and `interprocess { }`, shared by both applications. `goby3` is the TOML table the
/// gobyd settings go to. Returns the app warp factor when the file sets it.
fn import_app_and_interprocess(imp: &mut Import) -> Option<Value> {
    imp.map("app.name", "goby3", "app_name");
    imp.ignore_all("app.glog_config", GLOG);
    imp.ignore(
        "app.binary",
        "set by Goby3's configurator, not by users (cfg action NEVER)",
    );
    imp.ignore(
        "app.loop_frequency",
        "our services are event-driven; there is no loop() to pace",
    );
    imp.ignore_all(
        "app.health_cfg",
        "health is answered by our goby_coroner responder ([goby3] app_name)",
    );
    imp.ignore_all("app.tool_cfg", "set by Goby3's tools only");
    imp.ignore(
        "app.load_shared_library",
        "no DCCL/protobuf plugins are loaded: the frontseat messages are compiled in",
    );
    imp.ignore(
        "app.debug_cfg",
        "use `frontseat interface --import-goby3 FILE` to see the parsed config",
    );
    imp.ignore_all(
        "app.intervehicle_cfg",
        "no intervehicle (DCCL) layer in these services",
    );
    imp.ignore(
        "app.simulation.time.reference_microtime",
        "our sim clock warps from the process start",
    );
    imp.ignore(
        "app.simulation.time.use_sim_time",
        "the warp factor alone sets our simulated clock",
    );
    let warp = imp.take("app.simulation.time.warp_factor");
    // Goby3 always joins gobyd: so does an imported config.
    imp.set(
        "goby3",
        "enabled",
        toml::Value::Boolean(true),
        "Goby3 applications always join gobyd (interprocess)",
    );
    imp.map("interprocess.platform", "goby3", "platform");
    imp.map("interprocess.transport", "goby3", "transport");
    imp.map("interprocess.socket_name", "goby3", "socket_name");
    imp.map("interprocess.ipv4_address", "goby3", "ip_address");
    match imp.take("interprocess.ip_address") {
        Some(Value::String(s)) if s.is_empty() => imp.ignored.push(Note {
            path: "interprocess.ip_address".into(),
            value: "\"\"".into(),
            why: "empty: ipv4_address (or its default) is the manager's address".into(),
        }),
        Some(v) => {
            if let Ok(t) = imp.to_toml("interprocess.ip_address", &v) {
                imp.set("goby3", "ip_address", t, "interprocess.ip_address");
            }
        }
        None => {}
    }
    imp.map("interprocess.tcp_port", "goby3", "tcp_port");
    imp.map(
        "interprocess.manager_timeout_seconds",
        "goby3",
        "manager_timeout_seconds",
    );
    imp.map("interprocess.client_name", "goby3", "client_name");
    imp.ignore("interprocess.send_queue_size", ZMQ_TUNING);
    imp.ignore("interprocess.receive_queue_size", ZMQ_TUNING);
    imp.ignore("interprocess.zeromq_number_io_threads", ZMQ_TUNING);
    warp
}

/// `moos { }` / the moos_helm extension at `goby` → `[moos]`.
fn import_moos(imp: &mut Import, goby: &str) {
    if imp.take(goby).is_some() || imp.left.keys().any(|k| k.starts_with(&format!("{goby}."))) {
        // The block is present (even empty): the MOOS bridge runs, as in Goby3.
        if !imp.tables.iter().any(|(t, _)| t == "moos") {
            imp.tables.push(("moos".to_owned(), Vec::new()));
        }
    }
    imp.map(&format!("{goby}.server"), "moos", "server");
    imp.map(&format!("{goby}.port"), "moos", "port");
    let binary = format!("{goby}.use_binary_protobuf");
    if let Some(v) = imp.take(&binary) {
        if v == Value::Bool(false) {
            imp.ignored.push(Note {
                path: binary,
                value: "false".into(),
                why: "the default, which is what we speak".into(),
            });
        } else {
            imp.refuse(
                &binary,
                &v,
                "only the text technique is spoken to pHelmIvP (TECHNIQUE_PREFIXED_PROTOBUF_TEXT_FORMAT)"
                    .into(),
            );
        }
    }
    let technique = format!("{goby}.moos_parser_technique");
    if let Some(v) = imp.take(&technique) {
        let name = imp.text(&technique, &v);
        if name == "TECHNIQUE_PREFIXED_PROTOBUF_TEXT_FORMAT" {
            imp.ignored.push(Note {
                path: technique,
                value: name,
                why: "the default, which is what we speak".into(),
            });
        } else {
            imp.refuse(
                &technique,
                &v,
                "only TECHNIQUE_PREFIXED_PROTOBUF_TEXT_FORMAT (Goby3's default) is spoken".into(),
            );
        }
    }
}

/// Goby3's example configs print `""` for optional strings (`ntp_serial_port: ""`,
/// `extra_bplog: ""`); an empty one configures nothing, so it is named and left out rather than
/// becoming an empty serial port or an empty `$BPLOG,,ON`. Required strings stay, to be refused
/// by validation when empty.
fn drop_empty_strings(imp: &mut Import, prefix: &str) {
    const OPTIONAL: [&str; 3] = ["ntp_serial_port", "extra_bplog", "name"];
    let paths: Vec<String> = imp
        .left
        .keys()
        .filter(|k| k.starts_with(prefix))
        .filter(|k| OPTIONAL.iter().any(|o| k.ends_with(&format!(".{o}"))))
        .cloned()
        .collect();
    for p in paths {
        let empty = match imp.left.get(&p) {
            Some(Value::String(s)) => s.is_empty(),
            Some(Value::List(l)) => l.iter().all(|v| v.as_str() == Some("")),
            _ => false,
        };
        if empty {
            imp.ignore(&p, "empty: configures nothing, left out");
        }
    }
}

/// The basic simulator's `tcp_address: ""`, as Goby3's `-e` prints its required address: our
/// default, 127.0.0.1 (where `frontseat sim` listens; loopback, so nothing else is reached).
fn empty_sim_address(imp: &mut Import, ext_path: &str) {
    let path = format!("{ext_path}.tcp_address");
    if matches!(imp.left.get(&path), Some(Value::String(s)) if s.is_empty()) {
        imp.ignore(
            &path,
            "empty (Goby3's -e placeholder): frontseat's default 127.0.0.1, where `frontseat sim` \
             listens",
        );
    }
}

/// Whatever no rule placed: named, never dropped.
fn finish_unplaced(imp: &mut Import) {
    let rest: Vec<String> = imp.left.keys().cloned().collect();
    for p in rest {
        imp.ignore(&p, "no equivalent setting in frontseat");
    }
}

fn result(imp: Import, file: &str, header: &str) -> Result<Imported, ConfigError> {
    if !imp.refused.is_empty() {
        return Err(ConfigError::Invalid {
            file: file.to_owned(),
            errors: imp.refused,
        });
    }
    Ok(Imported {
        toml: imp.render(header),
        ignored: imp.ignored,
    })
}

fn header(kind: &str, file: &str) -> String {
    format!(
        "# frontseat {kind} config imported from the Goby3 config {file}\n\
         # Each setting names the Goby3 field it came from; fields with no setting here are\n\
         # listed at the end. Anything not set keeps its default (`frontseat {kind} --example_config`)."
    )
}

/// A goby_frontseat_interface .pb.cfg → the TOML of `frontseat interface`.
pub fn import_interface(text: &str, file: &str) -> Result<Imported, ConfigError> {
    let scanned = placeholder::scan(text);
    let msg = parse_text(INTERFACE_MESSAGE, &scanned.text, file)?;
    let mut imp = Import::new(&msg);
    note_banner(&mut imp, scanned.banner.as_deref());
    let app_warp = import_app_and_interprocess(&mut imp);

    let fs = "frontseat_cfg";
    imp.map(&format!("{fs}.name"), "", "name");
    imp.map(&format!("{fs}.type"), "", "type");
    for key in [
        "require_helm",
        "helm_running_timeout",
        "frontseat_connected_timeout",
        "status_period",
        "exit_on_error",
    ] {
        imp.map(&format!("{fs}.{key}"), "", key);
    }
    // One warp, as in Goby3 (app.simulation.time.warp_factor drives the interface's clock and
    // the MOOS side; sim_warp_factor what the basic simulator is told): two different values
    // cannot both hold here.
    let sim_warp = imp.take(&format!("{fs}.sim_warp_factor"));
    match (&app_warp, &sim_warp) {
        (Some(a), Some(s)) if a != s => {
            let why = format!(
                "differs from app.simulation.time.warp_factor = {}: frontseat runs the interface, \
                 the simulator and the MOOS side on one warp (sim_warp_factor); set them equal",
                imp.text("", a)
            );
            imp.refuse(&format!("{fs}.sim_warp_factor"), s, why);
        }
        (Some(w), also) => {
            let t = imp.to_toml("", w).unwrap_or(toml::Value::Integer(1));
            let from = if also.is_some() {
                format!("app.simulation.time.warp_factor and {fs}.sim_warp_factor")
            } else {
                "app.simulation.time.warp_factor".to_owned()
            };
            imp.set("", "sim_warp_factor", t, from);
        }
        (None, Some(w)) => {
            let t = imp.to_toml("", w).unwrap_or(toml::Value::Integer(1));
            imp.set("", "sim_warp_factor", t, format!("{fs}.sim_warp_factor"));
        }
        (None, None) => {}
    }

    // The datum: frontseat_cfg.origin, else app.geodesy (Goby3 apps take the datum from either).
    let geodesy = (
        imp.take("app.geodesy.lat_origin"),
        imp.take("app.geodesy.lon_origin"),
    );
    let has_origin = imp.left.contains_key(&format!("{fs}.origin.lat"));
    for key in ["lat", "lon", "depth"] {
        imp.map(&format!("{fs}.origin.{key}"), "origin", key);
    }
    let alt = format!("{fs}.origin.altitude");
    if let Some(v) = imp.take(&alt) {
        match v {
            // Goby3's default: unknown, which is ours when the key is left out.
            Value::F64(x) if x.is_nan() => imp.ignored.push(Note {
                path: alt.clone(),
                value: "nan".into(),
                why: "Goby3's \"unknown\", our default when origin.altitude is left out".into(),
            }),
            other => match imp.to_toml(&alt, &other) {
                Ok(t) => imp.set("origin", "altitude", t, alt.clone()),
                Err(why) => imp.refuse(&alt, &other, why),
            },
        }
    }
    if let (Some(lat), Some(lon)) = geodesy {
        for (key, v, path) in [
            ("lat", lat, "app.geodesy.lat_origin"),
            ("lon", lon, "app.geodesy.lon_origin"),
        ] {
            if has_origin {
                let ours = imp
                    .tables
                    .iter()
                    .find(|(t, _)| t == "origin")
                    .and_then(|(_, s)| s.iter().find(|s| s.key == key))
                    .map(|s| s.value.clone());
                let theirs = imp.to_toml(path, &v).ok();
                if ours != theirs {
                    imp.refuse(
                        path,
                        &v,
                        format!("differs from frontseat_cfg.origin.{key}: one datum per vehicle"),
                    );
                }
            } else {
                match imp.to_toml(path, &v) {
                    Ok(t) => imp.set("origin", key, t, path),
                    Err(why) => imp.refuse(path, &v, why),
                }
            }
        }
    }

    // The driver: its extension block names it (FRONTSEAT_DRIVER_LIBRARY may too, at start).
    let drivers = [
        (BLUEFIN_EXT, crate::BLUEFIN),
        (BASIC_EXT, crate::BASIC_SIMULATOR),
        (IVER_EXT, crate::IVER3),
        (SV2_EXT, crate::WAVEGLIDER_SV2),
    ];
    let mut named = Vec::new();
    for (ext, name) in drivers {
        let path = format!("{fs}.{ext}");
        if imp.take(&path).is_some() {
            named.push((path.clone(), name));
            drop_empty_strings(&mut imp, &path);
            if ext == BASIC_EXT {
                empty_sim_address(&mut imp, &path);
            }
            imp.map_same_names(&path, &format!("driver.{name}"));
        }
    }
    match named.as_slice() {
        [] => {}
        [(path, name)] => imp.set(
            "driver",
            "name",
            toml::Value::String((*name).to_owned()),
            format!("{path} is present"),
        ),
        many => {
            let list: Vec<&str> = many.iter().map(|(p, _)| p.as_str()).collect();
            imp.refused.push(FieldError::new(
                "(Goby3) frontseat_cfg",
                list.join(", "),
                "more than one driver's block: keep the one FRONTSEAT_DRIVER_LIBRARY loads",
            ));
        }
    }
    let driver = match named.as_slice() {
        [(path, name)] => Some((path.clone(), *name)),
        _ => None,
    };
    fill_interface_blanks(&mut imp, &scanned.blanks, driver, file)?;
    import_moos(&mut imp, MOOS_HELM_EXT);
    finish_unplaced(&mut imp);
    result(imp, file, &header("interface", file))
}

/// Goby3's line as it loads the driver library, when the file starts with it (a `-e` output
/// saved with stderr): named, skipped.
fn note_banner(imp: &mut Import, banner: Option<&str>) {
    if let Some(line) = banner {
        imp.ignored.push(Note {
            path: "(line 1)".into(),
            value: format!("{line:?}"),
            why: "what goby_frontseat_interface prints as it loads FRONTSEAT_DRIVER_LIBRARY, not \
                  config: skipped (the driver is the one its extension block names, or \
                  FRONTSEAT_DRIVER_LIBRARY's)"
                .into(),
        });
    }
}

/// Whether the file gives the datum's other coordinate than `key` (lat or lon).
fn half_datum(imp: &Import, key: &str) -> bool {
    let other = if key == "lat" { "lon" } else { "lat" };
    imp.tables.iter().any(|(t, s)| {
        t == "origin"
            && s.iter()
                .any(|s| s.key == other && s.from == format!("frontseat_cfg.origin.{other}"))
    })
}

/// A blank value that cannot be filled in safely: refused at its line and column.
fn blank_refused(file: &str, b: &placeholder::Blank, why: &str) -> ConfigError {
    ConfigError::Parse {
        file: file.to_owned(),
        line: b.line,
        column: b.column,
        message: format!(
            "{PARSE_ERROR_PREFIX}{} has no value (Goby3's -e placeholder for a value you give): \
             {why}",
            b.path
        ),
    }
}

/// Goby3's `-e` output leaves blank what the user must give. Only what frontseat can fill in
/// without risk to a vehicle is filled, each with a warning naming it; any other blank is refused
/// at its line and column, as Goby3 refuses the whole file:
/// - the datum (`frontseat_cfg.origin.lat/lon`): app.geodesy's when the file gives it; else,
///   for the basic simulator only, frontseat's default datum (the simulated world is placed
///   there, no vehicle moves); for a real vehicle refused, since every local x/y a helm steers
///   by is measured from it;
/// - the basic simulator's `start.lat/lon`: the datum (the simulated vehicle starts there);
/// - the basic simulator's `tcp_address: ""`: 127.0.0.1, where `frontseat sim` listens
///   (done with the empty strings, [`drop_empty_strings`]).
fn fill_interface_blanks(
    imp: &mut Import,
    blanks: &[placeholder::Blank],
    driver: Option<(String, &'static str)>,
    file: &str,
) -> Result<(), ConfigError> {
    let sim = driver
        .as_ref()
        .filter(|(_, name)| *name == crate::BASIC_SIMULATOR)
        .map(|(path, _)| path.clone());
    // app.geodesy has set the datum (it does when frontseat_cfg.origin gives none).
    let geodesy = imp
        .tables
        .iter()
        .any(|(t, s)| t == "origin" && s.iter().any(|s| s.from.starts_with("app.geodesy")));
    let datum = |imp: &Import, key: &str| -> toml::Value {
        imp.tables
            .iter()
            .find(|(t, _)| t == "origin")
            .and_then(|(_, s)| s.iter().find(|s| s.key == key))
            .map(|s| s.value.clone())
            .unwrap_or(toml::Value::Float(if key == "lat" {
                crate::DEFAULT_ORIGIN_LAT
            } else {
                crate::DEFAULT_ORIGIN_LON
            }))
    };
    // The datum first: the simulator's start follows it.
    let mut blanks: Vec<&placeholder::Blank> = blanks.iter().collect();
    blanks.sort_by_key(|b| !b.path.starts_with("frontseat_cfg.origin."));
    for b in blanks {
        let key = b.path.rsplit('.').next().unwrap_or_default();
        let origin = matches!(
            b.path.as_str(),
            "frontseat_cfg.origin.lat" | "frontseat_cfg.origin.lon"
        );
        let start = sim.as_ref().is_some_and(|p| {
            b.path == format!("{p}.start.lat") || b.path == format!("{p}.start.lon")
        });
        if origin && geodesy {
            imp.ignored.push(Note {
                path: b.path.clone(),
                value: "(blank)".into(),
                why: "Goby3's -e placeholder; the datum is app.geodesy's".into(),
            });
        } else if origin && half_datum(imp, key) {
            return Err(blank_refused(
                file,
                b,
                "the other coordinate of frontseat_cfg.origin is given: half a datum is not filled \
                 in from frontseat's default",
            ));
        } else if origin && sim.is_some() {
            let v = datum(imp, key);
            imp.set(
                "origin",
                key,
                v.clone(),
                format!(
                    "{} blank (Goby3's -e placeholder): frontseat's default datum, for the basic \
                     simulator only",
                    b.path
                ),
            );
            imp.ignored.push(Note {
                path: b.path.clone(),
                value: "(blank)".into(),
                why: format!(
                    "no datum given: the basic simulator's world is placed at frontseat's default \
                     datum ({key} = {v}); give frontseat_cfg.origin to place it elsewhere (a real \
                     vehicle's blank datum is refused)"
                ),
            });
        } else if origin {
            return Err(blank_refused(
                file,
                b,
                "a real vehicle's datum cannot be guessed: every local x/y a helm steers by is \
                 measured from it (give it here or in app.geodesy)",
            ));
        } else if start {
            let v = datum(imp, key);
            let table = format!("driver.{}.start", crate::BASIC_SIMULATOR);
            imp.set(
                &table,
                key,
                v.clone(),
                format!("{} blank (Goby3's -e placeholder): the datum", b.path),
            );
            imp.ignored.push(Note {
                path: b.path.clone(),
                value: "(blank)".into(),
                why: format!("the simulated vehicle starts at the datum ({key} = {v})"),
            });
        } else {
            return Err(blank_refused(
                file,
                b,
                "frontseat does not choose it for you; fill it in",
            ));
        }
    }
    Ok(())
}

/// A goby_moos_gateway .pb.cfg → the TOML of `frontseat moos-gateway` (reaching the interface
/// through gobyd, as Goby3's gateway does).
pub fn import_gateway(text: &str, file: &str) -> Result<Imported, ConfigError> {
    let scanned = placeholder::scan(text);
    let msg = parse_text(GATEWAY_MESSAGE, &scanned.text, file)?;
    if let Some(b) = scanned.blanks.first() {
        return Err(blank_refused(file, b, "fill it in"));
    }
    let mut imp = Import::new(&msg);
    note_banner(&mut imp, scanned.banner.as_deref());
    let warp = import_app_and_interprocess(&mut imp);
    // The gateway reaches the interface through gobyd alone, as Goby3's does.
    imp.set(
        "interprocess",
        "enabled",
        toml::Value::Boolean(false),
        "Goby3's gateway reaches the interface through gobyd only",
    );
    imp.tables.retain(|(t, _)| t != "moos");
    imp.tables.push(("moos".to_owned(), Vec::new()));
    import_moos(&mut imp, "moos");
    if let Some(w) = warp {
        match imp.to_toml("", &w) {
            Ok(t) => imp.set("moos", "time_warp", t, "app.simulation.time.warp_factor"),
            Err(why) => imp.refuse("app.simulation.time.warp_factor", &w, why),
        }
    }
    imp.ignore(
        "poll_frequency",
        "the bridge is event-driven: MOOS mail is handled as it arrives",
    );
    finish_unplaced(&mut imp);
    result(imp, file, &header("moos-gateway", file))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goby3_library_names_select_our_built_in_drivers() {
        for (lib, want) in [
            ("libgoby_frontseat_bluefin.so.30", Some("bluefin")),
            (
                "/usr/lib/x86_64-linux-gnu/libgoby_frontseat_iver.so.30",
                Some("iver3"),
            ),
            (
                "libgoby_frontseat_waveglider_sv2.so",
                Some("waveglider_sv2"),
            ),
            ("goby_frontseat_basic_simulator", Some("basic_simulator")),
            (
                "libgoby_frontseat_basic_simulator.so.30.1.2",
                Some("basic_simulator"),
            ),
            ("/opt/lib/libmy_driver.so", None),
            ("libgoby_frontseat_bluefinx.so", None),
            ("", None),
        ] {
            assert_eq!(goby3_driver_for_library(lib), want, "{lib}");
        }
    }
}
