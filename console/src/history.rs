//! The incident's timeline as the console keeps it: a snapshot of the map (where every
//! unit was, what it did, every fire's state and size) for every [`PERIOD_S`] of site
//! time, served to any page (`/api/history`) so that its timeline reaches back to the
//! incident's start however late it was opened or however often reloaded, and kept in
//! the console's state directory ([`LineLog`], [`FILE`]) so that a restarted console has
//! it too.
//!
//! Bounded twice. In memory: past [`MAX_SNAPSHOTS`] snapshots or [`MAX_ENTRIES`] units and
//! fires in all, the older half is thinned to one snapshot in two, as the page thins its
//! own (the whole incident stays, coarser further back: at four units that is an hour at
//! one a second, at a thousand some twenty minutes). Served: at most [`SERVED_ENTRIES`]
//! units and fires, evenly picked with the first and the newest, so that a late page at a
//! thousand units loads megabytes, not hundreds. The file keeps every snapshot (about
//! 100 bytes a unit: 0.4 kB/s at four units, 0.1 MB/s at a thousand).
//!
//! Not here: the live picture ([`crate::picture`]), drawing a snapshot (the page's
//! `console.js`), the audit log ([`crate::audit`]).

use std::path::Path;

use firefleet_model::{FireId, Point2, UnitId, UnitKind};
use firefleet_protocol::msg::{FireState, TaskPhase};
use serde::{Deserialize, Serialize};

use crate::line_log::{LineLog, LogError};
use crate::picture::Incident;

/// The file in the state directory.
pub const FILE: &str = "history.jsonl";
/// Site time between snapshots, s.
pub const PERIOD_S: f64 = 1.0;
/// Snapshots kept in memory at most (the page keeps as many of its own).
pub const MAX_SNAPSHOTS: usize = 3600;
/// Units and fires, over all snapshots, kept in memory at most: some 100 MB.
pub const MAX_ENTRIES: usize = 1_000_000;
/// Units and fires, over all snapshots, sent to a page at most.
pub const SERVED_ENTRIES: usize = 200_000;

/// The map at one moment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Site time.
    pub t: f64,
    pub units: Vec<UnitAt>,
    pub fires: Vec<FireAt>,
}

/// A unit in a snapshot: what the map draws of it, and what the after-action report
/// sums.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnitAt {
    pub id: UnitId,
    pub kind: UnitKind,
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
    pub lost: bool,
    pub autonomous: bool,
    pub fault: bool,
    /// Water on board, L (to 1 L); the after-action report's water used.
    #[serde(default)]
    pub water_l: f64,
    /// Radiant heat flux it feels, kW/m^2 (to 0.1); the report's heat dose.
    #[serde(default)]
    pub heat_kw_m2: f64,
    /// The fire it drives to or sprays, and where it believes that fire is.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub task: Option<TaskAt>,
}

/// What a unit in a snapshot works on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TaskAt {
    pub fire: FireId,
    pub x: f64,
    pub y: f64,
}

/// A fire in a snapshot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FireAt {
    pub id: FireId,
    pub state: FireState,
    pub position: Point2,
    /// Its estimated heat release, kW; none once out.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub hrr_kw: Option<f64>,
    pub assigned: Vec<UnitId>,
}

impl Snapshot {
    /// The map of `incident`: units heard from, every fire the coordinator in charge
    /// publishes.
    pub fn of(incident: &Incident) -> Self {
        let units = incident
            .units
            .iter()
            .filter_map(|u| {
                let s = u.state.as_ref()?;
                let task = s
                    .task
                    .filter(|p| matches!(p.phase, TaskPhase::Travelling | TaskPhase::Spraying))
                    .map(|p| TaskAt {
                        fire: p.fire,
                        x: p.target.x,
                        y: p.target.y,
                    });
                Some(UnitAt {
                    id: u.id.clone(),
                    kind: s.kind,
                    x: round(s.pose.x, 10.0),
                    y: round(s.pose.y, 10.0),
                    yaw: round(s.pose.yaw, 100.0),
                    lost: u.lost,
                    autonomous: s.autonomous,
                    fault: s.mode == firefleet_protocol::msg::UnitMode::Fault,
                    water_l: round(s.water_l, 1.0),
                    heat_kw_m2: round(s.heat_flux_kw_m2, 10.0),
                    task,
                })
            })
            .collect();
        let fires = incident
            .fires
            .iter()
            .map(|f| FireAt {
                id: f.id,
                state: f.state,
                position: Point2::new(round(f.position.x, 10.0), round(f.position.y, 10.0)),
                hrr_kw: f
                    .hrr_kw
                    .filter(|_| f.state != FireState::Out)
                    .map(|q| round(q, 1.0)),
                assigned: f.assigned.clone(),
            })
            .collect();
        Self {
            t: incident.t,
            units,
            fires,
        }
    }

    fn entries(&self) -> usize {
        self.units.len() + self.fires.len()
    }
}

/// `x` to the nearest `1 / per`: what a map shows, in fewer bytes.
fn round(x: f64, per: f64) -> f64 {
    (x * per).round() / per
}

/// The timeline.
#[derive(Debug, Default)]
pub struct History {
    file: Option<LineLog>,
    snaps: Vec<Snapshot>,
    entries: usize,
}

impl History {
    /// A timeline kept only in memory (a console with no state directory: a restart
    /// loses it, a reloaded page does not).
    pub fn in_memory() -> Self {
        Self::default()
    }

    /// The timeline in directory `dir` (made if missing), with what it already holds.
    pub fn open(dir: &Path) -> Result<Self, LogError> {
        let mut h = Self::default();
        let file = LineLog::open(dir, FILE, |s: Snapshot| h.keep(s))?;
        h.file = Some(file);
        Ok(h)
    }

    /// The site time of the newest snapshot.
    pub fn newest_t(&self) -> Option<f64> {
        self.snaps.last().map(|s| s.t)
    }

    /// Whether a snapshot is due at site time `t`: [`PERIOD_S`] after the newest. A site
    /// clock that went back (a simulator restarted from its start) starts a new run of
    /// snapshots after the old ones.
    pub fn due(&self, t: f64) -> bool {
        self.newest_t()
            .is_none_or(|last| t >= last + PERIOD_S || t < last - PERIOD_S)
    }

    /// Add `snap`, on disk first.
    pub fn record(&mut self, snap: Snapshot) {
        if let Some(file) = &self.file {
            // Not synced: a power cut loses the last seconds of the timeline, never what a
            // commander did (the audit log is synced).
            file.append(&snap, false);
        }
        self.keep(snap);
    }

    fn keep(&mut self, snap: Snapshot) {
        if self.snaps.last().is_some_and(|last| snap.t < last.t) {
            // A new run of the site clock: the old timeline would interleave with it.
            self.snaps.clear();
            self.entries = 0;
        }
        self.entries += snap.entries();
        self.snaps.push(snap);
        if self.snaps.len() > MAX_SNAPSHOTS || self.entries > MAX_ENTRIES {
            let half = self.snaps.len() / 2;
            let newer = self.snaps.split_off(half);
            let mut k = 0;
            self.snaps.retain(|_| {
                k += 1;
                k % 2 == 1
            });
            self.snaps.extend(newer);
            self.entries = self.snaps.iter().map(Snapshot::entries).sum();
        }
    }

    /// The snapshots to send a page, oldest first: every one kept, or if they hold more
    /// than [`SERVED_ENTRIES`] units and fires, an even pick with the first and the newest.
    pub fn served(&self) -> Vec<&Snapshot> {
        let n = self.snaps.len();
        let per = (self.entries / n.max(1)).max(1);
        let room = (SERVED_ENTRIES / per).max(2);
        if n <= room {
            return self.snaps.iter().collect();
        }
        let mut out: Vec<&Snapshot> = (0..room - 1)
            .map(|k| &self.snaps[k * (n - 1) / (room - 1)])
            .collect();
        out.push(&self.snaps[n - 1]);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn snap(t: f64, units: usize) -> Snapshot {
        Snapshot {
            t,
            units: (0..units)
                .map(|k| UnitAt {
                    id: UnitId::new(format!("ugv-{k}")).unwrap(),
                    kind: UnitKind::Ground,
                    x: t,
                    y: -2.5,
                    yaw: 0.0,
                    lost: false,
                    autonomous: false,
                    fault: false,
                    water_l: 1000.0 - t,
                    heat_kw_m2: 1.0,
                    task: None,
                })
                .collect(),
            fires: vec![FireAt {
                id: FireId(1),
                state: FireState::Assigned,
                position: Point2::new(60.0, -2.0),
                hrr_kw: Some(2500.0),
                assigned: vec![UnitId::new("ugv-0").unwrap()],
            }],
        }
    }

    #[test]
    fn the_timeline_outlives_a_restart_and_a_torn_last_line() {
        let dir = tempfile::tempdir().unwrap();
        let mut h = History::open(dir.path()).unwrap();
        for t in 0..5 {
            let t = f64::from(t);
            assert!(h.due(t));
            h.record(snap(t, 2));
            assert!(!h.due(t + 0.5));
        }
        drop(h);
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(dir.path().join(FILE))
            .unwrap();
        f.write_all(b"{\"t\": 5.0, \"units\"").unwrap();
        let mut back = History::open(dir.path()).unwrap();
        let ts: Vec<f64> = back.served().iter().map(|s| s.t).collect();
        assert_eq!(ts, [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(back.served()[4], &snap(4.0, 2));
        back.record(snap(5.0, 2));
        drop(back);
        let back = History::open(dir.path()).unwrap();
        assert_eq!(back.newest_t(), Some(5.0));
    }

    #[test]
    fn a_long_incident_is_kept_whole_and_coarser_further_back() {
        let mut h = History::in_memory();
        for t in 0..2 * MAX_SNAPSHOTS {
            h.record(snap(t as f64, 1));
        }
        let ts: Vec<f64> = h.served().iter().map(|s| s.t).collect();
        assert!(ts.len() <= MAX_SNAPSHOTS, "{}", ts.len());
        assert_eq!(ts[0], 0.0, "the start stays");
        assert_eq!(*ts.last().unwrap(), (2 * MAX_SNAPSHOTS - 1) as f64);
        assert!(ts.windows(2).all(|w| w[0] < w[1]));
        let (early, late) = (ts[1] - ts[0], ts[ts.len() - 1] - ts[ts.len() - 2]);
        assert!(early > late, "coarser further back: {early} against {late}");
    }

    #[test]
    fn a_thousand_units_are_served_within_the_budget_with_the_start_and_the_newest() {
        let mut h = History::in_memory();
        for t in 0..600 {
            h.record(snap(f64::from(t), 1000));
        }
        assert!(h.entries <= MAX_ENTRIES);
        let served = h.served();
        let entries: usize = served.iter().map(|s| s.entries()).sum();
        assert!(entries <= SERVED_ENTRIES, "{entries}");
        assert_eq!(served[0].t, 0.0);
        assert_eq!(served.last().unwrap().t, 599.0);
    }

    #[test]
    fn a_site_clock_that_starts_again_starts_a_new_timeline() {
        let mut h = History::in_memory();
        for t in [0.0, 1.0, 2.0, 3.0] {
            h.record(snap(t, 1));
        }
        assert!(h.due(0.0), "the clock went back");
        h.record(snap(0.0, 1));
        let ts: Vec<f64> = h.served().iter().map(|s| s.t).collect();
        assert_eq!(ts, [0.0]);
    }
}
