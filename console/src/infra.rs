//! The tunnel's own senses as the commander sees them: the ceiling's temperature along the
//! tunnel by DTS zone, the zones in alarm, the fans and the air's direction, and whether
//! the link to the tunnel's SCADA holds.
//!
//! What the bridge (`firefleet scada`) marks stale stays on the page marked stale, with
//! the site time it was read: a commander sees an old reading as old, never as news. The
//! link's state comes from the bridge's own word (`infra/link`) and from its silence: a
//! bridge not heard for [`SILENT_MS`] is as good as a cut link.
//!
//! Not here: the rest of the picture ([`crate::picture`]), or what the coordinator makes of
//! the readings.

use std::collections::BTreeMap;

use firefleet_model::infra::FanState;
use firefleet_protocol::msg::{DtsZone, ScadaLink, Vent};
use serde::Serialize;

/// A bridge not heard for this long is taken for gone, ms (it speaks every second).
pub const SILENT_MS: u64 = 5000;

/// One zone as the page draws it.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ZoneView {
    pub zone: u16,
    pub start_m: f64,
    pub end_m: f64,
    /// Degrees C, to 0.1.
    pub max_c: f64,
    pub alarm: bool,
    pub fault: bool,
    pub stale: bool,
    /// Site time it was read.
    pub t: f64,
}

/// The ventilation as the page draws it.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct VentView {
    /// m/s, positive towards the tunnel's end.
    pub air_m_s: f64,
    pub fans: Vec<FanState>,
    pub stale: bool,
    pub t: f64,
}

/// What the page is sent.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct InfraView {
    pub zones: Vec<ZoneView>,
    pub vent: Option<VentView>,
    /// The link to the SCADA holds: the bridge says so and is heard. None until heard.
    pub link_up: Option<bool>,
    /// What the bridge says went wrong, while the link is down.
    pub problem: String,
    /// Site time of the last good read.
    pub last_ok: Option<f64>,
}

/// What the console knows of the tunnel's senses.
#[derive(Debug, Default)]
pub struct Infra {
    zones: BTreeMap<u16, ZoneView>,
    vent: Option<VentView>,
    link: Option<ScadaLink>,
    /// When the bridge was last heard, ms.
    heard_ms: Option<u64>,
}

fn tenth(v: f64) -> f64 {
    (v * 10.0).round() / 10.0
}

impl Infra {
    /// Whether anything has been heard: a site without a bridge shows no layer.
    pub fn heard(&self) -> bool {
        self.heard_ms.is_some()
    }

    pub fn zone(&mut self, now_ms: u64, z: DtsZone) {
        self.heard_ms = Some(now_ms);
        if self.zones.get(&z.zone).is_some_and(|old| old.t > z.t) {
            return;
        }
        self.zones.insert(
            z.zone,
            ZoneView {
                zone: z.zone,
                start_m: z.start_m,
                end_m: z.end_m,
                max_c: tenth(z.reading.max_c),
                alarm: z.reading.alarm.any(),
                fault: z.reading.fault,
                stale: z.stale,
                t: z.t,
            },
        );
    }

    pub fn vent(&mut self, now_ms: u64, v: Vent) {
        self.heard_ms = Some(now_ms);
        if self.vent.as_ref().is_some_and(|old| old.t > v.t) {
            return;
        }
        self.vent = Some(VentView {
            air_m_s: tenth(v.reading.air_m_s),
            fans: v.reading.fans,
            stale: v.stale,
            t: v.t,
        });
    }

    /// The bridge's word on its link.
    pub fn link(&mut self, now_ms: u64, l: ScadaLink) {
        self.heard_ms = Some(now_ms);
        self.link = Some(l);
    }

    /// The link holds at `now_ms`: the bridge says so and was heard lately.
    pub fn up(&self, now_ms: u64) -> Option<bool> {
        let heard = self.heard_ms?;
        Some(self.link.as_ref().is_some_and(|l| l.up) && now_ms < heard.saturating_add(SILENT_MS))
    }

    /// The layer at `now_ms`: a silent bridge's readings all count as stale.
    pub fn view(&self, now_ms: u64) -> InfraView {
        let up = self.up(now_ms);
        let silent = up == Some(false);
        InfraView {
            zones: self
                .zones
                .values()
                .map(|z| ZoneView {
                    stale: z.stale || silent,
                    ..z.clone()
                })
                .collect(),
            vent: self.vent.clone().map(|v| VentView {
                stale: v.stale || silent,
                ..v
            }),
            link_up: up,
            problem: match (&self.link, silent) {
                (Some(l), _) if !l.problem.is_empty() => l.problem.clone(),
                (_, true) => "the SCADA bridge is not heard".into(),
                _ => String::new(),
            },
            last_ok: self.link.as_ref().and_then(|l| l.last_ok),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::infra::{DtsAlarm, DtsReading, VentReading};

    fn zone(t: f64, max_c: f64, stale: bool) -> DtsZone {
        DtsZone {
            zone: 4,
            start_m: 40.0,
            end_m: 50.0,
            t,
            reading: DtsReading {
                max_c,
                rise_c_min: 0.0,
                alarm: DtsAlarm {
                    max: max_c >= 60.0,
                    ..DtsAlarm::default()
                },
                fault: false,
            },
            stale,
        }
    }

    fn link(up: bool) -> ScadaLink {
        ScadaLink {
            t: 5.0,
            up,
            last_ok: Some(4.0),
            polls: 5,
            timeouts: 0,
            disconnects: u64::from(!up),
            exceptions: 0,
            out_of_range: 0,
            problem: if up { String::new() } else { "refused".into() },
        }
    }

    #[test]
    fn a_cut_link_or_a_silent_bridge_shows_every_reading_stale_and_keeps_it() {
        let mut i = Infra::default();
        assert!(!i.heard());
        i.zone(1000, zone(4.0, 85.04, false));
        i.vent(
            1000,
            Vent {
                t: 4.0,
                reading: VentReading {
                    air_m_s: 2.04,
                    fans: vec![FanState::Forward],
                },
                stale: false,
            },
        );
        i.link(1000, link(true));
        let v = i.view(1500);
        assert_eq!(v.link_up, Some(true));
        assert_eq!(v.zones[0].max_c, 85.0);
        assert!(v.zones[0].alarm && !v.zones[0].stale);
        // The bridge says the link is down, and re-sends the reading stale.
        i.link(2000, link(false));
        i.zone(2000, zone(4.0, 85.04, true));
        let v = i.view(2500);
        assert_eq!(v.link_up, Some(false));
        assert_eq!(v.problem, "refused");
        assert!(v.zones[0].stale && v.zones[0].t == 4.0 && v.zones[0].max_c == 85.0);
        // A late, older reading does not replace a newer one.
        i.zone(2600, zone(3.0, 20.0, false));
        assert_eq!(i.view(2700).zones[0].max_c, 85.0);
        // Back up, then the bridge falls silent: stale again, without its word.
        i.link(3000, link(true));
        i.zone(3000, zone(5.0, 90.0, false));
        let v = i.view(3000 + SILENT_MS);
        assert_eq!(v.link_up, Some(false));
        assert!(v.zones[0].stale && v.vent.as_ref().unwrap().stale);
        assert_eq!(v.problem, "the SCADA bridge is not heard");
    }
}
