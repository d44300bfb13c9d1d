//! The after-action report: the incident as the console kept it, on one HTML page that
//! prints (`/report`; a browser's "Print" or Chromium's print to PDF makes the file a
//! debrief passes round). Its sections: what and when; each fire's times from first seen
//! to first attacked and to out, and who worked it; each unit's water used and the heat it
//! took; the map at the start, as each fire went out and at the end; every alarm with its
//! lifecycle; who did what through the console; the decisions kept.
//!
//! Everything comes from what the console keeps ([`crate::history`]'s snapshots, the
//! alarms, [`crate::audit`]), so a report is as good a record as the timeline: times to
//! the snapshot period ([`crate::history::PERIOD_S`]), and the heat dose summed over the
//! snapshots (flux times the time to the next one), which a recording measures more
//! finely. Pure: the caller hands in the records and the time it is printed.
//!
//! Not here: serving it ([`crate::http`]), its print style (`assets/report.css`).

use std::collections::BTreeMap;
use std::fmt::Write;

use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::FireState;

use crate::audit::Entry;
use crate::history::Snapshot;
use crate::picture::{Alert, DecisionLine};
use crate::site::SiteMap;

/// What a report is made of.
pub struct Records<'a> {
    pub site: &'a SiteMap,
    /// The timeline, oldest first.
    pub snaps: &'a [&'a Snapshot],
    pub alerts: &'a [Alert],
    pub audit: &'a [Entry],
    pub decisions: &'a [DecisionLine],
    /// When it is printed, as people read it.
    pub printed: &'a str,
}

/// A fire's times, as the snapshots show them.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct FireTimes {
    pub seen_t: f64,
    /// First under attack (a unit's jet on it).
    pub attacked_t: Option<f64>,
    pub out_t: Option<f64>,
    pub units: Vec<UnitId>,
}

/// A unit's toll, as the snapshots show it.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct UnitToll {
    /// Water it used, L (drops in its tank; a refill is not negative use).
    pub water_l: f64,
    /// Radiant heat dose, kJ/m^2.
    pub dose_kj_m2: f64,
    pub peak_kw_m2: f64,
}

/// Each fire's times, by fire.
pub fn fire_times(snaps: &[&Snapshot]) -> BTreeMap<FireId, FireTimes> {
    let mut out: BTreeMap<FireId, FireTimes> = BTreeMap::new();
    for s in snaps {
        for f in &s.fires {
            let e = out.entry(f.id).or_insert_with(|| FireTimes {
                seen_t: s.t,
                ..FireTimes::default()
            });
            if f.state == FireState::Suppressing {
                e.attacked_t.get_or_insert(s.t);
            }
            if f.state == FireState::Out {
                e.out_t.get_or_insert(s.t);
            }
            for u in &f.assigned {
                if !e.units.contains(u) {
                    e.units.push(u.clone());
                }
            }
        }
    }
    out
}

/// Each unit's toll, by unit.
pub fn unit_tolls(snaps: &[&Snapshot]) -> BTreeMap<UnitId, UnitToll> {
    let mut out: BTreeMap<UnitId, UnitToll> = BTreeMap::new();
    let mut last: BTreeMap<&UnitId, (f64, f64, f64)> = BTreeMap::new();
    for s in snaps {
        for u in &s.units {
            let e = out.entry(u.id.clone()).or_default();
            e.peak_kw_m2 = e.peak_kw_m2.max(u.heat_kw_m2);
            if let Some((t, water, flux)) = last.get(&u.id) {
                e.water_l += (water - u.water_l).max(0.0);
                e.dose_kj_m2 += flux * (s.t - t).max(0.0);
            }
            last.insert(&u.id, (s.t, u.water_l, u.heat_kw_m2));
        }
    }
    out
}

/// Wall time `ms` (since the Unix epoch) as `YYYY-MM-DD HH:MM:SS UTC`: the proleptic
/// Gregorian date from the day number (H. Hinnant's `civil_from_days`), so the report says
/// when it was printed without a calendar crate for one line.
pub fn utc(ms: u64) -> String {
    let secs = ms / 1000;
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// `text` safe inside HTML.
fn esc(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn t(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |v| format!("{v:.0} s"))
}

/// The map at one snapshot, as SVG: the walls, each fire (red burning, blue under attack,
/// grey out) and each unit, across a strip of `w` x `h` px (the tunnel's width stretched
/// to be seen).
fn map_svg(site: &SiteMap, snap: &Snapshot) -> String {
    let (w, h) = (1000.0, 110.0);
    let pts = site.left_wall.iter().chain(&site.right_wall);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in pts {
        (x0, x1, y0, y1) = (x0.min(p[0]), x1.max(p[0]), y0.min(p[1]), y1.max(p[1]));
    }
    let sx = |x: f64| 10.0 + (x - x0) / (x1 - x0).max(1.0) * (w - 20.0);
    let sy = |y: f64| 10.0 + (y1 - y) / (y1 - y0).max(1.0) * (h - 20.0);
    let line = |ps: &[[f64; 2]]| {
        ps.iter()
            .map(|p| format!("{:.1},{:.1}", sx(p[0]), sy(p[1])))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut svg = format!(
        "<svg viewBox=\"0 0 {w} {h}\" class=\"map\" role=\"img\" aria-label=\"the tunnel at t = {:.0} s\">",
        snap.t
    );
    for wall in [&site.left_wall, &site.right_wall] {
        let _ = write!(
            svg,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#555\" stroke-width=\"1.5\"/>",
            line(wall)
        );
    }
    for f in &snap.fires {
        let colour = match f.state {
            FireState::Out => "#999",
            FireState::Suppressing => "#1890ff",
            _ => "#e8430c",
        };
        let (x, y) = (sx(f.position.x), sy(f.position.y));
        let _ = write!(
            svg,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"6\" fill=\"{colour}\"><title>{} {}</title></circle><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"9\">{}</text>",
            f.id,
            f.state,
            x + 8.0,
            y + 3.0,
            f.id
        );
    }
    for u in &snap.units {
        let colour = if u.lost { "#7a0000" } else { "#2f9e1a" };
        let (x, y) = (sx(u.x), sy(u.y));
        let _ = write!(
            svg,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"7\" height=\"7\" fill=\"{colour}\"><title>{}</title></rect><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"9\">{}</text>",
            x - 3.5,
            y - 3.5,
            esc(u.id.as_str()),
            x + 5.0,
            y - 5.0,
            esc(u.id.as_str())
        );
    }
    svg.push_str("</svg>");
    svg
}

/// The snapshots the report draws: the first, the first after each fire went out, and
/// the last.
fn moments<'a>(snaps: &[&'a Snapshot], fires: &BTreeMap<FireId, FireTimes>) -> Vec<&'a Snapshot> {
    let mut at: Vec<f64> = fires.values().filter_map(|f| f.out_t).collect();
    at.sort_by(f64::total_cmp);
    let mut out: Vec<&Snapshot> = Vec::new();
    let mut push = |s: &'a Snapshot| {
        if out.last().is_none_or(|l| l.t < s.t) {
            out.push(s);
        }
    };
    if let Some(first) = snaps.first() {
        push(first);
    }
    for t in at {
        if let Some(s) = snaps.iter().find(|s| s.t >= t) {
            push(s);
        }
    }
    if let Some(last) = snaps.last() {
        push(last);
    }
    out
}

/// The report, a whole HTML page.
pub fn render(r: &Records<'_>) -> String {
    let fires = fire_times(r.snaps);
    let tolls = unit_tolls(r.snaps);
    let (from, to) = (r.snaps.first().map(|s| s.t), r.snaps.last().map(|s| s.t));
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>After-action report: {site}</title>\
         <link rel=\"stylesheet\" href=\"/report.css\"></head><body>\
         <h1>After-action report</h1>\
         <section id=\"incident\"><h2>The incident</h2><p>Site {site} ({scenario}, {len:.0} m). \
         Site time {from} to {to}. Printed {printed} from what the console kept.</p></section>",
        site = esc(&r.site.site),
        scenario = esc(&r.site.scenario),
        len = r.site.length_m,
        from = t(from),
        to = t(to),
        printed = esc(r.printed),
    );
    h.push_str("<section id=\"fires\"><h2>Fires</h2><table><thead><tr><th>fire</th><th>first seen</th><th>first attacked</th><th>to attack</th><th>out</th><th>to out</th><th>units</th></tr></thead><tbody>");
    for (id, f) in &fires {
        let units: Vec<&str> = f.units.iter().map(UnitId::as_str).collect();
        let _ = write!(
            h,
            "<tr><td>{id}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            t(Some(f.seen_t)),
            t(f.attacked_t),
            t(f.attacked_t.map(|a| a - f.seen_t)),
            t(f.out_t),
            t(f.out_t.map(|o| o - f.seen_t)),
            esc(&units.join(", "))
        );
    }
    h.push_str("</tbody></table></section>");
    h.push_str("<section id=\"units\"><h2>Units</h2><table><thead><tr><th>unit</th><th>water used</th><th>heat dose</th><th>peak heat flux</th></tr></thead><tbody>");
    for (id, u) in &tolls {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.0} L</td><td>{:.1} kJ/m&sup2;</td><td>{:.1} kW/m&sup2;</td></tr>",
            esc(id.as_str()),
            u.water_l,
            u.dose_kj_m2,
            u.peak_kw_m2
        );
    }
    h.push_str("</tbody></table></section><section id=\"maps\"><h2>The map</h2>");
    for s in moments(r.snaps, &fires) {
        let _ = write!(
            h,
            "<figure>{}<figcaption>t = {:.0} s</figcaption></figure>",
            map_svg(r.site, s),
            s.t
        );
    }
    h.push_str("</section><section id=\"alarms\"><h2>Alarms</h2><table><thead><tr><th>P</th><th>raised</th><th>alarm</th><th>times</th><th>back to normal</th><th>acknowledged by</th></tr></thead><tbody>");
    for a in r.alerts {
        let shelved = a
            .shelved
            .as_ref()
            .map(|s| format!(" (shelved by {}: {})", esc(&s.by), esc(&s.reason)))
            .unwrap_or_default();
        let _ = write!(
            h,
            "<tr><td>P{}</td><td>{}</td><td>{}{shelved}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            a.priority,
            t(Some(a.t)),
            esc(&a.text),
            a.count,
            t(a.returned_t),
            esc(a.acked_by.as_deref().unwrap_or("-"))
        );
    }
    h.push_str("</tbody></table></section><section id=\"audit\"><h2>Who did what</h2><table><thead><tr><th>site time</th><th>who</th><th>what</th><th>outcome</th></tr></thead><tbody>");
    for e in r.audit {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:?}: {}</td><td>{}</td></tr>",
            t(Some(e.t)),
            esc(&e.who),
            e.action,
            esc(&e.what),
            esc(&e.outcome)
        );
    }
    h.push_str("</tbody></table></section><section id=\"decisions\"><h2>Decisions</h2><ol>");
    for d in r.decisions {
        let times = if d.count > 1 {
            format!(" (x{}, from {})", d.count, t(Some(d.first_t)))
        } else {
            String::new()
        };
        let _ = write!(h, "<li>{} {}{times}</li>", t(Some(d.t)), esc(&d.text));
    }
    h.push_str("</ol></section></body></html>");
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::history::{FireAt, UnitAt};
    use firefleet_model::{Point2, UnitKind};

    fn snap(t: f64, state: FireState, water_l: f64, heat: f64) -> Snapshot {
        Snapshot {
            t,
            units: vec![UnitAt {
                id: UnitId::new("ugv-1").unwrap(),
                kind: UnitKind::Ground,
                x: 10.0,
                y: -2.5,
                yaw: 0.0,
                lost: false,
                autonomous: false,
                fault: false,
                water_l,
                heat_kw_m2: heat,
                task: None,
            }],
            fires: vec![FireAt {
                id: FireId(1),
                state,
                position: Point2::new(60.0, -2.0),
                hrr_kw: None,
                assigned: vec![UnitId::new("ugv-1").unwrap()],
            }],
        }
    }

    #[test]
    fn wall_time_is_said_as_a_utc_date() {
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        // 2026-11-28 13:44:51 UTC, this session's start, and a leap day.
        assert_eq!(utc(1_795_873_491_000), "2026-11-28 13:44:51 UTC");
        assert_eq!(utc(951_782_400_000), "2000-02-29 00:00:00 UTC");
    }

    #[test]
    fn a_fire_s_times_and_a_unit_s_toll_come_from_the_timeline() {
        let snaps = [
            snap(10.0, FireState::Confirmed, 1000.0, 0.0),
            snap(11.0, FireState::Assigned, 1000.0, 2.0),
            snap(13.0, FireState::Suppressing, 990.0, 4.0),
            snap(14.0, FireState::Suppressing, 970.0, 4.0),
            snap(20.0, FireState::Out, 975.0, 0.0),
        ];
        let refs: Vec<&Snapshot> = snaps.iter().collect();
        let f = &fire_times(&refs)[&FireId(1)];
        assert_eq!(
            (f.seen_t, f.attacked_t, f.out_t),
            (10.0, Some(13.0), Some(20.0))
        );
        let u = &unit_tolls(&refs)[&UnitId::new("ugv-1").unwrap()];
        assert_eq!(u.water_l, 30.0, "a refill is not negative use");
        // 2 kW/m^2 for 2 s, then 4 for 1 s and 4 for 6 s.
        assert!((u.dose_kj_m2 - (2.0 * 2.0 + 4.0 + 4.0 * 6.0)).abs() < 1e-9);
        assert_eq!(u.peak_kw_m2, 4.0);
    }

    #[test]
    fn the_report_has_its_sections_and_escapes_what_people_typed() {
        let scenario = firefleet_model::builtin::resolve("vehicle-collision").unwrap();
        let site = SiteMap::new(&scenario);
        let snaps = [
            snap(0.0, FireState::Confirmed, 1000.0, 0.0),
            snap(5.0, FireState::Out, 990.0, 0.0),
        ];
        let refs: Vec<&Snapshot> = snaps.iter().collect();
        let audit = [Entry {
            wall_ms: 1,
            t: 3.0,
            who: "rossi".into(),
            action: crate::audit::Action::Goal,
            what: "<script>alert(1)</script>".into(),
            outcome: "accepted".into(),
        }];
        let page = render(&Records {
            site: &site,
            snaps: &refs,
            alerts: &[],
            audit: &audit,
            decisions: &[],
            printed: "12:00",
        });
        for id in [
            "incident",
            "fires",
            "units",
            "maps",
            "alarms",
            "audit",
            "decisions",
        ] {
            assert!(page.contains(&format!("<section id=\"{id}\">")), "{id}");
        }
        assert_eq!(
            page.matches("<figure>").count(),
            2,
            "the start and the fire out"
        );
        assert!(!page.contains("<script>"));
        assert!(page.contains("&lt;script&gt;"));
    }
}
