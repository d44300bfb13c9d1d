//! The lab's experiments from the command line, as CI runs them: their JSON, their
//! reproducibility and the orderings the papers and the fleet's design promise.

use std::process::{Command, Output};

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// `firefleet-lab ARGS`, run from the workspace's root (where the site files are).
fn lab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_firefleet-lab"))
        .args(args)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .output()
        .unwrap()
}

/// `firefleet-lab ARGS --json FILE`, which must succeed, and the JSON it wrote.
fn json_of(args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.json");
    let out = lab(&[args, &["--json", path.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap()
}

/// Asserts that every one of `keys` in `v` is a number.
fn assert_numbers(v: &serde_json::Value, keys: &[&str]) {
    for key in keys {
        assert!(v[key].is_number(), "{key} in {v}");
    }
}

#[test]
fn the_cannon_experiment_reports_every_angle_and_is_reproducible() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.json"), dir.path().join("b.json"));
    for path in [&a, &b] {
        let out = lab(&[
            "cannon",
            "--seed",
            "3",
            "--trials",
            "4",
            "--json",
            path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let (ja, jb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(ja, jb, "the same seed gives the same results");
    let v: serde_json::Value = serde_json::from_slice(&ja).unwrap();
    let angles = v["angles"].as_array().unwrap();
    assert_eq!(
        angles
            .iter()
            .map(|x| x["angle_deg"].as_f64().unwrap())
            .collect::<Vec<_>>(),
        [0.0, 30.0, 60.0]
    );
    for x in angles {
        assert_numbers(
            x,
            &[
                "trials",
                "mean_s_per_flame",
                "std_s_per_flame",
                "completion_rate",
            ],
        );
        assert!(x["completion_rate"].as_f64().unwrap() > 0.9, "{x}");
    }
}

#[test]
fn the_fleet_experiment_compares_the_strategies_with_and_without_the_scada_feed() {
    let v = json_of(&["fleet", "--trials", "1"]);
    let runs = v["strategies"].as_array().unwrap();
    assert_eq!(
        runs.len(),
        17,
        "4 scenarios x 4 strategies, and the ventilated one from downwind"
    );
    for r in runs {
        assert!(
            ["autonomous", "greedy", "optimal", "feed", "feed, downwind"]
                .contains(&r["strategy"].as_str().unwrap())
        );
        assert_numbers(
            r,
            &[
                "time_all_out_s",
                "heat_dose",
                "attack_heat_dose",
                "water_l",
                "fires_never_attacked",
            ],
        );
        assert_eq!(r["unfinished"], 0, "every fire out in {r}");
    }
    let run = |scenario: &str, strategy: &str| {
        runs.iter()
            .find(|r| r["scenario"] == scenario && r["strategy"] == strategy)
            .unwrap_or_else(|| panic!("no {strategy} run on {scenario}"))
    };
    let num = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
    // Upwind spares the attackers the fire's hot gas, and the fleet the downstream smoke.
    let (up, down) = (
        run("ventilated", "feed"),
        run("ventilated", "feed, downwind"),
    );
    assert!(
        num(up, "attack_heat_dose") < 0.5 * num(down, "attack_heat_dose"),
        "{up} {down}"
    );
    assert!(num(up, "heat_dose") < num(down, "heat_dose"), "{up} {down}");
    // The DTS finds the rail tunnel's far fire before any sensor of the fleet does.
    let (fed, optimal) = (run("rail-tunnel", "feed"), run("rail-tunnel", "optimal"));
    assert!(
        num(fed, "time_all_out_s") < num(optimal, "time_all_out_s"),
        "{fed} {optimal}"
    );
    // The drive floor is under every time on its scenario.
    let floors = v["floors"].as_array().unwrap();
    assert!(floors.len() >= 2, "{v}");
    for f in floors {
        let (name, floor) = (f[0].as_str().unwrap(), f[1].as_f64().unwrap());
        for r in runs.iter().filter(|r| r["scenario"] == name) {
            assert!(
                num(r, "time_all_out_s") > floor,
                "{r} under the floor {floor}"
            );
        }
    }
}

#[test]
fn the_costmap_experiment_reports_the_papers_three_cases_in_its_order() {
    let v = json_of(&["costmap-ga", "--size", "40"]);
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 3);
    let f = |k: usize| cases[k]["fitness"].as_f64().unwrap();
    for c in cases {
        for key in ["case", "fitness", "path_time", "heat_dose"] {
            assert!(c[key].is_number(), "{key} in {c}");
        }
    }
    assert!(
        f(2) <= f(1) && f(2) <= f(0),
        "the GA's weights plan the fittest path: {v}"
    );
    let h = |k: usize| cases[k]["heat_dose"].as_f64().unwrap();
    assert!(
        h(1) < h(0),
        "heat in the cost keeps the path out of the heat: {v}"
    );
}
