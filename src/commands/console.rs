//! `firefleet console`: the incident commander's web console, a Zenoh client like any other
//! role; `firefleet console add-user` makes its logins.
//!
//! This command joins the bus, binds the page's port and starts the console's parts: its
//! bus edge (`firefleet_console::node`), the stream's ticker and the HTTP server.
//!
//! Not here: the picture, the page, logins or the bus edge (`firefleet_console`).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use super::{RoleArgs, positive_f64};
use anyhow::Context;
use clap::{Args, Subcommand};
use firefleet::net::{join, shutdown_signal};
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_console::alarm_file::AlarmFile;
use firefleet_console::audit::Audit;
use firefleet_console::auth::{Role, Sessions, Users};
use firefleet_console::history::History;
use firefleet_console::http::{Console, Peer, Records, Serving, TICK};
use firefleet_console::node;
use firefleet_console::picture::Picture;
use firefleet_console::site::SiteMap;
use firefleet_console::tls::{TlsListener, server_config};
use firefleet_model::CommanderId;

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct ConsoleArgs {
    #[command(subcommand)]
    command: Option<ConsoleCommand>,
    #[command(flatten)]
    serve: ServeArgs,
}

#[derive(Subcommand, Debug)]
enum ConsoleCommand {
    /// Add a commander to a users file, or set their password (read from standard input,
    /// one line, at least 8 characters).
    AddUser(AddUserArgs),
}

#[derive(Args, Debug)]
struct AddUserArgs {
    /// The users file (made if missing, readable by its owner only).
    #[arg(long, value_name = "FILE")]
    users: PathBuf,
    /// The commander's name: the name goals are issued under.
    name: CommanderId,
    /// A viewer: reads the incident, steers nothing.
    #[arg(long)]
    viewer: bool,
}

#[derive(Args, Debug)]
struct ServeArgs {
    #[command(flatten)]
    role: RoleArgs,
    /// Where the page is served. Loopback by default: serving it wider is a site's decision.
    #[arg(long, value_name = "ADDR:PORT", default_value = "127.0.0.1:8080")]
    http: SocketAddr,
    /// The commanders who may log in (`firefleet console add-user`); without it the
    /// console is read-only.
    #[arg(long, value_name = "FILE")]
    users: Option<PathBuf>,
    /// Serve the page over HTTPS with this certificate (PEM, the chain from the leaf):
    /// on a site, the console's own from the site PKI (`firefleet pki`), whose CA the
    /// commanders' browsers trust. Without it the page is plain HTTP, for loopback.
    #[arg(long, value_name = "FILE", requires = "https_key")]
    https_cert: Option<PathBuf>,
    /// The private key of --https-cert (PEM).
    #[arg(long, value_name = "FILE", requires = "https_cert")]
    https_key: Option<PathBuf>,
    /// Hours a login lasts.
    #[arg(long, default_value_t = 8.0, value_parser = positive_f64, allow_negative_numbers = true)]
    session_hours: f64,
    /// Keep the audit log (who issued, cleared and acknowledged what) and the alarms as they
    /// stand in DIR, so a restart keeps them (the packaged service: its StateDirectory).
    /// Without it, memory only.
    #[arg(long, value_name = "DIR")]
    state_dir: Option<PathBuf>,
}

pub async fn run(a: ConsoleArgs) -> anyhow::Result<ExitCode> {
    match a.command {
        Some(ConsoleCommand::AddUser(u)) => add_user(u),
        None => serve(a.serve).await,
    }
}

fn add_user(a: AddUserArgs) -> anyhow::Result<ExitCode> {
    let mut password = String::new();
    std::io::stdin()
        .read_line(&mut password)
        .context("reading the password from standard input")?;
    let password = password.trim_end_matches(['\r', '\n']);
    let role = if a.viewer {
        Role::Viewer
    } else {
        Role::Commander
    };
    Users::add(&a.users, a.name.clone(), password, role)?;
    println!(
        "{} may log in as a {} ({})",
        a.name,
        if a.viewer { "viewer" } else { "commander" },
        a.users.display()
    );
    Ok(ExitCode::SUCCESS)
}

async fn serve(a: ServeArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    let users = match &a.users {
        Some(path) => Users::load(path)?,
        None if a.http.ip().is_loopback() => {
            tracing::warn!(
                "no --users file: nobody can log in, and anyone on this host reads the incident"
            );
            Users::default()
        }
        None => anyhow::bail!(
            "--http {}: a console served beyond loopback needs --users (reads show the whole incident)",
            a.http
        ),
    };
    let open_reads = users.is_empty();
    let tls = match (&a.https_cert, &a.https_key) {
        (Some(cert), Some(key)) => Some(server_config(cert, key)?),
        _ => None,
    };
    let listener = tokio::net::TcpListener::bind(a.http)
        .await
        .with_context(|| format!("serving the console on {}", a.http))?;
    let bus = join(
        &a.role.zenoh,
        &scenario,
        Expect::Identity(Identity::Console),
    )
    .await?;
    a.role.metrics.serve(&bus, false, None).await?;
    let (records, kept) = match &a.state_dir {
        Some(dir) => {
            let (alarms, kept) = AlarmFile::open(dir).context("--state-dir")?;
            let records = Records {
                audit: Audit::open(dir).context("--state-dir")?,
                alarms,
                history: History::open(dir).context("--state-dir")?,
            };
            (records, kept)
        }
        None => (Records::in_memory(), Vec::new()),
    };
    let mut picture = Picture::new(SiteMap::new(&scenario));
    picture.restore_alerts(kept);
    let (console, requests) = Console::new(
        picture,
        users,
        Sessions::new(Duration::from_secs_f64(a.session_hours * 3600.0)),
        Serving {
            secure: tls.is_some(),
            open_reads,
        },
        records,
    );
    let bus = Arc::new(bus);
    let feed = {
        let (bus, console) = (bus.clone(), console.clone());
        tokio::spawn(async move {
            if let Err(e) = node::feed(bus, console).await {
                tracing::error!("the console no longer hears the bus: {e}");
            }
        })
    };
    let goals = tokio::spawn(node::carry_goals(bus.clone(), requests));
    let (feed, goals) = (feed.abort_handle(), goals.abort_handle());
    let ticker = {
        let console = console.clone();
        tokio::spawn(async move {
            let mut every = tokio::time::interval(TICK);
            every.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
            loop {
                every.tick().await;
                console.tick();
            }
        })
    };
    let stop = shutdown_signal(a.role.zenoh.die_with_parent);
    let served = match tls {
        Some(config) => {
            tracing::info!("console on https://{}", listener.local_addr()?);
            let listener = TlsListener::new(listener, config)?;
            serve_on(listener, console, stop).await
        }
        None => {
            tracing::info!("console on http://{}", listener.local_addr()?);
            serve_on(listener, console, stop).await
        }
    };
    for task in [feed, goals, ticker.abort_handle()] {
        task.abort();
    }
    if let Ok(bus) = Arc::try_unwrap(bus) {
        bus.close().await;
    }
    served.context("serving the console")?;
    Ok(ExitCode::SUCCESS)
}

/// Serve `console` on `listener` until `stop`, each request knowing its client's address
/// (the login throttle keys on it).
async fn serve_on<L>(
    listener: L,
    console: Arc<Console>,
    stop: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()>
where
    L: axum::serve::Listener,
    L::Addr: std::fmt::Debug,
    Peer: for<'a> axum::extract::connect_info::Connected<axum::serve::IncomingStream<'a, L>>,
{
    axum::serve(
        listener,
        console
            .router()
            .into_make_service_with_connect_info::<Peer>(),
    )
    .with_graceful_shutdown(stop)
    .await
}
