//! The demo's roles: which processes a demo starts, and with which arguments.

use super::*;

/// The demo's roles, each as its identity on a secure site and the command that starts it
/// (its site file and how it joins are added when it is started).
pub(super) fn roles(
    a: &DemoArgs,
    scenario: &Scenario,
    seed: u64,
    site: Option<&SecureSite>,
) -> anyhow::Result<Vec<(Identity, RoleCommand)>> {
    let mut roles: Vec<(Identity, RoleCommand)> = Vec::new();
    if a.record.is_some() || a.foxglove.is_some() {
        let mut record = RoleCommand::new("record");
        if let Some(path) = &a.record {
            record = record.arg("--out").arg(path);
        }
        if let Some(addr) = a.foxglove {
            record = record.args(["--foxglove".into(), addr.to_string()]);
            println!("Foxglove live: ws://{addr}");
        }
        roles.push((Identity::Recorder, record));
    }
    let modbus = match a.scada {
        true => {
            anyhow::ensure!(
                scenario.scada.is_some(),
                "--scada: scenario '{}' maps no [scada] in its file",
                scenario.name
            );
            let port = free_loopback_port().context("finding a free port for Modbus")?;
            let addr = format!("127.0.0.1:{port}");
            let bridge = RoleCommand::new("scada").args(["--modbus", &addr, "--sim-clock"]);
            roles.push((Identity::Scada, bridge));
            Some(addr)
        }
        false => None,
    };
    let mut sim = RoleCommand::new("sim")
        .args(["--seed".into(), seed.to_string()])
        .args(["--time-scale".into(), a.time_scale.to_string()])
        .args(["--wait-for-fleet", "30", "--wait-for-coordinator"]);
    if a.platform == PlatformKind::Ros2 {
        sim = sim.arg("--ros2");
    }
    if a.perception == Sensing::Boxes {
        sim = sim.args(["--perception", "boxes"]);
    }
    if let Some(m) = &modbus {
        sim = sim.args(["--scada", m]);
    }
    if let Some(t) = a.cut_scada_at {
        sim = sim.args(["--cut-scada-at".into(), t.to_string()]);
    }
    roles.push((Identity::Sim, sim));
    let coordinator = RoleCommand::new("coordinator").arg("--sim-clock");
    roles.push((Identity::COORDINATOR, coordinator.clone()));
    if a.standby {
        let standby = coordinator.args(["--standby", "--rank", "1"]);
        roles.push((Identity::Coordinator(1), standby));
    }
    if let Some(dir) = &a.btlog_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("--btlog-dir {}", dir.display()))?;
    }
    for (k, u) in scenario.units.iter().enumerate() {
        let mut agent = RoleCommand::new("agent").args(["--unit", u.id.as_str()]);
        if a.platform == PlatformKind::Ros2 {
            agent = agent.args(["--platform", "ros2"]);
        }
        if let Some(base) = a.groot2 {
            let port = u16::try_from(k)
                .ok()
                .and_then(|k| base.checked_add(k))
                .with_context(|| format!("--groot2 {base}: no port left for unit {}", u.id))?;
            println!("Groot2: {} on 127.0.0.1:{port}", u.id);
            agent = agent.args(["--groot2".into(), format!("127.0.0.1:{port}")]);
        }
        if let Some(dir) = &a.btlog_dir {
            agent = agent
                .arg("--btlog")
                .arg(dir.join(format!("{}.btlog", u.id)));
        }
        roles.push((Identity::Unit(u.id.clone()), agent));
    }
    if let Some(addr) = a.console {
        let mut console = RoleCommand::new("console").args(["--http".into(), addr.to_string()]);
        if let Some(users) = &a.console_users {
            console = console.arg("--users").arg(users);
        }
        // On a secure site the page is HTTPS with the console's web certificate from the
        // site PKI (valid for loopback): commanders' browsers trust the site's web CA.
        let scheme = match site {
            Some(s) => {
                let dir = s.pki.join(Identity::Console.dir_name());
                console = console
                    .arg("--https-cert")
                    .arg(dir.join("https-cert.pem"))
                    .arg("--https-key")
                    .arg(dir.join("https-key.pem"));
                println!(
                    "the console's page is signed by the site's web CA: {}",
                    dir.join("web-ca.pem").display()
                );
                "https"
            }
            None => "http",
        };
        println!("the incident commander's console: {scheme}://{addr}/");
        roles.push((Identity::Console, console));
    }
    Ok(roles)
}
