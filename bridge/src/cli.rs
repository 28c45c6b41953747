//! The `floatball` command line.
//!
//! `floatball` with no subcommand serves the app and the API with the installation in
//! `--data-dir`; `floatball check` only reads and checks the configuration;
//! `floatball simulate` answers as a simulated UIM2503 gateway on a serial device or
//! as N of them on TCP sockets (`--listen`), (`--kind mbox`) as simulated MBOX boxes
//! on UDP sockets, or (`--kind scl`) as simulated MOONS' drives on a serial device (RS-485) or UDP sockets (eSCL). Every
//! subcommand is listed by `floatball --help`.

use std::net::{Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::Context;
use clap::{Parser, Subcommand};
use floatball_shared::mbox::{self, AxisCount};
use floatball_shared::scl::{escl, twin::StartWire};
use floatball_shared::uim2503::sim::{self, GatewayConfig};

use crate::auth::Clock;
use crate::commission::sim_units::SimUnits;
use crate::config::{self, Config, Overrides};
use crate::server;
use crate::state::{AppState, Paths};

/// Floatball's bridge: serves the operator app and relays to the ball matrix.
#[derive(Debug, Parser)]
#[command(
    name = "floatball",
    version,
    about,
    args_conflicts_with_subcommands = true
)]
pub struct Cli {
    /// What to do instead of serving.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Address and port to listen on (port 0 picks a free port); overrides `listen` in
    /// floatball.toml.
    #[arg(long)]
    pub listen: Option<SocketAddr>,
    /// A gateway's port: `sim`, a serial device such as /dev/ttyUSB0, or a serial device
    /// server `tcp://host:port` / `rfc2217://host:port`; the n-th flag replaces the port of the n-th `[[gateway]]` in floatball.toml.
    #[arg(long = "gateway", value_name = "PORT")]
    pub gateways: Vec<String>,
    /// Directory for the configuration, the password and the show files.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Directory holding the web app (`index.html` and the built `pkg/`).
    #[arg(long, default_value = "static")]
    pub static_dir: PathBuf,
    /// Simulated gateways' new units leave the factory as real ones do: all on
    /// station 5, to be commissioned (units already given stations keep them).
    #[arg(long)]
    pub sim_factory_fresh: bool,
    /// Tests only: `POST /api/test/clock` sets the scheduler's clock.
    #[arg(long, hide = true)]
    pub test_clock: bool,
    /// Tests only: as `--test-clock`, the clock set to this instant (RFC 3339) from
    /// the start.
    #[arg(long, hide = true, value_name = "INSTANT")]
    pub test_clock_at: Option<String>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Check floatball.toml (writing the defaults if it is missing) and exit.
    Check(CheckArgs),
    /// Answer as a simulated UIM2503 gateway with its units on a serial device (e.g. one
    /// end of a pseudo-terminal pair or a null-modem cable) or as N of them on TCP
    /// sockets (`--listen`, `--gateways`), or as simulated MBOX boxes on UDP sockets
    /// (`--kind mbox`). SIGHUP power-cycles the simulated UIM2503 gateways (a line speed
    /// stored by `BDR=x;` takes effect).
    Simulate(SimulateArgs),
}

/// What `floatball simulate` simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SimulateKind {
    /// A UIM2503 gateway and its units on a serial device (`--port`), or gateways on
    /// TCP sockets as behind serial device servers (`--listen`, `--gateways`).
    Uim2503,
    /// MBOX boxes on UDP sockets (`--listen`, `--axes`, `--boxes`, `--ip`).
    Mbox,
    /// MOONS' drives: on a serial device as an RS-485 line (`--port`, `--baud`), or on
    /// UDP sockets as eSCL (`--listen`); `--drives`, `--start-wire`.
    Scl,
}

/// Options of `floatball simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// What to simulate.
    #[arg(long, value_enum, default_value_t = SimulateKind::Uim2503)]
    pub kind: SimulateKind,
    /// (uim2503, scl) The serial device to answer on, e.g. /dev/pts/3 or /dev/ttyUSB1.
    #[arg(long)]
    pub port: Option<String>,
    /// (mbox, scl) The first box's or drive's UDP address; box or drive i listens on
    /// its port + i (port 0: each on a free port). Default: 127.0.0.1 on port 7408
    /// (mbox) or 7775 (scl, eSCL). (uim2503) The first gateway's TCP address instead of
    /// `--port`: gateway i listens on its port + i (port 0: each on a free port).
    #[arg(long)]
    pub listen: Option<SocketAddr>,
    /// (scl) Number of drives (addresses 0, 1, … 9, then " # $ & ' ( ) + , - . / : ; <
    /// = >).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u8).range(1..=crate::simulate::scl::MAX_DRIVES as i64))]
    pub drives: u8,
    /// (scl) The start wire, drive:output:input: that drive's output drives that input
    /// of every drive.
    #[arg(long, default_value = crate::simulate::scl::DEFAULT_START_WIRE, value_parser = crate::simulate::scl::parse_start_wire)]
    pub start_wire: StartWire,
    /// (mbox) Axes of every box: 3, 6 or 10.
    #[arg(long, default_value_t = 10, value_parser = parse_axes_count)]
    pub axes: u8,
    /// (uim2503 with --listen) Number of gateways.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..))]
    pub gateways: u16,
    /// (mbox) Number of boxes.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..))]
    pub boxes: u16,
    /// (mbox) The first box's IP address (its address in datagrams is the last two
    /// octets); box i has this + i.
    #[arg(long, default_value_t = mbox::FACTORY_IP)]
    pub ip: Ipv4Addr,
    /// The line's baud rate (a UIM2503 leaves the factory at 9600).
    #[arg(long, default_value_t = config::DEFAULT_SERIAL_BAUD)]
    pub baud: u32,
    /// Number of units behind the (each) gateway (stations 1…N).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u8).range(1..=sim::MAX_UNITS as i64))]
    pub units: u8,
    /// Every unit answers on station 5, as delivered from the factory.
    #[arg(long)]
    pub factory_fresh: bool,
    /// Seed of the units' serial numbers (uim2503), of the datagram losses (mbox).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// (mbox) Per cent of datagrams each box loses, on the way in and of its replies on
    /// the way out (a lossy network, for tests).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=100))]
    pub drop_percent: u8,
    /// Calibration: encoder counts per mm.
    #[arg(long, default_value_t = sim::DEFAULT_COUNTS_PER_MM)]
    pub counts_per_mm: f64,
}

/// `--axes`: 3, 6 or 10.
fn parse_axes_count(text: &str) -> Result<u8, String> {
    match text.parse::<u8>() {
        Ok(axes @ (3 | 6 | 10)) => Ok(axes),
        _ => Err(format!("{text} axes: an MBOX drives 3, 6 or 10")),
    }
}

/// Options of `floatball check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// Directory holding floatball.toml.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
}

/// The whole command line: [`Cli`] and `floatball generate`, whose options are built
/// at run time from the patterns' table ([`crate::generate::command`]).
#[must_use]
pub fn command() -> clap::Command {
    use clap::CommandFactory;
    Cli::command().subcommand(crate::generate::command())
}

/// Runs the command the user asked for until it ends or Ctrl-C is pressed.
///
/// # Errors
/// Whatever stops the command, in words for the person who started it.
pub async fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Some(Command::Simulate(args)) => simulate(args).await,
        Some(Command::Check(args)) => check(&args.data_dir),
        None => {
            let overrides = Overrides {
                listen: cli.listen,
                gateway_ports: cli.gateways,
            };
            let sim = SimUnits {
                factory_fresh: cli.sim_factory_fresh,
            };
            let test_clock = match cli.test_clock_at {
                Some(at) => Some(Some(at.parse::<jiff::Timestamp>().with_context(|| {
                    format!("--test-clock-at {at:?} is not an RFC 3339 instant")
                })?)),
                None => cli.test_clock.then_some(None),
            };
            serve(&cli.data_dir, &overrides, cli.static_dir, sim, test_clock).await
        }
    }
}

fn create_data_dir(data_dir: &std::path::Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(data_dir)
        .with_context(|| format!("cannot create the data directory {}", data_dir.display()))
}

/// `floatball check`.
fn check(data_dir: &std::path::Path) -> anyhow::Result<()> {
    create_data_dir(data_dir)?;
    let config = Config::load_or_create(data_dir, &Overrides::default())?;
    println!(
        "{} is valid: {} × {} balls on {} gateway(s)",
        data_dir.join(config::FILE_NAME).display(),
        config.installation.limits.rows,
        config.installation.limits.cols,
        config.installation.gateways.len()
    );
    print_schedule(data_dir);
    if let Some(osc) = &config.osc {
        let allow: Vec<String> = osc.allow.iter().map(ToString::to_string).collect();
        println!(
            "OSC on udp {} from {} (e-stop {}, motion {}), feedback {}",
            osc.listen,
            allow.join(", "),
            if osc.estop { "on" } else { "off" },
            if osc.motion { "on" } else { "off" },
            osc.feedback
                .map_or_else(|| "off".to_owned(), |to| format!("to {to}"))
        );
    }
    println!("{}", config.live.summary());
    if let Some(timecode) = &config.timecode {
        println!(
            "timecode chase: {} at {} fps, playlist start {}, loss after {} ms: {}, \
             locate beyond {} ms, first lead {} ms",
            timecode.source,
            timecode.rate,
            timecode.start_ms.map_or_else(
                || "none (entries' own)".to_owned(),
                |ms| floatball_shared::timecode::Timecode::from_ms(ms, timecode.rate).to_string()
            ),
            timecode.chase.loss_ms,
            match timecode.chase.on_loss {
                floatball_shared::timecode::chase::OnLoss::Hold => "hold",
                floatball_shared::timecode::chase::OnLoss::Stop => "stop",
            },
            timecode.chase.locate_threshold_ms,
            timecode.chase.lead_ms
        );
    }
    Ok(())
}

/// `floatball check`'s line about the schedule: off, or its next start.
fn print_schedule(data_dir: &std::path::Path) {
    use floatball_shared::schedule::{Memory, decide};
    let schedule = match crate::schedule::Schedules::open(data_dir) {
        Ok(schedules) => schedules.get(),
        Err(error) => {
            println!("schedule: {error}");
            return;
        }
    };
    if !schedule.enabled {
        println!("schedule: off");
        return;
    }
    if let Err(problems) = crate::schedule::check(&schedule) {
        for problem in problems {
            println!("schedule: {problem}");
        }
        return;
    }
    let zone = jiff::tz::TimeZone::get(&schedule.time_zone).unwrap_or(jiff::tz::TimeZone::UTC);
    let next = crate::schedule::local(jiff::Timestamp::now(), &zone)
        .and_then(|now| decide(&schedule, now, &Memory::default()).next_start);
    match next {
        Some(next) => println!("schedule: on, next start {next} ({})", schedule.time_zone),
        None => println!("schedule: on, no start ahead"),
    }
}

/// Serves the app and the API until Ctrl-C or SIGTERM.
async fn serve(
    data_dir: &std::path::Path,
    overrides: &Overrides,
    static_dir: PathBuf,
    sim: SimUnits,
    test_clock: Option<Option<jiff::Timestamp>>,
) -> anyhow::Result<()> {
    create_data_dir(data_dir)?;
    let config = Config::load_or_create(data_dir, overrides)?;
    if !static_dir.join("index.html").is_file() {
        tracing::warn!(
            "{} has no index.html: the app will not load (build it with `cargo xtask run`)",
            static_dir.display()
        );
    }
    let listen = config.listen;
    let osc = match config.osc.clone() {
        Some(osc) => {
            let socket = crate::osc::bind(&osc)
                .await
                .with_context(|| format!("cannot listen for OSC on udp {}", osc.listen))?;
            Some((socket, osc))
        }
        None => None,
    };
    let timecode = match config.timecode.clone() {
        Some(timecode) => {
            let socket = crate::timecode::bind(&timecode)
                .with_context(|| format!("cannot receive {}", timecode.source))?
                .map(Arc::new);
            Some((socket, timecode))
        }
        None => None,
    };
    let live = if config.live.enabled {
        let shared = match &timecode {
            Some((
                Some(socket),
                crate::config::TimecodeConfig {
                    source: crate::config::TimecodeSource::ArtNet(listen),
                    ..
                },
            )) => Some((socket, *listen)),
            _ => None,
        };
        Some(
            crate::live::bind(&config.live, shared)
                .context("cannot receive live input (Art-Net, sACN)")?,
        )
    } else {
        None
    };
    let state = AppState::open_with(
        config,
        Paths {
            data_dir: data_dir.to_owned(),
            static_dir,
        },
        Clock::system(),
        sim,
    )?;
    if let Some(at) = test_clock {
        state.schedules().enable_test_clock();
        state.schedules().set_clock(at);
        tracing::warn!("--test-clock: POST /api/test/clock sets the scheduler's clock");
    }
    let listener = tokio::net::TcpListener::bind(listen)
        .await
        .with_context(|| format!("cannot listen on {listen}"))?;
    let addr = listener
        .local_addr()
        .context("cannot read the listening address")?;
    if let Some((socket, osc)) = osc {
        tracing::info!(
            "OSC on udp {} (e-stop {}, motion {})",
            osc.listen,
            if osc.estop { "on" } else { "off" },
            if osc.motion { "on" } else { "off" }
        );
        crate::osc::spawn(state.clone(), socket, osc);
    }
    let live_feed = match live {
        Some(bound) => {
            let live = &state.config().live;
            tracing::info!(
                "live input: {}{}{}",
                if live.artnet {
                    format!("Art-Net on udp {}", live.artnet_listen)
                } else {
                    String::new()
                },
                if live.artnet && live.sacn { ", " } else { "" },
                if live.sacn {
                    format!(
                        "sACN on udp {} (multicast on {})",
                        live.sacn_listen, live.sacn_interface
                    )
                } else {
                    String::new()
                }
            );
            crate::live::spawn(state.clone(), bound)
        }
        None => None,
    };
    if let Some((socket, timecode)) = timecode {
        tracing::info!(
            "timecode chase: {} at {} fps",
            timecode.source,
            timecode.rate
        );
        crate::timecode::spawn(state.clone(), timecode, socket, live_feed);
    }
    // The first line on stdout is the URL: people read it, and tests parse it.
    println!("floatball listening on http://{addr}");
    server::run(listener, state, shutdown_signal()).await?;
    Ok(())
}

/// Completes when the process is asked to stop (Ctrl-C or SIGTERM).
async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(err) = tokio::signal::ctrl_c().await {
            tracing::error!("cannot listen for Ctrl-C: {err}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(err) => {
                tracing::error!("cannot listen for SIGTERM: {err}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {}
        () = terminate => {}
    }
    tracing::info!("shutting down");
}

/// `floatball simulate`: runs until Ctrl-C or SIGTERM; SIGHUP is the simulated
/// gateway's power cycle (a line speed stored by `BDR=x;` takes effect).
async fn simulate(args: SimulateArgs) -> anyhow::Result<()> {
    let port = match (args.kind, args.port.clone(), args.listen) {
        (SimulateKind::Scl, port, _) => return simulate_scl(&args, port).await,
        (SimulateKind::Mbox, None, _) => return simulate_mbox(&args).await,
        (SimulateKind::Mbox, Some(_), _) => {
            anyhow::bail!("--port is the serial device of --kind uim2503; MBOX boxes take --listen")
        }
        (SimulateKind::Uim2503, Some(_), Some(_)) => {
            anyhow::bail!(
                "--kind uim2503 answers on a serial device (--port) or on TCP (--listen), not both"
            )
        }
        (SimulateKind::Uim2503, None, Some(listen)) => {
            return simulate_uim2503_tcp(&args, listen).await;
        }
        (SimulateKind::Uim2503, Some(_), None) if args.gateways > 1 => {
            anyhow::bail!("--gateways is for --listen: a serial device (--port) has one gateway")
        }
        (SimulateKind::Uim2503, Some(port), None) => port,
        (SimulateKind::Uim2503, None, None) => {
            anyhow::bail!("--kind uim2503 needs --port (a serial device) or --listen (TCP)")
        }
    };
    let gateway = simulated_units(&args);
    let options = crate::simulate::SimulateOptions {
        port,
        baud: args.baud,
        gateway,
    };
    let stop = Arc::new(AtomicBool::new(false));
    let worker_stop = Arc::clone(&stop);
    let power_cycle = Arc::new(AtomicBool::new(false));
    let hangup = Arc::clone(&power_cycle);
    watch_power_cycles(move || hangup.store(true, Ordering::Release))?;
    let banner = format!(
        "floatball simulating a gateway with {} units on {} at {} baud",
        args.units, options.port, options.baud
    );
    let worker = tokio::task::spawn_blocking(move || {
        crate::simulate::run(&options, &worker_stop, &power_cycle, || {
            println!("{banner}")
        })
    });
    tokio::select! {
        result = worker => {
            result.context("the simulator stopped unexpectedly")?.map_err(anyhow::Error::msg)
        }
        () = shutdown_signal() => {
            stop.store(true, Ordering::Release);
            Ok(())
        }
    }
}

/// The units behind each simulated UIM2503 gateway, as the options say.
fn simulated_units(args: &SimulateArgs) -> GatewayConfig {
    let mut gateway = if args.factory_fresh {
        GatewayConfig::factory_fresh(usize::from(args.units))
    } else {
        GatewayConfig::numbered(args.units)
    };
    gateway.seed = args.seed;
    gateway.counts_per_mm = args.counts_per_mm;
    gateway
}

/// `floatball simulate --kind uim2503 --listen ADDR`: the gateways on TCP sockets
/// ([`crate::simulate::tcp`], whose documentation gives the lines printed) until Ctrl-C
/// or SIGTERM; SIGHUP power-cycles them all.
async fn simulate_uim2503_tcp(args: &SimulateArgs, listen: SocketAddr) -> anyhow::Result<()> {
    use crate::simulate::tcp;
    let bound = tcp::bind(tcp::ListenOptions {
        listen,
        gateways: args.gateways,
        baud: args.baud,
        gateway: simulated_units(args),
    })
    .map_err(anyhow::Error::msg)?;
    let power_cycles = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let hangup = Arc::clone(&power_cycles);
    watch_power_cycles(move || {
        hangup.fetch_add(1, Ordering::AcqRel);
    })?;
    // People read these lines, and tests parse them: the socket is the last word.
    for (index, socket) in bound
        .sockets()
        .map_err(anyhow::Error::msg)?
        .iter()
        .enumerate()
    {
        println!(
            "floatball simulating gateway {index} with {} units at {} baud on tcp {socket}",
            args.units, args.baud
        );
    }
    let stop = Arc::new(AtomicBool::new(false));
    let threads = bound
        .serve(&stop, &power_cycles)
        .map_err(anyhow::Error::msg)?;
    shutdown_signal().await;
    stop.store(true, Ordering::Release);
    for thread in threads {
        thread.thread().unpark();
        let _ = tokio::task::spawn_blocking(move || thread.join()).await;
    }
    Ok(())
}

/// SIGHUP is the simulated gateways' power cycle: calls `power_cycle` each time.
fn watch_power_cycles(power_cycle: impl Fn() + Send + 'static) -> anyhow::Result<()> {
    #[cfg(unix)]
    {
        let mut hangups = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::hangup())
            .context("cannot watch SIGHUP (the simulated gateway's power cycle)")?;
        tokio::spawn(async move {
            while hangups.recv().await.is_some() {
                power_cycle();
            }
        });
    }
    #[cfg(not(unix))]
    let _ = power_cycle;
    Ok(())
}

/// `floatball simulate --kind mbox`: one line a box once every socket listens; on
/// Ctrl-C or SIGTERM, each box's final state as one JSON line ([`SimBox`]).
///
/// [`SimBox`]: floatball_shared::api::SimBox
async fn simulate_mbox(args: &SimulateArgs) -> anyhow::Result<()> {
    let axes = AxisCount::ALL
        .into_iter()
        .find(|axes| axes.count() == usize::from(args.axes))
        .context("an MBOX drives 3, 6 or 10 axes")?;
    let boxes = crate::simulate::mbox::MboxBoxes::start(crate::simulate::mbox::MboxOptions {
        listen: args
            .listen
            .unwrap_or_else(|| SocketAddr::from(([127, 0, 0, 1], mbox::BOX_PORT))),
        boxes: args.boxes,
        axes,
        ip: args.ip,
        drop_percent: args.drop_percent,
        seed: args.seed,
    })
    .await
    .map_err(anyhow::Error::msg)?;
    // People read these lines, and tests parse them: the socket is the last word.
    for running in boxes.boxes() {
        println!(
            "floatball simulating MBOX box 0x{:04X} ({}, {} axes) on {}",
            mbox::BoxAddress::of_ip(running.ip).0,
            running.ip,
            axes.count(),
            running.socket
        );
    }
    shutdown_signal().await;
    for snapshot in boxes.stop().await {
        println!("{}", serde_json::to_string(&snapshot)?);
    }
    Ok(())
}

/// `floatball simulate --kind scl`: the drives on `--port` (RS-485) or, without it, on
/// UDP from `--listen` (eSCL); one banner line once they answer (a line a drive on
/// UDP, its socket the last word); on Ctrl-C or SIGTERM, one line a drive with its
/// position.
async fn simulate_scl(args: &SimulateArgs, port: Option<String>) -> anyhow::Result<()> {
    use crate::simulate::scl;
    let drives = usize::from(args.drives);
    let bus = scl::bus(drives, port.is_some(), args.start_wire).map_err(anyhow::Error::msg)?;
    let wire = args.start_wire;
    let wire_text = format!(
        "drive {}'s Y{} wired to X{} of every drive",
        wire.from, wire.output, wire.input
    );
    let bus = if let Some(port) = port {
        let stop = Arc::new(AtomicBool::new(false));
        let worker_stop = Arc::clone(&stop);
        let baud = args.baud;
        let banner = format!(
            "floatball simulating {drives} MOONS' drives ({wire_text}) on {port} at {baud} baud"
        );
        let mut worker = tokio::task::spawn_blocking(move || {
            scl::run_serial(&port, baud, bus, &worker_stop, || println!("{banner}"))
        });
        let joined = tokio::select! {
            result = &mut worker => result,
            () = shutdown_signal() => {
                stop.store(true, Ordering::Release);
                worker.await
            }
        };
        joined
            .context("the simulator stopped unexpectedly")?
            .map_err(anyhow::Error::msg)?
    } else {
        let listen = args
            .listen
            .unwrap_or_else(|| SocketAddr::from(([127, 0, 0, 1], escl::UDP_PORT)));
        let running = scl::UdpDrives::spawn(listen, bus).map_err(anyhow::Error::msg)?;
        // People read these lines, and tests parse them: the socket is the last word.
        for (name, socket) in floatball_shared::scl::Address::CHARACTERS
            .chars()
            .zip(running.sockets())
        {
            println!(
                "floatball simulating MOONS' drive {name} of {drives} ({wire_text}) on eSCL UDP {socket}"
            );
        }
        shutdown_signal().await;
        running.stop().await
    };
    for line in scl::positions(&bus) {
        println!("{line}");
    }
    Ok(())
}
