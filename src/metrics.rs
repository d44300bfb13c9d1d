//! `--metrics ADDR`: a long-running role's health and figures over HTTP, for the site's
//! monitoring (Prometheus, a load balancer's or an orchestrator's probes).
//!
//! - `/healthz`: 200 while the process serves at all.
//! - `/readyz`: 200 while it is linked to the site (a router or a peer; a router, once it
//!   listens) and nothing holds it back, else 503 with the reason: a unit whose router is
//!   gone is alive, not ready; so is one the coordinator does not know ([`Metrics::hold_back`]).
//! - `/metrics`: Prometheus text: `firefleet_links` by `with` (the routers, peers and, on a
//!   router, clients linked),
//!   `firefleet_messages_sent` and `_received` (valid messages), `firefleet_messages_rejected`
//!   by reason (the bus's refusal classes), `firefleet_ready`, and the role's own figures
//!   (the coordinator's report-to-task latency histogram, fires, tasks, lease misses:
//!   `firefleet_coordinator::stats`).
//!
//! Figures are read when scraped, from the bus's counters and the role's shared metrics;
//! nothing here is on the path of a message. Bind it to the site's management network or
//! loopback: it tells whoever reaches it what the role sees (counts, not contents).
//!
//! Not here: the figures' meaning (where they are counted).

use std::net::SocketAddr;
use std::sync::Arc;

use anyhow::Context;
use axum::Router;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::IntoResponse;
use axum::routing::get;
use clap::Args;
use firefleet_bus::Bus;
use prometheus_client::encoding::text::encode;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::registry::Registry;

/// Where a role serves its health and metrics.
#[derive(Args, Clone, Debug, Default)]
pub struct MetricsArg {
    /// Serve /healthz, /readyz and Prometheus /metrics on ADDR (e.g. 127.0.0.1:9464).
    #[arg(long, value_name = "ADDR")]
    pub metrics: Option<SocketAddr>,
}

/// A role's own figures, registered afresh at each scrape.
pub type Figures = Arc<dyn Fn(&mut Registry) + Send + Sync>;

/// Why a role linked to the site is still not ready, if it is not: asked at each probe.
pub type HeldBack = Arc<dyn Fn() -> Option<String> + Send + Sync>;

struct Served {
    /// The role's session: a unit that moves to a nearer router changes it.
    bus: std::sync::RwLock<Bus>,
    /// A router is ready once it listens; it has no router to be linked to.
    router: bool,
    figures: Option<Figures>,
    held_back: std::sync::RwLock<Option<HeldBack>>,
}

impl MetricsArg {
    /// Serve for `bus`'s role, if asked, from a task of its own; a port that cannot be
    /// bound ends the role with the reason (a monitoring that silently sees nothing is
    /// worse than a service that says it cannot start).
    pub async fn serve(
        &self,
        bus: &Bus,
        router: bool,
        figures: Option<Figures>,
    ) -> anyhow::Result<Metrics> {
        let Some(addr) = self.metrics else {
            return Ok(Metrics(None));
        };
        let listener = tokio::net::TcpListener::bind(addr)
            .await
            .with_context(|| format!("--metrics {addr}"))?;
        let served = Arc::new(Served {
            bus: std::sync::RwLock::new(bus.clone()),
            router,
            figures,
            held_back: std::sync::RwLock::new(None),
        });
        let app = Router::new()
            .route("/healthz", get(|| async { "ok\n" }))
            .route("/readyz", get(readyz))
            .route("/metrics", get(metrics))
            .with_state(served.clone());
        tracing::info!(%addr, "health and metrics served");
        tokio::spawn(async move {
            if let Err(e) = axum::serve(listener, app).await {
                tracing::warn!("the metrics server stopped: {e}");
            }
        });
        Ok(Metrics(Some(served)))
    }
}

/// What a role serves its health and metrics from, if it does.
pub struct Metrics(Option<Arc<Served>>);

impl Metrics {
    /// Not ready, even linked, while `why` says why (a unit the coordinator does not know).
    pub fn hold_back(&self, why: HeldBack) {
        if let Some(s) = &self.0 {
            *s.held_back
                .write()
                .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(why);
        }
    }

    /// Serve from `bus` from now on (a unit that moved to another router).
    pub fn follow(&self, bus: &Bus) {
        if let Some(s) = &self.0 {
            *s.bus
                .write()
                .unwrap_or_else(std::sync::PoisonError::into_inner) = bus.clone();
        }
    }
}

impl Served {
    fn bus(&self) -> Bus {
        self.bus
            .read()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }

    /// Ready, or why not.
    async fn ready(&self) -> Result<(), String> {
        if !(self.router || self.bus().connected().await) {
            return Err("not linked to the site: no router or peer".to_owned());
        }
        let held = self
            .held_back
            .read()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone();
        match held.and_then(|why| why()) {
            Some(why) => Err(why),
            None => Ok(()),
        }
    }
}

async fn readyz(State(s): State<Arc<Served>>) -> impl IntoResponse {
    match s.ready().await {
        Ok(()) => (StatusCode::OK, "ready\n".to_owned()),
        Err(why) => (StatusCode::SERVICE_UNAVAILABLE, format!("{why}\n")),
    }
}

async fn metrics(State(s): State<Arc<Served>>) -> impl IntoResponse {
    let mut registry = Registry::with_prefix("firefleet");
    let bus = s.bus();
    let linked = bus.linked().await;
    let links = Family::<Vec<(&'static str, &'static str)>, Gauge>::default();
    for (with, n) in [
        ("router", linked.routers),
        ("peer", linked.peers),
        ("client", linked.clients),
    ] {
        links.get_or_create(&vec![("with", with)]).set(n as i64);
    }
    registry.register(
        "links",
        "Zenoh sessions this process holds, by the far end (a router counts its clients)",
        links,
    );
    let ready = Gauge::<i64>::default();
    ready.set(i64::from(s.ready().await.is_ok()));
    registry.register("ready", "1 while linked to the site (see /readyz)", ready);
    let sent = Counter::<u64>::default();
    sent.inc_by(bus.traffic().sent());
    registry.register("messages_sent", "Messages put on the bus", sent);
    let received = Counter::<u64>::default();
    received.inc_by(bus.traffic().received());
    registry.register(
        "messages_received",
        "Valid messages taken off the bus",
        received,
    );
    let rejected = Family::<Vec<(&'static str, &'static str)>, Counter>::default();
    for (reason, n) in bus.rejects().snapshot() {
        rejected.get_or_create(&vec![("reason", reason)]).inc_by(n);
    }
    registry.register(
        "messages_rejected",
        "Messages refused on receipt, by reason",
        rejected,
    );
    if let Some(figures) = &s.figures {
        figures(&mut registry);
    }
    let mut text = String::new();
    match encode(&mut text, &registry) {
        Ok(()) => (
            StatusCode::OK,
            [(
                header::CONTENT_TYPE,
                "application/openmetrics-text; version=1.0.0; charset=utf-8",
            )],
            text,
        ),
        Err(e) => (
            StatusCode::INTERNAL_SERVER_ERROR,
            [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
            format!("encoding the metrics: {e}\n"),
        ),
    }
}
