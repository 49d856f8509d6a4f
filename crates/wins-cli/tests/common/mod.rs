//! Helpers shared by the CLI's end-to-end tests (each test file is its own binary and uses a
//! part of them).
#![allow(dead_code)]

pub mod live;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `wins` binary with `args` in the current directory.
pub fn wins(args: &[&str]) -> Output {
    wins_in(Path::new("."), args)
}

/// Runs the `wins` binary with `args` in `dir`.
pub fn wins_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wins"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("wins runs")
}

/// `wins args`, which must succeed: what it printed on stdout.
pub fn wins_ok(args: &[&str]) -> String {
    let out = wins(args);
    assert!(
        out.status.success(),
        "wins {}: {}",
        args.join(" "),
        stderr(&out)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// What the run printed on stderr.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A fresh, empty folder `wins-cli-{group}-{name}-{pid}` under the system's temporary folder.
pub fn fresh_dir(group: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-cli-{group}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
