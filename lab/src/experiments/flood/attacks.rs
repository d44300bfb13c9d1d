//! The attackers: what a thief does with a stolen unit certificate (fake fires, moved
//! fakes, false "out", replays, a flood), with a commander's (a keep-out on every zone),
//! with a coordinator's (every unit stood by), with a recorder's (lies at a recall) and
//! with the SCADA bridge's (alarms where no fire burns),
//! each as a task beside the site, numbering its lies by the site's clock.
//!
//! Not here: the site under attack and what is measured of it (the parent module).

use super::*;

/// What a lying unit needs to know: who it speaks for, where the site's real fires are
/// and its tunnel (a thief knows the site), and how fast site time runs.
pub(super) struct Lie {
    pub(super) unit: UnitId,
    pub(super) fires: Vec<Point2>,
    pub(super) time_scale: f64,
    pub(super) tunnel: firefleet_model::tunnel::Tunnel,
    /// The unit's camera: where it looks from, and how wide.
    pub(super) camera: firefleet_model::spec::CameraSpec,
}

/// The site's time, and where ugv-2 is and its camera looks, as the thief hears them:
/// ugv-2's own simulated sensors carry both.
#[derive(Clone, Default)]
struct SiteClock(Arc<std::sync::Mutex<(f64, Option<Pose2>)>>);

impl SiteClock {
    fn now(&self) -> f64 {
        self.0.lock().expect("never poisoned").0
    }

    fn eye(&self) -> Option<Pose2> {
        self.0.lock().expect("never poisoned").1
    }

    fn set(&self, t: f64, eye: Pose2) {
        *self.0.lock().expect("never poisoned") = (t, Some(eye));
    }
}

/// How far from the unit the fakes around it lie, m: well inside a camera's 30 m.
const AROUND_M: f64 = 20.0;

/// Fake fires: three, `seed`ed, none within 15 m of a real one.
fn fakes(rng: &mut ChaCha8Rng, real: &[Point2]) -> Vec<Point2> {
    let mut out: Vec<Point2> = Vec::new();
    while out.len() < 3 {
        let p = Point2::new(rng.random_range(10.0..290.0), rng.random_range(-3.0..3.0));
        if real.iter().chain(&out).all(|r| r.dist(p) > 15.0) {
            out.push(p);
        }
    }
    out
}

/// One report of flames at `at`, dated `t`, by `unit`, as its camera would place them.
fn report(unit: &UnitId, t: f64, at: &[Point2]) -> FlameReport {
    FlameReport {
        unit: unit.clone(),
        t,
        observer: Pose2::new(
            at.first().map_or(60.0, |p| (p.x - 15.0).max(1.0)),
            -2.0,
            0.0,
        ),
        observations: at
            .iter()
            .map(|&position| FlameObservation {
                position,
                cov: [0.3, 0.0, 0.3],
                confidence: 0.95,
                hrr_kw: Some(5000.0),
            })
            .collect(),
    }
}

/// Send `attack` on `lie.unit`'s keys until `stop`, counting in `sent`.
pub(super) async fn flood_as_unit(
    thief: Bus,
    lie: Lie,
    attack: Attack,
    seed: u64,
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
) {
    let unit = lie.unit.clone();
    let keys = thief.keys().clone();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let clock = SiteClock::default();
    if let Ok(sensors) = thief.subscribe(&keys.sim_sensors(&unit)).await {
        let (clock, camera) = (clock.clone(), lie.camera);
        tokio::spawn(async move {
            while let Some((_, s)) = sensors.recv().await {
                clock.set(s.t, camera.looking_from(&s.pose, s.cannon.pan));
            }
        });
    }
    let tasks = thief.subscribe(&keys.unit_tasks(&unit)).await.ok();
    // A unit's pace: a report every 0.25 s of site time.
    let pace = Duration::from_secs_f64(0.25 / lie.time_scale);
    let mut state = UnitState::idle(
        unit.clone(),
        UnitKind::Ground,
        Pose2::new(60.0, -2.0, 0.0),
        1000.0,
    );
    let big = vec![0xA5u8; 1 << 20];
    let mut fake = fakes(&mut rng, &lie.fires);
    let mut moved_at = 0.0;
    let mut claimed: Option<(u64, u32)> = None;
    while !stop.load(Ordering::Relaxed) {
        let now = clock.now();
        let (key, bytes) = match attack {
            Attack::None
            | Attack::Commander
            | Attack::Chief
            | Attack::ConsoleKey
            | Attack::StandbyKey
            | Attack::CoordinatorKey
            | Attack::RecorderKey
            | Attack::ScadaKey => {
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
            Attack::States => {
                state.t += 0.001;
                (
                    keys.unit_state(&unit).as_str().to_owned(),
                    codec::encode(&state),
                )
            }
            Attack::Garbage => {
                let n = rng.random_range(1..256);
                (
                    keys.unit_state(&unit).as_str().to_owned(),
                    (0..n).map(|_| rng.random()).collect(),
                )
            }
            Attack::Reports => {
                tokio::time::sleep(Duration::from_micros(1_000_000 / 94)).await;
                let at: Vec<Point2> = (0..MAX_LIST)
                    .map(|_| Point2::new(rng.random_range(0.0..300.0), rng.random_range(-4.0..4.0)))
                    .collect();
                (
                    keys.unit_report(&unit).as_str().to_owned(),
                    codec::encode(&report(&unit, state.t, &at)),
                )
            }
            Attack::AroundFakes => {
                tokio::time::sleep(Duration::from_micros(1_000_000 / 94)).await;
                let Some(pose) = clock.eye() else {
                    continue;
                };
                let half = lie.camera.hfov_rad() / 2.0;
                let at: Vec<Point2> = (0..MAX_LIST)
                    .map(|_| {
                        let (r, a) = (
                            AROUND_M * rng.random::<f64>().sqrt(),
                            pose.yaw + rng.random_range(-half..half),
                        );
                        Point2::new(pose.x + r * a.cos(), pose.y + r * a.sin())
                    })
                    .filter(|&p| lie.tunnel.contains(p, 0.5))
                    .collect();
                let mut r = report(&unit, now, &at);
                r.observer = pose;
                (
                    keys.unit_report(&unit).as_str().to_owned(),
                    codec::encode(&r),
                )
            }
            Attack::BigBt => (keys.unit_bt(&unit).as_str().to_owned(), big.clone()),
            Attack::FakeFires | Attack::MovingFakes => {
                tokio::time::sleep(pace).await;
                if attack == Attack::MovingFakes && now - moved_at >= 12.0 {
                    fake = fakes(&mut rng, &lie.fires);
                    moved_at = now;
                }
                (
                    keys.unit_report(&unit).as_str().to_owned(),
                    codec::encode(&report(&unit, now, &fake)),
                )
            }
            Attack::AheadStates => {
                tokio::time::sleep(pace).await;
                if now <= 0.0 {
                    continue;
                }
                state.t = now + 4.5;
                (
                    keys.unit_state(&unit).as_str().to_owned(),
                    codec::encode(&state),
                )
            }
            Attack::Replay => {
                tokio::time::sleep(pace).await;
                // What ugv-2 reported of the real fires 30 s ago, once there is a past.
                if now < 40.0 {
                    continue;
                }
                (
                    keys.unit_report(&unit).as_str().to_owned(),
                    codec::encode(&report(&unit, now - 30.0, &lie.fires)),
                )
            }
            Attack::FalseOut => {
                tokio::time::sleep(Duration::from_secs_f64(0.5 / lie.time_scale)).await;
                let Some(task) = tasks.as_ref().and_then(|t| {
                    let mut newest = None;
                    while let Some((_, task)) = t.try_recv() {
                        newest = Some(task);
                    }
                    newest
                }) else {
                    continue;
                };
                let firefleet_protocol::msg::TaskKind::Extinguish { fire, target, .. } = task.kind
                else {
                    continue;
                };
                // Three claims a task, dated a little ahead so that the unit's own states
                // do not shadow them.
                let times = match claimed {
                    Some((seq, n)) if seq == task.seq => n,
                    _ => 0,
                };
                if times >= 3 {
                    continue;
                }
                claimed = Some((task.seq, times + 1));
                let forged = UnitState {
                    t: now + 0.5,
                    task: Some(TaskProgress {
                        seq: task.seq,
                        fire,
                        phase: TaskPhase::Extinguished,
                        target,
                    }),
                    task_seq: Some(task.seq),
                    epoch: Some(task.epoch),
                    ..UnitState::idle(
                        unit.clone(),
                        UnitKind::Ground,
                        Pose2::new((target.x - 8.0).max(1.0), target.y, 0.0),
                        500.0,
                    )
                };
                (
                    keys.unit_state(&unit).as_str().to_owned(),
                    codec::encode(&forged),
                )
            }
        };
        if thief.put_raw(&key, bytes).await.is_ok() {
            sent.fetch_add(1, Ordering::Relaxed);
        }
        // The link's own pace, but never a task that starves the runtime.
        if sent.load(Ordering::Relaxed).is_multiple_of(256) {
            tokio::task::yield_now().await;
        }
    }
    thief.close().await;
}

/// How the honest side answers a stolen commander key's keep-outs once the alert shows.
pub(super) enum Answer {
    /// The incident commander clears every zone the thief (a sector commander) holds
    /// goals on: a higher rank's clear lifts them.
    Clear,
    /// Nobody outranks the thief (the incident commander's key, or the console's speaking
    /// in its name): `after` site seconds past the alert, the honest commander and a second
    /// asker (`operator`: the operator at the coordinator's host with its key, or the real
    /// incident commander) suspend `target`, and its goals lapse.
    Suspend {
        operator: Bus,
        target: Identity,
        after: f64,
    },
}

/// A stolen commander key's attack (or the console's, speaking in commander `sector`'s
/// name): keep-out at priority 255 on every zone as soon as a fire is confirmed, then 70
/// goals more; the honest commander (`chief_bus`, `chief`),
/// asking the status every 100 ms, answers as `answer` says once it names a stranded
/// fire. The alert's delay (site s) goes to `alert_delay`.
pub(super) async fn bar_every_zone(
    (thief, sector): (Bus, CommanderId),
    (chief_bus, chief): (Bus, CommanderId),
    answer: Answer,
    zones: Vec<ZoneId>,
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
    alert_delay: Arc<std::sync::Mutex<Option<f64>>>,
) {
    let status = |bus: Bus| async move {
        let key = bus.keys().expr(&Topic::CoordStatus);
        let answers = bus
            .ask(&key, Ask::within(Duration::from_secs(1)))
            .await
            .ok()?;
        let sample = answers.recv().await?;
        let status = codec::decode::<IncidentStatus>(&sample.bytes).ok()?;
        Some((bus, status))
    };
    // Strike once the firefighting is under way: a fire confirmed. (A keep-out before any
    // fire is known strands nothing the coordinator knows of, and raises no alert: see the
    // docs/zone-goals.md.)
    let mut chief_bus = chief_bus;
    loop {
        if stop.load(Ordering::Relaxed) {
            return;
        }
        match status(chief_bus.clone()).await {
            Some((b, s)) if s.fires.iter().any(|f| f.state != FireState::Tentative) => {
                chief_bus = b;
                break;
            }
            Some((b, _)) => chief_bus = b,
            None => {}
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let mut accepted_at = None;
    for zone in &zones {
        let goal = ZoneGoal {
            priority: 255,
            ..ZoneGoal::new(zone.clone(), GoalKind::KeepOut, sector.clone())
        };
        if let Ok(ack) = goal::issue(&thief, &goal, &sector, goal::ACK_TIMEOUT).await {
            sent.fetch_add(1, Ordering::Relaxed);
            if ack.accepted && accepted_at.is_none() {
                accepted_at = status(chief_bus.clone()).await.map(|(_, s)| s.t);
            }
        }
    }
    for k in 0..70u32 {
        let zone = &zones[k as usize % zones.len()];
        let goal = ZoneGoal {
            id: format!("flood-{k}"),
            priority: u8::try_from(k % 200).unwrap_or(0),
            ..ZoneGoal::new(zone.clone(), GoalKind::Monitor, sector.clone())
        };
        if goal::put(&thief, &goal, &sector).await.is_ok() {
            sent.fetch_add(1, Ordering::Relaxed);
        }
    }
    // The honest commander: the moment the alert shows, clear every zone the stolen
    // certificate holds goals on (a delete on the chief's own goal key of a zone clears the
    // lower ranks' goals there), and again should it strand a fire later; or suspend it.
    let mut alerted_at = None;
    let mut suspended = false;
    while !stop.load(Ordering::Relaxed) {
        if let Some((_, s)) = status(chief_bus.clone()).await
            && (!s.stranded.is_empty() || alerted_at.is_some())
        {
            alert_delay
                .lock()
                .expect("not poisoned")
                .get_or_insert_with(|| accepted_at.map_or(f64::NAN, |at| s.t - at));
            let alerted = *alerted_at.get_or_insert(s.t);
            if let Answer::Suspend {
                operator,
                target,
                after,
            } = &answer
            {
                if !suspended && s.t >= alerted + after {
                    let why = "its key is stolen: keep-outs on every zone";
                    suspended = goal::suspend(&chief_bus, target, why).await.is_ok()
                        && goal::suspend(operator, target, why).await.is_ok();
                }
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
            let mut named: Vec<ZoneId> = s
                .goals
                .iter()
                .filter(|g| g.issued_by.as_ref() == Some(&sector))
                .map(|g| g.zone.clone())
                .chain(s.stranded.iter().map(|x| x.zone.clone()))
                .collect();
            named.sort();
            named.dedup();
            for zone in named {
                let _ = goal::delete(&chief_bus, &zone, &chief).await;
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    thief.close().await;
    chief_bus.close().await;
    if let Answer::Suspend { operator, .. } = answer {
        operator.close().await;
    }
}

/// How often a stolen coordinator key tells every unit to stand by: faster than the
/// coordinator in office gives each its task again (every second).
const COMMAND_EVERY: Duration = Duration::from_millis(250);

/// A stolen coordinator key's attack, `rank`'s: once the coordinator in office has tasked
/// a unit, a claim on office (the lease of `rank`) and every unit of `units` told to stand
/// by, numbered above the newest task each was given (in the term of the coordinator in
/// office when the key is its own, so that units take it in order), every
/// [`COMMAND_EVERY`]. The honest side, two commanders (`honest`), hears the coordinator's
/// finding in its log (a rival's claim, or tasks on its own key it never sent), and
/// `after` site seconds later both ask that the identity be suspended. The delay from the
/// first claim to the finding (site s) goes to `alert_delay`.
pub(super) async fn command_as_coordinator(
    (thief, rank): (Bus, u32),
    units: Vec<UnitId>,
    honest: Vec<Bus>,
    after: f64,
    (stop, sent): (Arc<AtomicBool>, Arc<AtomicU64>),
    alert_delay: Arc<std::sync::Mutex<Option<f64>>>,
) {
    let keys = thief.keys().clone();
    let (Ok(tasks), Ok(clock), Some(log)) = (
        thief.subscribe(&keys.every_unit_task()).await,
        thief.subscribe(&keys.sim_clock()).await,
        match honest.first() {
            Some(b) => b.subscribe(&keys.coord_log()).await.ok(),
            None => None,
        },
    ) else {
        return;
    };
    // The newest task each unit was given, by anyone, and the site time.
    let mut newest: std::collections::BTreeMap<UnitId, firefleet_protocol::msg::Task> =
        Default::default();
    let mut t = 0.0;
    let mut claim = None;
    let (mut struck_at, mut found_at, mut suspended) = (None, None, false);
    let mut tick = tokio::time::interval(COMMAND_EVERY);
    while !stop.load(Ordering::Relaxed) {
        tokio::select! {
            Some((_, task)) = tasks.recv() => {
                if newest.get(&task.unit).is_none_or(|n| n.order() < task.order()) {
                    newest.insert(task.unit.clone(), task);
                }
            }
            Some((_, c)) = clock.recv() => t = c.t,
            Some((_, d)) = log.recv() => {
                let finding = d.impostor.is_some()
                    || d.text.starts_with(&format!("{} claims office", Identity::Coordinator(rank)));
                if finding && struck_at.is_some() && found_at.is_none() {
                    found_at = Some(d.t);
                    *alert_delay.lock().expect("not poisoned") =
                        struck_at.map(|s: f64| d.t - s);
                }
            }
            _ = tick.tick() => {
                if newest.is_empty() {
                    continue;
                }
                if claim.is_none() {
                    claim = thief.token(&Topic::CoordAlive(rank)).await.ok();
                    struck_at = Some(t);
                }
                let term = newest.values().map(|n| n.epoch).max().unwrap_or(0);
                let epoch = if firefleet_protocol::msg::epoch_rank(term) == rank {
                    term
                } else {
                    firefleet_protocol::msg::epoch_after(term, rank)
                };
                for unit in &units {
                    let above = newest.get(unit).map_or(epoch, |n| n.seq.max(epoch)) + 100;
                    let task = firefleet_protocol::msg::Task {
                        unit: unit.clone(),
                        epoch,
                        seq: above.min(firefleet_protocol::msg::task_seq_ceiling(t)),
                        t,
                        kind: firefleet_protocol::msg::TaskKind::Standby,
                    };
                    if thief.put(&keys.unit_task(unit, rank), &task).await.is_ok() {
                        sent.fetch_add(1, Ordering::Relaxed);
                    }
                }
                if let Some(found) = found_at
                    && !suspended
                    && t >= found + after
                {
                    let why = "its key is stolen: it tells every unit to stand by";
                    let target = Identity::Coordinator(rank);
                    let mut asked = 0;
                    for b in &honest {
                        asked += usize::from(goal::suspend(b, &target, why).await.is_ok());
                    }
                    suspended = asked == honest.len();
                }
            }
        }
    }
    drop(claim);
    thief.close().await;
    for b in honest {
        b.close().await;
    }
}

/// What a stolen recorder key lies about at a recall: the site's zones and its incident
/// commander (whose keep-outs it forges), an honest unit to name as the witness of fires
/// that never were, the real fires (the fakes keep clear of them), and the seed.
pub(super) struct Recall {
    pub(super) chief: CommanderId,
    pub(super) zones: Vec<ZoneId>,
    pub(super) witness: UnitId,
    pub(super) fires: Vec<Point2>,
    pub(super) seed: u64,
}

/// Answer every recall as a stolen recorder key can (the rules let it answer on `fire/*`
/// and `coord/*`, and put nothing): every fire the coordinator published, called out as
/// of the site clock (the newest track wins a recall); three fires that never were, seen
/// by `lie.witness` (the tracks sealed with the recorder's key); the incident commander's
/// keep-out on every zone, unsealed (the recorder holds no commander's key), dated now.
/// Counts the answers in `sent`.
pub(super) async fn answer_as_recorder(
    thief: Bus,
    lie: Recall,
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
) {
    let keys = thief.keys().clone();
    let (Ok(tracks), Ok(clock), Ok(fire_asks), Ok(goal_asks)) = (
        thief.subscribe(&keys.every_fire()).await,
        thief.subscribe(&keys.sim_clock()).await,
        thief.serve(keys.every_fire().as_str()).await,
        thief.serve(keys.coord_goals().as_str()).await,
    ) else {
        return;
    };
    let fakes = fakes(&mut ChaCha8Rng::seed_from_u64(lie.seed), &lie.fires);
    let mut heard: std::collections::BTreeMap<FireId, FireTrack> = Default::default();
    let mut t = 0.0;
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    while !stop.load(Ordering::Relaxed) {
        let mut answered = 0;
        tokio::select! {
            Some((_, f)) = tracks.recv() => {
                heard.insert(f.id, f);
            }
            Some((_, c)) = clock.recv() => t = c.t,
            Some(q) = fire_asks.recv() => {
                let next = heard.keys().map(|f| f.0).max().unwrap_or(0) + 1;
                let out = heard.values().map(|f| FireTrack {
                    t,
                    state: FireState::Out,
                    assigned: Vec::new(),
                    ..f.clone()
                });
                let made_up = (next..).zip(&fakes).map(|(id, &position)| FireTrack {
                    id: FireId(id),
                    t,
                    position,
                    cov: [0.3, 0.0, 0.3],
                    confidence: 1.0,
                    state: FireState::Confirmed,
                    assigned: Vec::new(),
                    seen_by: vec![lie.witness.clone()],
                    hrr_kw: Some(5000.0),
                });
                for track in out.chain(made_up) {
                    // Sealed with the key it holds, the recorder's.
                    let (key, bytes) = (keys.fire(track.id).as_str().to_owned(), codec::encode(&track));
                    let attachment = thief
                        .seals()
                        .map(|s| s.sealer.seal(&key, Some(&bytes)).to_attachment());
                    let forged = firefleet_bus::Raw { key, deleted: false, bytes, attachment };
                    if q.answer_as_heard(&forged).await.is_ok() {
                        answered += 1;
                    }
                }
            }
            Some(q) = goal_asks.recv() => {
                let goals = lie
                    .zones
                    .iter()
                    .map(|zone| GoalInForce {
                        goal: ZoneGoal {
                            priority: 255,
                            ..ZoneGoal::new(zone.clone(), GoalKind::KeepOut, lie.chief.clone())
                        },
                        since: t,
                        until: None,
                        proof: None,
                    })
                    .collect();
                let set = GoalsInForce {
                    t,
                    goals,
                    ..GoalsInForce::default()
                };
                if q.answer(keys.coord_goals().as_str(), codec::encode(&set)).await.is_ok() {
                    answered += 1;
                }
            }
            _ = tick.tick() => {}
        }
        sent.fetch_add(answered, Ordering::Relaxed);
    }
    thief.close().await;
}

/// What a stolen SCADA bridge key lies about: the site's DTS map, the tunnel's length and
/// the chainages of its real fires (a thief knows the site).
pub(super) struct Readings {
    pub(super) map: firefleet_model::infra::ScadaMap,
    pub(super) length_m: f64,
    pub(super) fires: Vec<f64>,
}

/// Put what a stolen SCADA key can (the rules let it put DTS zones, the ventilation and the
/// link, and hear nothing): at the bridge's pace, a fire alarm in every zone no fire burns
/// in (180 C, rising 30 K/min: maximum and rate of rise), and "all normal" in every zone
/// one does, each dated by the site `clock` (a site's hosts share it; the harness tells
/// the thief). Counts the readings in `sent`, and puts in `alert_delay` the site seconds
/// from the first lie to the coordinator's finding that someone else holds the key.
pub(super) async fn report_as_scada(
    (thief, clock): (Bus, Bus),
    lie: Readings,
    time_scale: f64,
    (stop, sent): (Arc<AtomicBool>, Arc<AtomicU64>),
    alert_delay: Arc<std::sync::Mutex<Option<f64>>>,
) {
    use firefleet_model::infra::{DtsAlarm, DtsReading};
    use firefleet_protocol::msg::DtsZone;
    let keys = thief.keys().clone();
    let (Ok(states), Ok(log)) = (
        clock.subscribe(&keys.every_unit_state()).await,
        clock.subscribe(&keys.coord_log()).await,
    ) else {
        return;
    };
    let mut t = 0.0_f64;
    let mut struck_at = None;
    let mut tick =
        tokio::time::interval(Duration::from_secs_f64(lie.map.dts.period_s / time_scale));
    while !stop.load(Ordering::Relaxed) {
        tokio::select! {
            Some((_, s)) = states.recv() => t = t.max(s.t),
            Some((_, d)) = log.recv() => {
                if d.impostor.as_deref() == Some("scada") {
                    let mut delay = alert_delay.lock().expect("not poisoned");
                    if delay.is_none() {
                        *delay = struck_at.map(|s: f64| d.t - s);
                    }
                }
            }
            _ = tick.tick() => {
                if t <= 0.0 {
                    continue;
                }
                struck_at.get_or_insert(t);
                for k in 0..lie.map.zone_count(lie.length_m) {
                    let (start_m, end_m) = lie.map.zone_span(k, lie.length_m);
                    let burning = lie.fires.iter().any(|&s| (start_m..end_m).contains(&s));
                    let alarm = !burning;
                    let zone = DtsZone {
                        zone: u16::try_from(k).unwrap_or(u16::MAX),
                        start_m,
                        end_m,
                        t,
                        reading: DtsReading {
                            max_c: if alarm { 180.0 } else { 20.0 },
                            rise_c_min: if alarm { 30.0 } else { 0.0 },
                            alarm: DtsAlarm {
                                max: alarm,
                                rise: alarm,
                                differential: false,
                            },
                            fault: false,
                        },
                        stale: false,
                    };
                    if thief.put(&keys.infra_dts(zone.zone), &zone).await.is_ok() {
                        sent.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
        }
    }
    thief.close().await;
    clock.close().await;
}
