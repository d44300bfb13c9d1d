//! A scenario builder for tests and benchmarks: the sites they need, said in a line
//! each instead of a pasted TOML file; and [`python_package`], how a test that checks our
//! output with an independent Python reader finds it or says it could not.
//!
//! ```
//! use firefleet_model::scenario::Scenario;
//! let s = Scenario::straight(120.0).car("car", 40.0, -2.5).fire("fire", 60.0, -2.0, 5000.0)
//!     .ground("u1", 5.0, -2.5).build();
//! assert_eq!(s.units.len(), 1);
//! ```
//!
//! Built sites are validated like a site file; an invalid one panics, naming what is
//! wrong (a test's own mistake). Not for production: site files are TOML, read with
//! [`Scenario::load`].

use crate::scenario::{FireSpec, Growth, Obstacle, Rail, Scenario, Tunnel, UnitSpec};
use crate::{UnitId, UnitKind};

/// A scenario under construction; see the module doc.
#[derive(Debug, Clone)]
pub struct ScenarioBuilder(Scenario);

impl Scenario {
    /// A straight tunnel `length_m` long, 10 m wide, 6.3 m high, two lanes, with a
    /// 300 s time limit and nothing in it yet.
    pub fn straight(length_m: f64) -> ScenarioBuilder {
        ScenarioBuilder(Scenario::empty(
            "test",
            crate::SiteId::new("tunnel").expect("valid literal"),
            Tunnel::straight(length_m, 10.0, 6.3, 2),
            300.0,
        ))
    }
}

impl ScenarioBuilder {
    pub fn name(mut self, name: &str) -> Self {
        self.0.name = name.into();
        self
    }

    pub fn time_limit(mut self, s: f64) -> Self {
        self.0.time_limit_s = s;
        self
    }

    /// The tunnel's cross-section.
    pub fn section(mut self, width_m: f64, height_m: f64) -> Self {
        self.0.tunnel.width_m = width_m;
        self.0.tunnel.height_m = height_m;
        self
    }

    /// A box on the road, `length_m` x `width_m` x `height_m`, centred at (x, y).
    pub fn obstacle(mut self, name: &str, (x_m, y_m): (f64, f64), size: [f64; 3]) -> Self {
        let [length_m, width_m, height_m] = size;
        self.0.obstacles.push(Obstacle {
            name: name.into(),
            x_m,
            y_m,
            length_m,
            width_m,
            height_m,
            yaw_rad: 0.0,
        });
        self
    }

    /// A parked car (4.5 x 1.8 x 1.5 m) at (x, y).
    pub fn car(self, name: &str, x_m: f64, y_m: f64) -> Self {
        self.obstacle(name, (x_m, y_m), [4.5, 1.8, 1.5])
    }

    /// A fast-growing fire of `peak_kw` at (x, y), burning since well before the start
    /// (ignition 120 s before; [`ScenarioBuilder::ignition`] changes it).
    pub fn fire(mut self, name: &str, x_m: f64, y_m: f64, peak_kw: f64) -> Self {
        self.0.fires.push(FireSpec {
            name: name.into(),
            x_m,
            y_m,
            growth: Growth::Fast,
            peak_kw,
            ignition_s: -120.0,
            radius_m: 1.0,
        });
        self
    }

    /// The ignition time of the last fire added, s of site time.
    pub fn ignition(mut self, s: f64) -> Self {
        self.0
            .fires
            .last_mut()
            .expect("ignition() follows fire()")
            .ignition_s = s;
        self
    }

    /// The t-squared growth class of the last fire added.
    pub fn growth(mut self, growth: Growth) -> Self {
        self.0
            .fires
            .last_mut()
            .expect("growth() follows fire()")
            .growth = growth;
        self
    }

    fn unit(mut self, id: &str, kind: UnitKind, x_m: f64, y_m: f64, rail: Option<&str>) -> Self {
        self.0.units.push(UnitSpec {
            id: UnitId::new(id).expect("a valid unit id"),
            kind,
            x_m,
            y_m,
            yaw_rad: 0.0,
            rail: rail.map(str::to_owned),
            profile: None,
        });
        self
    }

    /// The last unit added is of profile `name` (shipped, or added with
    /// [`ScenarioBuilder::with_profile`]).
    pub fn profile(mut self, name: &str) -> Self {
        self.0
            .units
            .last_mut()
            .expect("profile() follows a unit")
            .profile = Some(name.into());
        self
    }

    /// A profile of this site's own.
    pub fn with_profile(mut self, name: &str, p: crate::profile::Profile) -> Self {
        self.0.profiles.insert(name.into(), p);
        self
    }

    /// A ground unit at (x, y), facing +x.
    pub fn ground(self, id: &str, x_m: f64, y_m: f64) -> Self {
        self.unit(id, UnitKind::Ground, x_m, y_m, None)
    }

    /// A ceiling rail from `start_m` to `end_m` on the centreline, its monitor 5.8 m up,
    /// with hose points at `hose_points_m`.
    pub fn rail(mut self, id: &str, start_m: f64, end_m: f64, hose_points_m: &[f64]) -> Self {
        self.0.rails.push(Rail {
            id: id.into(),
            start_m,
            end_m,
            y_m: 0.0,
            height_m: 5.8,
            hose_points_m: hose_points_m.to_vec(),
        });
        self
    }

    /// The monitor's pivot height above the road of the last rail added, m.
    pub fn rail_height(mut self, height_m: f64) -> Self {
        self.0
            .rails
            .last_mut()
            .expect("rail_height() follows rail()")
            .height_m = height_m;
        self
    }

    /// A monorail unit on `rail`, at chainage `x_m`.
    pub fn monorail(self, id: &str, rail: &str, x_m: f64) -> Self {
        self.unit(id, UnitKind::Monorail, x_m, 0.0, Some(rail))
    }

    /// The scenario; panics if it would not pass as a site file.
    pub fn build(self) -> Scenario {
        if let Err(e) = self.0.validate() {
            panic!("test scenario '{}': {e}", self.0.name);
        }
        self.0
    }
}

/// Whether `python3` can import `module` (pip package `pip`), for a test that checks our
/// output with an independent reader. Where the environment variable `required_by` is set
/// (CI sets it), a missing package fails the test. Elsewhere the test goes on without the
/// check and says so where a person will see it: cargo captures a passing test's output,
/// so the line also goes to the file `FIREFLEET_SKIPPED` names (default `target/SKIPPED`),
/// which CI prints after the tests.
pub fn python_package(module: &str, pip: &str, required_by: &str) -> bool {
    // Quiet: a missing package is said below in one line, not as Python's traceback.
    let found = std::process::Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    found
        || missing(
            required_by,
            &format!(
                "python3 with {pip} is required here ({required_by} is set): pip install '{pip}'"
            ),
            &format!(
                "python3 cannot import {module} (pip install '{pip}'); checked without the independent reader"
            ),
        )
}

/// What the Python script `script` prints when run with `args` (an independent reader
/// checking our output); the test fails with the script's standard error if it fails.
pub fn python_stdout(script: &std::path::Path, args: &[&std::ffi::OsStr]) -> Vec<u8> {
    python(script, args, None)
}

/// What the Python script `script` prints when it reads `request` on its standard input,
/// as [`python_stdout`].
pub fn python_reply(script: &std::path::Path, request: &[u8]) -> Vec<u8> {
    python(script, &[], Some(request))
}

fn python(script: &std::path::Path, args: &[&std::ffi::OsStr], stdin: Option<&[u8]>) -> Vec<u8> {
    use std::io::Write as _;
    use std::process::Stdio;
    let mut child = std::process::Command::new("python3")
        .arg(script)
        .args(args)
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("python3 {}: {e}", script.display()));
    if let (Some(bytes), Some(mut pipe)) = (stdin, child.stdin.take()) {
        pipe.write_all(bytes)
            .unwrap_or_else(|e| panic!("python3 {}: its input: {e}", script.display()));
    }
    let out = child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("python3 {}: {e}", script.display()));
    assert!(
        out.status.success(),
        "python3 {} failed: {}",
        script.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// `bytes` as lower-case hex, the way tests hand binary data to a Python checker.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Hex digits back to bytes; panics on anything else (a checker's reply is trusted in a
/// test, and a malformed one fails it).
pub fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex digits"))
        .collect()
}

/// Whether `program` runs (`program --version`), for a test that checks our files with
/// another project's tool; missing, as [`python_package`] says it (`install`: how to get
/// it).
pub fn program(program: &str, install: &str, required_by: &str) -> bool {
    let found = std::process::Command::new(program)
        .arg("--version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    found
        || missing(
            required_by,
            &format!("{program} is required here ({required_by} is set): {install}"),
            &format!("{program} is missing ({install}); not checked"),
        )
}

/// What a missing tool means: a failed test where `required_by` is set (`required` says
/// why), else a skip said as [`skipped`] says it. Always false.
fn missing(required_by: &str, required: &str, skip: &str) -> bool {
    assert!(std::env::var_os(required_by).is_none(), "{required}");
    skipped(skip);
    false
}

/// Say that the running test skipped a check, on stderr and in `FIREFLEET_SKIPPED`'s file.
fn skipped(why: &str) {
    let line = format!(
        "SKIPPED: {}: {why}\n",
        std::thread::current().name().unwrap_or("a test")
    );
    #[allow(clippy::print_stderr, reason = "a skipped check says so")]
    {
        eprint!("{line}");
    }
    let file = std::env::var_os("FIREFLEET_SKIPPED").map_or_else(
        || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/SKIPPED"),
        std::path::PathBuf::from,
    );
    let appended = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&file)
        .and_then(|mut f| std::io::Write::write_all(&mut f, line.as_bytes()));
    if let Err(e) = appended {
        #[allow(clippy::print_stderr, reason = "a skipped check says so")]
        {
            eprintln!("(could not note the skip in {}: {e})", file.display());
        }
    }
}
