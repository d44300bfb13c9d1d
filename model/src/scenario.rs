//! The scenario (site) file: a tunnel, what stands in it, what burns, who responds.
//!
//! Scenarios are TOML, SI units with the unit in the field name (`length_m`, `yaw_rad`).
//! The same file configures every process: the simulator builds its world from it, agents
//! their maps, the coordinator its zones and bounds. A real deployment ships the same file
//! without `[[fires]]`.
//!
//! ```toml
//! name = "vehicle-collision"
//! site = "tunnel-a"          # optional, default "tunnel"
//! seed = 7                   # optional, default 0
//! time_limit_s = 240
//! portals = ["north", "south"] # optional: the portals' names at chainage 0 and at the
//!                            # end, as crews call them (default "portal A", "portal B")
//! simulated = true           # optional: the simulator's tunnel (true) or a real one
//!                            # (false); a deployed site says which (`Scenario::simulated`)
//!
//! [ventilation]              # optional, and [scada]: see `crate::infra`
//! air_m_s = 2.0
//!
//! [[routers]]                # optional: the site's routers, the first its own
//! name = "west"
//! host = "router-west.tunnel.local"
//! port = 7447                # optional, default 7447
//! chainage_m = 0.0
//!
//! [tunnel]
//! length_m = 200.0
//! width_m = 10.0
//! height_m = 6.3
//! lanes = 2
//!
//! [[obstacles]]              # parked vehicles: boxes on the road
//! name = "car-1"
//! x_m = 70.0
//! y_m = -1.75
//! length_m = 4.5
//! width_m = 1.8
//! height_m = 1.5
//! yaw_rad = 0.0              # optional
//!
//! [[fires]]
//! name = "car-fire"
//! x_m = 90.0
//! y_m = 1.75
//! growth = "fast"            # NFPA t-squared class: slow, medium, fast, ultrafast
//! peak_kw = 5000.0
//! ignition_s = -60.0         # negative: already burning when the run starts
//! radius_m = 1.0
//!
//! [[units]]
//! id = "ugv-1"
//! kind = "ground"
//! x_m = 5.0
//! y_m = -1.75
//! yaw_rad = 0.0
//!
//! [[zones]]
//! id = "z1"
//! start_m = 0.0
//! end_m = 100.0
//!
//! [[commanders]]             # who may set zone goals above whom (optional)
//! id = "chief"
//! rank = "incident"          # incident (the incident commander) or sector (the default)
//!
//! [[rails]]                  # a ceiling rail with a water main (monorail units)
//! id = "rail-1"
//! start_m = 0.0              # chainage range the carriage can reach
//! end_m = 200.0
//! y_m = 0.0                  # lateral offset of the rail
//! height_m = 5.8             # the monitor's pivot above the road
//! hose_points_m = [15.0, 45.0, 75.0, 105.0, 135.0, 165.0, 195.0]
//!
//! [[units]]
//! id = "rail-unit-1"
//! kind = "monorail"
//! rail = "rail-1"            # monorail units name their rail, stand on it (y_m = the
//! x_m = 10.0                 # rail's) and start within its range
//! y_m = 0.0
//! ```
//!
//! Loading validates everything; an error names the file, the field and the reason.
//!
//! Not here: simulating the site (`firefleet-sim`) or the tunnel's geometry
//! ([`crate::tunnel`]).

use std::collections::{BTreeMap, HashSet};
use std::f64::consts::TAU;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::geometry::{Point2, Pose2};
use crate::ids::{CommanderId, RouterId, SiteId, UnitId, ZoneId};
use crate::infra::{ScadaMap, Ventilation};
use crate::profile::{self, Profile};
use crate::spec::{GroundSpec, MonorailSpec, UnitKind};
use crate::tunnel::Chainage;
pub use crate::tunnel::{Segment, Station, Tunnel};
use crate::validate::{self, FileError, Invalid, Validate, in_range};

/// Why a scenario was rejected.
pub type ScenarioError = FileError;

/// Longest portal name, characters: a map label.
pub const MAX_PORTAL_NAME: usize = 32;

/// A whole scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default = "default_site")]
    pub site: SiteId,
    #[serde(default)]
    pub seed: u64,
    pub time_limit_s: f64,
    pub tunnel: Tunnel,
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    #[serde(default)]
    pub fires: Vec<FireSpec>,
    #[serde(default)]
    pub units: Vec<UnitSpec>,
    #[serde(default)]
    pub zones: Vec<Zone>,
    #[serde(default)]
    pub rails: Vec<Rail>,
    /// Commanders and their ranks; one not listed is a sector commander.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub commanders: Vec<CommanderSpec>,
    /// Robot profiles of this site's own, by name, beside the shipped ones
    /// ([`crate::profile`]).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub profiles: BTreeMap<String, Profile>,
    /// The portals' names, at chainage 0 and at the tunnel's end ([`Scenario::portal_names`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub portals: Option<[String; 2]>,
    /// Whether the site is the simulator's tunnel or a real one. A deployed site says: on
    /// a real one an agent refuses the simulator's platform, and on a simulated one the
    /// coordinator keeps the simulator's clock (tasks are numbered by site time, which a
    /// faster-than-real simulation runs ahead of the wall clock). Absent, as in the
    /// shipped scenarios the demo runs, each process is told (`--platform`, `--sim-clock`)
    /// and `firefleet doctor` asks the site file to say.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulated: Option<bool>,
    /// The site's Zenoh routers along the tunnel, the first the site's own (identity
    /// `router`), the others `router:<name>` ([`RouterSpec`]). Empty: the routers are given
    /// to `pki` and `deploy render` on the command line.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub routers: Vec<RouterSpec>,
    /// The tunnel's longitudinal ventilation ([`crate::infra`]); absent, the air is still.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ventilation: Option<Ventilation>,
    /// Where the tunnel's SCADA serves its DTS and ventilation over Modbus TCP
    /// ([`crate::infra`]); absent, the site has no feed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scada: Option<ScadaMap>,
}

/// The most routers a site lists: one every few hundred metres of the longest tunnels.
pub const MAX_ROUTERS: usize = 64;

/// A Zenoh router of the site: where it stands, and the host and port its clients reach
/// it at (the host is named in its certificate, which clients check).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RouterSpec {
    pub name: RouterId,
    pub host: String,
    #[serde(default = "default_router_port")]
    pub port: u16,
    pub chainage_m: f64,
}

fn default_router_port() -> u16 {
    7447
}

impl RouterSpec {
    /// The QUIC endpoint clients and neighbouring routers dial.
    pub fn endpoint(&self) -> String {
        if self.host.contains(':') {
            format!("quic/[{}]:{}", self.host, self.port)
        } else {
            format!("quic/{}:{}", self.host, self.port)
        }
    }
}

/// The rank of commander `c` among `commanders`: as listed, else [`Rank::Sector`].
pub fn rank_of(commanders: &[CommanderSpec], c: &CommanderId) -> Rank {
    commanders
        .iter()
        .find(|s| &s.id == c)
        .map_or(Rank::Sector, |s| s.rank)
}

/// `name` is not in `seen` yet (and is now); else the error names `field()`.
fn once<'a>(
    seen: &mut HashSet<&'a str>,
    name: &'a str,
    field: impl FnOnce() -> String,
) -> Result<(), Invalid> {
    if seen.insert(name) {
        Ok(())
    } else {
        Err(Invalid::new(field(), format!("'{name}' is used twice")))
    }
}

fn default_site() -> SiteId {
    SiteId::new("tunnel").expect("valid literal")
}

/// A box standing on the road (a parked vehicle).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Obstacle {
    pub name: String,
    pub x_m: f64,
    pub y_m: f64,
    pub length_m: f64,
    pub width_m: f64,
    pub height_m: f64,
    #[serde(default)]
    pub yaw_rad: f64,
}

impl Obstacle {
    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x_m, self.y_m, self.yaw_rad)
    }
    /// Whether a point of the road plane is inside the box's footprint grown by `margin`.
    pub fn footprint_contains(&self, p: Point2, margin: f64) -> bool {
        let b = self.pose().to_body(p);
        b.x.abs() <= self.length_m / 2.0 + margin && b.y.abs() <= self.width_m / 2.0 + margin
    }
    /// The four footprint corners in the site frame.
    pub fn corners(&self) -> [Point2; 4] {
        let (hl, hw) = (self.length_m / 2.0, self.width_m / 2.0);
        let pose = self.pose();
        [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)].map(|(x, y)| pose.to_site(Point2::new(x, y)))
    }
    /// `p` if it is `off` metres or more out of the footprint, else the point `off`
    /// metres out from the face nearest to it: where a fire placed inside the box (or
    /// against it) burns as seen from the road.
    pub fn off_body(&self, p: Point2, off: f64) -> Point2 {
        if !self.footprint_contains(p, off) {
            return p;
        }
        let b = self.pose().to_body(p);
        let (hl, hw) = (self.length_m / 2.0, self.width_m / 2.0);
        let out = if hl - b.x.abs() < hw - b.y.abs() {
            Point2::new((hl + off).copysign(b.x), b.y)
        } else {
            Point2::new(b.x, (hw + off).copysign(b.y))
        };
        self.pose().to_site(out)
    }
}

/// NFPA t-squared growth classes (NFPA 72, Annex B; NFPA 92).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Growth {
    Slow,
    Medium,
    Fast,
    Ultrafast,
}

/// A fire of the simulated world.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FireSpec {
    pub name: String,
    pub x_m: f64,
    pub y_m: f64,
    pub growth: Growth,
    pub peak_kw: f64,
    /// Site time of ignition, s; negative for a fire already burning at the start.
    #[serde(default)]
    pub ignition_s: f64,
    /// Radius of the burning area on the road, m.
    #[serde(default = "default_fire_radius")]
    pub radius_m: f64,
}

fn default_fire_radius() -> f64 {
    1.0
}

impl FireSpec {
    pub fn position(&self) -> Point2 {
        Point2::new(self.x_m, self.y_m)
    }
}

/// A unit of the fleet and where it starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitSpec {
    pub id: UnitId,
    pub kind: UnitKind,
    pub x_m: f64,
    pub y_m: f64,
    #[serde(default)]
    pub yaw_rad: f64,
    /// The rail a monorail unit runs on.
    #[serde(default)]
    pub rail: Option<String>,
    /// The robot model: a profile of `[profiles]` or a shipped one (default: `luf60` for
    /// ground units, `robogat` for monorail units).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
}

impl UnitSpec {
    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x_m, self.y_m, self.yaw_rad)
    }
}

/// A named chainage range of the tunnel that commanders give goals for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Zone {
    pub id: ZoneId,
    pub start_m: Chainage,
    pub end_m: Chainage,
}

/// A commander the site names, with the rank that orders their goals.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommanderSpec {
    pub id: CommanderId,
    pub rank: Rank,
}

/// A commander's authority over zone goals, lowest first: a goal of a higher rank governs
/// wherever it overlaps one of a lower rank, whatever their priorities, and a commander
/// may amend or clear the goals of any lower rank; equal ranks cannot override each
/// other. Incident command as fire services run it: one incident commander, sector
/// commanders under them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rank {
    Sector,
    Incident,
}

crate::names!(Rank, "a commander's rank" {
    Sector => "sector",
    Incident => "incident",
});

/// A ceiling rail along the tunnel, with a water main and hose points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rail {
    pub id: String,
    pub start_m: f64,
    pub end_m: f64,
    pub y_m: f64,
    pub height_m: f64,
    pub hose_points_m: Vec<f64>,
}

impl Rail {
    pub fn length_m(&self) -> f64 {
        self.end_m - self.start_m
    }
}

impl Scenario {
    /// A site of `tunnel` with nothing in it yet: no obstacles, fires, units, zones or
    /// rails, seed 0 (generated scenarios fill them in).
    pub fn empty(name: &str, site: SiteId, tunnel: Tunnel, time_limit_s: f64) -> Self {
        Self {
            name: name.into(),
            description: String::new(),
            site,
            seed: 0,
            time_limit_s,
            tunnel,
            obstacles: Vec::new(),
            fires: Vec::new(),
            units: Vec::new(),
            zones: Vec::new(),
            rails: Vec::new(),
            commanders: Vec::new(),
            profiles: BTreeMap::new(),
            portals: None,
            simulated: None,
            routers: Vec::new(),
            ventilation: None,
            scada: None,
        }
    }

    /// The rank of commander `c`: as listed, else [`Rank::Sector`].
    pub fn rank_of(&self, c: &CommanderId) -> Rank {
        rank_of(&self.commanders, c)
    }

    pub fn rail(&self, id: &str) -> Option<&Rail> {
        self.rails.iter().find(|r| r.id == id)
    }

    /// The scenario as a site file: what [`Scenario::from_toml`] reads back the same (a
    /// tool that adds to a site, e.g. its commanders, writes it for every process to read).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a scenario is plain data and serialises")
    }

    /// Parse and validate scenario text; `origin` (a file name) prefixes every error.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ScenarioError> {
        validate::from_toml(text, origin, Self::validate)
    }

    /// Read, parse and validate a scenario file.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        validate::load_toml(path, Self::validate)
    }

    /// Where a fire reported at `p` can be fought from the road: `p` itself, or, if `p`
    /// lies inside a parked vehicle (a DTS zone's chainage on the tunnel's axis, where a
    /// train or a lorry stands) or less than half a metre off its body, half a metre off
    /// the vehicle's face nearest to it. The flames of a burning vehicle come out of its
    /// faces; its inside is seen and reached from nowhere, and a point against its skin
    /// lies in the cell a map gives the body (a fire seen 2 cm off a locomotive's side
    /// had no sight line from anywhere, and six units gave it up in turn).
    pub fn fightable_at(&self, p: Point2) -> Point2 {
        const OFF_BODY_M: f64 = 0.5;
        self.obstacles
            .iter()
            .find(|o| o.footprint_contains(p, OFF_BODY_M))
            .map_or(p, |o| o.off_body(p, OFF_BODY_M))
    }

    pub fn unit(&self, id: &UnitId) -> Option<&UnitSpec> {
        self.units.iter().find(|u| &u.id == id)
    }

    /// The profile unit `u` names (this site's, else a shipped one), or its kind's default.
    pub fn profile_of(&self, u: &UnitSpec) -> Result<Profile, Invalid> {
        let name = u.profile.as_deref().unwrap_or(match u.kind {
            UnitKind::Ground => profile::DEFAULT_GROUND,
            UnitKind::Monorail => profile::DEFAULT_MONORAIL,
        });
        let p = self
            .profiles
            .get(name)
            .copied()
            .or_else(|| profile::shipped(name))
            .ok_or_else(|| {
                let shipped: Vec<&str> = profile::shipped_names().collect();
                Invalid::new(
                    "profile",
                    format!(
                        "no profile '{name}' in [profiles] or shipped ({})",
                        shipped.join(", ")
                    ),
                )
            })?;
        if p.kind() != u.kind {
            return Err(Invalid::new(
                "profile",
                format!(
                    "'{name}' is a {:?} profile, the unit a {:?} unit",
                    p.kind(),
                    u.kind
                ),
            ));
        }
        Ok(p)
    }

    /// Ground unit `id`'s body, from its profile; `None` for no such ground unit.
    pub fn ground_spec(&self, id: &UnitId) -> Option<GroundSpec> {
        match self.profile_of(self.unit(id)?) {
            Ok(Profile::Ground(g)) => Some(g),
            _ => None,
        }
    }

    /// Monorail unit `id`'s carriage and monitor, from its profile; `None` for no such
    /// monorail unit.
    pub fn monorail_spec(&self, id: &UnitId) -> Option<MonorailSpec> {
        match self.profile_of(self.unit(id)?) {
            Ok(Profile::Monorail(m)) => Some(m),
            _ => None,
        }
    }

    /// The portals' names, at chainage 0 and at the end: the site file's, else "portal A"
    /// and "portal B".
    pub fn portal_names(&self) -> [String; 2] {
        self.portals
            .clone()
            .unwrap_or_else(|| ["portal A".into(), "portal B".into()])
    }

    /// Every semantic check a TOML parser cannot make.
    pub fn validate(&self) -> Result<(), Invalid> {
        if self.name.trim().is_empty() {
            return Err(Invalid::new("name", "must not be empty"));
        }
        if let Some(portals) = &self.portals {
            for (i, p) in portals.iter().enumerate() {
                if p.trim().is_empty() || p.chars().count() > MAX_PORTAL_NAME {
                    return Err(Invalid::new(
                        format!("portals[{i}]"),
                        format!("must have 1 to {MAX_PORTAL_NAME} characters"),
                    ));
                }
            }
            if portals[0] == portals[1] {
                return Err(Invalid::new("portals", "the two portals need two names"));
            }
        }
        in_range("time_limit_s", self.time_limit_s, 1.0, 7.0 * 86400.0)?;
        let t = &self.tunnel;
        t.validate()?;

        let mut names = HashSet::new();
        for (i, o) in self.obstacles.iter().enumerate() {
            let f = |n: &str| format!("obstacles[{i}].{n}");
            once(&mut names, o.name.as_str(), || f("name"))?;
            in_range(&f("length_m"), o.length_m, 0.1, 50.0)?;
            in_range(&f("width_m"), o.width_m, 0.1, t.width_m)?;
            in_range(&f("height_m"), o.height_m, 0.1, t.height_m)?;
            in_range(&f("yaw_rad"), o.yaw_rad, -TAU, TAU)?;
            for c in o.corners() {
                t.check_inside(&f("x_m/y_m"), c)
                    .map_err(|e| Invalid::new(e.field, format!("a corner {}", e.reason)))?;
            }
        }

        let mut names = HashSet::new();
        for (i, fire) in self.fires.iter().enumerate() {
            let f = |n: &str| format!("fires[{i}].{n}");
            once(&mut names, fire.name.as_str(), || f("name"))?;
            t.check_inside(&f("x_m/y_m"), fire.position())?;
            in_range(&f("peak_kw"), fire.peak_kw, 1.0, 300_000.0)?;
            in_range(
                &f("ignition_s"),
                fire.ignition_s,
                -3600.0,
                self.time_limit_s,
            )?;
            in_range(&f("radius_m"), fire.radius_m, 0.1, t.width_m / 2.0)?;
        }

        let mut ids = HashSet::new();
        for (i, r) in self.rails.iter().enumerate() {
            let f = |n: &str| format!("rails[{i}].{n}");
            // The carriage model and the monorail planner measure the rail along x.
            if !t.is_straight() {
                return Err(Invalid::new(
                    f("id"),
                    "rails are supported in straight tunnels only",
                ));
            }
            once(&mut ids, r.id.as_str(), || f("id"))?;
            in_range(&f("start_m"), r.start_m, 0.0, t.length_m)?;
            in_range(&f("end_m"), r.end_m, 0.0, t.length_m)?;
            if r.end_m <= r.start_m {
                return Err(Invalid::new(f("end_m"), "must be greater than start_m"));
            }
            in_range(&f("y_m"), r.y_m, -t.width_m / 2.0, t.width_m / 2.0)?;
            // The carriage hangs below the rail: its pivot clears the ceiling.
            in_range(&f("height_m"), r.height_m, 2.0, t.height_m - 0.2)?;
            if r.hose_points_m.is_empty() {
                return Err(Invalid::new(
                    f("hose_points_m"),
                    "a rail needs a hose point",
                ));
            }
            for (k, h) in r.hose_points_m.iter().enumerate() {
                in_range(
                    &format!("rails[{i}].hose_points_m[{k}]"),
                    *h,
                    r.start_m,
                    r.end_m,
                )?;
            }
        }

        for (name, p) in &self.profiles {
            p.validate()
                .map_err(|e| e.within(&format!("profiles.{name}")))?;
        }
        let mut ids = HashSet::new();
        for (i, u) in self.units.iter().enumerate() {
            let f = |n: &str| format!("units[{i}].{n}");
            once(&mut ids, u.id.as_str(), || f("id"))?;
            self.profile_of(u)
                .map_err(|e| e.within(&format!("units[{i}]")))?;
            match (u.kind, &u.rail) {
                (UnitKind::Monorail, None) => {
                    return Err(Invalid::new(
                        f("rail"),
                        "a monorail unit must name its rail",
                    ));
                }
                (UnitKind::Monorail, Some(name)) => {
                    let Some(r) = self.rail(name) else {
                        return Err(Invalid::new(
                            f("rail"),
                            format!("no rail '{name}' in rails[]"),
                        ));
                    };
                    if !(r.start_m..=r.end_m).contains(&u.x_m) {
                        return Err(Invalid::new(
                            f("x_m"),
                            format!(
                                "{} is off rail '{name}' ([{}, {}])",
                                u.x_m, r.start_m, r.end_m
                            ),
                        ));
                    }
                    if (u.y_m - r.y_m).abs() > 1e-6 {
                        return Err(Invalid::new(
                            f("y_m"),
                            format!("must be rail '{name}''s y_m, {}", r.y_m),
                        ));
                    }
                }
                (UnitKind::Ground, Some(_)) => {
                    return Err(Invalid::new(f("rail"), "only monorail units run on a rail"));
                }
                (UnitKind::Ground, None) => {}
            }
            in_range(&f("yaw_rad"), u.yaw_rad, -TAU, TAU)?;
            let p = Point2::new(u.x_m, u.y_m);
            t.check_inside(&f("x_m/y_m"), p)?;
            if let Some(o) = self
                .obstacles
                .iter()
                .find(|o| u.kind == UnitKind::Ground && o.footprint_contains(p, 0.5))
            {
                return Err(Invalid::new(
                    f("x_m/y_m"),
                    format!("starts inside obstacle '{}'", o.name),
                ));
            }
        }

        let mut ids = HashSet::new();
        for (i, z) in self.zones.iter().enumerate() {
            let f = |n: &str| format!("zones[{i}].{n}");
            once(&mut ids, z.id.as_str(), || f("id"))?;
            in_range(&f("start_m"), z.start_m.m(), 0.0, t.length_m)?;
            in_range(&f("end_m"), z.end_m.m(), 0.0, t.length_m)?;
            if z.end_m <= z.start_m {
                return Err(Invalid::new(f("end_m"), "must be greater than start_m"));
            }
        }
        let mut ids = HashSet::new();
        for (i, c) in self.commanders.iter().enumerate() {
            once(&mut ids, c.id.as_str(), || format!("commanders[{i}].id"))?;
        }
        if self.routers.len() > MAX_ROUTERS {
            return Err(Invalid::new(
                "routers",
                format!("{} routers: at most {MAX_ROUTERS}", self.routers.len()),
            ));
        }
        let mut ids = HashSet::new();
        for (i, r) in self.routers.iter().enumerate() {
            let f = |n: &str| format!("routers[{i}].{n}");
            once(&mut ids, r.name.as_str(), || f("name"))?;
            let host_ok = !r.host.is_empty()
                && r.host.len() <= 253
                && r.host
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | ':'));
            if !host_ok {
                return Err(Invalid::new(
                    f("host"),
                    format!("'{}' is no host name or address", r.host),
                ));
            }
            if r.port == 0 {
                return Err(Invalid::new(f("port"), "must be 1 to 65535"));
            }
            in_range(&f("chainage_m"), r.chainage_m, 0.0, t.length_m)?;
        }
        if let Some(v) = &self.ventilation {
            v.validate(t.length_m)
                .map_err(|e| e.within("ventilation"))?;
        }
        if let Some(m) = &self.scada {
            let fans = self.ventilation.as_ref().map_or(0, |v| v.fans.len());
            m.validate(t.length_m, fans)
                .map_err(|e| e.within("scada"))?;
        }
        Ok(())
    }

    /// Air velocity along the tunnel, m/s, positive towards its end (0 without ventilation).
    pub fn air_m_s(&self) -> f64 {
        self.ventilation.as_ref().map_or(0.0, |v| v.air_m_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fire_inside_a_vehicle_is_fought_off_its_nearest_face() {
        let s = Scenario::from_toml(OK, "t.toml").unwrap();
        // The car spans x 38-42, y -2.9 to -1.1: the axis is 1.1 m off its kerb side.
        let axis = Point2::new(40.5, -1.5);
        let at = s.fightable_at(axis);
        assert!(
            (at.x - 40.5).abs() < 1e-9 && (at.y - (-1.1 + 0.5)).abs() < 1e-9,
            "{at:?}"
        );
        let end = s.fightable_at(Point2::new(41.8, -2.0));
        assert!(
            (end.x - 42.5).abs() < 1e-9 && (end.y + 2.0).abs() < 1e-9,
            "{end:?}"
        );
        let road = Point2::new(20.0, 1.0);
        assert_eq!(s.fightable_at(road), road);
        // Against the kerb side, 2 cm off it: half a metre off.
        let skin = s.fightable_at(Point2::new(39.0, -1.08));
        assert!((skin.y - (-1.1 + 0.5)).abs() < 1e-9, "{skin:?}");
    }

    const OK: &str = r#"
        name = "t"
        time_limit_s = 100
        [tunnel]
        length_m = 100.0
        width_m = 10.0
        height_m = 6.0
        lanes = 2
        [[obstacles]]
        name = "car"
        x_m = 40.0
        y_m = -2.0
        length_m = 4.0
        width_m = 1.8
        height_m = 1.5
        [[fires]]
        name = "f"
        x_m = 60.0
        y_m = 1.0
        growth = "fast"
        peak_kw = 3000.0
        [[units]]
        id = "u1"
        kind = "ground"
        x_m = 5.0
        y_m = -2.0
        [[zones]]
        id = "z1"
        start_m = 0.0
        end_m = 50.0
    "#;

    fn err(text: &str) -> String {
        Scenario::from_toml(text, "s.toml").unwrap_err().to_string()
    }

    #[test]
    fn ventilation_and_scada_map_are_validated_in_the_site_file() {
        let ok = format!(
            "{OK}\n[ventilation]\nair_m_s = 2.0\nfans = [{{ name = \"jf-1\", chainage_m = 30.0 }}]\n[scada.dts]\nzone_length_m = 10.0\n"
        );
        let s = Scenario::from_toml(&ok, "s.toml").unwrap();
        assert_eq!(s.air_m_s(), 2.0);
        assert_eq!(s.scada.as_ref().unwrap().zone_count(100.0), 10);
        let e = err(&ok.replace("chainage_m = 30.0", "chainage_m = 130.0"));
        assert!(e.contains("ventilation.fans[0].chainage_m"), "{e}");
        let e = err(&format!("{ok}[scada.vent]\nfirst_register = 20\n"));
        assert!(e.contains("scada.vent.first_register"), "{e}");
        let e = err(&ok.replace("zone_length_m = 10.0", "zone_length_m = 0.0"));
        assert!(e.contains("scada.dts.zone_length_m"), "{e}");
    }

    #[test]
    fn commanders_are_ranked_as_listed_and_sector_otherwise() {
        let text = format!(
            "{OK}\n[[commanders]]\nid = \"chief\"\nrank = \"incident\"\n[[commanders]]\nid = \"rossi\"\nrank = \"sector\"\n"
        );
        let s = Scenario::from_toml(&text, "s.toml").unwrap();
        let c = |n: &str| CommanderId::new(n).unwrap();
        assert_eq!(s.rank_of(&c("chief")), Rank::Incident);
        assert_eq!(s.rank_of(&c("rossi")), Rank::Sector);
        assert_eq!(s.rank_of(&c("unlisted")), Rank::Sector);
        assert!(Rank::Incident > Rank::Sector);
        for r in Rank::ALL {
            assert_eq!(serde_json::to_value(r).unwrap(), r.as_str());
        }
        let back = Scenario::from_toml(&s.to_toml(), "written.toml").unwrap();
        assert_eq!(back, s, "written and read back the same");
        let twice = text.replace("\"rossi\"", "\"chief\"");
        assert!(err(&twice).contains("commanders[1].id"), "{}", err(&twice));
        let bad = text.replace("\"sector\"", "\"general\"");
        assert!(err(&bad).contains("general"), "{}", err(&bad));
    }

    #[test]
    fn a_good_scenario_loads() {
        let s = Scenario::from_toml(OK, "s.toml").unwrap();
        assert_eq!(s.site.as_str(), "tunnel");
        assert_eq!(s.fires[0].radius_m, 1.0);
        assert!((s.tunnel.lane_center_y(0) + 2.5).abs() < 1e-12);
    }

    #[test]
    fn a_curved_centerline_loads_and_its_mistakes_are_named() {
        let curved = OK.replace(
            "lanes = 2\n",
            "lanes = 2\ncenterline = [{ straight_m = 40.0 }, { arc_deg = 30.0, radius_m = 60.0, turn = \"right\" }, { straight_m = 28.584 }]\n",
        );
        let s = Scenario::from_toml(&curved, "c.toml").unwrap();
        assert!(!s.tunnel.is_straight());
        let end = s.tunnel.centre_pose(Chainage::new(100.0));
        assert!((end.yaw + 30f64.to_radians()).abs() < 1e-9, "turns right");
        let e = err(&curved.replace("turn = \"right\"", "turn = \"up\""));
        assert!(
            e.contains("line 9") && e.contains("unknown variant `up`"),
            "{e}"
        );
        let e = err(&curved.replace("radius_m = 60.0, ", ""));
        assert!(e.contains("either { straight_m }"), "{e}");
        let e = err(&curved.replace("28.584", "20.0"));
        assert!(
            e.contains("tunnel.length_m: is 100 but the centerline adds up to 91.416"),
            "{e}"
        );
    }

    #[test]
    fn routers_stand_along_the_tunnel_at_hosts_their_clients_dial() {
        let listed = format!(
            "{OK}\n[[routers]]\nname = \"west\"\nhost = \"router-west.site\"\nchainage_m = 0.0\n\
             [[routers]]\nname = \"east\"\nhost = \"10.0.0.2\"\nport = 7450\nchainage_m = 90.0\n"
        );
        let s = Scenario::from_toml(&listed, "r.toml").unwrap();
        assert_eq!(s.routers[0].endpoint(), "quic/router-west.site:7447");
        assert_eq!(s.routers[1].endpoint(), "quic/10.0.0.2:7450");
        refused(
            &listed,
            &[
                ("\"east\"", "\"west\"", "routers[1].name"),
                (
                    "\"10.0.0.2\"",
                    "\"a host\"",
                    "routers[1].host: 'a host' is no host",
                ),
                ("port = 7450", "port = 0", "routers[1].port"),
                (
                    "chainage_m = 90.0",
                    "chainage_m = 120.0",
                    "routers[1].chainage_m",
                ),
            ],
        );
    }

    #[test]
    fn portals_are_named_by_the_site_file_or_by_letter() {
        let s = Scenario::from_toml(OK, "s.toml").unwrap();
        assert_eq!(s.portal_names(), ["portal A", "portal B"]);
        let named = OK.replace(
            "time_limit_s",
            "portals = [\"north\", \"south\"]\ntime_limit_s",
        );
        let s = Scenario::from_toml(&named, "n.toml").unwrap();
        assert_eq!(s.portal_names(), ["north", "south"]);
        refused(
            &named,
            &[
                (
                    "\"south\"",
                    "\"north\"",
                    "portals: the two portals need two names",
                ),
                (
                    "\"south\"",
                    "\" \"",
                    "portals[1]: must have 1 to 32 characters",
                ),
                ("\"north\", \"south\"", "\"north\"", "portals"),
            ],
        );
    }

    /// Each `(from, to, says)`: `base` with `from` replaced by `to` is refused, saying `says`.
    fn refused(base: &str, cases: &[(&str, &str, &str)]) {
        for (from, to, says) in cases {
            let e = err(&base.replace(from, to));
            assert!(e.contains(says), "{from} -> {to}: {e}");
        }
    }

    #[test]
    fn errors_name_file_field_and_reason() {
        let e = err(&OK.replace("x_m = 60.0", "x_m = 160.0"));
        assert!(
            e.starts_with("s.toml: fires[0].x_m/y_m: (160.00, 1.00) is outside the tunnel"),
            "{e}"
        );
        let e = err(&OK.replace("growth = \"fast\"", "growth = \"quick\""));
        assert!(e.contains("s.toml") && e.contains("quick"), "{e}");
        refused(
            OK,
            &[
                ("id = \"u1\"", "id = \"U 1\"", "unit id"),
                (
                    "x_m = 5.0",
                    "x_m = 40.0",
                    "units[0].x_m/y_m: starts inside obstacle 'car'",
                ),
                ("end_m = 50.0", "end_m = 0.0", "zones[0].end_m"),
                ("lanes = 2", "lanes = 2\ncolour = 3", "colour"),
                (
                    "kind = \"ground\"",
                    "kind = \"monorail\"",
                    "units[0].rail: a monorail unit must name its rail",
                ),
            ],
        );
    }

    const RAIL: &str = r#"
        [[rails]]
        id = "r"
        start_m = 10.0
        end_m = 90.0
        y_m = 0.0
        height_m = 5.5
        hose_points_m = [20.0, 50.0, 80.0]
    "#;

    fn with_rail_unit(unit: &str) -> String {
        format!("{OK}{RAIL}\n[[units]]\n{unit}")
    }

    #[test]
    fn monorail_units_stand_on_a_declared_rail() {
        let ok =
            with_rail_unit("id = \"m\"\nkind = \"monorail\"\nrail = \"r\"\nx_m = 40.0\ny_m = 0.0");
        let s = Scenario::from_toml(&ok, "s.toml").unwrap();
        assert_eq!(s.rail("r").unwrap().length_m(), 80.0);
        refused(
            &ok,
            &[
                ("rail = \"r\"", "rail = \"q\"", "units[1].rail: no rail 'q'"),
                (
                    "x_m = 40.0\ny_m = 0.0",
                    "x_m = 5.0\ny_m = 0.0",
                    "units[1].x_m: 5 is off rail 'r'",
                ),
                (
                    "x_m = 40.0\ny_m = 0.0",
                    "x_m = 40.0\ny_m = 1.0",
                    "units[1].y_m",
                ),
                ("height_m = 5.5", "height_m = 6.0", "rails[0].height_m"),
                (
                    "[20.0, 50.0, 80.0]",
                    "[20.0, 95.0]",
                    "rails[0].hose_points_m[1]",
                ),
            ],
        );
        let e = err(&OK.replace("kind = \"ground\"", "kind = \"ground\"\nrail = \"r\""));
        assert!(e.contains("only monorail units"), "{e}");
    }
}
