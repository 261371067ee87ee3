//! Shared pieces of the SDK tests: building the C example with the `cc` crate, finding the
//! example binaries cargo built (the Rust plugin, the stand-alone driver host), and waiting for
//! interface statuses with a deadline.
#![allow(dead_code)]

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use frontseat_actors::bus::{Bus, Envelope};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    InterfaceState, InterfaceStatus,
};
use tokio::sync::mpsc::UnboundedReceiver;

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Compiles c_example/example_driver.c into a shared library named `lib{name}.so`, with the
/// extra compiler `flags` (e.g. `-DFSD_EXAMPLE_CRASH_ON_COMMAND=5`); returns its path.
pub fn build_c_plugin(name: &str, flags: &[&str]) -> PathBuf {
    let out_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("c_plugins");
    std::fs::create_dir_all(&out_dir).unwrap();
    let out = out_dir.join(format!("lib{name}.so"));
    let target = env!("FRONTSEAT_SDK_TARGET");
    let compiler = cc::Build::new()
        .target(target)
        .host(target)
        .opt_level(0)
        .debug(false)
        .cargo_metadata(false)
        .try_get_compiler()
        .expect("a C compiler");
    let mut cmd = compiler.to_command();
    cmd.args([
        "-shared", "-fPIC", "-std=c11", "-Wall", "-Wextra", "-Werror",
    ])
    .arg("-I")
    .arg(manifest().join("include"))
    .arg(manifest().join("c_example/example_driver.c"))
    .arg("-o")
    .arg(&out)
    .arg("-lm");
    cmd.args(flags);
    let status = cmd.status().expect("run the C compiler");
    assert!(status.success(), "compiling the C example failed: {cmd:?}");
    out
}

/// target/<profile>/examples, where `cargo test` put the examples.
fn examples_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().parent().unwrap().join("examples")
}

fn example(file: &str) -> PathBuf {
    let p = examples_dir().join(file);
    if !p.exists() {
        // `cargo test --test x` does not build examples; build them once here.
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = std::process::Command::new(cargo)
            .args([
                "build",
                "-p",
                "frontseat-driver-sdk",
                "--features",
                "host",
                "--examples",
            ])
            .current_dir(manifest())
            .status()
            .unwrap();
        assert!(status.success(), "building the examples failed");
    }
    assert!(p.exists(), "{} missing", p.display());
    p
}

pub fn rust_plugin() -> PathBuf {
    example("libbasic_sim_plugin.so")
}

pub fn driver_host() -> PathBuf {
    example("driver_host")
}

pub fn env_with(vars: Vec<(&'static str, String)>) -> impl Fn(&str) -> Option<String> {
    move |k| vars.iter().find(|(n, _)| *n == k).map(|(_, v)| v.clone())
}

pub fn path_str(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// Every status the interface publishes, in order.
pub struct StatusWatch {
    rx: UnboundedReceiver<Envelope<InterfaceStatus>>,
    pub seen: Vec<InterfaceStatus>,
}

impl StatusWatch {
    pub fn new(bus: &Bus) -> Self {
        let (sub, rx) =
            bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS, "test", 10_000);
        std::mem::forget(sub);
        Self {
            rx,
            seen: Vec::new(),
        }
    }

    pub async fn until(
        &mut self,
        what: &str,
        within: Duration,
        pred: impl Fn(&InterfaceStatus) -> bool,
    ) -> InterfaceStatus {
        let deadline = tokio::time::Instant::now() + within;
        loop {
            match tokio::time::timeout_at(deadline, self.rx.recv()).await {
                Ok(Some(env)) => {
                    let s = *env.msg;
                    self.seen.push(s);
                    if pred(&s) {
                        return s;
                    }
                }
                Ok(None) => panic!("status channel closed while waiting for {what}"),
                Err(_) => panic!(
                    "timed out after {within:?} waiting for {what}; states seen: {:?}",
                    self.states()
                ),
            }
        }
    }

    pub async fn until_state(
        &mut self,
        state: InterfaceState,
        within: Duration,
    ) -> InterfaceStatus {
        self.until(&format!("{state:?}"), within, |s| s.state() == state)
            .await
    }

    pub fn states(&self) -> Vec<InterfaceState> {
        let mut v: Vec<InterfaceState> = Vec::new();
        for s in &self.seen {
            if v.last() != Some(&s.state()) {
                v.push(s.state());
            }
        }
        v
    }
}
