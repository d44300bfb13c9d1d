//! What the bridge knows between polls: the last good reading of every DTS zone and of the
//! ventilation, whether each could be read again since, and the link's counts.
//!
//! A poll's registers (or why there are none) go in, the site's messages come out. The
//! bridge never invents a value: a zone or the ventilation it could not read again is
//! published again as it last read it, marked stale with the time it was read, and a zone
//! never read is not published. The link is up when every register was read; a zone whose
//! registers make no sense is that zone's problem (stale, counted), not the link's.
//!
//! Not here: the Modbus connection and the bus ([`crate::node`]), or the register map and
//! its decoding (`firefleet_model::infra`).

use std::ops::Range;

use firefleet_model::infra::{DTS_REGISTERS_PER_ZONE, DtsReading, MAX_READ, ScadaMap, VentReading};
use firefleet_model::scenario::Scenario;
use firefleet_protocol::msg::{DtsZone, MAX_PROBLEM, ScadaLink, Vent};

/// What one poll failed on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Failure {
    /// A request to `server` unanswered within `after`.
    #[error("no answer from {server} within {after:?}")]
    Timeout {
        server: std::net::SocketAddr,
        after: std::time::Duration,
    },
    /// The connection to `server` could not be made, or was lost.
    #[error("{}", cut.said_of(*server))]
    Disconnected {
        server: std::net::SocketAddr,
        cut: Cut,
    },
    /// The server answered with a Modbus exception.
    #[error("Modbus exception {0}")]
    Exception(String),
    /// Registers outside what the map allows.
    #[error("{0}")]
    OutOfRange(String),
}

impl Failure {
    /// Whether the connection is no use after this failure (the next poll reconnects).
    pub fn drops_connection(&self) -> bool {
        matches!(self, Failure::Timeout { .. } | Failure::Disconnected { .. })
    }
}

/// Why a connection to the SCADA's Modbus server could not be made or was lost, in the
/// terms an operator acts on (the console shows it as the alarm's text): the socket's own
/// words ("Operation now in progress (os error 115)") name no cause and no fix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Cut {
    /// Something answers at the address, nothing listens on the port.
    Refused,
    /// Nothing answers at the address: the network between is cut or filtered.
    Unreachable,
    /// A connection that was up was closed or reset by the other end.
    Dropped,
    /// Anything else, in the system's words.
    Other(String),
}

impl Cut {
    /// The cause of the socket error `e`.
    pub fn of(e: &std::io::Error) -> Self {
        use std::io::ErrorKind as K;
        // Linux's EINPROGRESS: a non-blocking connect that never completed, what a
        // connection to an address nothing answers at ends in. (Stable Rust's ErrorKind
        // has no name for it yet, and the product runs on Linux.)
        const EINPROGRESS: i32 = 115;
        if e.raw_os_error() == Some(EINPROGRESS) {
            return Cut::Unreachable;
        }
        match e.kind() {
            K::ConnectionRefused => Cut::Refused,
            K::NetworkUnreachable
            | K::HostUnreachable
            | K::NetworkDown
            | K::TimedOut
            | K::AddrNotAvailable => Cut::Unreachable,
            K::ConnectionReset
            | K::ConnectionAborted
            | K::BrokenPipe
            | K::UnexpectedEof
            | K::NotConnected => Cut::Dropped,
            _ => Cut::Other(e.to_string()),
        }
    }

    /// What an operator reads of this cut of the link to `server`.
    pub fn said_of(&self, server: std::net::SocketAddr) -> String {
        match self {
            Cut::Refused => format!(
                "the SCADA's Modbus server at {server} refuses the connection: is it running, and on that port?"
            ),
            Cut::Unreachable => format!(
                "no way through to the SCADA's Modbus server at {server}: check the network between (cable, switch, firewall)"
            ),
            Cut::Dropped => format!("the SCADA's Modbus server at {server} dropped the connection"),
            Cut::Other(why) => format!("the link to the SCADA's Modbus server at {server}: {why}"),
        }
    }
}

/// The registers of one poll: the DTS block and the ventilation block, each in order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Registers {
    pub dts: Vec<u16>,
    pub vent: Vec<u16>,
}

/// A reading as last read: when, what, and whether it could not be read again since.
#[derive(Debug, Clone, PartialEq)]
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

/// The bridge's state for one site's map.
#[derive(Debug, Clone)]
pub struct Bridge {
    map: ScadaMap,
    length_m: f64,
    fans: usize,
    /// Per zone, its last good reading.
    zones: Vec<Option<Held<DtsReading>>>,
    vent: Option<Held<VentReading>>,
    link: ScadaLink,
}

impl Bridge {
    /// The bridge of `scenario`'s site, reading by `map`; nothing read yet.
    pub fn new(scenario: &Scenario, map: ScadaMap) -> Self {
        let length_m = scenario.tunnel.length_m;
        let zones = vec![None; map.zone_count(length_m)];
        Self {
            fans: scenario.ventilation.as_ref().map_or(0, |v| v.fans.len()),
            length_m,
            map,
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

    /// The Modbus unit id the map names.
    pub fn unit_id(&self) -> u8 {
        self.map.unit_id
    }

    /// The requests of one poll, (first register, count): whole DTS zones per request, as
    /// many as a request may carry, then the ventilation block.
    pub fn requests(&self) -> (Vec<(u16, u16)>, (u16, u16)) {
        let per_read = (MAX_READ / DTS_REGISTERS_PER_ZONE) * DTS_REGISTERS_PER_ZONE;
        let dts = self.map.dts_block(self.length_m);
        let mut reads = Vec::new();
        let mut at = dts.start;
        while at < dts.end {
            let n = (dts.end - at).min(u32::from(per_read)) as u16;
            reads.push((at as u16, n));
            at += u32::from(n);
        }
        let Range { start, end } = self.map.vent_block(self.fans);
        (reads, (start as u16, (end - start) as u16))
    }

    /// Take one poll at site time `t`: its registers, or why the link failed. Returns the
    /// failures counted (the link's, or each zone's and the ventilation's).
    pub fn poll(&mut self, t: f64, read: Result<Registers, Failure>) -> Vec<Failure> {
        self.link.t = t;
        self.link.polls += 1;
        self.link.up = read.is_ok();
        if self.link.up {
            self.link.last_ok = Some(t);
        }
        let before = std::mem::take(&mut self.link.problem);
        let failures = match read {
            Ok(regs) => self.take(t, &regs),
            Err(f) => {
                // Nothing read this time: everything held is now stale.
                self.zones.iter_mut().for_each(spoil);
                spoil(&mut self.vent);
                vec![f]
            }
        };
        for f in &failures {
            match f {
                Failure::Timeout { .. } => self.link.timeouts += 1,
                Failure::Disconnected { .. } => self.link.disconnects += 1,
                Failure::Exception(_) => self.link.exceptions += 1,
                Failure::OutOfRange(_) => self.link.out_of_range += 1,
            }
            self.link.problem = f.to_string().chars().take(MAX_PROBLEM).collect();
        }
        // Said once when it starts, not every second it lasts.
        if self.link.problem != before {
            match self.link.problem.as_str() {
                "" => tracing::info!(t, "SCADA: every register read again"),
                problem => tracing::warn!(t, "SCADA: {problem}"),
            }
        }
        failures
    }

    /// The zones and fans of a complete read: each decoded or, failing its check, stale.
    fn take(&mut self, t: f64, regs: &Registers) -> Vec<Failure> {
        let mut failures = Vec::new();
        for (k, chunk) in regs
            .dts
            .chunks_exact(usize::from(DTS_REGISTERS_PER_ZONE))
            .enumerate()
            .take(self.zones.len())
        {
            match self.map.decode_zone(k, chunk) {
                Ok(r) => self.zones[k] = Some(Held::new(t, r)),
                Err(e) => {
                    spoil(&mut self.zones[k]);
                    failures.push(Failure::OutOfRange(e.to_string()));
                }
            }
        }
        match self.map.decode_vent(&regs.vent, self.fans) {
            Ok(v) => self.vent = Some(Held::new(t, v)),
            Err(e) => {
                spoil(&mut self.vent);
                failures.push(Failure::OutOfRange(e.to_string()));
            }
        }
        failures
    }

    /// Every zone ever read, as last read (or stale).
    pub fn zones(&self) -> impl Iterator<Item = DtsZone> + '_ {
        self.zones.iter().enumerate().filter_map(|(k, z)| {
            let z = z.as_ref()?;
            let (start_m, end_m) = self.map.zone_span(k, self.length_m);
            Some(DtsZone {
                zone: k as u16,
                start_m,
                end_m,
                t: z.t,
                reading: z.reading,
                stale: z.stale,
            })
        })
    }

    /// The ventilation, as last read (or stale), if ever read.
    pub fn vent(&self) -> Option<Vent> {
        self.vent.as_ref().map(|v| Vent {
            t: v.t,
            reading: v.reading.clone(),
            stale: v.stale,
        })
    }

    /// The link's state and counts.
    pub fn link(&self) -> &ScadaLink {
        &self.link
    }
}

#[cfg(test)]
mod tests {
    use firefleet_model::builtin;
    use firefleet_model::infra::{DtsAlarm, FanState};

    use super::*;

    fn bridge() -> (Bridge, ScadaMap, usize) {
        let s = builtin::resolve("ventilated").unwrap();
        let map = s.scada.clone().unwrap();
        let fans = s.ventilation.as_ref().unwrap().fans.len();
        (Bridge::new(&s, map.clone()), map, fans)
    }

    /// What a SCADA holds: every zone at `c`, the ventilation's air.
    fn registers(b: &Bridge, map: &ScadaMap, fans: usize, c: f64) -> Registers {
        let zones = vec![
            DtsReading {
                max_c: c,
                rise_c_min: 0.0,
                alarm: DtsAlarm::default(),
                fault: false,
            };
            b.zones.len()
        ];
        let vent = VentReading {
            air_m_s: 2.0,
            fans: vec![FanState::Forward; fans],
        };
        Registers {
            dts: map.encode_dts(&zones),
            vent: map.encode_vent(&vent),
        }
    }

    #[test]
    fn readings_are_published_as_read_then_stale_never_invented() {
        let (mut b, map, fans) = bridge();
        assert_eq!(b.zones().count(), 0, "nothing before the first read");
        let timeout = Failure::Timeout {
            server: "127.0.0.1:502".parse().unwrap(),
            after: std::time::Duration::from_secs(1),
        };
        assert!(b.poll(1.0, Err(timeout))[0].drops_connection());
        assert_eq!(b.zones().count(), 0, "a zone never read is not published");
        assert!(!b.link().up);
        let regs = registers(&b, &map, fans, 40.0);
        assert!(b.poll(2.0, Ok(regs)).is_empty());
        assert!(b.link().up);
        assert_eq!(b.link().problem, "");
        let z: Vec<DtsZone> = b.zones().collect();
        assert_eq!(z.len(), b.zones.len());
        assert!(
            z.iter()
                .all(|z| !z.stale && z.t == 2.0 && (z.reading.max_c - 40.0).abs() < 0.2)
        );
        // The link is cut: everything is sent again as it was read, stale, with its time.
        b.poll(
            3.0,
            Err(Failure::Disconnected {
                server: "10.0.0.5:502".parse().unwrap(),
                cut: Cut::Refused,
            }),
        );
        assert!(b.zones().all(|z| z.stale && z.t == 2.0));
        assert!(b.vent().is_some_and(|v| v.stale && v.t == 2.0));
        assert_eq!(
            (b.link().timeouts, b.link().disconnects, b.link().polls),
            (1, 1, 3)
        );
        assert_eq!(b.link().last_ok, Some(2.0));
    }

    #[test]
    fn a_zone_that_makes_no_sense_is_that_zone_s_problem_not_the_link_s() {
        let (mut b, map, fans) = bridge();
        let mut regs = registers(&b, &map, fans, 40.0);
        b.poll(1.0, Ok(regs.clone()));
        // Zone 3's status word with every bit set: undefined bits.
        regs.dts[3 * usize::from(DTS_REGISTERS_PER_ZONE) + 2] = u16::MAX;
        let failures = b.poll(2.0, Ok(regs));
        assert_eq!(failures.len(), 1, "{failures:?}");
        assert!(matches!(failures[0], Failure::OutOfRange(_)));
        assert!(b.link().up, "every register was read");
        assert_eq!(b.link().out_of_range, 1);
        let z: Vec<DtsZone> = b.zones().collect();
        assert!(z[3].stale && z[3].t == 1.0);
        assert!(
            z.iter()
                .enumerate()
                .all(|(k, z)| k == 3 || (!z.stale && z.t == 2.0))
        );
    }

    #[test]
    fn requests_cover_the_map_in_whole_zones() {
        let (b, map, fans) = bridge();
        let (dts, (vent_at, vent_n)) = b.requests();
        let block = map.dts_block(b.length_m);
        assert_eq!(u32::from(dts[0].0), block.start);
        assert!(
            dts.iter()
                .all(|&(_, n)| n <= MAX_READ && n % DTS_REGISTERS_PER_ZONE == 0)
        );
        assert_eq!(
            dts.iter().map(|&(_, n)| u32::from(n)).sum::<u32>(),
            block.len() as u32
        );
        assert_eq!(
            map.vent_block(fans),
            u32::from(vent_at)..u32::from(vent_at) + u32::from(vent_n)
        );
    }

    /// The socket's words name no cause; the operator's do, with where to look.
    #[test]
    fn a_cut_link_is_said_as_an_operator_acts_on_it() {
        use std::io::{Error, ErrorKind};
        let server = "10.0.0.5:502".parse().unwrap();
        let said = |e: Error| {
            Failure::Disconnected {
                server,
                cut: Cut::of(&e),
            }
            .to_string()
        };
        assert_eq!(
            said(Error::from(ErrorKind::ConnectionRefused)),
            "the SCADA's Modbus server at 10.0.0.5:502 refuses the connection: is it running, and on that port?"
        );
        // What a connect to an address nothing answers at gave on the site.
        let in_progress = Error::from_raw_os_error(115);
        assert!(
            said(in_progress)
                .starts_with("no way through to the SCADA's Modbus server at 10.0.0.5:502"),
        );
        assert!(said(Error::from(ErrorKind::ConnectionReset)).ends_with("dropped the connection"));
        assert!(said(Error::other("odd")).ends_with("10.0.0.5:502: odd"));
    }
}
