//! The tunnel's SCADA over Modbus TCP, both ways against an implementation of Modbus that
//! is not ours (Python's `pymodbus`): its client reads the simulator's registers by the
//! documented map, and our bridge reads a SCADA its server plays. Then the whole fleet with
//! the bridge as one more process, its link cut mid-incident.

use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use firefleet_model::builtin;
use firefleet_model::infra::FanState;
use firefleet_model::testing::python_package;
use firefleet_protocol::msg::{DtsZone, ScadaLink, Vent};

use crate::support::*;

/// The scenario both tests use: a ventilated tunnel, 30 zones of 10 m, three fans.
const SCENARIO: &str = "ventilated";

fn pymodbus() -> bool {
    python_package(
        "pymodbus",
        "pymodbus>=3.10,<4",
        "FIREFLEET_REQUIRE_PYMODBUS",
    )
}

/// Wait until something accepts TCP connections on `port`.
fn listening(port: u16, within: Duration) {
    let until = Instant::now() + within;
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < until, "nothing listens on {port}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn an_independent_modbus_client_reads_the_alarm_zone_at_the_fire() {
    if !pymodbus() {
        return;
    }
    let scenario = builtin::resolve(SCENARIO).unwrap();
    let (bus, endpoint) = router("tunnel-v").await;
    let port = firefleet_bus::free_loopback_port().unwrap();
    let addr = format!("127.0.0.1:{port}");
    let _fleet = Fleet(vec![spawn_role(
        SCENARIO,
        &endpoint,
        &["sim", "--scada", &addr, "--time-scale", "4"],
    )]);
    listening(port, patient(Duration::from_secs(20)));
    // 40 s of site time: the fire has grown and the detector measured it since.
    until_site_time(&bus, 40.0, Duration::from_secs(30)).await;
    let zones = scenario.scada.as_ref().unwrap().zone_count(300.0);
    let out = Command::new("python3")
        .args(["tests/scada/read.py", "127.0.0.1", &port.to_string()])
        .arg(zones.to_string())
        .args(["--fans", "3"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let read: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let zs = read["zones"].as_array().unwrap();
    assert_eq!(zs.len(), 30);
    let alarmed: Vec<&serde_json::Value> = zs
        .iter()
        .filter(|z| {
            z["alarm_max"] == true || z["alarm_rise"] == true || z["alarm_differential"] == true
        })
        .collect();
    assert!(!alarmed.is_empty(), "no zone in alarm: {read}");
    // The hottest zone in alarm holds the van's chainage (150 m, on the line between
    // zones 14 and 15), and the air carries the heat east: hotter downstream than up.
    let hottest = alarmed
        .iter()
        .max_by(|a, b| {
            a["max_c"]
                .as_f64()
                .partial_cmp(&b["max_c"].as_f64())
                .unwrap()
        })
        .unwrap();
    let k = hottest["zone"].as_u64().unwrap();
    assert!(
        (14..=15).contains(&k),
        "hottest zone in alarm is {k}: {read}"
    );
    let t = |k: usize| zs[k]["max_c"].as_f64().unwrap();
    assert!(
        t(17) > t(12) + 5.0,
        "20 m downstream {} C, upstream {} C",
        t(17),
        t(12)
    );
    assert!(t(0) < 25.0, "the west portal's zone reads {} C", t(0));
    assert_eq!(read["vent"]["air_m_s"], 2.0);
    assert_eq!(read["vent"]["fan_states"], serde_json::json!([1, 1, 1]));
    assert_eq!(
        read["unmapped_refused"], true,
        "a register off the map answered"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn the_bridge_publishes_what_a_scada_holds_and_marks_it_stale_when_the_link_is_cut() {
    if !pymodbus() {
        return;
    }
    let (bus, endpoint) = router("tunnel-v").await;
    let keys = bus.keys().clone();
    let zones = bus
        .subscribe::<DtsZone>(&keys.every_dts_zone())
        .await
        .unwrap();
    let vents = bus.subscribe::<Vent>(&keys.infra_vent()).await.unwrap();
    let links = bus
        .subscribe::<ScadaLink>(&keys.infra_link())
        .await
        .unwrap();
    let port = firefleet_bus::free_loopback_port().unwrap();
    let mut plc = Command::new("python3")
        .args(["tests/scada/plc.py", &port.to_string(), "30", "3"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    listening(port, patient(Duration::from_secs(20)));
    let _bridge = Fleet(vec![spawn_role(
        SCENARIO,
        &endpoint,
        &[
            "scada",
            "--modbus",
            &format!("127.0.0.1:{port}"),
            "--period-s",
            "0.2",
            "--timeout-s",
            "0.5",
        ],
    )]);
    // What the server holds, as the bridge publishes it.
    let within = patient(Duration::from_secs(20));
    let until = Instant::now() + within;
    let (mut seven, mut nine, mut vent) = (None, false, None);
    while seven.is_none() || vent.is_none() {
        assert!(
            Instant::now() < until,
            "zone 7 or the ventilation never came"
        );
        tokio::select! {
            Some((_, z)) = zones.recv() => {
                nine |= z.zone == 9;
                if z.zone == 7 { seven = Some(z); }
            }
            Some((_, v)) = vents.recv() => vent = Some(v),
            _ = tokio::time::sleep(Duration::from_millis(100)) => {}
        }
    }
    let z = seven.unwrap();
    assert_eq!((z.start_m, z.end_m), (70.0, 80.0));
    assert!((z.reading.max_c - 85.3).abs() < 1e-9, "{z:?}");
    assert!((z.reading.rise_c_min - 12.5).abs() < 1e-9, "{z:?}");
    assert!(z.reading.alarm.max && z.reading.alarm.rise && !z.reading.alarm.differential);
    assert!(!z.stale && !z.reading.fault);
    let v = vent.unwrap();
    assert!((v.reading.air_m_s - 1.75).abs() < 1e-9, "{v:?}");
    assert_eq!(v.reading.fans, vec![FanState::Forward; 3]);
    // Zone 9 sets a bit the map does not define: counted, never published.
    assert!(!nine, "zone 9 was published");
    // (The link's problem is the poll's last: wait for a poll that failed on zone 9.)
    let link = loop {
        let (_, l) = links.recv().await.unwrap();
        if l.problem.contains("zone 9") {
            break l;
        }
    };
    assert!(
        link.up && link.out_of_range > 0 && link.last_ok.is_some(),
        "{link:?}"
    );
    let last_good = z.t;

    // Cut the link: the bridge says so and sends zone 7 again as it last read it, stale.
    plc.kill().unwrap();
    plc.wait().unwrap();
    let until = Instant::now() + within;
    let (mut cut, mut stale) = (None, None);
    while cut.is_none() || stale.is_none() {
        assert!(Instant::now() < until, "no word of the cut link");
        tokio::select! {
            // Once the dropped connection is behind it, every poll's connect is refused:
            // said as an operator acts on it, not in the socket's words.
            Some((_, l)) = links.recv() => if !l.up && l.problem.contains("refuses the connection: is it running") { cut = Some(l) },
            Some((_, z)) = zones.recv() => if z.zone == 7 && z.stale { stale = Some(z) },
            _ = tokio::time::sleep(Duration::from_millis(100)) => {}
        }
    }
    let (cut, stale) = (cut.unwrap(), stale.unwrap());
    assert!(cut.last_ok.is_some() && cut.disconnects > 0, "{cut:?}");
    assert!(
        cut.problem
            .contains("the SCADA's Modbus server at 127.0.0.1:"),
        "{cut:?}"
    );
    assert!((stale.reading.max_c - 85.3).abs() < 1e-9);
    assert!(
        stale.t >= last_good && stale.t <= cut.t,
        "{stale:?} {cut:?}"
    );
}

#[test]
fn a_fleet_with_the_bridge_puts_its_fire_out_and_a_cut_link_shows_stale_on_the_console() {
    let port = firefleet_bus::free_loopback_port().unwrap();
    let addr = format!("127.0.0.1:{port}");
    let demo = Command::new(BIN)
        .args([
            "demo",
            "--scenario",
            SCENARIO,
            "--scada",
            "--cut-scada-at",
            "30",
            "--time-scale",
            "4",
            "--console",
            &addr,
            "--linger",
            "4",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Before the cut, the layer is live with the fire's zone in alarm; after it, stale.
    let until = Instant::now() + patient(Duration::from_secs(90));
    let (mut live, mut cut) = (false, None);
    while cut.is_none() {
        assert!(
            Instant::now() < until,
            "the console never showed the cut link"
        );
        std::thread::sleep(Duration::from_millis(500));
        let Some(inc) = get_json(&addr, "/api/incident") else {
            continue;
        };
        let infra = &inc["infra"];
        if infra["link_up"] == true
            && infra["zones"]
                .as_array()
                .is_some_and(|zs| zs.iter().any(|z| z["alarm"] == true))
        {
            live = true;
        }
        if live && infra["link_up"] == false {
            cut = Some(inc);
        }
    }
    let inc = cut.unwrap();
    let zones = inc["infra"]["zones"].as_array().unwrap();
    assert_eq!(zones.len(), 30);
    assert!(zones.iter().all(|z| z["stale"] == true), "{inc}");
    assert!(
        inc["alerts"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["kind"] == "scada-lost"),
        "{inc}"
    );
    let out = demo.wait_with_output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("all 1 fires out"), "{said}");
}

/// The bridge killed and started again mid-incident, the rest of the fleet left alone
/// (issue #46: every role restarted alone keeps the incident going). Its readings come back
/// stamped on the site clock, not from t = 0 (which every role would refuse as more than
/// 10 s behind), fresh, and the fire goes out.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bridge_restarted_alone_mid_incident_reads_on_the_site_clock_and_the_fire_goes_out() {
    let (bus, endpoint) = router("tunnel-v").await;
    let keys = bus.keys().clone();
    let zones = bus
        .subscribe::<DtsZone>(&keys.every_dts_zone())
        .await
        .unwrap();
    let truths = bus
        .subscribe::<firefleet_protocol::msg::SimTruth>(&keys.sim_truth())
        .await
        .unwrap();
    let modbus = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    let bridge = || {
        spawn_role(
            SCENARIO,
            &endpoint,
            &[
                "scada",
                "--modbus",
                &modbus,
                "--sim-clock",
                "--period-s",
                "0.5",
            ],
        )
    };
    let mut roles = vec![
        spawn_role(
            SCENARIO,
            &endpoint,
            &[
                "sim",
                "--time-scale",
                "4",
                "--wait-for-fleet",
                "30",
                "--wait-for-coordinator",
                "--scada",
                &modbus,
            ],
        ),
        spawn_role(SCENARIO, &endpoint, &["coordinator", "--sim-clock"]),
    ];
    let scenario = builtin::resolve(SCENARIO).unwrap();
    for u in &scenario.units {
        roles.push(spawn_role(
            SCENARIO,
            &endpoint,
            &["agent", "--unit", u.id.as_str()],
        ));
    }
    roles.push(bridge());
    let mut fleet = Fleet(roles);
    let bridge_at = fleet.0.len() - 1;

    // A fresh reading some seconds into the incident, then the bridge killed.
    let fresh_after = |t0: f64| {
        let zones = &zones;
        async move {
            tokio::time::timeout(patient(Duration::from_secs(60)), async {
                loop {
                    let (_, z) = zones.recv().await.expect("bus open");
                    if !z.stale && z.t > t0 {
                        return z.t;
                    }
                }
            })
            .await
            .expect("no fresh DTS reading")
        }
    };
    let before = fresh_after(10.0).await;
    fleet.0[bridge_at].kill().unwrap();
    fleet.0[bridge_at].wait().unwrap();
    while zones.try_recv().is_some() {}
    fleet.0[bridge_at] = bridge();
    let after = fresh_after(0.0).await;
    assert!(
        after >= before,
        "the restarted bridge stamped a reading {after:.1} s, before {before:.1} s"
    );
    drop(zones);
    let truth = outcome(&truths, Duration::from_secs(120)).await;
    assert!(truth.all_out(), "{truth:?}");
    drop(fleet);
    bus.close().await;
}
