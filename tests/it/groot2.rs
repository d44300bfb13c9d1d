//! A demo unit's behavior tree, watched as Groot2 watches one and replayed from the file
//! it wrote: the demo started with `--groot2 PORT --btlog-dir DIR`, a Groot2-protocol
//! client asks the units' agents (both ground units, on PORT and PORT + 1) for their tree,
//! the status of every node, and their blackboard until one is seen at work; once the demo
//! is over that unit's `.btlog` is read back from the format alone
//! (`agent/tests/btcpp/btlog.py`).

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use firefleet_agent::groot2::Client;
use firefleet_bus::free_loopback_ports;

use crate::support::{BIN, patient};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_demo_units_tree_is_watched_in_groot2_and_recorded_for_replay() {
    let dir = tempfile::tempdir().unwrap();
    let units = ["ugv-1", "ugv-2"];
    // Each unit serves Groot2 on its own port from this one.
    let port = free_loopback_ports(units.len() as u16).unwrap();
    let mut demo = Command::new(BIN)
        .args([
            "demo",
            "--scenario",
            "vehicle-collision",
            // At x1 the units are at work for some 40 s of wall time: at x4, and once at
            // x2, a busy machine's slow answers (each look may take seconds under CI's
            // load) missed the whole of it.
            "--time-scale",
            "1",
        ])
        .args(["--groot2", &port.to_string(), "--btlog-dir"])
        .arg(dir.path())
        .env_remove("RUST_LOG")
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    // Looked at until one is seen at work, or the demo is over (all out at some 55 s).
    let deadline = Instant::now() + patient(Duration::from_secs(90));
    let mut working = None;
    for k in (0..units.len()).cycle() {
        if Instant::now() > deadline || working.is_some() || demo.try_wait().unwrap().is_some() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(150)).await;
        let addr = format!("127.0.0.1:{}", port + k as u16).parse().unwrap();
        let Ok(Ok(mut c)) =
            tokio::time::timeout(Duration::from_secs(2), Client::connect(addr)).await
        else {
            continue;
        };
        let look = async {
            let xml = c.tree().await?;
            let statuses = c.statuses().await?;
            let bb = c.blackboards("GroundUnit").await?;
            Ok::<_, firefleet_agent::groot2::ClientError>((xml, statuses, bb))
        };
        let Ok(Ok((xml, statuses, bb))) = tokio::time::timeout(Duration::from_secs(5), look).await
        else {
            continue;
        };
        // At work: on its way to a fire or fighting it, the fire on its blackboard.
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let at_work = statuses.iter().any(|(uid, s)| {
            *s == 1
                && doc.descendants().any(|e| {
                    e.attribute("_uid") == Some(&uid.to_string())
                        && matches!(e.attribute("ID"), Some("NavigateToFire" | "ExtinguishFire"))
                })
        });
        if at_work && !bb["GroundUnit"]["fire"].is_null() {
            working = Some((units[k], xml, statuses, bb));
        }
    }
    let (unit, xml, statuses, bb) = working.expect("a unit seen at work through Groot2");
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let uids = doc
        .descendants()
        .filter(|e| e.has_attribute("_uid"))
        .count();
    assert_eq!(statuses.len(), uids, "a status for every node");
    assert!(
        doc.descendants()
            .any(|e| e.tag_name().name() == "TreeNodesModel"),
        "the unit's own node types are described: {xml}"
    );
    assert!(!bb["GroundUnit"]["task"].is_null(), "{bb}");

    let status = demo.wait().unwrap();
    assert!(status.success(), "demo exited with {status}");
    let log = dir.path().join(format!("{unit}.btlog"));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("agent/tests/btcpp/btlog.py");
    let out = firefleet_model::testing::python_stdout(&script, &["read".as_ref(), log.as_os_str()]);
    let replay: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let nodes = replay["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), uids, "the file's tree is the one served");
    let transitions = replay["transitions"].as_array().unwrap();
    assert!(transitions.len() > 100, "{} transitions", transitions.len());
    let times: Vec<u64> = transitions.iter().map(|t| t[0].as_u64().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "in time order");
    let known = |uid: u64| nodes.iter().any(|n| n[0].as_u64() == Some(uid));
    assert!(transitions.iter().all(|t| known(t[1].as_u64().unwrap())));
}
