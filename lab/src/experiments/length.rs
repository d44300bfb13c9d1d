//! `firefleet-lab length`: what a tunnel's length costs the fleet's software, on the
//! generated family of 1-10 km tunnels (`firefleet_lab::tunnels`): the memory and build
//! time of one ground unit's planner state and of the coordinator's incident (its road
//! maps with a field for every fire), and a ground unit's plan times by the stretch of
//! tunnel planned over.
//!
//! Memory is counted by the lab binary's allocator ([`Counting`]): the bytes live after a
//! structure is built less those before, so it is exact, and includes everything the
//! structure owns. Times are wall-clock, one build or plan each (the release build is the
//! one to read; a debug build is several times slower).
//!
//! Not here: the fleet's behaviour at that length (`fleet --generated`), or the planner's
//! benchmark on the 200 m tunnel (`cargo bench -p firefleet-nav`).

use std::alloc::{GlobalAlloc, Layout, System};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use firefleet_agent::ground::unit::{NavPurpose, Unit};
use firefleet_coordinator::Incident;
use firefleet_coordinator::assign::Strategy;
use firefleet_coordinator::incident::LEASE_S;
use firefleet_model::scenario::Scenario;
use firefleet_model::{Point2, UnitKind};
use serde::Serialize;

use firefleet::args::write_json;
use firefleet_lab::tunnels;

/// The system allocator, counting the bytes live.
pub struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is passed to the system allocator unchanged; only an atomic counter,
// which does not allocate, is kept beside it.
#[allow(unsafe_code, reason = "a global allocator is an unsafe trait")]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        LIVE.fetch_add(new, Ordering::Relaxed);
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.realloc(p, l, new) }
    }
}

/// `make()`'s result, the bytes it holds live, and the milliseconds it took.
fn measured<T>(make: impl FnOnce() -> T) -> (T, usize, f64) {
    let before = LIVE.load(Ordering::Relaxed);
    let start = Instant::now();
    let made = make();
    let ms = start.elapsed().as_secs_f64() * 1e3;
    (
        made,
        LIVE.load(Ordering::Relaxed).saturating_sub(before),
        ms,
    )
}

#[derive(Args, Debug)]
pub struct LengthArgs {
    /// Tunnels of the generated family measured.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u16).range(1..=100))]
    tunnels: u16,
    /// The generated family's seed.
    #[arg(long, default_value_t = 51)]
    family: u64,
    /// Also write the results as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<std::path::PathBuf>,
}

/// The stretches a ground unit plans over from its portal, m (the whole tunnel last).
const STRETCHES_M: [f64; 3] = [250.0, 1000.0, 3000.0];

#[derive(Serialize)]
struct Row {
    tunnel: String,
    length_m: f64,
    units: usize,
    fires: usize,
    unit_mib: f64,
    unit_build_ms: f64,
    /// (stretch m, plan ms); `None` where no path was found.
    plans: Vec<(f64, Option<f64>)>,
    coordinator_mib: f64,
    coordinator_build_ms: f64,
}

pub fn run(a: LengthArgs) -> anyhow::Result<ExitCode> {
    let family = tunnels::family(a.family, usize::from(a.tunnels))?;
    println!(
        "length experiment: family {}, one ground unit's planner state, its grid plans from \
         the west portal by stretch, and the coordinator's incident with every fire known",
        a.family
    );
    println!(
        "{:<10} {:>7} {:>6} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>11} {:>10}",
        "tunnel",
        "km",
        "units",
        "unit MiB",
        "build ms",
        "250 m ms",
        "1 km ms",
        "3 km ms",
        "whole ms",
        "coord. MiB",
        "build ms"
    );
    let mut rows = Vec::new();
    for s in &family {
        let row = measure(s)?;
        let plans: Vec<String> = row
            .plans
            .iter()
            .map(|(_, ms)| ms.map_or("-".into(), |ms| format!("{ms:.1}")))
            .collect();
        println!(
            "{:<10} {:>7.2} {:>6} {:>9.1} {:>9.1} {:>9} {:>9} {:>9} {:>9} {:>11.1} {:>10.1}",
            row.tunnel,
            row.length_m / 1000.0,
            row.units,
            row.unit_mib,
            row.unit_build_ms,
            plans[0],
            plans[1],
            plans[2],
            plans[3],
            row.coordinator_mib,
            row.coordinator_build_ms
        );
        rows.push(row);
    }
    write_json(a.json.as_deref(), &rows)?;
    Ok(ExitCode::SUCCESS)
}

fn measure(s: &Scenario) -> anyhow::Result<Row> {
    const MIB: f64 = 1024.0 * 1024.0;
    let shared = Arc::new(s.clone());
    let first = s
        .units
        .iter()
        .find(|u| u.kind == UnitKind::Ground && u.x_m < 10.0)
        .context("a ground unit at the west portal")?;
    let spec = s.ground_spec(&first.id).context("a ground profile")?;
    let (mut unit, unit_bytes, unit_ms) =
        measured(|| Unit::new(first.id.clone(), spec, shared.clone()));
    // Plans along the unit's own lane, to the end of each stretch (and of the tunnel).
    let plans = STRETCHES_M
        .iter()
        .copied()
        .chain([s.tunnel.length_m - 10.0])
        .map(|d| {
            if d > s.tunnel.length_m - 10.0 {
                return (d, None);
            }
            let goal = Point2::new(first.x_m + d, first.y_m);
            let start = Instant::now();
            let ok = unit.navigate(goal, NavPurpose::Cruise);
            unit.stop_navigation(NavPurpose::Cruise);
            (d, ok.then(|| start.elapsed().as_secs_f64() * 1e3))
        })
        .collect();
    let known = super::fleet::known_fires(s);
    let (incident, coordinator_bytes, coordinator_ms) = measured(|| {
        let mut inc = Incident::from_scenario(s, LEASE_S, Strategy::Optimal)?;
        inc.restore(&known, 0.0);
        anyhow::Ok(inc)
    });
    drop(incident?);
    Ok(Row {
        tunnel: s.name.clone(),
        length_m: s.tunnel.length_m,
        units: s.units.len(),
        fires: s.fires.len(),
        unit_mib: unit_bytes as f64 / MIB,
        unit_build_ms: unit_ms,
        plans,
        coordinator_mib: coordinator_bytes as f64 / MIB,
        coordinator_build_ms: coordinator_ms,
    })
}
