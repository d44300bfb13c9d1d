//! The command line: exit codes and messages a user relies on.

use crate::support::{assert_says, firefleet, json_of};

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn bt_validate_accepts_the_shipped_trees_and_names_every_error() {
    let ok = firefleet(&[
        "bt",
        "validate",
        "agent/trees/ground_unit.xml",
        "examples/trees/patrol.xml",
        "examples/trees/scripting.xml",
    ]);
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    assert!(
        text(&ok.stdout).contains("ground_unit.xml: valid (5 trees)"),
        "{}",
        text(&ok.stdout)
    );

    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.xml");
    std::fs::write(&bad, "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"T\">\n<Sequence>\n<Fly/>\n<Timeout><AlwaysSuccess/></Timeout>\n<Script code=\"x := (1 +\"/>\n<AlwaysSuccess _skipIf=\"x == = 2\"/>\n</Sequence>\n</BehaviorTree>\n</root>\n").unwrap();
    let out = firefleet(&["bt", "validate", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(
        err.contains("bad.xml:4: Fly: unknown node type 'Fly'"),
        "{err}"
    );
    assert!(
        err.contains("bad.xml:5: Timeout: missing required port 'msec'"),
        "{err}"
    );
    // A script's error says where in the script, as well as where in the file.
    assert!(
        err.contains(
            "bad.xml:6: Script: code: column 10: the script ends where an operand was expected"
        ),
        "{err}"
    );
    assert!(
        err.contains("bad.xml:7: AlwaysSuccess: _skipIf: column 6: expected an operand, found '='"),
        "{err}"
    );
}

#[test]
fn bt_run_runs_a_tree_that_sets_its_blackboard_with_scripts() {
    let out = firefleet(&["bt", "run", "examples/trees/scripting.xml", "--ticks", "6"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("root SUCCESS"), "{stdout}");
    assert!(
        stdout.contains("ScriptCondition \"done\"") && stdout.contains("IDLE -> SUCCESS"),
        "{stdout}"
    );
}

#[test]
fn bt_run_dry_runs_built_in_trees_on_a_simulated_clock() {
    let out = firefleet(&[
        "bt",
        "run",
        "examples/trees/patrol.xml",
        "--ticks",
        "8",
        "--period-ms",
        "100",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("tick   8  t=   0.700 s  root SUCCESS"),
        "{stdout}"
    );
    assert!(
        stdout.contains("Sleep \"drive\"") && stdout.contains("RUNNING -> SUCCESS"),
        "{stdout}"
    );

    let out = firefleet(&["bt", "run", "agent/trees/ground_unit.xml"]);
    assert_says(&out, 2, "knows only the built-in nodes");
}

#[test]
fn bad_scenarios_and_arguments_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "name = \"x\"\ntime_limit_s = 10\n[tunnel]\nlength_m = 50.0\nwidth_m = 10.0\nheight_m = 6.0\nlanes = 2\n[[fires]]\nname = \"f\"\nx_m = 80.0\ny_m = 0.0\ngrowth = \"fast\"\npeak_kw = 100.0\n").unwrap();
    let out = firefleet(&["demo", "--scenario", bad.to_str().unwrap()]);
    assert_says(
        &out,
        2,
        "fires[0].x_m/y_m: (80.00, 0.00) is outside the tunnel",
    );

    let out = firefleet(&[
        "agent",
        "--scenario",
        "vehicle-collision",
        "--unit",
        "ugv-9",
    ]);
    assert_says(
        &out,
        2,
        "--unit ugv-9: the scenario 'vehicle-collision' has no such unit",
    );

    let out = firefleet(&["coordinator", "--assignment", "auction"]);
    assert_says(&out, 2, "'auction' is not an assignment strategy");

    let out = firefleet(&["sim", "--time-scale", "0"]);
    assert_says(&out, 2, "0 is not a positive number");
    // Used to panic in the simulator's timer.
    let out = firefleet(&["demo", "--time-scale", "1e9"]);
    assert_says(&out, 2, "1000000000 is faster than the fleet can follow");
}

/// A reader that stops reading ends the command quietly, with the status a shell gives a
/// program a closed pipe stopped (141): no panic, no message (`firefleet status | head`
/// used to panic on the first line after).
#[test]
fn a_closed_pipe_ends_a_command_quietly() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_firefleet"))
        .args(["schema", "FireTrack"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Nobody reads: the first write fails on a closed pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(141), "{:?}", out.status);
    assert!(
        !text(&out.stderr).contains("panicked"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn plan_grid_solves_a_movingai_benchmark_to_its_optimal_lengths() {
    // The fixture's optimal lengths come from an independent Dijkstra
    // (tests/fixtures/make_grid_bench.py).
    let fixtures = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures");
    let map = format!("{fixtures}/grid-bench.map");
    let scen = format!("{fixtures}/grid-bench.scen");
    let v = json_of(&["plan", "grid", "--map", &map, "--scen", &scen]);
    assert_eq!(v["problems"], 60);
    assert_eq!(v["solved"], 60);
    assert!(v["mean_rel_error"].as_f64().unwrap() < 1e-8, "{v}");
    assert!(v["mean_ms"].is_number());

    let out = firefleet(&["plan", "grid", "--map", &scen, "--scen", &scen]);
    assert_says(&out, 2, "grid-bench.scen: line 1: expected 'type'");
}

#[test]
fn deploy_render_writes_the_documented_rules_and_a_site_router_refuses_plain_links() {
    let dir = tempfile::tempdir().unwrap();
    let path = |p: &str| dir.path().join(p).to_str().unwrap().to_owned();
    let (pki, cfg) = (path("pki"), path("cfg"));
    let init = [
        "pki",
        "init",
        "--scenario",
        "vehicle-collision",
        "--out",
        &pki,
    ];
    assert!(
        firefleet(&[&init[..], &["--commander", "rossi"]].concat())
            .status
            .success()
    );
    let render = [
        "deploy",
        "render",
        "--scenario",
        "vehicle-collision",
        "--pki",
        &pki,
        "--out",
        &cfg,
    ];
    let out = firefleet(&[&render[..], &["--commander", "rossi"]].concat());
    assert_says(
        &out,
        0,
        "1 router configuration(s), 9 client configurations",
    );
    let table = std::fs::read_to_string(dir.path().join("cfg/ACCESS.md")).unwrap();
    let readme = std::fs::read_to_string("deploy/README.md").unwrap();
    assert!(
        readme.contains(&table),
        "deploy/README.md's table is not what deploy render writes:\n{table}"
    );
    // A commander without a certificate, and a plain endpoint, are refused by name.
    let out = firefleet(&[&render[..], &["--commander", "verdi"]].concat());
    assert_says(&out, 2, "commander:verdi has no certificate");
    let out = firefleet(&[&render[..], &["--listen", "tcp/0.0.0.0:7447"]].concat());
    assert_says(&out, 2, "a site's links are quic/");
    // A site's router: QUIC with mutual TLS and access rules, or --plain said out loud.
    let out = firefleet(&[
        "router",
        "--scenario",
        "vehicle-collision",
        "--listen",
        "tcp/127.0.0.1:0",
    ]);
    assert_says(&out, 2, "takes QUIC links with mutual TLS only");
    let out = firefleet(&[
        "router",
        "--scenario",
        "vehicle-collision",
        "--zenoh-config",
        "deploy/router.json5",
    ]);
    assert_says(&out, 2, "takes QUIC links with mutual TLS only");
}

#[test]
fn the_scada_roles_refuse_a_site_file_that_maps_no_scada() {
    let site = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/site/site.toml");
    let out = firefleet(&["scada", "--scenario", site, "--modbus", "127.0.0.1:1"]);
    assert_says(&out, 2, "site 'nord': its file maps no [scada]");
    let out = firefleet(&["sim", "--scenario", site, "--scada", "127.0.0.1:1"]);
    assert_says(&out, 2, "--scada: site 'nord': its file maps no [scada]");
    let out = firefleet(&["demo", "--scenario", site, "--scada"]);
    assert_says(
        &out,
        2,
        "--scada: scenario 'guide-rehearsal' maps no [scada]",
    );
    let out = firefleet(&["scada", "--scenario", "ventilated", "--modbus", "nowhere"]);
    assert_says(&out, 2, "--modbus");
}
