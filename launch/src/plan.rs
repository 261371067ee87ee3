//! From a launch file to the ordered list of processes to start: stages in order, one interface
//! per vehicle (its config generated from the template and the vehicle's values, and validated
//! as `frontseat interface --check` would), per-vehicle processes expanded, and processes whose
//! programs are missing from PATH skipped. No process is started here; `--check` runs all of it.

use std::path::{Path, PathBuf};

use frontseat_config::{InterfaceConfig, RestartConfig};

use crate::config::{LaunchConfig, ProcessEntry, ReadyConfig, Stage, VehicleEntry};

/// One process to start.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcSpec {
    /// Position in start order, from 0; the exit code of a failed launch is 10 + this.
    pub index: usize,
    pub name: String,
    pub program: PathBuf,
    pub args: Vec<String>,
    pub env: Vec<(String, String)>,
    pub cwd: PathBuf,
    pub ready: ReadyConfig,
    pub restart: RestartConfig,
}

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
    };
    for p in cfg
        .process
        .iter()
        .filter(|p| p.stage == Stage::BeforeVehicles)
    {
        push_process(&mut out, p, None);
    }
    for (i, v) in cfg.vehicle.iter().enumerate() {
        let config_path = if v.config.is_empty() {
            let path = run_dir.join(format!("interface-{}.toml", v.name));
            let label = format!("vehicle {} (template + its values)", v.name);
            let text = vehicle_config(&template, v, &label)?;
            out.configs.push(GeneratedConfig {
                path: path.clone(),
                text,
            });
            path
        } else {
            let path = resolve(base, &v.config);
            frontseat_config::load::<InterfaceConfig>(&path).map_err(|source| {
                PlanError::Interface {
                    vehicle: v.name.clone(),
                    source,
                }
            })?;
            path
        };
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
            [[vehicle]]
            name = "b"
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
}
