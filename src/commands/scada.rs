//! `firefleet scada`: the bridge from the tunnel's SCADA to the fleet's bus.
//!
//! Every period (1 s unless told) it reads the DTS zones and the ventilation as Modbus
//! input registers by the site file's map ([`firefleet_model::infra`]) and publishes them,
//! typed and validated, on `ff/<site>/infra/dts/<zone>` and `ff/<site>/infra/vent`, with
//! the state of the link on `ff/<site>/infra/link`.
//!
//! What goes wrong is counted by kind on the link message and in the log: a request
//! unanswered within the timeout, the connection lost or refused, a Modbus exception, a
//! register outside what the map allows. The bridge never invents a value: a zone or the
//! ventilation it could not read again is published again as it last read it, marked stale
//! with the time it was read, and a zone never read is not published. A timeout or a lost
//! connection drops the connection; the next poll reconnects.
//!
//! Not here: what the coordinator makes of the readings
//! (`firefleet_coordinator::incident`), or the simulator's server (`firefleet_sim::scada`).

use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use firefleet_bus::Bus;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_model::clock::{Clock, ExternalClock, SystemClock};
use firefleet_model::infra::{DTS_REGISTERS_PER_ZONE, DtsReading, MAX_READ, ScadaMap, VentReading};
use firefleet_model::scenario::Scenario;
use firefleet_protocol::msg::{DtsZone, MAX_PROBLEM, ScadaLink, Vent};
use tokio_modbus::client::{Context as Modbus, Reader};
use tokio_modbus::{ExceptionCode, Slave};

use super::{ScenarioArg, positive_f64};
use firefleet::net::{ZenohArgs, join, shutdown_signal};

#[derive(Args, Debug)]
pub struct ScadaArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    #[command(flatten)]
    metrics: crate::metrics::MetricsArg,
    /// The SCADA's Modbus TCP server, HOST:PORT.
    #[arg(long, value_name = "HOST:PORT")]
    modbus: SocketAddr,
    /// Seconds between polls.
    #[arg(long, default_value_t = 1.0, value_parser = positive_f64, allow_negative_numbers = true)]
    period_s: f64,
    /// Seconds a request may take before the link counts as down.
    #[arg(long, default_value_t = 1.0, value_parser = positive_f64, allow_negative_numbers = true)]
    timeout_s: f64,
    /// Follow the simulator's clock (implied on a site whose file says `simulated = true`).
    #[arg(long)]
    sim_clock: bool,
}

pub async fn run(a: ScadaArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.scenario.load()?;
    let map = scenario.scada.clone().with_context(|| {
        format!(
            "site '{}': its file maps no [scada] (see the site file format)",
            scenario.site
        )
    })?;
    let sim_clock = super::sim_clock(&scenario, a.sim_clock).map_err(anyhow::Error::msg)?;
    let bus = join(&a.zenoh, &scenario, Expect::Identity(Identity::Scada)).await?;
    a.metrics.serve(&bus, false, None).await?;
    let site_time = ExternalClock::new(0.0);
    let clock: Arc<dyn Clock> = if sim_clock {
        Arc::new(site_time.clone())
    } else {
        Arc::new(SystemClock)
    };
    let clock_msgs = bus.subscribe(&bus.keys().sim_clock()).await?;
    let mut bridge = Bridge::new(
        &scenario,
        map,
        a.modbus,
        Duration::from_secs_f64(a.timeout_s),
    );
    tracing::info!(modbus = %a.modbus, period_s = a.period_s, "bridging the tunnel's SCADA");
    firefleet::net::ready();
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(a.period_s));
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let shutdown = shutdown_signal(a.zenoh.die_with_parent);
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            _ = &mut shutdown => break,
            Some((_, c)) = clock_msgs.recv() => site_time.set(c.t),
            _ = ticker.tick() => {
                bridge.poll(clock.now()).await;
                bridge.publish(&bus).await?;
            }
        }
    }
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// What one poll failed on.
#[derive(Debug)]
enum Failure {
    Timeout,
    Disconnected(String),
    Exception(ExceptionCode),
    OutOfRange(String),
}

/// A reading as last read: when, what, and whether it could not be read again since.
#[derive(Debug, Clone)]
struct Held<T> {
    t: f64,
    reading: T,
    stale: bool,
}

impl<T> Held<T> {
    fn new(t: f64, reading: T) -> Self {
        Self {
            t,
            reading,
            stale: false,
        }
    }
}

/// Mark what `held` holds stale: it could not be read again.
fn spoil<T>(held: &mut Option<Held<T>>) {
    if let Some(h) = held {
        h.stale = true;
    }
}

/// The bridge's state: its connection, the last good readings and the counts.
struct Bridge {
    map: ScadaMap,
    length_m: f64,
    fans: usize,
    addr: SocketAddr,
    timeout: Duration,
    modbus: Option<Modbus>,
    /// Per zone, its last good reading.
    zones: Vec<Option<Held<DtsReading>>>,
    vent: Option<Held<VentReading>>,
    link: ScadaLink,
}

impl Bridge {
    fn new(scenario: &Scenario, map: ScadaMap, addr: SocketAddr, timeout: Duration) -> Self {
        let length_m = scenario.tunnel.length_m;
        let zones = vec![None; map.zone_count(length_m)];
        Self {
            fans: scenario.ventilation.as_ref().map_or(0, |v| v.fans.len()),
            length_m,
            map,
            addr,
            timeout,
            modbus: None,
            zones,
            vent: None,
            link: ScadaLink {
                t: 0.0,
                up: false,
                last_ok: None,
                polls: 0,
                timeouts: 0,
                disconnects: 0,
                exceptions: 0,
                out_of_range: 0,
                problem: "not polled yet".into(),
            },
        }
    }

    /// Read everything at site time `t`; what fails is counted and goes stale.
    async fn poll(&mut self, t: f64) {
        self.link.t = t;
        self.link.polls += 1;
        // The link holds when every register was read; a zone whose registers make no
        // sense is that zone's problem (stale, counted), not the link's.
        let read = self.read(t).await;
        self.link.up = read.is_ok();
        if self.link.up {
            self.link.last_ok = Some(t);
        }
        let before = std::mem::take(&mut self.link.problem);
        let failures = match read {
            Ok(failures) => failures,
            Err(f) => {
                // Nothing read this time: everything held is now stale.
                self.zones.iter_mut().for_each(spoil);
                spoil(&mut self.vent);
                vec![f]
            }
        };
        for f in failures {
            let problem = match &f {
                Failure::Timeout => {
                    self.link.timeouts += 1;
                    self.modbus = None;
                    format!("no answer from {} within {:?}", self.addr, self.timeout)
                }
                Failure::Disconnected(e) => {
                    self.link.disconnects += 1;
                    self.modbus = None;
                    format!("{}: {e}", self.addr)
                }
                Failure::Exception(e) => {
                    self.link.exceptions += 1;
                    format!("Modbus exception {e:?}")
                }
                Failure::OutOfRange(e) => {
                    self.link.out_of_range += 1;
                    e.clone()
                }
            };
            self.link.problem = problem.chars().take(MAX_PROBLEM).collect();
        }
        // Said once when it starts, not every second it lasts.
        if self.link.problem != before {
            match self.link.problem.as_str() {
                "" => tracing::info!(t, "SCADA: every register read again"),
                problem => tracing::warn!(t, "SCADA: {problem}"),
            }
        }
    }

    /// One read of every register; the zones and fans read are taken, each zone or the
    /// ventilation that failed its check goes stale. `Err` when the link itself failed.
    async fn read(&mut self, t: f64) -> Result<Vec<Failure>, Failure> {
        let modbus = match &mut self.modbus {
            Some(m) => m,
            None => {
                let ctx = tokio::time::timeout(
                    self.timeout,
                    tokio_modbus::client::tcp::connect_slave(self.addr, Slave(self.map.unit_id)),
                )
                .await
                .map_err(|_| Failure::Timeout)?
                .map_err(|e| Failure::Disconnected(e.to_string()))?;
                tracing::info!(addr = %self.addr, "SCADA link up");
                self.modbus.insert(ctx)
            }
        };
        let dts = self.map.dts_block(self.length_m);
        // Whole zones per request, as many as a request may carry.
        let per_read = (MAX_READ / DTS_REGISTERS_PER_ZONE) * DTS_REGISTERS_PER_ZONE;
        let mut regs = Vec::with_capacity(dts.len());
        let mut at = dts.start;
        while at < dts.end {
            let n = (dts.end - at).min(u32::from(per_read)) as u16;
            regs.extend(read(modbus, at as u16, n, self.timeout).await?);
            at += u32::from(n);
        }
        let vent = self.map.vent_block(self.fans);
        let vent_regs = read(
            modbus,
            vent.start as u16,
            (vent.end - vent.start) as u16,
            self.timeout,
        )
        .await?;
        let mut failures = Vec::new();
        for (k, chunk) in regs
            .chunks_exact(usize::from(DTS_REGISTERS_PER_ZONE))
            .enumerate()
        {
            match self.map.decode_zone(k, chunk) {
                Ok(r) => self.zones[k] = Some(Held::new(t, r)),
                Err(e) => {
                    spoil(&mut self.zones[k]);
                    failures.push(Failure::OutOfRange(e.to_string()));
                }
            }
        }
        match self.map.decode_vent(&vent_regs, self.fans) {
            Ok(v) => self.vent = Some(Held::new(t, v)),
            Err(e) => {
                spoil(&mut self.vent);
                failures.push(Failure::OutOfRange(e.to_string()));
            }
        }
        Ok(failures)
    }

    /// Everything held, as read (or stale), and the link.
    async fn publish(&self, bus: &Bus) -> anyhow::Result<()> {
        let keys = bus.keys();
        for (k, z) in self.zones.iter().enumerate() {
            let Some(z) = z else {
                continue;
            };
            let (start_m, end_m) = self.map.zone_span(k, self.length_m);
            let zone = k as u16;
            let msg = DtsZone {
                zone,
                start_m,
                end_m,
                t: z.t,
                reading: z.reading,
                stale: z.stale,
            };
            bus.put(&keys.infra_dts(zone), &msg).await?;
        }
        if let Some(v) = &self.vent {
            let msg = Vent {
                t: v.t,
                reading: v.reading.clone(),
                stale: v.stale,
            };
            bus.put(&keys.infra_vent(), &msg).await?;
        }
        bus.put(&keys.infra_link(), &self.link).await?;
        Ok(())
    }
}

/// `n` input registers from `addr`, within `timeout`.
async fn read(
    modbus: &mut Modbus,
    addr: u16,
    n: u16,
    timeout: Duration,
) -> Result<Vec<u16>, Failure> {
    tokio::time::timeout(timeout, modbus.read_input_registers(addr, n))
        .await
        .map_err(|_| Failure::Timeout)?
        .map_err(|e| Failure::Disconnected(e.to_string()))?
        .map_err(Failure::Exception)
}
