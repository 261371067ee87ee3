//! The Python `mcap` package's ordinary open (`make_reader`, what Foxglove and every script use)
//! on a recording, through `tests/python/make_reader_digest.py`. Shared by the root tests and
//! `record/tests/` (included there by path), so it depends on nothing else in `common`.

use std::path::Path;
use std::process::{Command, Stdio};

/// Whether python3 can import `mcap`. When it cannot and `FRONTSEAT_REQUIRE_PYTHON_HELM` is set
/// (`.ci/run` installs tests/python/requirements.txt and sets it), the test fails instead of
/// skipping its Python part.
pub fn python_reader() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import mcap.reader"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        assert!(
            std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_none(),
            "FRONTSEAT_REQUIRE_PYTHON_HELM is set but python3 cannot import mcap"
        );
        println!("python3 cannot import mcap: the make_reader checks are not run here");
    }
    ok
}

/// make_reader on `file`: Ok((messages, digest)) or Err(its error). `repo` is the repository's
/// root (the script lives under it).
pub fn make_reader(repo: &Path, file: &Path) -> Result<(u64, u64), String> {
    let script = repo.join("tests/python/make_reader_digest.py");
    let out = Command::new("python3")
        .arg(script)
        .arg(file)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "make_reader_digest.py: {e}: {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    if v["ok"] == true {
        assert!(out.status.success());
        Ok((
            v["messages"].as_u64().unwrap(),
            v["digest"].as_u64().unwrap(),
        ))
    } else {
        assert_eq!(out.status.code(), Some(3), "{v}");
        Err(v["error"].as_str().unwrap_or_default().to_string())
    }
}
