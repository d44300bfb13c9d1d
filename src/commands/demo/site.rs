//! A secure demo site: a PKI (given, or made for the run) and the configurations rendered
//! for a router on loopback.
//!
//! Not here: the PKI and the rendering themselves (`firefleet_bus::pki`, `render`).

use super::*;

/// A secure demo site: its PKI and the configurations rendered for it.
pub(super) struct SecureSite {
    pub(super) pki: PathBuf,
    pub(super) configs: PathBuf,
    /// Holds what was made for the run (configurations, a PKI) until the demo ends.
    _made: tempfile::TempDir,
}

impl SecureSite {
    /// Use `pki` (or make one) and render the site's configurations for a router on
    /// loopback `port`, with `commander` among the identities.
    pub(super) fn make(
        scenario: &Scenario,
        pki: Option<PathBuf>,
        port: u16,
        commander: &CommanderId,
        time_scale: f64,
    ) -> anyhow::Result<Self> {
        let made = tempfile::Builder::new()
            .prefix("firefleet-demo-")
            .tempdir()
            .context("a directory for the demo's site")?;
        let pki = match pki {
            Some(p) => p,
            None => {
                let p = made.path().join("pki");
                let terms = pki::Terms::default();
                pki::make_site(scenario, std::slice::from_ref(commander), &terms, &p)?;
                p
            }
        };
        let configs = made.path().join("configs");
        let endpoint = format!("quic/127.0.0.1:{port}");
        let layout = Layout {
            time_scale,
            ..Layout::loopback(pki.clone(), configs.clone(), endpoint, commander.clone())
        };
        render_site(scenario, &layout)
            .with_context(|| format!("rendering the site for the PKI in {}", pki.display()))?;
        Ok(Self {
            pki,
            configs,
            _made: made,
        })
    }

    /// How identity `who` joins the site.
    pub(super) fn client(&self, who: &Identity) -> Connect {
        Connect {
            config_file: Some(self.configs.join(format!("{}.json5", who.dir_name()))),
            ..Connect::default()
        }
    }
}
