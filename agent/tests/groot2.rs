//! The Groot2 publisher and the `.btlog` writer, against BehaviorTree.CPP 4.8 itself
//! (`behaviortreepy`): our protocol client is first checked on BT.CPP's own
//! Groot2Publisher, then asks our publisher the same questions about the same tree; our
//! `.btlog` is parsed beside one BT.CPP's FileLogger2 wrote for the same tree and ticks.
//! Without python3 and behaviortreepy (required in CI) the checks against BT.CPP are
//! skipped, said so, and ours still run.

use std::io::{BufRead, BufReader, Write};
use std::net::SocketAddr;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use firefleet_agent::btlog::BtLog;
use firefleet_agent::groot2::{Client, ClientError, Groot2};
use firefleet_bt::{Registry, Transition, Tree, xml};

/// A tree whose statuses do not depend on time: `keep` runs for ever.
const TREE: &str = "<root BTCPP_format=\"4\"><BehaviorTree ID=\"MainTree\"><Sequence name=\"work\">\
    <Script name=\"set\" code=\"x := 1; mode := 'spray'\"/>\
    <KeepRunningUntilFailure name=\"keep\"><AlwaysSuccess name=\"ok\"/></KeepRunningUntilFailure>\
    </Sequence></BehaviorTree></root>";

fn btcpp() -> bool {
    firefleet_model::testing::python_package(
        "behaviortreepy",
        "behaviortreepy==0.1.4",
        "FIREFLEET_REQUIRE_BEHAVIORTREEPY",
    )
}

fn script(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/btcpp")
        .join(name)
}

fn ours() -> Tree<()> {
    xml::build(
        &xml::parse_str(TREE, "groot2.xml").unwrap(),
        &Registry::new(),
    )
    .unwrap()
}

/// `(uid, element, name)` of every node of a Groot2 XML, by uid.
fn nodes(text: &str) -> Vec<(u16, String, String)> {
    let doc = roxmltree::Document::parse(text).unwrap();
    let mut out: Vec<_> = doc
        .descendants()
        .filter_map(|e| {
            let uid = e.attribute("_uid")?.parse().ok()?;
            let name = e.attribute("name").or(e.attribute("ID")).unwrap_or("");
            Some((uid, e.tag_name().name().to_owned(), name.to_owned()))
        })
        .collect();
    out.sort();
    out
}

/// What a Groot2 client learns of the tree at `addr`: its nodes, each node's status byte
/// by name, and the main blackboard.
async fn look(
    addr: SocketAddr,
) -> (
    Vec<(u16, String, String)>,
    Vec<(String, u8)>,
    serde_json::Value,
) {
    let mut c = Client::connect(addr).await.unwrap();
    let tree = nodes(&c.tree().await.unwrap());
    let statuses = c.statuses().await.unwrap();
    let by_name = statuses
        .iter()
        .map(|(uid, s)| {
            let n = tree
                .iter()
                .find(|n| n.0 == *uid)
                .expect("a uid of the tree");
            (n.2.clone(), *s)
        })
        .collect();
    let bb = c.blackboards("MainTree").await.unwrap();
    (tree, by_name, bb)
}

#[tokio::test]
async fn groot2_sees_our_tree_as_it_sees_bt_cpps() {
    let mut tree = ours();
    let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::<Transition>::new()));
    let sink = seen.clone();
    tree.set_observer(move |t| sink.borrow_mut().push(*t));
    let g = Groot2::serve("127.0.0.1:0".parse().unwrap(), &tree)
        .await
        .unwrap();
    // Asked once, so that the blackboard is copied at the next steps.
    Client::connect(g.addr())
        .await
        .unwrap()
        .tree()
        .await
        .unwrap();
    for k in 0..3 {
        tree.tick(f64::from(k), &mut ());
        g.update(
            &tree,
            &seen.borrow_mut().drain(..).collect::<Vec<_>>(),
            f64::from(k),
        );
    }
    let (our_nodes, our_status, our_bb) = look(g.addr()).await;
    // What we do not implement is said, and the publisher goes on. (BT.CPP's server
    // thread dies on this malformed hook: not asked of it.)
    let mut c = Client::connect(g.addr()).await.unwrap();
    match c.ask(b'I', Some("{}")).await {
        Err(ClientError::Refused(why)) => assert!(why.contains("breakpoints"), "{why}"),
        other => panic!("a hook request should be refused, not {other:?}"),
    }
    match c.ask(b'?', None).await {
        Err(ClientError::Refused(why)) => assert!(why.contains("0x3f"), "{why}"),
        other => panic!("an unknown request should be refused, not {other:?}"),
    }
    assert_eq!(c.statuses().await.unwrap().len(), 4, "still serving");
    assert_eq!(our_nodes.len(), 4);
    // Running: the sequence and the loop; the script done (a sequence resets its children
    // when it completes).
    let status = |n: &str| our_status.iter().find(|(m, _)| m == n).unwrap().1;
    assert_eq!((status("work"), status("keep"), status("set")), (1, 1, 2));
    assert_eq!(our_bb["MainTree"]["x"], 1);
    assert_eq!(our_bb["MainTree"]["mode"], "spray");

    if !btcpp() {
        return;
    }
    let port = firefleet_bus::free_loopback_port().unwrap();
    let mut python = Command::new("python3")
        .arg(script("publisher.py"))
        .arg(port.to_string())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = python.stdin.take().unwrap();
    writeln!(stdin, "{TREE}").unwrap();
    let mut ready = String::new();
    BufReader::new(python.stdout.take().unwrap())
        .read_line(&mut ready)
        .unwrap();
    assert_eq!(ready.trim(), "ready");
    let addr: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let theirs = tokio::time::timeout(Duration::from_secs(20), look(addr)).await;
    drop(stdin);
    python.wait().unwrap();
    let (their_nodes, their_status, their_bb) = theirs.expect("BT.CPP's publisher answers");
    assert_eq!(our_nodes, their_nodes, "the same nodes under the same uids");
    assert_eq!(our_status, their_status, "the same status buffer");
    assert_eq!(our_bb, their_bb, "the same blackboard dump");
}

/// Parse a `.btlog` with `btlog.py read`.
fn read_btlog(path: &Path) -> serde_json::Value {
    let out = firefleet_model::testing::python_stdout(
        &script("btlog.py"),
        &["read".as_ref(), path.as_os_str()],
    );
    serde_json::from_slice(&out).unwrap()
}

#[test]
fn our_btlog_reads_back_as_bt_cpps_file_logger_writes_it() {
    const TICKS: usize = 3;
    let dir = std::env::temp_dir().join(format!("firefleet-btlog-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut tree = ours();
    let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::<Transition>::new()));
    let sink = seen.clone();
    tree.set_observer(move |t| sink.borrow_mut().push(*t));
    let path = dir.join("ours.btlog");
    assert!(
        BtLog::create(&dir.join("ours.log"), &tree).is_err(),
        "only .btlog"
    );
    let mut log = BtLog::create(&path, &tree).unwrap();
    for k in 0..TICKS {
        let now = k as f64 * 0.1;
        tree.tick_exactly_once(now, &mut ());
        log.append(&seen.borrow_mut().drain(..).collect::<Vec<_>>(), now)
            .unwrap();
    }
    log.flush().unwrap();
    drop(log);
    if !btcpp() {
        return;
    }
    let ours = read_btlog(&path);
    let theirs_path = dir.join("theirs.btlog");
    let mut python = Command::new("python3")
        .arg(script("btlog.py"))
        .args([
            "write".as_ref(),
            theirs_path.as_os_str(),
            TICKS.to_string().as_ref(),
        ])
        .stdin(Stdio::piped())
        .spawn()
        .unwrap();
    python
        .stdin
        .take()
        .unwrap()
        .write_all(TREE.as_bytes())
        .unwrap();
    assert!(python.wait().unwrap().success());
    let theirs = read_btlog(&theirs_path);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(ours["version"], theirs["version"]);
    assert_eq!(
        ours["nodes"], theirs["nodes"],
        "the same nodes under the same uids"
    );
    // The same transitions, in order; the times are each engine's own.
    let changes = |v: &serde_json::Value| -> Vec<(u64, u64)> {
        v["transitions"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| (t[1].as_u64().unwrap(), t[2].as_u64().unwrap()))
            .collect()
    };
    assert!(!changes(&ours).is_empty());
    assert_eq!(changes(&ours), changes(&theirs));
    let times: Vec<u64> = ours["transitions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t[0].as_u64().unwrap())
        .collect();
    assert_eq!(
        times.last(),
        Some(&200_000),
        "the third tick, 0.2 s after the first"
    );
}
