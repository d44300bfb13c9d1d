//! The doctor's look at the network: the routers' endpoints (resolved, answering, with a
//! router certificate for the name dialled), whether each router's rules admit the
//! identity, and the protocol the site's coordinator speaks.

use super::*;

/// The routers a role dials, as the doctor found them.
pub(super) enum Reached {
    /// A plain (loopback) configuration: nothing to knock at.
    Plain,
    /// These endpoints linked with the role's identity (none: no router was reached).
    Linked(Vec<String>),
}

/// Every router endpoint the role dials: resolved, answering, presenting a router's
/// certificate of the site valid for the name dialled; those that linked. With an
/// identity already found wrong (`identity_ok` false) the router's refusal of the link is
/// its consequence, not a problem of its own.
pub(super) async fn routers(
    f: &mut Findings,
    links: &Links,
    scenario: &Scenario,
    identity_ok: bool,
    within: Duration,
) -> Reached {
    let Some(files) = &links.tls else {
        return Reached::Plain;
    };
    let mut linked = Vec::new();
    for endpoint in &links.connect {
        let shown = endpoint.split(['#', '?']).next().unwrap_or(endpoint);
        let listed = probe::quic_host_port(endpoint)
            .ok()
            .and_then(|(host, port)| {
                scenario
                    .routers
                    .iter()
                    .find(|r| r.host == host && r.port == port)
            });
        // Where the address came from, so the fix says what to correct.
        let from = match (listed, scenario.routers.is_empty()) {
            (Some(r), _) => format!("the site file's [[routers]] entry '{}'", r.name),
            (None, false) => {
                f.problem(
                    format_args!(
                        "router {shown}: the configuration dials a router the site file's [[routers]] does not list"
                    ),
                    "render this identity's configuration again from the site file (firefleet deploy render) and copy it",
                );
                continue;
            }
            (None, true) => "deploy render --connect".to_owned(),
        };
        match probe::knock(endpoint, files, within).await {
            Err(KnockError::Resolve { host, why }) => f.problem(
                format_args!("router {shown}: the host '{host}' does not resolve ({why})"),
                format_args!(
                    "add the router's name to DNS or /etc/hosts; if the name is wrong, correct {from} and render again"
                ),
            ),
            Err(KnockError::NoAnswer { addr, why, .. }) => f.problem(
                format_args!("router {shown}: nothing answers at {addr} ({why})"),
                format_args!(
                    "check that {addr} is the router's address (DNS or /etc/hosts, and {from}: render again if it is wrong), that the router runs there (systemctl status on its host), and that UDP to its port is open"
                ),
            ),
            // A knock with an identity found wrong above fails because of it: said once.
            Err(e) if !identity_ok => f.note(format_args!(
                "router {shown}: not knocked at with the identity above ({e})"
            )),
            Err(e) => f.problem(
                format_args!("router {shown}: {e}"),
                "render this identity's configuration again",
            ),
            Ok(answered) => {
                let (host, _) = probe::quic_host_port(endpoint).expect("knocked at");
                match (&answered.presented, &answered.linked) {
                    (Ok(c), _) if c.identity.role() != Role::Router => f.problem(
                        format_args!(
                            "router {shown}: {} answers with {}'s certificate, not a router's",
                            answered.addr, c.identity
                        ),
                        "point the configuration at the site's router (deploy render --connect)",
                    ),
                    (Ok(c), Err(why)) if !c.hosts.iter().any(|h| h == &host) => f.problem(
                        format_args!(
                            "router {shown}: {} presents {}'s certificate, which is not for '{host}' (it names {}): {why}",
                            answered.addr,
                            c.identity,
                            c.hosts.join(", ")
                        ),
                        format_args!(
                            "dial the router by a name its certificate lists (deploy render --connect quic/NAME:PORT), or issue it again with --host {host}"
                        ),
                    ),
                    (Ok(c), Err(why)) if !identity_ok => f.note(format_args!(
                        "router {shown}: {} ({}) refused the link, as it must with the identity above ({why})",
                        answered.addr, c.identity
                    )),
                    (Ok(c), Err(why)) => f.problem(
                        format_args!("router {shown}: {} ({}) refused the link: {why}", answered.addr, c.identity),
                        "check that both ends hold certificates of this site's CA and that the router lists this identity",
                    ),
                    (Err(why), _) => f.problem(
                        format_args!("router {shown}: {} presents a certificate that is no site identity's: {why}", answered.addr),
                        "point the configuration at the site's router",
                    ),
                    (Ok(c), Ok(())) => {
                        linked.push(endpoint.clone());
                        f.ok(format_args!(
                            "router {shown}: {} answers as {}, certified for '{host}'",
                            answered.addr, c.identity
                        ))
                    }
                }
            }
        }
    }
    Reached::Linked(linked)
}

/// Whether each router in `linked` admits the identity: it answers the identity's hello
/// ([`firefleet_bus::hello`]). A router that links the identity and does not answer gives
/// it nothing: the one sign, on the identity's own host, that the site revoked its name
/// (or that the router runs rules rendered before the name was issued). Whether every
/// router admits it.
pub(super) async fn admission(
    f: &mut Findings,
    a: &DoctorArgs,
    scenario: &Scenario,
    linked: &[String],
    within: Duration,
) -> bool {
    let mut admitted = true;
    for endpoint in linked {
        let shown = endpoint.split(['#', '?']).next().unwrap_or(endpoint);
        let mut only = a.zenoh.connect(Some(Expect::Identity(a.identity.clone())));
        only.connect = vec![endpoint.clone()];
        let answer = match Bus::open(&only, scenario.site.clone()).await {
            Ok(bus) => {
                let answer = firefleet_bus::hello::admitted_by(&bus, within).await;
                bus.close().await;
                answer
            }
            Err(e) => Err(e),
        };
        match answer {
            Ok(Some(name)) => f.ok(format_args!(
                "router {shown}: its rules admit {} (router '{name}' answered)",
                a.identity
            )),
            Ok(None) => {
                admitted = false;
                f.problem(
                    format_args!(
                        "router {shown}: links {} but its rules give it nothing: the site has revoked this name (or the router runs rules rendered before it was issued)",
                        a.identity
                    ),
                    "if the name was revoked (firefleet pki list on the PKI's host says so), this host stays off the site until it has an identity of a new site CA; if not, render the rules again (firefleet deploy render) and restart this router",
                )
            }
            Err(e) => {
                admitted = false;
                f.problem(
                    format_args!("router {shown}: joining the site through it: {e}"),
                    "see the lines above; if none says why, run with RUST_LOG=zenoh=debug",
                )
            }
        }
    }
    admitted
}

/// The protocol version the site's coordinator speaks, from a postcard message the role
/// may ask for (its first byte is the version).
pub(super) async fn protocol(
    f: &mut Findings,
    a: &DoctorArgs,
    scenario: &Scenario,
    within: Duration,
) {
    let keys = firefleet_protocol::keys::Keys::new(scenario.site.clone());
    let key = match a.identity.role() {
        Role::Unit | Role::Console | Role::Commander => keys.expr(&Topic::CoordBarred),
        Role::Coordinator => keys.every_fire().as_str().to_owned(),
        Role::Recorder | Role::Sim | Role::Scada | Role::Router => return,
    };
    let expect = match a.identity.role() {
        Role::Router => None,
        _ => Some(Expect::Identity(a.identity.clone())),
    };
    let bus = match Bus::open(&a.zenoh.connect(expect), scenario.site.clone()).await {
        Ok(b) => b,
        Err(e) => {
            f.problem(
                format_args!("joining the site: {e}"),
                "see the lines above; if none says why, run with RUST_LOG=zenoh=debug",
            );
            return;
        }
    };
    let answer = match bus.ask(&key, Ask::within(within)).await {
        Ok(answers) => answers.recv().await,
        Err(e) => {
            f.problem(
                format_args!("asking {key}: {e}"),
                "check the router's rules for this identity (deploy render)",
            );
            None
        }
    };
    match answer.and_then(|a| a.bytes.first().copied()) {
        Some(v) if v == PROTOCOL_VERSION => f.ok(format_args!(
            "protocol: the site speaks version {v}, as this build"
        )),
        Some(v) => f.problem(
            format_args!("protocol: the site's coordinator speaks version {v}, this build {PROTOCOL_VERSION}"),
            "install the site's release on this host, or upgrade the site as deploy/UPGRADE.md says",
        ),
        None => f.note(format_args!(
            "protocol: nothing answered {key} within {within:?} (no coordinator in charge yet?)"
        )),
    }
    bus.close().await;
}
