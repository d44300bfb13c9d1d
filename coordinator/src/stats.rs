//! What the coordinator counts for a site's monitoring: how long a flame report takes to
//! become a task, the fires burning, the tasks held, the units lost to their lease, and
//! whether it is in office.
//!
//! The figures are Prometheus metric types (shared atomics, cheap to update from the loop);
//! [`crate::node`] updates them and the role's edge registers and serves them
//! (`firefleet coordinator --metrics ADDR`). The latency is the coordinator's own part:
//! from taking a report off the bus to handing the task it caused to Zenoh; the flight of
//! either over the network is not in it (the scale experiment measures end to end).
//!
//! Not here: serving them (the binary's `metrics` edge), or counting messages (the bus's
//! traffic and refusal counts).

use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::Registry;

/// The coordinator's figures; clones share them.
#[derive(Debug, Clone)]
pub struct Stats {
    pub report_to_task: Histogram,
    pub reports: Counter,
    pub fires: Gauge,
    pub tasks: Gauge,
    pub lease_misses: Counter,
    pub in_office: Gauge,
    /// Tasks heard that this coordinator did not send (a rival's, or a thief's on its key).
    pub claimed_tasks: Counter,
}

impl Default for Stats {
    fn default() -> Self {
        Self {
            // 0.25 ms to 4 s: a report is acted on within milliseconds, and one that waits
            // seconds is a fault worth seeing in its own bucket.
            report_to_task: Histogram::new(exponential_buckets(0.000_25, 2.0, 15)),
            reports: Counter::default(),
            fires: Gauge::default(),
            tasks: Gauge::default(),
            lease_misses: Counter::default(),
            in_office: Gauge::default(),
            claimed_tasks: Counter::default(),
        }
    }
}

impl Stats {
    /// Register every figure in `registry` (names prefixed `coordinator_`).
    pub fn register(&self, registry: &mut Registry) {
        let r = registry.sub_registry_with_prefix("coordinator");
        r.register(
            "report_to_task_seconds",
            "From a flame report taken off the bus to the task it caused handed to Zenoh",
            self.report_to_task.clone(),
        );
        r.register("reports", "Flame reports taken", self.reports.clone());
        r.register("fires", "Fire tracks not out", self.fires.clone());
        r.register("tasks", "Tasks held by units", self.tasks.clone());
        r.register(
            "lease_misses",
            "Units counted lost for silence past their lease",
            self.lease_misses.clone(),
        );
        r.register(
            "in_office",
            "1 while this coordinator is in charge",
            self.in_office.clone(),
        );
        r.register(
            "claimed_tasks",
            "Tasks heard that this coordinator did not send while in office: a rival's, or on its own key a thief's",
            self.claimed_tasks.clone(),
        );
    }
}
