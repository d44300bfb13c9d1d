//! What one identity may send on its own keys, in rate and size: the bounds a site's
//! router enforces so that a flood costs the sender, not the site.
//!
//! Access rules ([`crate::access`]) stop an identity from touching another's keys; on its
//! own keys a stolen certificate could still send as fast and as large as its link
//! allows, and every subscriber would pay. [`LIMITS`] gives each key a unit sends a rate
//! and a size well above what an honest robot sends (the agent's state and reports at
//! 4 Hz, behaviour-tree batches at 5 Hz, body commands at the simulator's 20 Hz, all in
//! site time) and far below a flood. Zenoh's downsampler is a minimum interval between two
//! messages, not a bucket that lets a burst through: a process that falls behind and
//! catches up sends two messages a few milliseconds apart, so the bounds sit ten times
//! above the honest rates (measured: an honest pile-up at time x8 lost ~1 % of its body
//! commands to a bound 2.5 times their rate). [`zenoh_limits`] renders them into the router's
//! configuration: Zenoh's `downsampling` (messages on one key from one link closer together
//! than 1/rate are dropped at the router) and `low_pass_filter` (larger messages are
//! dropped), both on the router's ingress, one rule per unit and key so each unit has its
//! own budget even when one link speaks for many (the scale experiment's load generator).
//!
//! Goals are bounded in size only: a commander's goals are rare, and two set within a
//! moment of each other must both arrive, which a downsampler would not promise.
//!
//! Not here: the application's own bounds on what one sender can make it hold (the
//! coordinator's tracks, the recorder's bytes per channel), which hold on any link.

use serde_json::{Value, json};

use firefleet_model::UnitId;
use firefleet_protocol::keys::Keys;

/// A key class a unit sends on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnitKey {
    State,
    Report,
    Bt,
    /// A simulated body's commands (simulated sites only).
    SimCmd,
    SimRailCmd,
}

/// The bounds on one key class.
#[derive(Debug, Clone, Copy)]
pub struct Limit {
    pub key: UnitKey,
    /// At most this many messages a second of site time.
    pub rate_hz: f64,
    /// At most this many bytes of payload.
    pub max_bytes: usize,
    /// What an honest unit sends, for the table.
    pub honest: &'static str,
}

/// Each unit key's bounds.
pub const LIMITS: [Limit; 5] = [
    Limit {
        key: UnitKey::State,
        rate_hz: 40.0,
        max_bytes: 2048,
        honest: "4 Hz, ~120 B",
    },
    Limit {
        key: UnitKey::Report,
        rate_hz: 40.0,
        max_bytes: 4096,
        honest: "4 Hz, 64 observations at most (3.7 kB)",
    },
    Limit {
        key: UnitKey::Bt,
        rate_hz: 50.0,
        max_bytes: 16_384,
        honest: "5 Hz batches of a few transitions",
    },
    Limit {
        key: UnitKey::SimCmd,
        rate_hz: 200.0,
        max_bytes: 256,
        honest: "20 Hz, ~40 B",
    },
    Limit {
        key: UnitKey::SimRailCmd,
        rate_hz: 200.0,
        max_bytes: 256,
        honest: "20 Hz, ~40 B",
    },
];

/// The most bytes a goal (JSON) may have.
pub const MAX_GOAL_BYTES: usize = 4096;

impl UnitKey {
    pub fn as_str(self) -> &'static str {
        match self {
            UnitKey::State => "state",
            UnitKey::Report => "report",
            UnitKey::Bt => "bt",
            UnitKey::SimCmd => "sim cmd",
            UnitKey::SimRailCmd => "sim rail cmd",
        }
    }

    fn expr(self, keys: &Keys, u: &UnitId) -> String {
        match self {
            UnitKey::State => keys.unit_state(u).as_str().to_owned(),
            UnitKey::Report => keys.unit_report(u).as_str().to_owned(),
            UnitKey::Bt => keys.unit_bt(u).as_str().to_owned(),
            UnitKey::SimCmd => keys.sim_cmd(u).as_str().to_owned(),
            UnitKey::SimRailCmd => keys.sim_rail_cmd(u).as_str().to_owned(),
        }
    }
}

/// The router's `downsampling` and `low_pass_filter` sections for `units` of the site of
/// `keys`, with rates scaled by `time_scale` (a simulated site running faster than real
/// time sends that much faster; a real site is 1).
pub fn zenoh_limits(keys: &Keys, units: &[UnitId], time_scale: f64) -> (Value, Value) {
    let rules: Vec<Value> = LIMITS
        .iter()
        .flat_map(|l| {
            units.iter().map(
                move |u| json!({ "key_expr": l.key.expr(keys, u), "freq": l.rate_hz * time_scale }),
            )
        })
        .collect();
    // Zenoh refuses a downsampler or filter with no rules or keys: a site without units
    // gets none of them.
    let downsampling = if units.is_empty() {
        json!([])
    } else {
        json!([{
            "id": "unit keys",
            "messages": ["put", "delete"],
            "flows": ["ingress"],
            "rules": rules,
        }])
    };
    let mut low_pass: Vec<Value> = LIMITS
        .iter()
        .filter(|_| !units.is_empty())
        .map(|l| {
            json!({
                "id": format!("unit {}", l.key.as_str()),
                "messages": ["put", "delete"],
                "flows": ["ingress"],
                "key_exprs": units.iter().map(|u| l.key.expr(keys, u)).collect::<Vec<_>>(),
                "size_limit": l.max_bytes,
            })
        })
        .collect();
    low_pass.push(json!({
        "id": "goals",
        "messages": ["put", "delete"],
        "flows": ["ingress"],
        "key_exprs": [keys.every_zone_goal().as_str()],
        "size_limit": MAX_GOAL_BYTES,
    }));
    (downsampling, Value::Array(low_pass))
}

/// The limits as a Markdown table, for `ACCESS.md`.
pub fn table(time_scale: f64) -> String {
    let mut out = String::from(
        "| a unit's key | at most (router) | at most bytes | an honest unit |\n|---|---|---|---|\n",
    );
    for l in LIMITS {
        out.push_str(&format!(
            "| {} | {} Hz | {} | {} |\n",
            l.key.as_str(),
            l.rate_hz * time_scale,
            l.max_bytes,
            l.honest
        ));
    }
    out.push_str(&format!(
        "| goal (commanders) | - | {MAX_GOAL_BYTES} | rare |\n"
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::SiteId;

    #[test]
    fn every_unit_has_its_own_budget_per_key() {
        let keys = Keys::new(SiteId::new("s").unwrap());
        let units = [UnitId::new("a").unwrap(), UnitId::new("b").unwrap()];
        let (ds, lp) = zenoh_limits(&keys, &units, 4.0);
        let rules = ds[0]["rules"].as_array().unwrap();
        assert_eq!(rules.len(), LIMITS.len() * 2);
        assert!(rules.contains(&json!({"key_expr": "ff/s/unit/b/state", "freq": 160.0})));
        let state = &lp[0];
        assert_eq!(state["size_limit"], 2048);
        assert_eq!(
            state["key_exprs"],
            json!(["ff/s/unit/a/state", "ff/s/unit/b/state"])
        );
        // Zenoh reads them as its own configuration.
        let mut c = zenoh::Config::default();
        c.insert_json5("downsampling", &ds.to_string()).unwrap();
        c.insert_json5("low_pass_filter", &lp.to_string()).unwrap();
        let (ds, lp) = zenoh_limits(&keys, &[], 1.0);
        c.insert_json5("downsampling", &ds.to_string()).unwrap();
        c.insert_json5("low_pass_filter", &lp.to_string()).unwrap();
    }

    #[test]
    fn the_largest_honest_messages_fit_their_bounds() {
        use firefleet_model::{Point2, Pose2};
        use firefleet_protocol::codec::encode;
        use firefleet_protocol::msg::{FlameObservation, FlameReport, MAX_LIST};
        let id = "u".repeat(48);
        let limit = |k: UnitKey| LIMITS.iter().find(|l| l.key == k).unwrap().max_bytes;
        let report = FlameReport {
            unit: UnitId::new(id.clone()).unwrap(),
            t: 1e6,
            observer: Pose2::new(-1e3, 1e3, 3.0),
            observations: vec![
                FlameObservation {
                    position: Point2::new(-1e3, 1e3),
                    cov: [1e3, 1e3, 1e3],
                    confidence: 0.99,
                    hrr_kw: Some(3e5),
                };
                MAX_LIST
            ],
        };
        assert!(
            encode(&report).len() <= limit(UnitKey::Report),
            "{}",
            encode(&report).len()
        );
        let state = firefleet_protocol::testing::ground_state(&id, -1e3, 1e3);
        // A state with all its options set stays a quarter of its bound.
        assert!(
            encode(&state).len() * 4 <= limit(UnitKey::State),
            "{}",
            encode(&state).len()
        );
    }
}
