//! The README's newcomer path, run as written: the block marked `<!-- newcomer -->` starts a
//! demo in the background and reaches it with `status` and `goal`, as a person who has just
//! cloned the repository would. Only the port is changed, to a free one, so the test does
//! not collide with another on the same machine.
//!
//! And the docs' key table: every key the protocol defines appears in `docs/keys.md`.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use firefleet_bus::free_loopback_port;

use crate::support::{BIN, Fleet, patient, text};

fn repo_file(path: &str) -> String {
    std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The commands of the README's block marked `<!-- newcomer`: (the words after
/// `firefleet`, whether it runs in the background).
fn newcomer_commands(readme: &str) -> Vec<(Vec<String>, bool)> {
    let after = readme
        .split_once("<!-- newcomer")
        .expect("the README marks its newcomer block")
        .1;
    let block = after
        .split_once("```sh\n")
        .and_then(|(_, b)| b.split_once("```"))
        .expect("a sh block follows the marker")
        .0;
    block
        .lines()
        .map(|line| {
            let line = line.trim();
            let (line, background) = match line.strip_suffix('&') {
                Some(l) => (l.trim(), true),
                None => (line, false),
            };
            let mut words = line.split_whitespace().map(str::to_owned);
            assert_eq!(words.next().as_deref(), Some("firefleet"), "{line}");
            (words.collect(), background)
        })
        .collect()
}

#[test]
fn the_readme_newcomer_path_works_as_written() {
    let readme = repo_file("README.md");
    let commands = newcomer_commands(&readme);
    assert!(commands.len() >= 3, "{commands:?}");
    assert!(commands[0].1, "the demo runs in the background");
    let port = free_loopback_port().unwrap().to_string();
    let with_port = |words: &[String]| -> Vec<String> {
        words.iter().map(|w| w.replace("17447", &port)).collect()
    };
    let demo = Command::new(BIN)
        .args(with_port(&commands[0].0))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _fleet = Fleet(vec![demo]);
    let mut said = Vec::new();
    for (words, background) in &commands[1..] {
        assert!(!background, "only the demo runs in the background");
        let args = with_port(words);
        // The first command waits for the demo's coordinator to answer; each after it
        // must succeed at once.
        let deadline = Instant::now() + patient(Duration::from_secs(60));
        let out = loop {
            let out = Command::new(BIN)
                .args(&args)
                .current_dir(env!("CARGO_MANIFEST_DIR"))
                .output()
                .unwrap();
            if out.status.success() || !said.is_empty() || Instant::now() > deadline {
                break out;
            }
            std::thread::sleep(Duration::from_millis(500));
        };
        assert!(out.status.success(), "firefleet {args:?}: {}", text(&out));
        said.push(text(&out));
    }
    // `status` shows the demo's units; `goal set` was taken; `goal list` lists it.
    assert!(said[0].contains("ugv-1"), "{}", said[0]);
    let set = commands
        .iter()
        .position(|(w, _)| w.starts_with(&["goal".into(), "set".into()]))
        .expect("the path sets a goal");
    let list = commands
        .iter()
        .position(|(w, _)| w.starts_with(&["goal".into(), "list".into()]))
        .expect("the path lists the goals");
    assert!(said[set - 1].contains("on zone far"), "{}", said[set - 1]);
    assert!(said[list - 1].contains("far"), "{}", said[list - 1]);
}

#[test]
fn every_key_of_the_protocol_is_in_the_docs_key_table() {
    let doc = repo_file("docs/keys.md");
    let table: Vec<&str> = doc
        .lines()
        .filter(|l| l.starts_with("| `ff/<site>/"))
        .collect();
    let missing: Vec<&str> = firefleet_protocol::keys::Topic::TEMPLATES
        .iter()
        .copied()
        .filter(|key| {
            !table
                .iter()
                .any(|row| row.contains(&format!("`ff/<site>/{key}`")))
        })
        .collect();
    assert!(
        missing.is_empty(),
        "docs/keys.md has no row for {missing:?}"
    );
}
