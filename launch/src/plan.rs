//! From a launch file to the ordered list of processes to start: stages in order, one interface
//! per vehicle (its config generated from the template and the vehicle's values, and validated
//! as `frontseat interface --check` would), per-vehicle processes expanded, and processes whose
//! programs are missing from PATH skipped. No process is started here; `--check` runs all of it.
//! The launch file's `[record]` is written into each templated vehicle's config here, its files
//! set apart by the vehicle's name.

use std::path::{Path, PathBuf};

use frontseat_config::{InterfaceConfig, RecordConfig};

use crate::config::{LaunchConfig, ProcessEntry, ReadyConfig, Stage, VehicleEntry};
use crate::ports::{self, Binding};
pub use crate::spec::ProcSpec;

/// A generated interface config to write before the processes start.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedConfig {
    pub path: PathBuf,
    pub text: String,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plan {
    pub processes: Vec<ProcSpec>,
    pub configs: Vec<GeneratedConfig>,
    /// Why a listed process is not started (a program it needs is not on PATH).
    pub skipped: Vec<String>,
    /// Where each recording vehicle writes: `(vehicle, where)`.
    pub records: Vec<(String, String)>,
    /// What the user should know (a vehicle's own `[record]` winning over the launch file's).
    pub warnings: Vec<String>,
    /// Every address the processes will bind, in start order ([`crate::ports`]).
    pub bindings: Vec<Binding>,
}

#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("vehicle {vehicle}: {source}")]
    Interface {
        vehicle: String,
        #[source]
        source: frontseat_config::ConfigError,
    },
    #[error("vehicle {vehicle}: set.{key}: {why}")]
    Set {
        vehicle: String,
        key: String,
        why: String,
    },
    #[error("template {file}: {why}")]
    Template { file: String, why: String },
    /// Two processes would bind one port: the second would fail at run time.
    #[error(
        "port {port} ({proto}) is bound by both {} ({}) and {} ({}): give each its own port",
        first.owner, first.what, second.owner, second.what
    )]
    PortClash {
        port: u16,
        proto: crate::ports::Proto,
        first: Box<Binding>,
        second: Box<Binding>,
    },
}

fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// `value` at the dotted `path` of `table`, creating the tables on the way.
fn set_path(table: &mut toml::Table, path: &str, value: toml::Value) -> Result<(), String> {
    let mut parts = path.split('.').peekable();
    let mut t = table;
    while let Some(part) = parts.next() {
        if part.is_empty() {
            return Err("an empty key in the path".into());
        }
        if parts.peek().is_none() {
            t.insert(part.to_string(), value);
            return Ok(());
        }
        let next = t
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = match next {
            toml::Value::Table(inner) => inner,
            _ => return Err(format!("`{part}` is a value, not a table")),
        };
    }
    Err("an empty path".into())
}

/// The launch file's `[record]` for `vehicle`: its files apart from every other vehicle's, and
/// relative paths taken from the launch file's directory.
pub fn vehicle_record(r: &RecordConfig, base: &Path, vehicle: &str) -> RecordConfig {
    let mut r = r.clone();
    let dir = if r.dir.contains("{vehicle}") {
        PathBuf::from(r.dir.replace("{vehicle}", vehicle))
    } else {
        Path::new(&r.dir).join(vehicle)
    };
    r.dir = resolve(base, &dir.to_string_lossy()).display().to_string();
    if let Some(p) = &r.path {
        let p = if p.contains("{vehicle}") {
            PathBuf::from(p.replace("{vehicle}", vehicle))
        } else {
            let p = Path::new(p);
            let stem = p
                .file_stem()
                .map(|s| s.to_string_lossy())
                .unwrap_or_default();
            let name = match p.extension() {
                Some(ext) => format!("{stem}-{vehicle}.{}", ext.to_string_lossy()),
                None => format!("{stem}-{vehicle}"),
            };
            p.with_file_name(name)
        };
        r.path = Some(resolve(base, &p.to_string_lossy()).display().to_string());
    }
    r
}

/// Where a vehicle's `[record]` writes, as `--check` shows it.
fn record_target(r: &RecordConfig, vehicle: &str) -> String {
    match &r.path {
        Some(p) => p.clone(),
        None => {
            // As the recorder names its files (frontseat-record, RecorderOptions::from_config).
            let prefix: String = vehicle
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' {
                        c
                    } else {
                        '-'
                    }
                })
                .collect();
            format!(
                "{}/{prefix}_<UTC start>_<seq>.mcap (rotated: {} MiB / {} s; budget {} MiB)",
                r.dir.trim_end_matches('/'),
                r.rotate_mb,
                r.rotate_s,
                r.budget_mb
            )
        }
    }
}

fn json_to_toml(v: &serde_json::Value) -> Result<toml::Value, String> {
    toml::Value::try_from(v).map_err(|e| format!("not a TOML value: {e}"))
}

/// The interface config of a templated vehicle, as TOML text that passes validation.
pub fn vehicle_config(
    template: &toml::Table,
    v: &VehicleEntry,
    label: &str,
) -> Result<String, PlanError> {
    let mut t = template.clone();
    let set_err = |key: &str, why: String| PlanError::Set {
        vehicle: v.name.clone(),
        key: key.to_string(),
        why,
    };
    let mut put = |key: &str, value: toml::Value| {
        set_path(&mut t, key, value).map_err(|why| set_err(key, why))
    };
    put("name", v.name.clone().into())?;
    if let Some(d) = v.datum {
        put("origin.lat", d.lat.into())?;
        put("origin.lon", d.lon.into())?;
    }
    if let Some(s) = v.start {
        put("driver.basic_simulator.start.lat", s.lat.into())?;
        put("driver.basic_simulator.start.lon", s.lon.into())?;
    }
    if let Some(port) = v.sim_port {
        put("driver.basic_simulator.tcp_port", i64::from(port).into())?;
    }
    let list = |l: &[String]| toml::Value::Array(l.iter().cloned().map(Into::into).collect());
    if !v.zenoh_listen.is_empty() {
        put("interprocess.listen", list(&v.zenoh_listen))?;
    }
    if !v.zenoh_connect.is_empty() {
        put("interprocess.connect", list(&v.zenoh_connect))?;
    }
    if let Some(w) = &v.web_listen {
        put("web.enabled", true.into())?;
        put("web.listen", w.clone().into())?;
    }
    for (key, value) in &v.set {
        let value = json_to_toml(value).map_err(|why| set_err(key, why))?;
        put(key, value)?;
    }
    let text = toml::to_string(&t).map_err(|e| set_err("", e.to_string()))?;
    frontseat_config::parse::<InterfaceConfig>(&text, label).map_err(|source| {
        PlanError::Interface {
            vehicle: v.name.clone(),
            source,
        }
    })?;
    Ok(text)
}

/// The template every vehicle without a config of its own starts from.
pub fn load_template(cfg: &LaunchConfig, base: &Path) -> Result<toml::Table, PlanError> {
    if cfg.vehicles.template.is_empty() {
        let mut t = toml::Table::new();
        // A fleet talks over Zenoh: without a template, every interface exports its groups.
        let _ = set_path(&mut t, "interprocess.enabled", true.into());
        return Ok(t);
    }
    let path = resolve(base, &cfg.vehicles.template);
    let file = path.display().to_string();
    let meta = std::fs::metadata(&path).map_err(|e| PlanError::Template {
        file: file.clone(),
        why: e.to_string(),
    })?;
    if meta.len() > frontseat_config::MAX_FILE_BYTES {
        return Err(PlanError::Template {
            file,
            why: "too large for a config file".into(),
        });
    }
    let text = std::fs::read_to_string(&path).map_err(|e| PlanError::Template {
        file: file.clone(),
        why: e.to_string(),
    })?;
    text.parse::<toml::Table>()
        .map_err(|e| PlanError::Template {
            file,
            why: e.message().to_string(),
        })
}

fn substitute(s: &str, vehicle: &str, index: usize) -> String {
    s.replace("{vehicle}", vehicle)
        .replace("{index}", &index.to_string())
}

/// The launch file as processes in start order. `frontseat` is the binary a `frontseat`
/// command runs; `on_path` says whether a program can be found.
pub fn plan(
    cfg: &LaunchConfig,
    base: &Path,
    run_dir: &Path,
    frontseat: &Path,
    on_path: impl Fn(&str) -> bool,
) -> Result<Plan, PlanError> {
    let mut out = Plan::default();
    let template = load_template(cfg, base)?;
    let program = |p: &str| -> PathBuf {
        if p == "frontseat" {
            frontseat.to_path_buf()
        } else {
            PathBuf::from(p)
        }
    };
    let push_process = |out: &mut Plan, p: &ProcessEntry, vehicle: Option<(&str, usize)>| {
        let sub = |s: &str| match vehicle {
            Some((v, i)) => substitute(s, v, i),
            None => s.to_string(),
        };
        let name = match vehicle {
            Some((v, _)) => format!("{}-{v}", p.name),
            None => p.name.clone(),
        };
        if let Some(missing) = p.when_on_path.iter().find(|prog| !on_path(prog)) {
            out.skipped.push(format!(
                "{name}: skipped, `{missing}` is not on PATH (when_on_path)"
            ));
            return;
        }
        let Some((first, rest)) = p.command.split_first() else {
            return;
        };
        out.processes.push(ProcSpec {
            index: out.processes.len(),
            name,
            program: program(&sub(first)),
            args: rest.iter().map(|a| sub(a)).collect(),
            env: p.env.iter().map(|(k, v)| (k.clone(), sub(v))).collect(),
            cwd: if p.cwd.is_empty() {
                base.to_path_buf()
            } else {
                resolve(base, &sub(&p.cwd))
            },
            ready: ReadyConfig {
                address: sub(&p.ready.address),
                line: sub(&p.ready.line),
                ..p.ready.clone()
            },
            restart: p.restart.clone(),
        });
        if let Some(spec) = out.processes.last() {
            ports::of_process(spec, frontseat, &mut out.bindings);
        }
    };
    for p in cfg
        .process
        .iter()
        .filter(|p| p.stage == Stage::BeforeVehicles)
    {
        push_process(&mut out, p, None);
    }
    let launch_records = cfg.record.enabled;
    for (i, v) in cfg.vehicle.iter().enumerate() {
        let interface_err = |source| PlanError::Interface {
            vehicle: v.name.clone(),
            source,
        };
        let (config_path, ic) = if v.config.is_empty() {
            let path = run_dir.join(format!("interface-{}.toml", v.name));
            let label = format!("vehicle {} (template + its values)", v.name);
            // The vehicle's own [record] (template or `set`) is the more specific: it wins.
            let own = template.contains_key("record")
                || v.set
                    .keys()
                    .any(|k| k == "record" || k.starts_with("record."));
            let mut t = template.clone();
            if launch_records && own {
                out.warnings.push(format!(
                    "vehicle {}: its own [record] (template or set) wins; the launch file's [record] is not applied to it",
                    v.name
                ));
            } else if launch_records {
                let r = vehicle_record(&cfg.record, base, &v.name);
                let value = toml::Value::try_from(&r).map_err(|e| PlanError::Set {
                    vehicle: v.name.clone(),
                    key: "record".into(),
                    why: e.to_string(),
                })?;
                t.insert("record".into(), value);
            }
            let text = vehicle_config(&t, v, &label)?;
            let ic =
                frontseat_config::parse::<InterfaceConfig>(&text, &label).map_err(interface_err)?;
            out.configs.push(GeneratedConfig {
                path: path.clone(),
                text,
            });
            (path, ic)
        } else {
            let path = resolve(base, &v.config);
            let ic = frontseat_config::load::<InterfaceConfig>(&path).map_err(interface_err)?;
            if launch_records {
                out.warnings.push(format!(
                    "vehicle {}: it has its own config ({}); its [record] is used, the launch file's is not applied to it",
                    v.name,
                    path.display()
                ));
            }
            (path, ic)
        };
        if ic.record.enabled {
            out.records
                .push((v.name.clone(), record_target(&ic.record, &v.name)));
        }
        ports::of_interface(&ic, &format!("vehicle {}", v.name), &mut out.bindings);
        out.processes.push(ProcSpec {
            index: out.processes.len(),
            name: format!("interface-{}", v.name),
            program: frontseat.to_path_buf(),
            args: vec![
                "interface".into(),
                "-c".into(),
                config_path.display().to_string(),
            ],
            env: Vec::new(),
            cwd: base.to_path_buf(),
            ready: cfg.vehicles.ready.clone(),
            restart: cfg.vehicles.restart.clone(),
        });
        for p in cfg.process.iter().filter(|p| p.stage == Stage::PerVehicle) {
            push_process(&mut out, p, Some((&v.name, i)));
        }
    }
    for p in cfg
        .process
        .iter()
        .filter(|p| p.stage == Stage::AfterVehicles)
    {
        push_process(&mut out, p, None);
    }
    if let Some((first, second)) = ports::first_clash(&out.bindings) {
        return Err(PlanError::PortClash {
            port: second.port,
            proto: second.proto,
            first: Box::new(first.clone()),
            second: Box::new(second.clone()),
        });
    }
    Ok(out)
}

/// Whether `program` can be run: a path that exists, or a name found in PATH.
pub fn on_path(program: &str) -> bool {
    if program.contains('/') {
        return Path::new(program).is_file();
    }
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{LatLon, VehicleEntry};

    fn parse(text: &str) -> LaunchConfig {
        frontseat_config::parse::<LaunchConfig>(text, "t.toml").unwrap()
    }

    #[test]
    fn stages_start_in_order_with_per_vehicle_processes_after_their_interface() {
        let cfg = parse(
            r#"
            [[process]]
            name = "topside"
            command = ["frontseat", "topside"]
            stage = "after_vehicles"
            [[process]]
            name = "helm"
            command = ["helm", "--platform", "{vehicle}", "--n", "{index}"]
            stage = "per_vehicle"
            [[process]]
            name = "sim"
            command = ["frontseat", "sim"]
            [[vehicle]]
            name = "a"
            zenoh_listen = ["tcp/127.0.0.1:7448"]
            [[vehicle]]
            name = "b"
            zenoh_listen = ["tcp/127.0.0.1:7449"]
            "#,
        );
        let p = plan(
            &cfg,
            Path::new("/base"),
            Path::new("/run"),
            Path::new("/bin/fs"),
            |_| true,
        )
        .unwrap();
        let names: Vec<&str> = p.processes.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "sim",
                "interface-a",
                "helm-a",
                "interface-b",
                "helm-b",
                "topside"
            ]
        );
        assert_eq!(p.processes[0].program, Path::new("/bin/fs"));
        assert_eq!(p.processes[4].args, ["--platform", "b", "--n", "1"]);
        assert_eq!(
            p.processes[3].args,
            ["interface", "-c", "/run/interface-b.toml"]
        );
        assert!(p.processes.iter().enumerate().all(|(i, s)| s.index == i));
        assert_eq!(p.configs.len(), 2);
    }

    #[test]
    fn a_process_whose_program_is_missing_is_skipped_and_said_so() {
        let cfg = parse(
            r#"
            [[process]]
            name = "moos"
            command = ["MOOSDB"]
            when_on_path = ["MOOSDB", "pHelmIvP"]
            "#,
        );
        let p = plan(
            &cfg,
            Path::new("/"),
            Path::new("/r"),
            Path::new("/f"),
            |p| p == "MOOSDB",
        )
        .unwrap();
        assert!(p.processes.is_empty());
        assert!(p.skipped[0].contains("pHelmIvP"), "{:?}", p.skipped);
    }

    #[test]
    fn template_values_land_in_the_vehicle_config_and_are_validated() {
        let v = VehicleEntry {
            name: "auv2".into(),
            sim_port: Some(6000),
            start: Some(LatLon {
                lat: 42.0,
                lon: -70.0,
            }),
            zenoh_listen: vec!["tcp/127.0.0.1:7449".into()],
            set: [("sim_warp_factor".to_string(), serde_json::json!(5.0))].into(),
            ..Default::default()
        };
        let cfg = LaunchConfig::default();
        let t = load_template(&cfg, Path::new("/")).unwrap();
        let text = vehicle_config(&t, &v, "x").unwrap();
        let ic = frontseat_config::parse::<InterfaceConfig>(&text, "x").unwrap();
        assert_eq!(ic.name, "auv2");
        assert_eq!(ic.driver.basic_simulator.tcp_port, 6000);
        assert_eq!(ic.driver.basic_simulator.start.lat, 42.0);
        assert!(ic.interprocess.enabled);
        assert_eq!(ic.interprocess.listen, ["tcp/127.0.0.1:7449"]);
        assert_eq!(ic.sim_warp_factor, 5.0);

        let bad = VehicleEntry {
            set: [("sim_warp_factor".to_string(), serde_json::json!(-1.0))].into(),
            ..v.clone()
        };
        let e = vehicle_config(&t, &bad, "x").unwrap_err().to_string();
        assert!(e.contains("sim_warp_factor"), "{e}");
        let typo = VehicleEntry {
            set: [("requre_helm".to_string(), serde_json::json!(true))].into(),
            ..v
        };
        let e = vehicle_config(&t, &typo, "x").unwrap_err().to_string();
        assert!(e.contains("requre_helm"), "{e}");
    }

    #[test]
    fn the_launch_record_goes_to_every_templated_vehicle_apart_unless_it_has_its_own() {
        let cfg = parse(
            r#"
            [record]
            enabled = true
            dir = "rec"
            flush_s = 0.2
            [[vehicle]]
            name = "a"
            zenoh_listen = ["tcp/127.0.0.1:7448"]
            [[vehicle]]
            name = "b.1"
            zenoh_listen = ["tcp/127.0.0.1:7449"]
            [[vehicle]]
            name = "own"
            zenoh_listen = ["tcp/127.0.0.1:7450"]
            set = { "record.enabled" = true, "record.path" = "/x/own.mcap" }
            "#,
        );
        let p = plan(
            &cfg,
            Path::new("/base"),
            Path::new("/run"),
            Path::new("/f"),
            |_| true,
        )
        .unwrap();
        let ic =
            |i: usize| frontseat_config::parse::<InterfaceConfig>(&p.configs[i].text, "t").unwrap();
        assert!(ic(0).record.enabled);
        assert_eq!(ic(0).record.dir, "/base/rec/a");
        assert_eq!(ic(0).record.flush_s, 0.2);
        assert_eq!(ic(1).record.dir, "/base/rec/b.1");
        // The vehicle's own `set` wins, said in a warning.
        assert_eq!(ic(2).record.path.as_deref(), Some("/x/own.mcap"));
        assert_eq!(
            ic(2).record.flush_s,
            1.0,
            "nothing of the launch's [record]"
        );
        assert_eq!(p.warnings.len(), 1, "{:?}", p.warnings);
        assert!(p.warnings[0].contains("own"), "{:?}", p.warnings);
        let names: Vec<&str> = p.records.iter().map(|(v, _)| v.as_str()).collect();
        assert_eq!(names, ["a", "b.1", "own"]);
        assert!(
            p.records[0].1.starts_with("/base/rec/a/a_<UTC start>"),
            "{:?}",
            p.records
        );
        assert!(
            p.records[1].1.starts_with("/base/rec/b.1/b-1_"),
            "{:?}",
            p.records
        );
        assert_eq!(p.records[2].1, "/x/own.mcap");

        // Without [record] in the launch file nothing records.
        let quiet = parse("[[vehicle]]\nname = \"a\"\n");
        let p = plan(
            &quiet,
            Path::new("/"),
            Path::new("/r"),
            Path::new("/f"),
            |_| true,
        )
        .unwrap();
        assert!(p.records.is_empty() && p.warnings.is_empty());
    }

    #[test]
    fn a_single_record_path_gets_the_vehicle_name() {
        let r = RecordConfig {
            path: Some("logs/run.mcap".into()),
            ..Default::default()
        };
        let at = |r: &RecordConfig, v| vehicle_record(r, Path::new("/b"), v).path.unwrap();
        assert_eq!(at(&r, "auv1"), "/b/logs/run-auv1.mcap");
        let placed = RecordConfig {
            path: Some("/abs/{vehicle}/x".into()),
            dir: "/d/{vehicle}/files".into(),
            ..Default::default()
        };
        assert_eq!(at(&placed, "auv2"), "/abs/auv2/x");
        assert_eq!(
            vehicle_record(&placed, Path::new("/b"), "auv2").dir,
            "/d/auv2/files"
        );
    }

    #[test]
    fn a_launch_record_serving_foxglove_is_refused() {
        let e = frontseat_config::parse::<LaunchConfig>(
            "[record]\nenabled = true\nflush_s = 100\n[record.foxglove]\nenabled = true\n",
            "t.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("record.foxglove.enabled"), "{e}");
        assert!(e.contains("record.flush_s"), "{e}");
    }

    /// A vehicle named `..` would record in the parent of the record directory (and write its
    /// config beside the run directory): refused by the config check, with the field's path.
    #[test]
    fn a_vehicle_or_process_whose_name_is_a_path_is_a_config_error() {
        // As TOML writes them.
        for bad in [
            r#""..""#,
            r#"".""#,
            r#""a/b""#,
            r#"'x\y'"#,
            r#""auv\u0007""#,
        ] {
            let text = format!(
                "[record]\nenabled = true\n[[vehicle]]\nname = {bad}\n[[process]]\nname = {bad}\ncommand = [\"true\"]\n"
            );
            let e = frontseat_config::parse::<LaunchConfig>(&text, "t.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains("vehicle[0].name"), "{bad:?}: {e}");
            assert!(e.contains("process[0].name"), "{bad:?}: {e}");
        }
    }
    fn clash(text: &str) -> Option<String> {
        let dir = std::env::temp_dir().join(format!("fs-launch-ports-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        std::fs::write(
            dir.join("alpha.moos"),
            "ServerHost = localhost\nServerPort = 9001\n",
        )
        .ok();
        std::fs::write(dir.join("sim.toml"), "port = 7000\n").ok();
        let r = plan(
            &parse(text),
            &dir,
            Path::new("/run"),
            Path::new("/f"),
            |_| true,
        );
        match r {
            Ok(_) => None,
            Err(e @ PlanError::PortClash { .. }) => Some(e.to_string()),
            Err(other) => panic!("{other}"),
        }
    }

    #[test]
    fn two_vehicles_given_one_port_are_refused_naming_both_and_the_port() {
        // The template's default Zenoh listen (tcp/127.0.0.1:7447) for both.
        let e = clash("[[vehicle]]\nname = \"auv1\"\n[[vehicle]]\nname = \"auv2\"\n").unwrap();
        assert_eq!(
            e,
            "port 7447 (TCP) is bound by both vehicle auv1 (interprocess.listen \
             \"tcp/127.0.0.1:7447\") and vehicle auv2 (interprocess.listen \
             \"tcp/127.0.0.1:7447\"): give each its own port"
        );
        // Web pages, one on every address.
        let e = clash(
            "[[vehicle]]\nname = \"a\"\nzenoh_listen = [\"tcp/127.0.0.1:7448\"]\n\
             web_listen = \"0.0.0.0:50002\"\n\
             [[vehicle]]\nname = \"b\"\nzenoh_listen = [\"tcp/127.0.0.1:7449\"]\n\
             web_listen = \"127.0.0.1:50002\"\n",
        )
        .unwrap();
        assert!(
            e.contains("port 50002 (TCP)")
                && e.contains("vehicle a (web.listen \"0.0.0.0:50002\")"),
            "{e}"
        );
        assert!(
            e.contains("vehicle b (web.listen \"127.0.0.1:50002\")"),
            "{e}"
        );
        // A vehicle's Foxglove server on another's Zenoh port, through `set`.
        let e = clash(
            "[[vehicle]]\nname = \"a\"\nzenoh_listen = [\"tcp/127.0.0.1:7448\"]\n\
             [[vehicle]]\nname = \"b\"\nzenoh_listen = [\"tcp/127.0.0.1:7449\"]\n\
             set = { \"record.enabled\" = true, \"record.foxglove.enabled\" = true, \
             \"record.foxglove.bind\" = \"127.0.0.1:7448\" }\n",
        )
        .unwrap();
        assert!(
            e.contains("vehicle a (interprocess.listen")
                && e.contains("vehicle b (record.foxglove.bind"),
            "{e}"
        );
    }

    #[test]
    fn processes_clash_with_vehicles_and_with_each_other_per_vehicle() {
        // A per-vehicle simulator without {index}: both vehicles' simulators on one port.
        let e = clash(
            "[[process]]\nname = \"sim\"\nstage = \"per_vehicle\"\n\
             command = [\"frontseat\", \"sim\", \"--port\", \"6000\"]\n\
             [[vehicle]]\nname = \"a\"\nsim_port = 6000\nzenoh_listen = [\"tcp/127.0.0.1:7448\"]\n\
             [[vehicle]]\nname = \"b\"\nsim_port = 6000\nzenoh_listen = [\"tcp/127.0.0.1:7449\"]\n",
        )
        .unwrap();
        assert!(e.contains("port 6000 (TCP) is bound by both process sim-a (--port 6000) and process sim-b (--port 6000)"), "{e}");
        // ... and with {index} in the port, each its own: fine; so is one simulator shared.
        assert_eq!(
            clash(
                "[[process]]\nname = \"sim\"\nstage = \"per_vehicle\"\n\
                 command = [\"frontseat\", \"sim\", \"--port\", \"600{index}\"]\n\
                 [[vehicle]]\nname = \"a\"\nsim_port = 6000\nzenoh_listen = [\"tcp/127.0.0.1:7448\"]\n\
                 [[vehicle]]\nname = \"b\"\nsim_port = 6001\nzenoh_listen = [\"udp/127.0.0.1:7448\"]\n"
            ),
            None
        );
        // A simulator's config file port; a topside's web page; a MOOSDB's mission file.
        let e = clash(
            "[[process]]\nname = \"sim\"\ncommand = [\"frontseat\", \"sim\", \"-c\", \"sim.toml\"]\n\
             [[vehicle]]\nname = \"a\"\nzenoh_listen = [\"tcp/127.0.0.1:7000\"]\n",
        )
        .unwrap();
        assert!(
            e.contains("process sim (port (its config))") && e.contains("vehicle a"),
            "{e}"
        );
        let e = clash(
            "[[process]]\nname = \"top\"\nstage = \"after_vehicles\"\ncommand = [\"frontseat\", \"topside\"]\n\
             [[vehicle]]\nname = \"a\"\nweb_listen = \"127.0.0.1:50080\"\n",
        )
        .unwrap();
        assert!(
            e.contains("vehicle a (web.listen")
                && e.contains("process top (web.listen \"127.0.0.1:50080\")"),
            "{e}"
        );
        let e = clash(
            "[[process]]\nname = \"moos\"\ncommand = [\"pAntler\", \"alpha.moos\"]\n\
             [[process]]\nname = \"db2\"\ncommand = [\"MOOSDB\", \"--moos_port=9001\"]\n",
        )
        .unwrap();
        assert!(
            e.contains("port 9001 (TCP)")
                && e.contains("process moos (ServerPort = 9001 (alpha.moos))")
                && e.contains("process db2 (--moos_port=9001)"),
            "{e}"
        );
        // A process waited for on a TCP address binds it.
        let e = clash(
            "[[process]]\nname = \"x\"\ncommand = [\"x\"]\nready = { kind = \"tcp\", address = \"127.0.0.1:7448\" }\n\
             [[vehicle]]\nname = \"a\"\nzenoh_listen = [\"tcp/127.0.0.1:7448\"]\n",
        )
        .unwrap();
        assert!(
            e.contains("process x (ready.address \"127.0.0.1:7448\")"),
            "{e}"
        );
    }
}
