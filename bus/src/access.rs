//! Who may do what on a site's bus: the access rules, derived from the key table.
//!
//! Each process of a site holds one identity, the common name of its certificate
//! (`firefleet pki`): `unit:<id>`, `coordinator` and `coordinator:<rank>`, `recorder`,
//! `sim`, `commander:<name>`, `console` for the commanders' web console, and `router` for
//! the site's router. [`grants`] lists what an identity may do, as [`Grant`]s of an [`Op`]
//! on a key expression built by [`Keys`], so no key is written twice; [`zenoh_acl`] turns the grants of every identity into the `access_control`
//! section of the router's Zenoh configuration, default deny, one subject per common name.
//!
//! Least privilege, by identity:
//! - a unit puts only its own state, reports and behaviour-tree log, declares only its own
//!   token, hears only its own tasks, what is barred, the coordinators' leases and the asks
//!   to suspend (it judges who holds office itself), and (simulated sites) drives only its
//!   own simulated body;
//! - a coordinator puts tasks on its own rank's keys only and declares only its own rank's
//!   lease, and puts fire tracks, its log, the barred space, the goals in force and goal
//!   answers; it hears states, reports, goals, every task and lease (rivals and thieves of
//!   its key are alarmed) and (simulated) the site clock;
//! - a recorder hears everything and answers the coordinator's and the fire tracks'
//!   queries on the coordinator's behalf;
//! - a commander puts and deletes only goals under its own name (so a goal's issuer is the
//!   router's word, not the goal's text), and reads what a commander follows;
//! - the console reads what a commander follows and puts and deletes goals under any
//!   commander's name: it speaks for the commanders who log in to it, and its login (an
//!   Argon2id password per commander) is what vouches for the issuer of those goals, not
//!   a certificate per commander. A site that wants the router's word for every issuer
//!   gives each commander a certificate and no console;
//! - the simulator speaks only `sim/` keys, and only on a simulated site;
//! - the SCADA bridge (`firefleet scada`) puts only the tunnel's readings (`infra/`), and
//!   hears the simulator's clock on a simulated site; the coordinator, the commanders and
//!   the console hear them;
//! - every identity with a part on the site may ask the routers' `router/hello`, which
//!   tells it the rules admit it (`firefleet doctor`).
//!
//! The rules stop an identity from touching another's keys; what an identity may send on
//! its own keys is the application's to check (task fencing, validation, the coordinator's
//! doubts). Not here: certificates (`firefleet pki`), enforcement (Zenoh's router).

use std::fmt;
use std::str::FromStr;

use serde_json::{Value, json};

use firefleet_model::UnitKind;
use firefleet_model::scenario::Scenario;
use firefleet_model::{ids::CommanderId, ids::IdError, ids::RouterId, ids::UnitId};
use firefleet_protocol::keys::{Keys, Topic};

/// How many coordinator identities a site's PKI issues: the one that starts in office and
/// its standby (`deploy/README.md`). A site with more standbys issues their certificates
/// with `firefleet pki issue --role coordinator --name <rank>`.
pub const COORDINATORS: u32 = 2;

/// One identity of a site: a certificate's common name.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Identity {
    Unit(UnitId),
    /// A coordinator of the site, by its rank (`--rank`): `coordinator` for rank 0, the
    /// one that starts in office, `coordinator:<rank>` for its standbys. Each has its own
    /// key, so the routers vouch for which one sent a task, and a stolen one can be cut
    /// off without the others.
    Coordinator(u32),
    Recorder,
    Sim,
    Commander(CommanderId),
    /// The commanders' web console (`firefleet console`).
    Console,
    /// The bridge from the tunnel's SCADA (`firefleet scada`).
    Scada,
    /// A router of the site: `router` for its first, `router:<name>` for any other. It
    /// links everyone and is granted nothing (its own session is not a remote face its
    /// rules apply to; it runs no role). Only a router's certificate may serve TLS.
    Router(Option<RouterId>),
}

/// What kind of process an identity is; the part of its common name before `:`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Role {
    Unit,
    Coordinator,
    Recorder,
    Sim,
    Commander,
    Console,
    Scada,
    Router,
}

firefleet_model::names!(Role, "role" {
    Unit => "unit",
    Coordinator => "coordinator",
    Recorder => "recorder",
    Sim => "sim",
    Commander => "commander",
    Console => "console",
    Scada => "scada",
    Router => "router",
});

impl Identity {
    /// The identity's directory in a site PKI (the common name, `:` made `-`).
    pub fn dir_name(&self) -> String {
        self.to_string().replace(':', "-")
    }

    /// The site's first router.
    pub const ROUTER: Identity = Identity::Router(None);

    /// The coordinator that starts in office (rank 0).
    pub const COORDINATOR: Identity = Identity::Coordinator(0);

    pub fn role(&self) -> Role {
        match self {
            Identity::Unit(_) => Role::Unit,
            Identity::Coordinator(_) => Role::Coordinator,
            Identity::Recorder => Role::Recorder,
            Identity::Sim => Role::Sim,
            Identity::Commander(_) => Role::Commander,
            Identity::Console => Role::Console,
            Identity::Scada => Role::Scada,
            Identity::Router(_) => Role::Router,
        }
    }

    /// Every identity of `scenario`'s site, with `commanders` and the commanders its site
    /// file names (once each), in a stable order.
    pub fn of_site(scenario: &Scenario, commanders: &[CommanderId]) -> Vec<Identity> {
        let mut all: Vec<Identity> = scenario
            .units
            .iter()
            .map(|u| Identity::Unit(u.id.clone()))
            .collect();
        all.extend((0..COORDINATORS).map(Identity::Coordinator));
        all.extend([
            Identity::Recorder,
            Identity::Sim,
            Identity::Console,
            Identity::ROUTER,
        ]);
        // The SCADA bridge, where the site file maps the tunnel's SCADA.
        if scenario.scada.is_some() {
            all.push(Identity::Scada);
        }
        // The site file's further routers (the first is `router`).
        all.extend(
            scenario
                .routers
                .iter()
                .skip(1)
                .map(|r| Identity::Router(Some(r.name.clone()))),
        );
        let mut named: Vec<CommanderId> = commanders.to_vec();
        for c in &scenario.commanders {
            if !named.contains(&c.id) {
                named.push(c.id.clone());
            }
        }
        all.extend(named.into_iter().map(Identity::Commander));
        all
    }
}

impl fmt::Display for Identity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Identity::Unit(u) => write!(f, "unit:{u}"),
            Identity::Coordinator(0) => f.write_str("coordinator"),
            Identity::Coordinator(rank) => write!(f, "coordinator:{rank}"),
            Identity::Recorder => f.write_str("recorder"),
            Identity::Sim => f.write_str("sim"),
            Identity::Commander(c) => write!(f, "commander:{c}"),
            Identity::Console => f.write_str("console"),
            Identity::Scada => f.write_str("scada"),
            Identity::Router(None) => f.write_str("router"),
            Identity::Router(Some(r)) => write!(f, "router:{r}"),
        }
    }
}

/// A common name that is no identity of ours.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "'{name}' is not an identity (unit:<id>, coordinator, coordinator:<rank>, recorder, sim, commander:<name>, console, scada, router, router:<name>): {reason}"
)]
pub struct IdentityError {
    pub name: String,
    pub reason: String,
}

impl FromStr for Identity {
    type Err = IdentityError;
    fn from_str(s: &str) -> Result<Self, IdentityError> {
        let err = |reason: String| IdentityError {
            name: s.to_owned(),
            reason,
        };
        let named = |e: IdError| err(e.to_string());
        match s.split_once(':') {
            Some(("unit", u)) => Ok(Identity::Unit(UnitId::new(u).map_err(named)?)),
            Some(("commander", c)) => Ok(Identity::Commander(CommanderId::new(c).map_err(named)?)),
            Some(("router", r)) => Ok(Identity::Router(Some(RouterId::new(r).map_err(named)?))),
            Some(("coordinator", r)) => r
                .parse::<u32>()
                .ok()
                .filter(|r| (1..firefleet_protocol::msg::EPOCH_RANKS).contains(&u64::from(*r)))
                .map(Identity::Coordinator)
                .ok_or_else(|| {
                    err(format!(
                        "a standby coordinator's rank is 1 to {}",
                        firefleet_protocol::msg::EPOCH_RANKS - 1
                    ))
                }),
            Some(_) => Err(err("unknown kind".into())),
            None => match s {
                "coordinator" => Ok(Identity::COORDINATOR),
                "recorder" => Ok(Identity::Recorder),
                "sim" => Ok(Identity::Sim),
                "console" => Ok(Identity::Console),
                "scada" => Ok(Identity::Scada),
                "router" => Ok(Identity::ROUTER),
                _ => Err(err("unknown".into())),
            },
        }
    }
}

/// What an identity may do on a key expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Op {
    /// Publish samples.
    Put,
    /// Publish deletes.
    Delete,
    /// Receive samples and deletes.
    Subscribe,
    /// Ask queryables and receive their replies.
    Query,
    /// Answer queries.
    Answer,
    /// Declare a liveliness token.
    Token,
    /// Follow and query liveliness tokens.
    Watch,
}

impl Op {
    pub const ALL: [Op; 7] = [
        Op::Put,
        Op::Delete,
        Op::Subscribe,
        Op::Query,
        Op::Answer,
        Op::Token,
        Op::Watch,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Op::Put => "put",
            Op::Delete => "delete",
            Op::Subscribe => "subscribe",
            Op::Query => "query",
            Op::Answer => "answer",
            Op::Token => "token",
            Op::Watch => "watch",
        }
    }

    /// The Zenoh messages the router must let through, as `(message, flow)` seen from the
    /// router's face to the identity: ingress is what the identity sends, egress what it
    /// is sent.
    fn zenoh_messages(self) -> &'static [(&'static str, &'static str)] {
        match self {
            Op::Put => &[("put", "ingress")],
            Op::Delete => &[("delete", "ingress")],
            Op::Subscribe => &[
                ("declare_subscriber", "ingress"),
                ("put", "egress"),
                ("delete", "egress"),
            ],
            Op::Query => &[("query", "ingress"), ("reply", "egress")],
            Op::Answer => &[
                ("declare_queryable", "ingress"),
                ("query", "egress"),
                ("reply", "ingress"),
            ],
            Op::Token => &[("liveliness_token", "ingress")],
            Op::Watch => &[
                ("declare_liveliness_subscriber", "ingress"),
                ("liveliness_query", "ingress"),
                ("liveliness_token", "egress"),
            ],
        }
    }
}

/// One thing an identity may do.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Grant {
    pub op: Op,
    pub key_expr: String,
}

/// Why an identity has no rules on a site.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0} is not a unit of this site")]
pub struct UnknownUnit(pub UnitId);

/// What `who` may do on `scenario`'s site; `simulated` grants the simulator's keys (to the
/// simulator and to each unit for its own body), which a real site does not have.
pub fn grants(
    scenario: &Scenario,
    who: &Identity,
    simulated: bool,
) -> Result<Vec<Grant>, UnknownUnit> {
    let keys = Keys::new(scenario.site.clone());
    let mut g = Vec::new();
    let mut grant = |op: Op, key_expr: &str| {
        g.push(Grant {
            op,
            key_expr: key_expr.to_owned(),
        })
    };
    match who {
        Identity::Unit(u) => {
            let spec = scenario
                .units
                .iter()
                .find(|s| &s.id == u)
                .ok_or_else(|| UnknownUnit(u.clone()))?;
            grant(Op::Put, keys.unit_state(u).as_str());
            grant(Op::Put, keys.unit_report(u).as_str());
            grant(Op::Put, keys.unit_bt(u).as_str());
            grant(Op::Token, &keys.expr(&Topic::UnitAlive(u.clone())));
            grant(Op::Subscribe, keys.unit_tasks(u).as_str());
            grant(Op::Subscribe, keys.coord_barred().as_str());
            grant(Op::Query, keys.coord_barred().as_str());
            grant(Op::Watch, &keys.every_coord_alive());
            // Who holds office is the unit's own judgement: the asks to suspend a
            // coordinator, heard live and kept with the goals in force, seals checked.
            grant(Op::Subscribe, keys.every_suspend().as_str());
            grant(Op::Query, keys.coord_goals().as_str());
            if simulated {
                match spec.kind {
                    UnitKind::Ground => {
                        grant(Op::Subscribe, keys.sim_sensors(u).as_str());
                        grant(Op::Put, keys.sim_cmd(u).as_str());
                    }
                    UnitKind::Monorail => {
                        grant(Op::Subscribe, keys.sim_rail_sensors(u).as_str());
                        grant(Op::Put, keys.sim_rail_cmd(u).as_str());
                    }
                }
            }
        }
        Identity::Coordinator(rank) => {
            // Its own tasks and lease only: the key a unit hears a task on names the
            // coordinator the routers let send it.
            grant(Op::Put, keys.every_unit_task_of(*rank).as_str());
            grant(Op::Put, keys.every_fire().as_str());
            grant(Op::Put, keys.coord_log().as_str());
            grant(Op::Put, keys.coord_barred().as_str());
            grant(Op::Put, keys.coord_goals().as_str());
            grant(Op::Put, keys.every_zone_ack().as_str());
            grant(Op::Token, &keys.expr(&Topic::CoordAlive(*rank)));
            // A standby says it is standing by (operators see who could take over), and
            // what it follows.
            grant(Op::Token, &keys.expr(&Topic::CoordStandbyAlive(*rank)));
            grant(Op::Put, keys.coord_standby_health(*rank).as_str());
            grant(Op::Subscribe, keys.every_unit_state().as_str());
            grant(Op::Subscribe, keys.every_unit_report().as_str());
            grant(Op::Subscribe, keys.every_zone_goal().as_str());
            // Asks to suspend an identity, and its own (the operator at its host's).
            grant(Op::Subscribe, keys.every_suspend().as_str());
            grant(Op::Put, keys.suspends_by(&who.dir_name()).as_str());
            grant(Op::Watch, &keys.every_unit_alive());
            grant(Op::Query, keys.every_fire().as_str());
            grant(Op::Query, keys.coord_goals().as_str());
            grant(Op::Answer, &keys.every_coord());
            // Every coordinator's tasks: a rival's are alarmed, and its own that it never
            // sent betray a stolen key.
            grant(Op::Subscribe, keys.every_unit_task().as_str());
            // A standby follows the coordinator in office.
            grant(Op::Subscribe, keys.every_fire().as_str());
            grant(Op::Subscribe, keys.coord_goals().as_str());
            grant(Op::Watch, &keys.every_coord_alive());
            // The other standbys: the lowest standing by takes office first.
            grant(Op::Watch, &keys.every_standby_alive());
            grant(Op::Subscribe, &keys.every_infra());
            if simulated {
                grant(Op::Subscribe, keys.sim_clock().as_str());
            }
        }
        Identity::Recorder => {
            grant(Op::Subscribe, &keys.all());
            grant(Op::Watch, &keys.all());
            grant(Op::Answer, keys.every_fire().as_str());
            grant(Op::Answer, &keys.every_coord());
        }
        Identity::Commander(_) | Identity::Console => {
            let goals = match who {
                Identity::Commander(c) => keys.zone_goals_by(c),
                _ => keys.every_zone_goal(),
            };
            grant(Op::Put, goals.as_str());
            grant(Op::Delete, goals.as_str());
            // A commander asks, under its own name, that an identity be suspended; the
            // console may not (a stolen console key would speak for two commanders).
            if let Identity::Commander(_) = who {
                grant(Op::Put, keys.suspends_by(&who.dir_name()).as_str());
            }
            // Its own goal keys heard: a goal sealed with its key that it never sent is
            // someone else's, who holds the key.
            grant(Op::Subscribe, goals.as_str());
            grant(Op::Subscribe, keys.every_zone_ack().as_str());
            grant(Op::Subscribe, keys.every_fire().as_str());
            grant(Op::Subscribe, keys.every_unit_state().as_str());
            // What each unit was ordered, beside what it does.
            grant(Op::Subscribe, keys.every_unit_task().as_str());
            grant(Op::Subscribe, keys.coord_log().as_str());
            grant(Op::Subscribe, keys.coord_goals().as_str());
            grant(Op::Subscribe, keys.coord_barred().as_str());
            grant(Op::Subscribe, keys.every_standby_health().as_str());
            grant(Op::Subscribe, &keys.every_infra());
            grant(Op::Query, &keys.every_coord());
            grant(Op::Watch, &keys.every_alive());
            // The console's picture runs on site time.
            if simulated && *who == Identity::Console {
                grant(Op::Subscribe, keys.sim_clock().as_str());
            }
        }
        Identity::Sim if simulated => {
            grant(Op::Put, keys.sim_clock().as_str());
            grant(Op::Put, keys.sim_truth().as_str());
            grant(Op::Put, keys.every_sim_sensors().as_str());
            grant(Op::Put, keys.every_sim_rail_sensors().as_str());
            grant(Op::Subscribe, keys.every_sim_cmd().as_str());
            grant(Op::Subscribe, keys.every_sim_rail_cmd().as_str());
            grant(Op::Watch, &keys.every_alive());
        }
        Identity::Scada => {
            grant(Op::Put, keys.every_dts_zone().as_str());
            grant(Op::Put, keys.infra_vent().as_str());
            grant(Op::Put, keys.infra_link().as_str());
            if simulated {
                grant(Op::Subscribe, keys.sim_clock().as_str());
            }
        }
        Identity::Sim | Identity::Router(_) => {}
    }
    // Whether the router admits it at all, for an identity with a part on this site: one
    // its rules leave nothing (revoked, or issued after the router's rules were rendered)
    // gets no answer, and the doctor says so on the identity's own host.
    if !g.is_empty() {
        g.push(Grant {
            op: Op::Query,
            key_expr: keys.expr(&Topic::RouterHello),
        });
    }
    Ok(g)
}

/// Whether `grants` let their holder do `op` on the concrete key `key` (a grant's key
/// expression includes it), the same test Zenoh's router applies.
pub fn allows(grants: &[Grant], op: Op, key: &str) -> bool {
    let Ok(key) = zenoh::key_expr::KeyExpr::try_from(key) else {
        return false;
    };
    grants.iter().any(|g| {
        g.op == op
            && zenoh::key_expr::KeyExpr::try_from(g.key_expr.as_str())
                .is_ok_and(|e| e.includes(&key))
    })
}

/// The `access_control` section of the router's Zenoh configuration for `identities` of
/// `scenario`'s site: default deny, one subject per common name (matched on the client's
/// TLS certificate), one rule per identity and operation.
pub fn zenoh_acl(
    scenario: &Scenario,
    identities: &[Identity],
    simulated: bool,
) -> Result<Value, UnknownUnit> {
    let granted = identities
        .iter()
        .map(|who| Ok((who.clone(), grants(scenario, who, simulated)?)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(zenoh_acl_of(&Keys::new(scenario.site.clone()), &granted))
}

/// The `access_control` section for identities granted as given, on the site of `keys`
/// (what [`zenoh_acl`] renders; load tests grant a load generator more).
pub fn zenoh_acl_of(keys: &Keys, granted: &[(Identity, Vec<Grant>)]) -> Value {
    let mut rules = Vec::new();
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    for (who, granted) in granted {
        if granted.is_empty() {
            continue;
        }
        let subject = who.to_string();
        // Zenoh filters on the writer's side: a client publishes (or queries) only once the
        // router has told it that someone listens, by passing it the listeners'
        // declarations. Those carry the listener's key expression (the coordinator's
        // `unit/*/state`, a recorder's `**`), not the writer's key, so they are let out on
        // the whole site: an identity learns which key expressions are listened to, never
        // a sample it may not read.
        let routing = format!("{subject} routing");
        rules.push(json!({
            "id": routing,
            "messages": ["declare_subscriber", "declare_queryable", "declare_liveliness_subscriber"],
            "flows": ["egress"],
            "permission": "allow",
            "key_exprs": [keys.all()],
        }));
        let mut rule_ids = vec![routing];
        for op in Op::ALL {
            let exprs: Vec<&str> = granted
                .iter()
                .filter(|g| g.op == op)
                .map(|g| g.key_expr.as_str())
                .collect();
            if exprs.is_empty() {
                continue;
            }
            for (message, flow) in op.zenoh_messages() {
                let id = format!("{subject} {} {message} {flow}", op.as_str());
                rules.push(json!({
                    "id": id,
                    "messages": [message],
                    "flows": [flow],
                    "permission": "allow",
                    "key_exprs": exprs,
                }));
                rule_ids.push(id);
            }
        }
        subjects.push(json!({ "id": subject, "cert_common_names": [subject] }));
        policies.push(json!({ "id": subject, "rules": rule_ids, "subjects": [subject] }));
    }
    json!({
        "enabled": true,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn site() -> Scenario {
        Scenario::straight(200.0)
            .ground("ugv-1", 10.0, 2.0)
            .ground("ugv-2", 20.0, 2.0)
            .rail("r", 0.0, 200.0, &[50.0])
            .monorail("rail-1", "r", 30.0)
            .build()
    }

    #[test]
    fn the_site_file_s_commanders_are_identities_of_the_site_once_each() {
        use firefleet_model::scenario::{CommanderSpec, Rank};
        let mut s = site();
        for (name, rank) in [("chief", Rank::Incident), ("rossi", Rank::Sector)] {
            s.commanders.push(CommanderSpec {
                id: CommanderId::new(name).unwrap(),
                rank,
            });
        }
        let commanders: Vec<String> = Identity::of_site(&s, &[CommanderId::new("rossi").unwrap()])
            .into_iter()
            .filter(|w| w.role() == Role::Commander)
            .map(|w| w.to_string())
            .collect();
        assert_eq!(commanders, ["commander:rossi", "commander:chief"]);
    }

    #[test]
    fn identities_round_trip_through_their_common_names() {
        let s = site();
        for who in Identity::of_site(&s, &[CommanderId::new("rossi").unwrap()]) {
            assert_eq!(who.to_string().parse::<Identity>().unwrap(), who);
        }
        for bad in ["unit:", "unit:UGV", "admin", "commander:a/b", "unit"] {
            assert!(bad.parse::<Identity>().is_err(), "{bad}");
        }
    }

    fn of(s: &Scenario, who: &str) -> Vec<Grant> {
        grants(s, &who.parse().unwrap(), true).unwrap()
    }

    #[test]
    fn a_coordinator_commands_and_holds_office_only_under_its_own_rank() {
        let s = site();
        let k = |tail: &str| format!("ff/{}/{tail}", s.site);
        let first = of(&s, "coordinator");
        let standby = of(&s, "coordinator:1");
        for (who, mine, theirs) in [(&first, "0", "1"), (&standby, "1", "0")] {
            assert!(allows(who, Op::Put, &k(&format!("unit/ugv-1/task/{mine}"))));
            assert!(allows(
                who,
                Op::Token,
                &k(&format!("coord/office/{mine}/alive"))
            ));
            assert!(!allows(
                who,
                Op::Put,
                &k(&format!("unit/ugv-1/task/{theirs}"))
            ));
            assert!(!allows(
                who,
                Op::Token,
                &k(&format!("coord/office/{theirs}/alive"))
            ));
            assert!(!allows(
                who,
                Op::Token,
                &k(&format!("coord/standby/{theirs}/alive"))
            ));
            // Every coordinator hears every task and every lease: rivals are alarmed.
            assert!(allows(
                who,
                Op::Subscribe,
                &k(&format!("unit/ugv-1/task/{theirs}"))
            ));
            assert!(allows(
                who,
                Op::Watch,
                &k(&format!("coord/office/{theirs}/alive"))
            ));
        }
        for bad in ["coordinator:0", "coordinator:16", "coordinator:a"] {
            assert!(bad.parse::<Identity>().is_err(), "{bad}");
        }
    }

    #[test]
    fn a_unit_touches_only_its_own_keys() {
        let s = site();
        let ugv2 = of(&s, "unit:ugv-2");
        let k = |tail: &str| format!("ff/{}/{tail}", s.site);
        for (op, key) in [
            (Op::Put, "unit/ugv-2/state"),
            (Op::Put, "unit/ugv-2/report"),
            (Op::Token, "unit/ugv-2/alive"),
            (Op::Subscribe, "unit/ugv-2/task/0"),
            (Op::Subscribe, "unit/ugv-2/task/1"),
            (Op::Subscribe, "coord/barred"),
            (Op::Query, "coord/barred"),
            (Op::Watch, "coord/office/0/alive"),
            (Op::Watch, "coord/office/1/alive"),
            (Op::Put, "sim/unit/ugv-2/cmd"),
        ] {
            assert!(allows(&ugv2, op, &k(key)), "{op:?} {key}");
        }
        for (op, key) in [
            (Op::Put, "unit/ugv-1/state"),
            (Op::Put, "unit/ugv-1/task/0"),
            (Op::Put, "unit/ugv-2/task/0"),
            (Op::Put, "fire/f1"),
            (Op::Put, "zone/deep/goal/ugv-2"),
            (Op::Delete, "zone/deep/goal/rossi"),
            (Op::Put, "coord/barred"),
            (Op::Put, "sim/unit/ugv-1/cmd"),
            (Op::Put, "sim/rail/rail-1/cmd"),
            (Op::Token, "coord/office/0/alive"),
            (Op::Token, "unit/ugv-1/alive"),
            (Op::Subscribe, "unit/ugv-1/task/0"),
            (Op::Answer, "fire/f1"),
            (Op::Answer, "coord/barred"),
            (Op::Answer, "coord/status"),
        ] {
            assert!(!allows(&ugv2, op, &k(key)), "{op:?} {key}");
        }
    }

    #[test]
    fn a_commander_puts_and_clears_goals_only_under_its_own_name() {
        let s = site();
        let rossi = of(&s, "commander:rossi");
        let k = |tail: &str| format!("ff/{}/{tail}", s.site);
        assert!(allows(&rossi, Op::Put, &k("zone/deep/goal/rossi")));
        assert!(allows(&rossi, Op::Delete, &k("zone/deep/goal/rossi")));
        assert!(!allows(&rossi, Op::Put, &k("zone/deep/goal/bianchi")));
        assert!(!allows(&rossi, Op::Delete, &k("zone/deep/goal/bianchi")));
        assert!(!allows(&rossi, Op::Put, &k("unit/ugv-1/task/0")));
        assert!(allows(&rossi, Op::Query, &k("coord/status")));
        assert!(allows(&rossi, Op::Subscribe, &k("zone/deep/ack")));
    }

    #[test]
    fn the_console_speaks_for_any_commander_and_commands_no_unit() {
        let s = site();
        let console = grants(&s, &"console".parse().unwrap(), true).unwrap();
        let k = |tail: &str| format!("ff/{}/{tail}", s.site);
        for key in ["zone/deep/goal/rossi", "zone/portal/goal/bianchi"] {
            assert!(allows(&console, Op::Put, &k(key)), "{key}");
            assert!(allows(&console, Op::Delete, &k(key)), "{key}");
        }
        for (op, key) in [
            (Op::Subscribe, "unit/ugv-1/state"),
            (Op::Subscribe, "fire/f1"),
            (Op::Subscribe, "zone/deep/ack"),
            (Op::Subscribe, "coord/log"),
            (Op::Subscribe, "coord/goals"),
            (Op::Subscribe, "sim/clock"),
            (Op::Watch, "unit/ugv-1/alive"),
        ] {
            assert!(allows(&console, op, &k(key)), "{op:?} {key}");
        }
        for (op, key) in [
            (Op::Put, "unit/ugv-1/task/0"),
            (Op::Put, "coord/barred"),
            (Op::Put, "coord/goals"),
            (Op::Put, "zone/deep/ack"),
            (Op::Put, "fire/f1"),
            (Op::Put, "sim/unit/ugv-1/cmd"),
            (Op::Token, "coord/office/0/alive"),
            (Op::Subscribe, "sim/unit/ugv-1/sensors"),
        ] {
            assert!(!allows(&console, op, &k(key)), "{op:?} {key}");
        }
        let real = grants(&s, &Identity::Console, false).unwrap();
        assert!(!allows(&real, Op::Subscribe, &k("sim/clock")));
    }

    #[test]
    fn a_real_site_grants_no_simulator_keys() {
        let s = site();
        let k = |tail: &str| format!("ff/{}/{tail}", s.site);
        let unit = grants(&s, &"unit:ugv-1".parse().unwrap(), false).unwrap();
        assert!(!allows(&unit, Op::Put, &k("sim/unit/ugv-1/cmd")));
        assert!(grants(&s, &Identity::Sim, false).unwrap().is_empty());
        assert!(grants(&s, &"unit:ugv-9".parse().unwrap(), true).is_err());
    }

    #[test]
    fn every_key_has_a_writer_and_a_reader_besides_the_recorder() {
        let s = site();
        let keys = Keys::new(s.site.clone());
        let who = Identity::of_site(&s, &[CommanderId::new("rossi").unwrap()]);
        let granted: Vec<(Identity, Vec<Grant>)> = who
            .iter()
            .map(|w| (w.clone(), grants(&s, w, true).unwrap()))
            .collect();
        let u = |s: &str| UnitId::new(s).unwrap();
        let zone = firefleet_model::ZoneId::new("deep").unwrap();
        let topics = [
            (Op::Put, Topic::UnitState(u("ugv-1"))),
            (Op::Token, Topic::UnitAlive(u("ugv-1"))),
            (Op::Put, Topic::UnitReport(u("ugv-1"))),
            (Op::Put, Topic::UnitTask(u("ugv-1"), 0)),
            (Op::Put, Topic::UnitTask(u("ugv-1"), 1)),
            (Op::Put, Topic::UnitBt(u("ugv-1"))),
            (Op::Put, Topic::Fire(firefleet_model::FireId(3))),
            (
                Op::Put,
                Topic::ZoneGoal(zone.clone(), CommanderId::new("rossi").unwrap()),
            ),
            (Op::Put, Topic::ZoneAck(zone)),
            (Op::Token, Topic::CoordAlive(0)),
            (Op::Token, Topic::CoordAlive(1)),
            (Op::Token, Topic::CoordStandbyAlive(1)),
            (Op::Answer, Topic::CoordStatus),
            (Op::Put, Topic::CoordLog),
            (Op::Put, Topic::CoordBarred),
            (Op::Put, Topic::CoordGoals),
            (Op::Put, Topic::CoordStandbyHealth(1)),
            (Op::Put, Topic::SimClock),
            (Op::Put, Topic::SimTruth),
            (Op::Put, Topic::SimSensors(u("ugv-1"))),
            (Op::Put, Topic::SimCmd(u("ugv-1"))),
            (Op::Put, Topic::SimRailSensors(u("rail-1"))),
            (Op::Put, Topic::SimRailCmd(u("rail-1"))),
        ];
        for (write, topic) in topics {
            let key = keys.expr(&topic);
            let read = match write {
                Op::Token => Op::Watch,
                Op::Answer => Op::Query,
                _ => Op::Subscribe,
            };
            let writers: Vec<&Identity> = granted
                .iter()
                .filter(|(_, g)| allows(g, write, &key))
                .map(|(w, _)| w)
                .collect();
            // Recorders answer the coordinators' queries on their behalf (coord/*) and
            // both coordinators answer them (a standby its status); the console speaks for
            // the commanders who log in to it; both coordinators keep the incident's own
            // record (tracks, log, barred space, goals, answers).
            let expected = match (write, &topic) {
                (Op::Answer, _) => 3,
                (Op::Put, Topic::ZoneGoal(..)) => 2,
                (
                    Op::Put,
                    Topic::Fire(_)
                    | Topic::CoordLog
                    | Topic::CoordBarred
                    | Topic::CoordGoals
                    | Topic::ZoneAck(_),
                ) => 2,
                _ => 1,
            };
            assert_eq!(writers.len(), expected, "{key}: written by {writers:?}");
            let readers = granted
                .iter()
                .filter(|(w, g)| *w != Identity::Recorder && allows(g, read, &key))
                .count();
            let recorded = allows(
                &granted
                    .iter()
                    .find(|(w, _)| *w == Identity::Recorder)
                    .unwrap()
                    .1,
                read,
                &key,
            ) || read == Op::Query;
            assert!(
                readers > 0 || topic == Topic::UnitBt(u("ugv-1")) || topic == Topic::SimTruth,
                "{key}: read by nobody"
            );
            assert!(recorded, "{key}: not recorded");
        }
    }
}
