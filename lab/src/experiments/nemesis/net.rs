//! The nemesis's network: a namespace per process, each joined to the router's by a veth
//! pair, and the iptables rules its faults are made of. Made per run, removed when
//! dropped.

use anyhow::{Context, bail};

/// Root, `ip` and `iptables`, and a namespace made and removed.
pub(super) fn preflight() -> anyhow::Result<()> {
    let probe = format!("ffprobe{}", std::process::id());
    sh("ip", &["netns", "add", &probe])?;
    let iptables = sh("ip", &["netns", "exec", &probe, "iptables", "-L", "-n"]);
    sh("ip", &["netns", "del", &probe])?;
    iptables.map(|_| ())
}

/// Run `cmd args`, failing with what it printed.
pub(super) fn sh(cmd: &str, args: &[&str]) -> anyhow::Result<String> {
    let out = std::process::Command::new(cmd)
        .args(args)
        .output()
        .with_context(|| format!("running {cmd}"))?;
    if !out.status.success() {
        bail!(
            "{cmd} {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The namespaces of one run: the router's, and one per process, each joined to the
/// router's by a veth pair (10.200.i.2 on the process's side, 10.200.i.1 on the router's).
/// Link 0 is the harness's own, from the initial namespace. Removed when dropped.
pub(super) struct Net {
    tag: String,
    links: u8,
}

impl Net {
    /// The namespaces of run `run` of this process.
    pub(super) fn new(run: usize) -> anyhow::Result<Self> {
        // Short (interface names take 15 characters at most), and new for every run: a
        // namespace's removal completes in the background.
        let tag = format!("ff{}x{run}", std::process::id() % 10_000);
        let net = Self { tag, links: 0 };
        sh("ip", &["netns", "add", &net.router()])?;
        net.exec_in(&net.router(), &["ip", "link", "set", "lo", "up"])?;
        Ok(net)
    }

    pub(super) fn router(&self) -> String {
        format!("{}r", self.tag)
    }

    pub(super) fn exec_in(&self, ns: &str, args: &[&str]) -> anyhow::Result<String> {
        let mut all = vec!["netns", "exec", ns];
        all.extend_from_slice(args);
        sh("ip", &all)
    }

    /// A new link; its process's namespace (`None` for the harness's, the initial one).
    pub(super) fn link(&mut self) -> anyhow::Result<(u8, Option<String>)> {
        let i = self.links;
        self.links += 1;
        let (ours, theirs) = (format!("{}v{i}a", self.tag), self.router_side(i));
        sh(
            "ip",
            &[
                "link", "add", &ours, "type", "veth", "peer", "name", &theirs,
            ],
        )?;
        sh("ip", &["link", "set", &theirs, "netns", &self.router()])?;
        let r = self.router();
        self.exec_in(
            &r,
            &[
                "ip",
                "addr",
                "add",
                &format!("10.200.{i}.1/30"),
                "dev",
                &theirs,
            ],
        )?;
        self.exec_in(&r, &["ip", "link", "set", &theirs, "up"])?;
        let ns = (i > 0).then(|| format!("{}n{i}", self.tag));
        let addr = format!("10.200.{i}.2/30");
        match &ns {
            Some(ns) => {
                sh("ip", &["netns", "add", ns])?;
                sh("ip", &["link", "set", &ours, "netns", ns])?;
                self.exec_in(ns, &["ip", "addr", "add", &addr, "dev", &ours])?;
                self.exec_in(ns, &["ip", "link", "set", &ours, "up"])?;
                self.exec_in(ns, &["ip", "link", "set", "lo", "up"])?;
            }
            None => {
                sh("ip", &["addr", "add", &addr, "dev", &ours])?;
                sh("ip", &["link", "set", &ours, "up"])?;
            }
        }
        Ok((i, ns))
    }

    pub(super) fn router_side(&self, link: u8) -> String {
        format!("{}v{link}b", self.tag)
    }

    /// Drop what link `link` carries: `loss` of it at random, `both` ways or only
    /// towards the process.
    pub(super) fn cut(&self, link: u8, loss: Option<f64>, both: bool) -> anyhow::Result<()> {
        let dev = self.router_side(link);
        let p = loss.map(|p| p.to_string());
        let rule = |chain: &str, dir: &str| {
            let mut args = vec!["iptables", "-A", chain, dir, dev.as_str()];
            if let Some(p) = &p {
                args.extend(["-m", "statistic", "--mode", "random", "--probability", p]);
            }
            args.extend(["-j", "DROP"]);
            self.exec_in(&self.router(), &args).map(|_| ())
        };
        rule("OUTPUT", "-o")?;
        if both {
            rule("INPUT", "-i")?;
        }
        Ok(())
    }

    pub(super) fn heal(&self) -> anyhow::Result<()> {
        for chain in ["INPUT", "OUTPUT"] {
            self.exec_in(&self.router(), &["iptables", "-F", chain])?;
        }
        Ok(())
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        // Deleting a namespace deletes its veth ends, and so their peers, but in the
        // background: the harness's end goes now.
        let _ = sh("ip", &["link", "del", &format!("{}v0a", self.tag)]);
        for i in 1..self.links {
            let _ = sh("ip", &["netns", "del", &format!("{}n{i}", self.tag)]);
        }
        let _ = sh("ip", &["netns", "del", &self.router()]);
    }
}
