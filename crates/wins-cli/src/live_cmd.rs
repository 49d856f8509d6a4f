//! `wins live` (the estimator on board: CSI over TCP, IMU over MAVLink, poses back over
//! MAVLink) and `wins replay` (a dataset played as a drone would send it).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result, bail};
use wins::Config;
use wins::live::mavlink::signing::key_file_warning;
use wins::live::player::{PlayFault, PlayOptions, Streams, play};
use wins::live::run::{LiveOptions, run_live};
use wins::live::{ApBy, PoseMessage};

/// Arguments of `wins live`.
#[derive(clap::Args)]
pub struct LiveArgs {
    /// The rig: a dataset folder whose `dataset.toml` describes the IMU, the array, the channel
    /// and the APs with their `mac` (its logs are not read). Also `live.rig`.
    #[arg(long, value_name = "DIR")]
    rig: Option<PathBuf>,
    /// Where the CSI Tool's `log_to_server` connects, IP:PORT (default 127.0.0.1:8090,
    /// the loopback; 0.0.0.0:8090 for every network); for a Nexmon rig where its UDP packets
    /// arrive, for a FeitCSI rig where its records come back. Also `live.csi_listen`.
    #[arg(long, value_name = "HOST:PORT")]
    csi_listen: Option<String>,
    /// A logger allowed to connect, by IP address (repeat for each NIC's; none: any). Also
    /// `live.csi_peers`.
    #[arg(long = "csi-peer", value_name = "IP")]
    csi_peers: Vec<String>,
    /// A FeitCSI rig: FeitCSI's command socket, IP:PORT (`feitcsi --udp-socket` listens on UDP
    /// 8008; default 127.0.0.1:8008). Also `live.feitcsi_server`.
    #[arg(long, value_name = "HOST:PORT")]
    feitcsi_server: Option<String>,
    /// A FeitCSI rig: the options its measurement starts with, as on FeitCSI's command line
    /// (e.g. "-f 5180 -w 20 -r HT"; default: the rig's channel). Also `live.feitcsi_options`.
    #[arg(long, value_name = "OPTIONS", allow_hyphen_values = true)]
    feitcsi_options: Option<String>,
    /// The flight controller's link: udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT,
    /// tcpin:HOST:PORT or serial:DEVICE:BAUD (default udpin:127.0.0.1:14540). Also `live.mavlink`.
    #[arg(long, value_name = "URL")]
    mavlink: Option<String>,
    /// Sign every MAVLink message sent, and refuse those received unsigned or not signed with
    /// this key: a file of 32 raw bytes, PX4's 40-byte key file, or 64 hex digits (the key the
    /// flight controller has; docs/LIVE.md, Security). Also `live.mavlink_key`.
    #[arg(long, value_name = "FILE")]
    mavlink_key: Option<PathBuf>,
    /// Output folder (new or empty): trajectory.tum, stats.json, config.toml, recording/.
    #[arg(long, short)]
    out: PathBuf,
    /// Settings (TOML; the `[live]` table and every other; see `configs/live.toml`).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Send VISION_POSITION_ESTIMATE instead of ODOMETRY (older firmware). Also `live.message`.
    #[arg(long)]
    vision_position_estimate: bool,
    /// Every CSI record is the rig's only AP (no frame records needed). Also `live.ap_by`.
    #[arg(long)]
    single_ap: bool,
    /// Stop after this many seconds without input, once inputs came. Also `live.idle_exit_s`.
    #[arg(long, value_name = "SECONDS")]
    idle_exit: Option<f64>,
    /// Do not record the inputs. Also `live.record = false`.
    #[arg(long)]
    no_record: bool,
}

/// `wins live`.
pub fn live(args: LiveArgs) -> Result<()> {
    let mut config = match &args.config {
        Some(path) => Config::from_toml_file(path)?,
        None => Config::default(),
    };
    let l = &mut config.live;
    if let Some(r) = &args.rig {
        l.rig = r.display().to_string();
    }
    if let Some(a) = args.csi_listen {
        l.csi_listen = a;
    }
    if !args.csi_peers.is_empty() {
        l.csi_peers = args.csi_peers;
    }
    if let Some(f) = args.feitcsi_server {
        l.feitcsi_server = f;
    }
    if let Some(f) = args.feitcsi_options {
        l.feitcsi_options = f;
    }
    if let Some(m) = args.mavlink {
        l.mavlink = m;
    }
    if let Some(k) = &args.mavlink_key {
        l.mavlink_key = k.display().to_string();
    }
    if args.vision_position_estimate {
        l.message = PoseMessage::VisionPositionEstimate;
    }
    if args.single_ap {
        l.ap_by = ApBy::Single;
    }
    if let Some(s) = args.idle_exit {
        l.idle_exit_s = s;
    }
    if args.no_record {
        l.record = false;
    }
    if l.rig.is_empty() {
        bail!("no rig: give --rig DIR (a dataset folder describing the drone) or live.rig");
    }
    let options = LiveOptions {
        rig_dir: PathBuf::from(&l.rig),
        out: args.out.clone(),
    };
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("installing the Ctrl-C handler")?;
    }
    eprintln!(
        "wins live: CSI on {}, MAVLink {}, writing {} (Ctrl-C stops)",
        config.live.csi_listen,
        config.live.mavlink,
        args.out.display()
    );
    if !config.live.mavlink_key.is_empty() {
        let key = Path::new(&config.live.mavlink_key);
        eprintln!(
            "wins live: MAVLink signing with the key in {}: every message sent is signed; \
             unsigned or wrongly signed messages received are refused and counted",
            key.display()
        );
        if let Some(warning) = key_file_warning(key) {
            eprintln!("wins live: warning: {warning}");
        }
    }
    for open in config.live.open_to_every_network() {
        eprintln!(
            "wins live: {open} listens on every network this computer is on: anyone who reaches \
             it can send inputs"
        );
    }
    let summary = run_live(&config, &options, &stop, &mut |status| {
        eprintln!("{status}");
    })?;
    let s = &summary.live;
    println!(
        "stopped: {} IMU samples, {} CSI records ({} used), {} frames ({} converged), {} poses sent",
        s.imu_received,
        s.csi_records,
        s.csi_used_per_ap.iter().sum::<u64>(),
        s.frames,
        s.frames_converged,
        summary.poses_sent
    );
    if let Some(c) = summary.mavlink_signing {
        println!(
            "MAVLink signing: {} messages signed and sent, {} taken, refused: {} unsigned, {} bad \
             signature, {} replayed, {} stale",
            c.signed_out, c.accepted, c.unsigned, c.bad_signature, c.replayed, c.stale
        );
    }
    if let Some((p50, p99)) = summary.latency_ms {
        println!("pose age when sent: {p50:.1} ms median, {p99:.1} ms p99");
    }
    println!("wrote {}", args.out.display());
    Ok(())
}

/// Arguments of `wins replay`.
#[derive(clap::Args)]
pub struct ReplayArgs {
    /// Dataset directory to play.
    dataset: PathBuf,
    /// Play at the pace of the dataset's clock (the only mode: `wins run` replays offline).
    #[arg(long)]
    realtime: bool,
    /// Where `wins live` listens for CSI, IP:PORT.
    #[arg(long, value_name = "HOST:PORT", default_value = "127.0.0.1:8090")]
    csi_connect: String,
    /// Where `wins live` listens for MAVLink: udpout:HOST:PORT (its udpin address).
    #[arg(long, value_name = "URL", default_value = "udpout:127.0.0.1:14540")]
    mavlink: String,
    /// Play speed (1: real time).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// Unix time (s) at which to play the dataset's first input, to start with another player.
    #[arg(long, value_name = "UNIX_TIME")]
    start_at: Option<f64>,
    /// Send only the CSI (`csi`) or only the IMU and barometer (`imu`).
    #[arg(long, value_parser = ["csi", "imu"])]
    only: Option<String>,
    /// Write the MAVLink datagrams that come back (the poses) to this file, raw.
    #[arg(long, value_name = "FILE")]
    capture: Option<PathBuf>,
    /// Put a fault into the streams, KIND@AT:VALUE with AT in s of the dataset (repeatable):
    /// imu-shift@AT:S (one IMU sample S s off), imu-silence@AT:S (no IMU for S s),
    /// fc-reboot@AT:S (silent S s, then the clock reads from 0 at AT), imu-nan@AT:S (NaN
    /// readings for S s), imu-saturate@AT:S (39 g and 45 rad/s for S s), mav-corrupt@AT:N (each
    /// of N IMU messages first sent after garbage with a bad CRC, then intact), csi-shift@AT:S
    /// (one record's NIC time S s off), csi-garbage@AT:BYTES (random bytes in the CSI stream).
    #[arg(long, value_name = "KIND@AT:VALUE")]
    fault: Vec<String>,
    /// The MAVLink system id to send from (1: the flight controller `wins live` expects; another
    /// plays a stranger on the network, whose messages `wins live` counts and leaves out).
    #[arg(long, default_value_t = 1)]
    system_id: u8,
}

/// `wins replay`.
pub fn replay(args: ReplayArgs) -> Result<()> {
    if !args.realtime {
        bail!(
            "wins replay plays a dataset to `wins live` over the network: give --realtime \
             (to run WINS on a dataset offline, use `wins run`)"
        );
    }
    let Some(to) = args.mavlink.strip_prefix("udpout:") else {
        bail!(
            "--mavlink {:?}: wins replay sends to `wins live`'s udpin address, as udpout:HOST:PORT",
            args.mavlink
        );
    };
    let mavlink_to = to
        .parse()
        .with_context(|| format!("--mavlink {:?}: not IP:PORT", args.mavlink))?;
    let csi_connect = args
        .csi_connect
        .parse()
        .with_context(|| format!("--csi-connect {:?}: not IP:PORT", args.csi_connect))?;
    let options = PlayOptions {
        dataset: args.dataset,
        csi_connect,
        mavlink_to,
        speed: args.speed,
        start_at: args.start_at,
        streams: Streams {
            csi: args.only.as_deref() != Some("imu"),
            imu: args.only.as_deref() != Some("csi"),
        },
        capture: args.capture,
        system_id: args.system_id,
        faults: args
            .fault
            .iter()
            .map(|f| f.parse::<PlayFault>().map_err(anyhow::Error::msg))
            .collect::<Result<_>>()?,
    };
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("installing the Ctrl-C handler")?;
    }
    let s = play(&options, &stop)?;
    println!(
        "played {:.1} s: {} IMU samples, {} barometer readings, {} CSI records ({} not sent, {} connections), {} MAVLink datagrams back, at worst {:.1} ms late",
        s.played_s,
        s.imu_sent,
        s.baro_sent,
        s.csi_sent,
        s.csi_not_sent,
        s.csi_connects,
        s.mavlink_received,
        s.max_lag_s * 1e3
    );
    Ok(())
}
