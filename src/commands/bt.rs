//! `firefleet bt`: check, show and dry-run behavior-tree files without a robot.
//!
//! Not here: the engine (`firefleet-bt`) or the unit leaves (`firefleet-agent`).

use std::cell::RefCell;
use std::path::PathBuf;
use std::process::ExitCode;
use std::rc::Rc;

use clap::{Args, Subcommand, ValueEnum};
use firefleet_bt::xml::{self, Document, XmlErrors};
use firefleet_bt::{Registry, Transition};

/// Which unit's leaves a tree is checked against.
#[derive(ValueEnum, Clone, Copy, Debug, Default)]
pub enum Kind {
    #[default]
    Ground,
    Monorail,
}

fn validate(doc: &Document, kind: Kind) -> Result<(), XmlErrors> {
    match kind {
        Kind::Ground => xml::validate(doc, &firefleet_agent::ground::leaves::registry()),
        Kind::Monorail => xml::validate(doc, &firefleet_agent::monorail::registry()),
    }
}

#[derive(Subcommand, Debug)]
pub enum BtCommand {
    /// Check files against every node type the agent registers; exit 0 if all are valid.
    Validate {
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// The kind of unit the trees are for.
        #[arg(long, value_enum, default_value_t)]
        kind: Kind,
    },
    /// Print a file's main tree as text, subtrees expanded.
    Show {
        file: PathBuf,
        #[arg(long, value_enum, default_value_t)]
        kind: Kind,
    },
    /// Dry-run a tree of built-in nodes on a simulated clock, printing every transition.
    Run(RunArgs),
}

#[derive(Args, Debug)]
pub struct RunArgs {
    file: PathBuf,
    /// How many ticks.
    #[arg(long, default_value_t = 10)]
    ticks: u32,
    /// Simulated time between ticks, ms.
    #[arg(long, default_value_t = 100)]
    period_ms: u64,
}

pub fn run(cmd: BtCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        BtCommand::Validate { files, kind } => {
            let mut ok = true;
            for f in files {
                match xml::load_file(&f).and_then(|doc| validate(&doc, kind).map(|()| doc)) {
                    Ok(doc) => println!("{}: valid ({} trees)", f.display(), doc.trees.len()),
                    Err(e) => {
                        ok = false;
                        eprintln!("{e}");
                    }
                }
            }
            Ok(if ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
        BtCommand::Show { file, kind } => {
            let doc = xml::load_file(&file)?;
            print!("{}", xml::render(&doc).map_err(anyhow::Error::msg)?);
            match validate(&doc, kind) {
                Ok(()) => Ok(ExitCode::SUCCESS),
                Err(e) => {
                    eprintln!("{e}");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        BtCommand::Run(a) => dry_run(a),
    }
}

fn dry_run(a: RunArgs) -> anyhow::Result<ExitCode> {
    let doc = xml::load_file(&a.file)?;
    let registry = Registry::<()>::new();
    let mut tree = xml::build(&doc, &registry)
        .map_err(|e| anyhow::anyhow!("{e}\n(`bt run` knows only the built-in nodes)"))?;
    let labels: Vec<String> = (0..tree.len() as u32)
        .map(|i| {
            if tree.name(i) == tree.type_name(i) {
                tree.type_name(i).to_owned()
            } else {
                format!("{} \"{}\"", tree.type_name(i), tree.name(i))
            }
        })
        .collect();
    let seen: Rc<RefCell<Vec<Transition>>> = Rc::default();
    let sink = seen.clone();
    tree.set_observer(move |t| sink.borrow_mut().push(*t));
    for k in 0..a.ticks {
        let t = f64::from(k) * a.period_ms as f64 / 1000.0;
        let status = tree.tick(t, &mut ());
        println!("tick {:3}  t={t:8.3} s  root {status}", k + 1);
        for tr in seen.borrow_mut().drain(..) {
            println!(
                "    {:<40} {} -> {}",
                labels[tr.node as usize], tr.from, tr.to
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
