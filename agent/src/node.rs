//! An agent process: one controller, its platform, and its link to the coordinator.
//!
//! [`drive`] is the agent's whole life: it holds the unit's liveliness token (the
//! coordinator learns of a lost unit the moment its session drops), runs the controller
//! on its body, and moves to a nearer router when [`crate::rehome`] finds one, the body
//! made again on the new session and the controller kept (a token on each session for a
//! moment, so the unit never vanishes). [`run`] is one session's loop: it follows the
//! coordinator's own token to know whether to act alone, takes tasks and the barred space
//! commanders' goals make (asking for the newest at start: the coordinator and recorders
//! answer), steps the controller on every sensor frame, and publishes the unit's state
//! and flame reports a few times a second of site time, and its behavior tree's
//! transitions every step (for recordings).
//!
//! Its start-up question names the unit, so the coordinator can say it does not know it (a
//! robot added to the site whose coordinator still runs on the old site file): the agent
//! then logs the coordinator's reason and holds it in its [`Standing`] (the unit's
//! `/readyz` says it). It asks again every [`REASK_UNKNOWN`], and whenever a coordinator
//! appears (one that was not there at start, or one restarted with a new site file), until
//! a task shows the coordinator takes the unit, which clears the refusal.
//!
//! Not here: deciding anything; the controller decides, this loop only carries frames,
//! commands and messages.

use std::cell::RefCell;
use std::future::Future;
use std::rc::Rc;
use std::time::Duration;

use firefleet_bt::{Status, Transition, Tree};
use firefleet_bus::access::Identity;
use firefleet_bus::office::Office;
use firefleet_bus::seal::wall_ms;
use firefleet_bus::{Answers, Ask, Bus, BusError, Raw};
use firefleet_model::UnitId;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{BarredSpace, BtTransition, BtTransitions, GoalsInForce, NodeStatus};

use crate::btlog::BtLog;
use crate::controller::{Controller, Services};
use crate::groot2::Groot2;
use crate::platform::{Platform, PlatformError};
use crate::rehome::{self, Rehoming};

/// How long the agent's start-up question for the barred space stays open.
const BARRED_QUERY_TIMEOUT: Duration = Duration::from_secs(2);
/// How often a unit asks again whether the coordinator takes it, until a task shows it
/// does (a coordinator taking office answers no question; a restart of the coordinator
/// with the new site file is what a refused unit waits for).
pub const REASK_UNKNOWN: Duration = Duration::from_secs(10);

/// Whether the site's coordinator knows this unit: why not, while it does not. Shared
/// with whatever serves the unit's readiness; cloning shares it.
#[derive(Debug, Clone, Default)]
pub struct Standing(std::sync::Arc<std::sync::Mutex<Option<String>>>);

impl Standing {
    /// Why the coordinator does not take this unit, if it said so at the last asking.
    pub fn refused(&self) -> Option<String> {
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }

    fn set(&self, why: Option<String>) {
        *self
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = why;
    }
}
/// Site seconds between two batches of behaviour-tree transitions: 5 Hz, a tenth of the
/// router's bound on a unit's `bt` key (`firefleet_bus::limits`).
const BT_BATCH_S: f64 = 0.2;

/// How an agent runs.
#[derive(Debug, Clone)]
pub struct AgentOptions {
    pub unit: UnitId,
    /// Site-time period of state and report messages, s.
    pub report_period_s: f64,
    /// Print the tree with live statuses to stderr about once a second of site time.
    pub print_tree: bool,
    /// Whether the coordinator knows the unit, as it last answered.
    pub standing: Standing,
    /// Serve the tree to Groot2 on this address (BT.CPP's Groot2 protocol).
    pub groot2: Option<std::net::SocketAddr>,
    /// Record the tree's transitions in this `.btlog` (BT.CPP's FileLogger2).
    pub btlog: Option<std::path::PathBuf>,
}

/// Who else sees each step of the tree: Groot2, a `.btlog`. Made once for the agent's
/// life, so that a move to another router keeps them.
pub struct Taps {
    groot2: Option<Groot2>,
    btlog: Option<BtLog>,
}

impl Taps {
    /// What `opts` asks for, on `tree`.
    pub async fn open<C>(opts: &AgentOptions, tree: &Tree<C>) -> Result<Self, DriveError> {
        let groot2 = match opts.groot2 {
            Some(addr) => Some(Groot2::serve(addr, tree).await?),
            None => None,
        };
        let btlog = match &opts.btlog {
            Some(path) => Some(BtLog::create(path, tree)?),
            None => None,
        };
        Ok(Self { groot2, btlog })
    }

    /// Show the step's transitions to the taps. A `.btlog` that cannot be written any more
    /// (a full disk) is closed with an error in the log: the unit works on, unrecorded,
    /// rather than stop for its recorder.
    fn step<C>(&mut self, tree: &Tree<C>, fresh: &[Transition], now: f64) {
        if let Some(g) = &self.groot2 {
            g.update(tree, fresh, now);
        }
        if let Some(Err(e)) = self.btlog.as_mut().map(|log| log.append(fresh, now)) {
            self.give_up_log(&e);
        }
    }

    fn flush(&mut self) {
        if let Some(Err(e)) = self.btlog.as_mut().map(BtLog::flush) {
            self.give_up_log(&e);
        }
    }

    fn give_up_log(&mut self, e: &crate::btlog::BtLogError) {
        tracing::error!("no longer recording the behavior tree: {e}");
        self.btlog = None;
    }
}

fn status(s: Status) -> NodeStatus {
    match s {
        Status::Idle => NodeStatus::Idle,
        Status::Running => NodeStatus::Running,
        Status::Success => NodeStatus::Success,
        Status::Failure => NodeStatus::Failure,
        Status::Skipped => NodeStatus::Skipped,
    }
}

/// The barred space in `raw` (put live, or an answer: the coordinator's or a recorder's),
/// if a coordinator not suspended sealed it; refused and counted under `from` otherwise.
/// The routers let only coordinators put it, but a recorder's key answers anything, and a
/// suspended coordinator's key still puts: a restarted unit told that every zone is barred
/// would refuse every task (nothing is checked on an open site).
fn sealed_barred(bus: &Bus, office: &Office, raw: &Raw, from: &str) -> Option<BarredSpace> {
    let suspended =
        |who: &Identity| matches!(who, Identity::Coordinator(rank) if office.suspended(*rank));
    let check = bus.seals().map(|s| &s.check);
    if let Err(why) = firefleet_bus::seal::by_coordinator(check, raw, suspended) {
        bus.rejects().refuse_seal(from, &why);
        return None;
    }
    bus.decode(raw, "barred space")
}

/// Ask whether the coordinator takes the unit once more. A failure is logged, not fatal:
/// the question only decides the unit's readiness, and is asked again later.
async fn ask_once_more(bus: &Bus, question: &str, ask: Ask) -> Option<Answers> {
    match bus.ask(question, ask).await {
        Ok(a) => Some(a),
        Err(e) => {
            tracing::warn!("asking {question}: {e}");
            None
        }
    }
}

/// Why the agent stopped on an error ([`drive`], [`run`]).
#[derive(Debug, thiserror::Error)]
pub enum DriveError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("the unit's body: {0}")]
    Platform(#[from] PlatformError),
    #[error(transparent)]
    Groot2(#[from] crate::groot2::ServeError),
    #[error("the behavior-tree log: {0}")]
    BtLog(#[from] crate::btlog::BtLogError),
}

/// Run controller `ctl` on the body `platform` makes on `bus`'s session until `shutdown`
/// completes or the body goes away, holding the unit's liveliness token; with `moves`,
/// moving to a nearer router whenever it finds one (the body made again on the new
/// session, the controller kept, `on_moved` told of the new session). The session it
/// ends on, for the caller to close.
pub async fn drive<P, U>(
    mut bus: Bus,
    mut ctl: Controller<U>,
    mut platform: impl AsyncFnMut(&Bus) -> Result<P, PlatformError>,
    opts: &AgentOptions,
    moves: Option<Rehoming>,
    mut on_moved: impl FnMut(&Bus),
    shutdown: impl Future<Output = ()>,
) -> Result<Bus, DriveError>
where
    P: Platform,
    U: Services<Sensors = P::Sensors, Command = P::Command>,
{
    tokio::pin!(shutdown);
    let unit = Topic::UnitAlive(opts.unit.clone());
    let mut token = bus.token(&unit).await?;
    let mut taps = Taps::open(opts, ctl.tree()).await?;
    loop {
        let body = platform(&bus).await?;
        let move_to = async {
            match &moves {
                Some(m) => m.nearer(&bus).await,
                None => std::future::pending().await,
            }
        };
        let ended = run(
            &bus,
            body,
            &mut ctl,
            opts,
            &mut taps,
            shutdown.as_mut(),
            move_to,
        );
        match ended.await? {
            Ended::Stopped => {
                drop(token);
                return Ok(bus);
            }
            // Make before break: the unit's token on the new session came first; the old
            // session and its token go a moment later.
            Ended::Moved((next, next_token)) => {
                on_moved(&next);
                let old = std::mem::replace(&mut bus, next);
                let old_token = std::mem::replace(&mut token, next_token);
                tokio::spawn(async move {
                    tokio::time::sleep(rehome::OVERLAP).await;
                    drop(old_token);
                    old.close().await;
                });
            }
        }
    }
}

/// Why [`run`] returned.
pub enum Ended<M> {
    /// Shut down, or the platform went away: the unit was halted.
    Stopped,
    /// `move_to` gave what it waited for (a session linked through another router): the
    /// caller runs on with it, the controller as it is and the body not halted.
    Moved(M),
}

/// Run the agent with controller `ctl` until `shutdown` completes, the platform goes away
/// or `move_to` completes. The caller holds the unit's liveliness token on `bus`'s session:
/// it must outlive a move to another session, or the unit would vanish for a moment.
pub async fn run<P, U, M>(
    bus: &Bus,
    mut platform: P,
    ctl: &mut Controller<U>,
    opts: &AgentOptions,
    taps: &mut Taps,
    shutdown: impl Future<Output = ()>,
    move_to: impl Future<Output = M>,
) -> Result<Ended<M>, DriveError>
where
    P: Platform,
    U: Services<Sensors = P::Sensors, Command = P::Command>,
{
    let keys = bus.keys().clone();
    let unit = &opts.unit;
    let transitions: Rc<RefCell<Vec<Transition>>> = Rc::default();
    let sink = transitions.clone();
    ctl.tree_mut()
        .set_observer(move |t| sink.borrow_mut().push(*t));
    let labels: Vec<String> = (0..ctl.tree().len() as u32)
        .map(|i| {
            let (n, t) = (ctl.tree().name(i), ctl.tree().type_name(i));
            if n == t {
                t.to_owned()
            } else {
                format!("{t} \"{n}\"")
            }
        })
        .collect();

    // The coordinators' leases and, on a secure site, the coordinators suspended: the
    // unit obeys the one in office only (`firefleet_protocol::office`), whatever a task
    // announces. The asks to suspend are checked here, live and as the goals in force
    // keep them (asked at start, for a unit that starts after them).
    let coord = bus.watch_tokens(&keys.every_coord_alive()).await?;
    let mut office = Office::default();
    // The coordinator in office as the unit last acted on it.
    let mut in_office = None;
    let check = bus.seals().map(|s| &s.check);
    let mut suspends = match check {
        Some(_) => Some(
            bus.subscribe_raw(&[keys.every_suspend().as_str()], false)
                .await?,
        ),
        None => None,
    };
    let mut kept = match check {
        Some(_) => Some(
            bus.ask(
                keys.coord_goals().as_str(),
                Ask {
                    every_answer: true,
                    ..Ask::within(BARRED_QUERY_TIMEOUT)
                },
            )
            .await?,
        ),
        None => None,
    };
    let tasks = bus.subscribe(&keys.unit_tasks(unit)).await?;
    let mut barred = bus
        .subscribe_raw(&[keys.coord_barred().as_str()], false)
        .await?;
    // Asked, not awaited: the answers come in with everything else.
    // Every answer (the coordinator's, each recorder's): the newest is kept.
    let ask = Ask {
        every_answer: true,
        ..Ask::within(BARRED_QUERY_TIMEOUT)
    };
    let question = format!("{}?unit={unit}", keys.coord_barred().as_str());
    let mut barred_answers = bus.ask(&question, ask).await?;
    // Whether the question is open; whether to ask again once it closes; whether a task
    // showed the coordinator takes the unit (only a coordinator that knows it tasks it).
    let (mut asking, mut ask_again, mut taken) = (true, false, false);
    let mut reask = tokio::time::interval(REASK_UNKNOWN);
    reask.reset();
    let state_key = keys.unit_state(unit);
    let report_key = keys.unit_report(unit);
    // Its first report is of a fire: the router learns the key now, not then.
    bus.declare(&report_key).await?;
    let bt_key = keys.unit_bt(unit);
    let mut next_report = f64::NEG_INFINITY;
    let mut next_bt = f64::NEG_INFINITY;
    // What a refusal is logged under: the key, and which unit refused it.
    let tasks_from = keys.unit_tasks(unit).as_str().to_owned();
    let barred_from = format!("{} (at {unit})", keys.coord_barred().as_str());
    let mut next_print = f64::NEG_INFINITY;
    // How many of `transitions` the taps have seen (a batch drains them).
    let mut tapped = 0;
    let batch = || BtTransitions {
        unit: unit.clone(),
        transitions: transitions
            .borrow_mut()
            .drain(..)
            .map(|t| BtTransition {
                node: t.node,
                name: labels[t.node as usize].clone(),
                t: t.t,
                from: status(t.from),
                to: status(t.to),
            })
            .collect(),
    };
    tracing::info!(%unit, nodes = ctl.tree().len(), "agent started");
    tokio::pin!(shutdown);
    tokio::pin!(move_to);
    let mut halt = None;
    let mut moved = None;
    loop {
        // The office changed hands (a lease, a suspension): the unit takes the new
        // holder's next task whatever its term, and asks it whether it takes the unit (one
        // that was not there at the first asking, or one restarted with a new site file).
        if office.holder() != in_office {
            in_office = office.holder();
            tracing::info!(%unit, holder = ?in_office, "the coordinator in office changed");
            ctl.office_changed(in_office.is_some());
            if in_office.is_some() {
                taken = false;
                if asking {
                    ask_again = true;
                } else if let Some(a) = ask_once_more(bus, &question, ask).await {
                    (barred_answers, asking) = (a, true);
                }
            }
        }
        tokio::select! {
            // Biased, the barred space first: the coordinator tells it before the tasks
            // that depend on it (a goal cleared, then a unit sent where it barred), and a
            // task taken before a barred space already here would be refused for a goal
            // the coordinator had lifted (an unbiased select picks either when both wait).
            // The platform's frames last: on a loaded host they may always be waiting, and
            // must not starve the rare messages (a coordinator's coming, a shutdown).
            biased;
            Some(raw) = barred.recv() => {
                if let Some(b) = sealed_barred(bus, &office, &raw, &barred_from)
                    && let Err(e) = ctl.on_barred(b)
                {
                    bus.rejects().refuse_invalid(&barred_from, &e);
                }
            }
            task = tasks.recv() => {
                let Some((topic, task)) = task else { break };
                let Topic::UnitTask(_, from) = topic else { continue };
                if !office.obeys(from) {
                    bus.rejects().refuse_invalid(&tasks_from, &format_args!(
                        "a task from the coordinator of rank {from}, which does not hold office ({}{})",
                        office.holder().map_or_else(|| "nobody does".to_owned(), |h| format!("rank {h} does")),
                        if office.suspended(from) { "; it is suspended" } else { "" },
                    ));
                } else if &task.unit == unit {
                    if let Err(e) = ctl.on_task(task.epoch, task.seq, task.kind) {
                        bus.rejects().refuse_invalid(&tasks_from, &e);
                    } else if !taken {
                        taken = true;
                        if opts.standing.refused().is_some() {
                            tracing::info!(%unit, "the coordinator takes this unit now");
                            opts.standing.set(None);
                        }
                    }
                } else {
                    bus.rejects().refuse_invalid(&tasks_from, &format_args!("a task addressed to {}", task.unit));
                }
            }
            answer = barred_answers.recv_or_refusal(), if asking => match answer {
                Some(Ok(answer)) => {
                    if let Some(b) = sealed_barred(bus, &office, &answer, &barred_from)
                        && let Err(e) = ctl.on_barred(b)
                    {
                        bus.rejects().refuse_invalid(&barred_from, &format_args!("an answer: {e}"));
                    }
                }
                Some(Err(why)) => {
                    if opts.standing.refused().is_none() {
                        tracing::error!(%unit, "the coordinator does not take this unit: {why}");
                    }
                    opts.standing.set(Some(why));
                }
                None if ask_again => {
                    // A coordinator appeared while this question was open: ask it.
                    ask_again = false;
                    match ask_once_more(bus, &question, ask).await {
                        Some(a) => barred_answers = a,
                        None => asking = false,
                    }
                }
                None => asking = false,
            },
            // Until a task shows the coordinator takes the unit, asked again now and then:
            // a coordinator still taking office answers no question.
            _ = reask.tick(), if !asking && !taken => {
                if let Some(a) = ask_once_more(bus, &question, ask).await {
                    (barred_answers, asking) = (a, true);
                }
            }
            change = coord.recv() => {
                let Some((topic, alive)) = change else { break };
                let before = office.token(&topic, alive);
                if let Topic::CoordAlive(rank) = topic
                    && alive
                    && office.holder() == before
                    && before != Some(rank)
                {
                    tracing::warn!(%unit, rank, "a coordinator claims office while another holds it: its tasks are refused");
                }
            }
            Some(sample) = async { match &mut suspends { Some(s) => s.recv().await, None => std::future::pending().await } } => {
                if let Err(why) = office.ask(check, &sample, wall_ms()) {
                    bus.rejects().refuse_invalid(&sample.key, &format_args!("an ask to suspend: {why}"));
                }
            }
            answer = async { match &kept { Some(k) => k.recv().await, None => std::future::pending().await } } => match answer {
                Some(raw) => {
                    if let (Some(g), Some(check)) = (bus.decode::<GoalsInForce>(&raw, "goals in force answer"), check) {
                        office.kept(check, &g.suspensions);
                    }
                }
                None => kept = None,
            },
            _ = &mut shutdown => break,
            next = &mut move_to => {
                moved = Some(next);
                break;
            }
            frame = platform.sense() => {
                let Some(s) = frame else { break };
                let cmd = ctl.step(&s);
                platform.actuate(cmd).await?;
                let t = U::time(&s);
                if let Some(found) = ctl.found() {
                    platform.found(t, found)?;
                }
                halt = Some(U::halt(&s));
                taps.step(ctl.tree(), &transitions.borrow()[tapped..], t);
                tapped = transitions.borrow().len();
                // The tree's transitions go out in batches, at most every BT_BATCH_S, so a
                // unit stays far inside the router's rate bound on its `bt` key
                // (`firefleet_bus::limits`) however fast its platform's frames come.
                if t >= next_bt && !transitions.borrow().is_empty() {
                    next_bt = t + BT_BATCH_S;
                    bus.put(&bt_key, &batch()).await?;
                    tapped = 0;
                    taps.flush();
                }
                if opts.print_tree && t >= next_print {
                    next_print = t + 1.0;
                    #[allow(clippy::print_stderr, reason = "--print-tree asks for the tree on stderr")]
                    {
                        eprintln!("{unit} t={t:.1}\n{}", ctl.tree().render());
                    }
                }
                if t >= next_report {
                    next_report = t + opts.report_period_s;
                    bus.put(&state_key, &ctl.state()).await?;
                    if let Some(r) = ctl.report() {
                        bus.put(&report_key, &r).await?;
                    }
                }
            }
        }
    }
    // What the tree did since the last batch goes out before the agent does.
    if !transitions.borrow().is_empty() {
        bus.put(&bt_key, &batch()).await?;
    }
    taps.flush();
    if let Some(next) = moved {
        return Ok(Ended::Moved(next));
    }
    if let Some(cmd) = halt {
        platform.actuate(cmd).await?;
    }
    Ok(Ended::Stopped)
}
