//! `frontseat interface` with `[web] enabled = true` serves the page from its own process, and
//! `--check` warns about a non-loopback bind without a token (exit 0: the config is valid).

mod common;

use std::process::{Command, Stdio};
use std::time::Duration;

use common::procs::{Kill, free_port, scratch, wait_for_tcp};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frontseat"))
}

#[test]
fn check_warns_about_a_non_loopback_bind_without_a_token() {
    let dir = scratch("web", "check");
    let cfg = dir.join("iface.toml");
    std::fs::write(&cfg, "[web]\nenabled = true\nlisten = \"0.0.0.0:50001\"\n").unwrap();
    let out = bin()
        .args(["interface", "--check", "-c"])
        .arg(&cfg)
        .env_remove("FRONTSEAT_WEB_TOKEN")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: web.listen") && stderr.contains("not a loopback address"),
        "{stderr}"
    );
    std::fs::write(&cfg, "[web]\nenabled = true\n").unwrap();
    let out = bin()
        .args(["interface", "--check", "-c"])
        .arg(&cfg)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_interface_serves_the_page_itself() {
    let dir = scratch("web", "serve");
    let web_port = free_port();
    let sim_port = free_port();
    let cfg = dir.join("iface.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"web-auv\"\n[driver.basic_simulator]\ntcp_port = {sim_port}\n\
             [web]\nenabled = true\nlisten = \"127.0.0.1:{web_port}\"\n"
        ),
    )
    .unwrap();
    let _iface = Kill(
        bin()
            .args(["interface", "-c"])
            .arg(&cfg)
            .env("RUST_LOG", "warn")
            .env_remove("FRONTSEAT_WEB_TOKEN")
            .env_remove("NOTIFY_SOCKET")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    wait_for_tcp(web_port).await;
    for (path, needle) in [
        ("/", "<script src=\"app.js\">"),
        ("/api/info", "\"web-auv\""),
    ] {
        let mut s = tokio::net::TcpStream::connect(("127.0.0.1", web_port))
            .await
            .unwrap();
        s.write_all(
            format!(
                "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{web_port}\r\nConnection: close\r\n\r\n"
            )
            .as_bytes(),
        )
        .await
        .unwrap();
        let mut reply = String::new();
        tokio::time::timeout(Duration::from_secs(20), s.read_to_string(&mut reply))
            .await
            .expect("reply in time")
            .unwrap();
        assert!(reply.starts_with("HTTP/1.1 200"), "{path}: {reply}");
        assert!(reply.contains(needle), "{path}: {reply}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn demo_with_web_serves_the_page() {
    let web_port = free_port();
    let out = scratch("web", "demo");
    let _demo = Kill(
        bin()
            .args(["demo", "--web", "--warp", "50", "--lines", "--out"])
            .arg(&out)
            .arg("--web-listen")
            .arg(format!("127.0.0.1:{web_port}"))
            .env("RUST_LOG", "warn")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    wait_for_tcp(web_port).await;
    let mut s = tokio::net::TcpStream::connect(("127.0.0.1", web_port))
        .await
        .unwrap();
    s.write_all(
        format!(
            "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:{web_port}\r\nConnection: close\r\n\r\n"
        )
        .as_bytes(),
    )
    .await
    .unwrap();
    let mut reply = String::new();
    tokio::time::timeout(Duration::from_secs(20), s.read_to_string(&mut reply))
        .await
        .expect("reply in time")
        .unwrap();
    assert!(reply.contains("\"demo-auv\""), "{reply}");
}
