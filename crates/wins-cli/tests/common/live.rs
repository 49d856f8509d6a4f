//! Helpers of the tests that run `wins live` over real sockets (`cli_live.rs`,
//! `cli_live_faults.rs`, `cli_live_kill.rs`, `cli_live_spoof.rs`).

// Tests stop at the line that failed.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::fs;
use std::net::{TcpListener, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use super::{s, wins_ok};

/// A free local TCP port and a free local UDP port (bound, then released).
pub fn free_ports() -> (u16, u16) {
    let tcp = TcpListener::bind("127.0.0.1:0").unwrap();
    let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
    (
        tcp.local_addr().unwrap().port(),
        udp.local_addr().unwrap().port(),
    )
}

/// A child process killed when the guard goes (a test that fails leaves nothing running).
pub struct Running {
    name: String,
    child: Option<Child>,
    log: PathBuf,
}

impl Running {
    /// Starts `program args`, its stdout and stderr in `log`.
    pub fn spawn(name: &str, program: &str, args: &[&str], log: PathBuf) -> Self {
        let file = fs::File::create(&log).unwrap();
        let child = Command::new(program)
            .args(args)
            .stdin(Stdio::null())
            .stdout(file.try_clone().unwrap())
            .stderr(file)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name} ({program}): {e}"));
        Self {
            name: name.to_string(),
            child: Some(child),
            log,
        }
    }

    pub fn wins(name: &str, args: &[&str], dir: &Path) -> Self {
        let log = dir.join(format!("{name}.log"));
        Self::spawn(name, env!("CARGO_BIN_EXE_wins"), args, log)
    }

    /// Its output so far.
    pub fn output(&self) -> String {
        fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Waits for the end, at most `timeout`; panics (the guard then kills it) when it does not
    /// end in time or fails.
    pub fn finish(&mut self, timeout: Duration) -> String {
        let until = Instant::now() + timeout;
        let child = self.child.as_mut().unwrap();
        let status: ExitStatus = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            assert!(
                Instant::now() < until,
                "{} did not end within {timeout:?}:\n{}",
                self.name,
                self.output()
            );
            thread::sleep(Duration::from_millis(50));
        };
        self.child = None;
        assert!(
            status.success(),
            "{} failed ({status}):\n{}",
            self.name,
            self.output()
        );
        self.output()
    }
}

impl Running {
    /// Kills it at once (SIGKILL on Unix: no handler runs, nothing is flushed) and waits for it.
    pub fn kill(&mut self) {
        if let Some(mut child) = self.child.take() {
            child.kill().unwrap();
            let status = child.wait().unwrap();
            assert!(!status.success(), "{} was not killed: {status}", self.name);
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// `wins live` on the rig `ds`, listening on free ports, writing `dir/live`; returns once its
/// MAVLink port is bound (the CSI server is up before it), with (CSI port, MAVLink port); it
/// stops `idle_exit_s` after its inputs stop.
pub fn start_live(dir: &Path, ds: &Path, idle_exit_s: &str) -> (Running, u16, u16) {
    start_live_with(dir, ds, idle_exit_s, &[])
}

/// [`start_live`] with more options.
pub fn start_live_with(
    dir: &Path,
    ds: &Path,
    idle_exit_s: &str,
    more: &[&str],
) -> (Running, u16, u16) {
    let (csi_port, mav_port) = free_ports();
    let out = dir.join("live");
    let csi_listen = format!("127.0.0.1:{csi_port}");
    let mavlink = format!("udpin:127.0.0.1:{mav_port}");
    let mut args = vec![
        "live",
        "--rig",
        s(ds),
        "--csi-listen",
        &csi_listen,
        "--mavlink",
        &mavlink,
        "--out",
        s(&out),
        "--idle-exit",
        idle_exit_s,
    ];
    args.extend_from_slice(more);
    let live = Running::wins("wins live", &args, dir);
    let until = Instant::now() + Duration::from_secs(20);
    // The port is taken once `wins live` has bound it: no packet is sent to find out.
    while UdpSocket::bind(("127.0.0.1", mav_port)).is_ok() {
        assert!(
            Instant::now() < until,
            "wins live did not open its ports:\n{}",
            live.output()
        );
        thread::sleep(Duration::from_millis(20));
    }
    (live, csi_port, mav_port)
}

/// `wins replay` of `ds` in real time into a `wins live` on these ports (CSI over TCP, MAVLink
/// over UDP), with `more` options.
pub fn start_replay(dir: &Path, ds: &Path, csi_port: u16, mav_port: u16, more: &[&str]) -> Running {
    let csi = format!("127.0.0.1:{csi_port}");
    let mav = format!("udpout:127.0.0.1:{mav_port}");
    let mut args = vec![
        "replay",
        s(ds),
        "--realtime",
        "--csi-connect",
        &csi,
        "--mavlink",
        &mav,
    ];
    args.extend_from_slice(more);
    Running::wins("wins replay", &args, dir)
}

/// `wins simulate` of the paper's circle with `seed`, `seconds` long, into `out`; returns `out`.
pub fn simulate_circle(out: &Path, seed: &str, seconds: &str) -> PathBuf {
    wins_ok(&[
        "simulate",
        "--scenario",
        "paper-circle",
        "--seed",
        seed,
        "--duration",
        seconds,
        "-o",
        s(out),
    ]);
    out.to_path_buf()
}

/// `wins run` of the recording `wins live` left in `live` with the settings it used, into
/// `again`; returns the trajectory it wrote.
pub fn run_recording(live: &Path, again: &Path) -> PathBuf {
    wins_ok(&[
        "run",
        s(&live.join("recording")),
        "--config",
        s(&live.join("config.toml")),
        "--out",
        s(again),
        "--no-plots",
    ]);
    again.join("trajectory.tum")
}

/// A TUM trajectory in time order: (time in µs, position, [w, x, y, z]).
pub type Trajectory = Vec<(i64, [f64; 3], [f64; 4])>;

pub fn read_tum(path: &Path) -> Trajectory {
    let text = fs::read_to_string(path).unwrap();
    let mut poses = Vec::new();
    for line in text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
    {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(v.len(), 8, "{}: {line}", path.display());
        let t_us = (v[0] * 1e6).round() as i64;
        poses.push((t_us, [v[1], v[2], v[3]], [v[7], v[4], v[5], v[6]]));
    }
    poses.sort_by_key(|p| p.0);
    poses
}
