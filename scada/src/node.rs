//! The bridge as a process on the bus: every period it reads the SCADA's input registers
//! over Modbus TCP, hands them to the [`Bridge`], and publishes what it holds on
//! `ff/<site>/infra/dts/<zone>`, `ff/<site>/infra/vent` and `ff/<site>/infra/link`.
//!
//! A timeout or a lost connection drops the connection; the next poll reconnects.
//!
//! Not here: what is held and how it goes stale ([`crate::bridge`]), or joining the bus
//! and the process's signals (the `firefleet scada` command).

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use firefleet_bus::{Bus, BusError};
use firefleet_model::clock::{Clock, ExternalClock, SystemClock};
use firefleet_model::infra::ScadaMap;
use firefleet_model::scenario::Scenario;
use tokio_modbus::Slave;
use tokio_modbus::client::{Context as Modbus, Reader};

use crate::bridge::{Bridge, Cut, Failure, Registers};

/// How the bridge runs.
#[derive(Debug, Clone)]
pub struct ScadaOptions {
    /// The SCADA's Modbus TCP server.
    pub modbus: SocketAddr,
    /// Time between polls.
    pub period: Duration,
    /// Time a request may take before the link counts as down.
    pub timeout: Duration,
    /// Follow the simulator's clock (`ff/<site>/sim/clock`) instead of the system clock.
    pub sim_clock: bool,
}

/// Bridge `scenario`'s SCADA, read by `map`, onto `bus` until `shutdown` completes.
pub async fn run(
    bus: &Bus,
    scenario: &Scenario,
    map: ScadaMap,
    opts: &ScadaOptions,
    shutdown: impl Future<Output = ()>,
) -> Result<(), BusError> {
    let site_time = ExternalClock::new(0.0);
    let clock: Arc<dyn Clock> = if opts.sim_clock {
        Arc::new(site_time.clone())
    } else {
        Arc::new(SystemClock)
    };
    let clock_msgs = bus.subscribe(&bus.keys().sim_clock()).await?;
    let mut bridge = Bridge::new(scenario, map);
    let mut link = Link {
        addr: opts.modbus,
        timeout: opts.timeout,
        modbus: None,
    };
    tracing::info!(modbus = %opts.modbus, period = ?opts.period, "bridging the tunnel's SCADA");
    let mut ticker = tokio::time::interval(opts.period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    tokio::pin!(shutdown);
    // On the simulator's clock, nothing is polled before the clock is heard: a reading
    // stamped t = 0 by a bridge restarted mid-incident is refused by the coordinator as
    // off the site clock, and the first rates of rise would be taken against it.
    let mut clocked = !opts.sim_clock;
    loop {
        tokio::select! {
            _ = &mut shutdown => return Ok(()),
            Some((_, c)) = clock_msgs.recv() => {
                site_time.set(c.t);
                clocked = true;
            }
            _ = ticker.tick(), if clocked => {
                let read = link.read(&bridge).await;
                if bridge.poll(clock.now(), read).iter().any(Failure::drops_connection) {
                    link.modbus = None;
                }
                publish(bus, &bridge).await?;
            }
        }
    }
}

/// Everything held, as read (or stale), and the link.
async fn publish(bus: &Bus, bridge: &Bridge) -> Result<(), BusError> {
    let keys = bus.keys();
    for zone in bridge.zones() {
        bus.put(&keys.infra_dts(zone.zone), &zone).await?;
    }
    if let Some(vent) = bridge.vent() {
        bus.put(&keys.infra_vent(), &vent).await?;
    }
    bus.put(&keys.infra_link(), bridge.link()).await
}

/// The connection to the SCADA's server, made when a poll needs it.
struct Link {
    addr: SocketAddr,
    timeout: Duration,
    modbus: Option<Modbus>,
}

impl Link {
    /// Every register of one poll of `bridge`'s map, or why not.
    async fn read(&mut self, bridge: &Bridge) -> Result<Registers, Failure> {
        let (server, after) = (self.addr, self.timeout);
        let modbus = match &mut self.modbus {
            Some(m) => m,
            None => {
                let ctx = tokio::time::timeout(
                    after,
                    tokio_modbus::client::tcp::connect_slave(self.addr, Slave(bridge.unit_id())),
                )
                .await
                .map_err(|_| Failure::Timeout { server, after })?
                .map_err(|e| Failure::Disconnected {
                    server,
                    cut: Cut::of(&e),
                })?;
                tracing::info!(addr = %self.addr, "SCADA link up");
                self.modbus.insert(ctx)
            }
        };
        let (dts, (vent_at, vent_n)) = bridge.requests();
        let mut regs = Registers::default();
        for (at, n) in dts {
            regs.dts.extend(read(modbus, at, n, server, after).await?);
        }
        regs.vent = read(modbus, vent_at, vent_n, server, after).await?;
        Ok(regs)
    }
}

/// `n` input registers from register `at` of `server`, within `after`.
async fn read(
    modbus: &mut Modbus,
    at: u16,
    n: u16,
    server: SocketAddr,
    after: Duration,
) -> Result<Vec<u16>, Failure> {
    tokio::time::timeout(after, modbus.read_input_registers(at, n))
        .await
        .map_err(|_| Failure::Timeout { server, after })?
        .map_err(|e| Failure::Disconnected {
            server,
            cut: match e {
                tokio_modbus::Error::Transport(io) => Cut::of(&io),
                tokio_modbus::Error::Protocol(p) => Cut::Other(p.to_string()),
            },
        })?
        .map_err(|e| Failure::Exception(format!("{e:?}")))
}
