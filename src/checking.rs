//! A recording through the incident's invariants: what `firefleet check` prints and the
//! lab's nemesis judges its runs by.
//!
//! Not here: the invariants themselves (`firefleet_coordinator::invariants`) or reading MCAP
//! records (`firefleet_recorder::parts`, `firefleet_protocol::payload`); this feeds one to
//! the other.

use firefleet_bus::access::Identity;
use firefleet_bus::suspension::coordinator_rank;
use firefleet_coordinator::incident::freshness::{AHEAD_S, BEHIND_S};
use firefleet_coordinator::invariants::churn::ChurnTally;
use firefleet_coordinator::invariants::pinned::BlockedTally;
use firefleet_coordinator::invariants::{Event, Invariants, Tally, Violation};
use firefleet_model::scenario::Scenario;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::office::Leases;
use firefleet_protocol::payload::{GoalClear, Liveliness, Payload};
use firefleet_recorder::parts::Recording;

/// What the checker found in a recording.
pub struct Checked {
    pub violations: Vec<Violation>,
    /// How many of its messages are of the site.
    pub messages: usize,
    /// States and tasks naming a unit other than the one their key belongs to (or tasks
    /// of another coordinator's term than their key's): set aside, not judged as that
    /// unit's.
    pub forged: usize,
    /// Tasks from a coordinator that did not hold office (a rival, a suspended key): every
    /// unit refused them, so they are not judged.
    pub refused: usize,
    /// States dated off the site clock by more than the coordinator's window (a thief's,
    /// a replay): the coordinator refused them, so they are not judged.
    pub off_clock: usize,
    /// Tasks in the term of a coordinator whose own log says someone else held its key,
    /// numbered below one already given: the thief's fight with the holder
    /// ([`Invariants::stolen_key_tasks`]).
    pub stolen_key_tasks: usize,
    pub continuity: Tally,
    /// How often fires' attackers changed.
    pub churn: ChurnTally,
    /// How often units were blocked.
    pub blocked: BlockedTally,
}

/// The invariants over `recording` of `scenario`'s site, whose coordinator counted units
/// silent for `lease_s` lost.
pub fn check(recording: &Recording, scenario: &Scenario, lease_s: f64) -> anyhow::Result<Checked> {
    let mut inv = Invariants::with_lease(scenario, lease_s);
    let (mut t, mut messages, mut forged, mut refused) = (0.0, 0usize, 0usize, 0usize);
    // The site clock, where the recording has the simulator's: the checker's time then,
    // which no unit's or coordinator's message moves, and what a state is judged against.
    // A stolen unit key's states dated 2400 s ahead once had every honest unit "fall
    // silent" here, though the coordinator had refused them all.
    let (mut site_clock, mut off_clock) = (None, 0usize);
    // Who held office, from the recorded leases and suspensions: a task from anyone else
    // was refused by every unit, and is not judged (a recording with no lease recorded,
    // say one made before leases were recorded, judges every task).
    let mut office = Leases::default();
    let mut leases_recorded = false;
    // The identities already found suspended (the goals in force say so every second),
    // and when each was last asked to be.
    let mut suspended = std::collections::BTreeSet::new();
    let mut asked = std::collections::BTreeMap::new();
    let liveliness = format!("{}/liveliness", scenario.site);
    for m in recording.messages() {
        let m = match m {
            Ok(m) => m,
            Err(e) if messages == 0 => anyhow::bail!("not an MCAP recording: {e}"),
            Err(e) => {
                eprintln!("a file of the recording is cut short: {e}");
                continue;
            }
        };
        if m.channel.topic == liveliness {
            if let Ok(l) = serde_json::from_slice::<Liveliness>(&m.data)
                && let Ok((_, Topic::CoordAlive(rank))) = keys::parse(&l.key)
            {
                office.set(rank, l.alive);
                leases_recorded = true;
            }
            continue;
        }
        let Ok((site, topic)) = keys::parse(&m.channel.topic) else {
            continue;
        };
        if site != scenario.site {
            continue;
        }
        messages += 1;
        let schema = m.channel.schema.as_ref().map(|s| s.name.as_str());
        let event = match (&topic, Payload::from_json(&topic, &m.data)) {
            (Topic::ZoneGoal(zone, by), _) if GoalClear::of_record(schema, &m.data).is_some() => {
                Some(Event::Clear {
                    zone: zone.clone(),
                    by: by.clone(),
                })
            }
            (_, Ok(Payload::SimClock(c))) => {
                t = c.t;
                site_clock = Some(c.t);
                None
            }
            // The unit a message belongs to is the one its key names: the router lets only
            // that unit put there. A state or task naming another unit is forged (or a
            // bug) and says nothing about the unit it names.
            (Topic::UnitState(owner), Ok(Payload::UnitState(s))) => {
                if &s.unit != owner {
                    forged += 1;
                    continue;
                }
                match site_clock {
                    Some(now) if s.t > now + AHEAD_S || s.t < now - BEHIND_S => {
                        off_clock += 1;
                        continue;
                    }
                    Some(_) => {}
                    None => t = s.t,
                }
                Some(Event::State(s))
            }
            // Likewise the coordinator: only the one of that rank puts on its key, and its
            // tasks are of its own terms.
            (Topic::UnitTask(owner, rank), Ok(Payload::Task(task))) => {
                if &task.unit != owner || task.rank() != *rank {
                    forged += 1;
                    continue;
                }
                if leases_recorded && !office.obeys(*rank) {
                    refused += 1;
                    continue;
                }
                if site_clock.is_none() {
                    t = task.t;
                }
                Some(Event::Task(task))
            }
            (_, Ok(Payload::SimTruth(truth))) => {
                t = truth.t;
                site_clock = Some(truth.t);
                inv.observe(t, Event::blocked(&truth));
                Some(Event::burning(&truth))
            }
            (Topic::ZoneAck(_), Ok(Payload::Ack(ack))) => Some(Event::Ack(ack)),
            // A coordinator that heard tasks on its own key that it never sent says so.
            (Topic::CoordLog, Ok(Payload::Decision(d))) => d
                .impostor
                .and_then(|who| who.parse().ok())
                .and_then(|who| match who {
                    Identity::Coordinator(rank) => Some(Event::KeyStolen { rank }),
                    _ => None,
                }),
            // The goals in force carry the asks of every identity suspended: its goals
            // lapsed there, as the coordinator says.
            (Topic::CoordGoals, Ok(Payload::Goals(g))) => {
                for ask in &g.suspensions {
                    if let Ok((_, Topic::Suspend(target, _))) = keys::parse(&ask.key)
                        && suspended.insert(target.clone())
                    {
                        if let Some(rank) = coordinator_rank(&target) {
                            office.suspend(rank);
                        }
                        let in_force = g.goals.iter().map(|k| k.goal.id.clone()).collect();
                        let asked_at = asked.get(&target).copied().unwrap_or(t);
                        inv.observe(
                            t,
                            Event::Suspended {
                                name: target,
                                in_force,
                                asked_at,
                            },
                        );
                    }
                }
                None
            }
            // An ask to suspend an identity: whether it took is the coordinator's to say
            // (in the goals in force), when it came is here.
            (Topic::Suspend(target, _), _) => {
                asked.insert(target.clone(), t);
                None
            }
            (Topic::ZoneGoal(zone, by), Ok(Payload::Goal(goal))) => Some(Event::Goal {
                key_zone: zone.clone(),
                by: by.clone(),
                goal,
            }),
            _ => None,
        };
        if let Some(e) = event {
            inv.observe(t, e);
        }
    }
    Ok(Checked {
        violations: inv.violations().to_vec(),
        messages,
        forged,
        refused,
        off_clock,
        stolen_key_tasks: inv.stolen_key_tasks(),
        continuity: inv.continuity(),
        churn: inv.churn(),
        blocked: inv.blocked(),
    })
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::io::Cursor;

    use firefleet_model::{CommanderId, Pose2, UnitId, UnitKind, ZoneId, builtin};
    use firefleet_protocol::msg::{GoalKind, UnitState, ZoneGoal};

    use super::*;

    /// An MCAP recording of `records` (topic, schema name, JSON), as a recorder writes
    /// them, a channel per topic and schema.
    fn recording(records: &[(String, &str, Vec<u8>)]) -> Recording {
        let mut w = mcap::Writer::new(Cursor::new(Vec::new())).unwrap();
        let mut channels = BTreeMap::new();
        for (k, (topic, schema, json)) in records.iter().enumerate() {
            let key = (topic.clone(), schema.to_string());
            let id = match channels.get(&key) {
                Some(id) => *id,
                None => {
                    let s = w.add_schema(schema, "jsonschema", b"{}").unwrap();
                    let id = w.add_channel(s, topic, "json", &BTreeMap::new()).unwrap();
                    channels.insert(key, id);
                    id
                }
            };
            let header = mcap::records::MessageHeader {
                channel_id: id,
                sequence: k as u32,
                log_time: k as u64,
                publish_time: k as u64,
            };
            w.write_to_known_channel(&header, json).unwrap();
        }
        w.finish().unwrap();
        Recording::from_bytes(w.into_inner().into_inner())
    }

    fn state(key_unit: &str, named: &str, x: f64, t: f64) -> (String, &'static str, Vec<u8>) {
        let named = UnitId::new(named).unwrap();
        let st = UnitState {
            t,
            ..UnitState::idle(named, UnitKind::Ground, Pose2::new(x, -2.5, 0.0), 1000.0)
        };
        (
            format!("ff/tunnel-a/unit/{key_unit}/state"),
            "firefleet.UnitState",
            serde_json::to_vec(&st).unwrap(),
        )
    }

    /// The violations `c` found, as the checker prints them.
    fn said(c: &Checked) -> Vec<String> {
        c.violations.iter().map(ToString::to_string).collect()
    }

    fn keep_out_core() -> (String, &'static str, Vec<u8>) {
        let g = ZoneGoal::new(
            ZoneId::new("core").unwrap(),
            GoalKind::KeepOut,
            CommanderId::new("rossi").unwrap(),
        );
        (
            "ff/tunnel-a/zone/core/goal/rossi".into(),
            "firefleet.ZoneGoal",
            serde_json::to_vec(&g).unwrap(),
        )
    }

    /// ugv-1 at 100 m, in the core zone, every second from `from` to `to`, on the key of
    /// `key_unit`.
    fn in_core(key_unit: &str, from: u32, to: u32) -> Vec<(String, &'static str, Vec<u8>)> {
        (from..to)
            .map(|s| state(key_unit, "ugv-1", 100.0, f64::from(s)))
            .collect()
    }

    #[test]
    fn a_state_is_judged_as_its_key_s_unit_and_a_clear_is_seen_on_either_channel() {
        let scenario = builtin::resolve("vehicle-collision").unwrap();
        let ugv1 = UnitId::new("ugv-1").unwrap();
        let judge = |records: Vec<(String, &'static str, Vec<u8>)>| {
            check(&recording(&records), &scenario, 5.0).unwrap()
        };
        // ugv-1 itself inside a keep-out for 200 s: a violation.
        let mut honest = vec![keep_out_core()];
        honest.extend(in_core("ugv-1", 0, 200));
        let c = judge(honest);
        assert!(
            c.violations
                .iter()
                .any(|v| v.to_string().contains(ugv1.as_str())),
            "the check still sees the real thing: {:?}",
            said(&c)
        );
        // The same states on ugv-2's key (a thief with ugv-2's certificate naming ugv-1):
        // set aside, no false violation.
        let mut forged = vec![keep_out_core()];
        forged.extend(in_core("ugv-2", 0, 200));
        let c = judge(forged);
        assert!(c.violations.is_empty(), "{:?}", said(&c));
        assert_eq!(c.forged, 200);
        // The goal cleared at once, the clear kept on the goal's own channel (as recorders
        // before clears had a channel of their own did) or on its own: ugv-1 may be there.
        let clear = serde_json::to_vec(&GoalClear {
            zone: ZoneId::new("core").unwrap(),
            by: CommanderId::new("rossi").unwrap(),
        })
        .unwrap();
        for schema in ["firefleet.ZoneGoal", GoalClear::NAME] {
            let mut cleared = vec![
                keep_out_core(),
                (
                    "ff/tunnel-a/zone/core/goal/rossi".into(),
                    schema,
                    clear.clone(),
                ),
            ];
            cleared.extend(in_core("ugv-1", 0, 200));
            let c = judge(cleared);
            assert!(
                c.violations.is_empty(),
                "clear under {schema}: {:?}",
                said(&c)
            );
        }
    }

    #[test]
    fn a_state_dated_off_the_site_clock_is_set_aside_and_moves_no_clock() {
        use firefleet_protocol::msg::SimClock;
        let scenario = builtin::resolve("vehicle-collision").unwrap();
        let clock = |t: f64| {
            (
                "ff/tunnel-a/sim/clock".to_owned(),
                "firefleet.SimClock",
                serde_json::to_vec(&SimClock { t, time_scale: 1.0 }).unwrap(),
            )
        };
        // ugv-1 stays clear of the keep-out and says so every second.
        let mut records = vec![keep_out_core()];
        for s in 0..30 {
            records.push(clock(f64::from(s)));
            records.push(state("ugv-1", "ugv-1", 5.0, f64::from(s)));
        }
        // ugv-2's stolen key: in the keep-out, dated 2400 s ahead and 25 s behind. The
        // coordinator refused both; here they neither count nor move the clock past
        // ugv-1's lease.
        records.push(state("ugv-2", "ugv-2", 100.0, 2429.0));
        records.push(state("ugv-2", "ugv-2", 100.0, 4.0));
        records.push(clock(30.0));
        records.push(state("ugv-1", "ugv-1", 5.0, 30.0));
        let c = check(&recording(&records), &scenario, 5.0).unwrap();
        assert!(c.violations.is_empty(), "{:?}", said(&c));
        assert_eq!(c.off_clock, 2);
    }

    #[test]
    fn a_task_from_a_coordinator_not_in_office_is_not_judged() {
        use firefleet_protocol::msg::{Task, TaskKind};
        let scenario = builtin::resolve("vehicle-collision").unwrap();
        let lease = |rank: u32, alive: bool| {
            (
                "tunnel-a/liveliness".to_owned(),
                Liveliness::NAME,
                serde_json::to_vec(&Liveliness {
                    key: format!("ff/tunnel-a/coord/office/{rank}/alive"),
                    alive,
                })
                .unwrap(),
            )
        };
        // Into the core, where a keep-out holds: a violation if a unit was told it.
        let into_core = |rank: u32| {
            let epoch = firefleet_protocol::msg::epoch_after(1000, rank);
            let task = Task {
                unit: UnitId::new("ugv-1").unwrap(),
                epoch,
                seq: epoch,
                t: 1.0,
                kind: TaskKind::Cruise {
                    goal: firefleet_model::Point2::new(100.0, -2.5),
                },
            };
            (
                format!("ff/tunnel-a/unit/ugv-1/task/{rank}"),
                "firefleet.Task",
                serde_json::to_vec(&task).unwrap(),
            )
        };
        let judge = |records: Vec<(String, &'static str, Vec<u8>)>| {
            check(&recording(&records), &scenario, 5.0).unwrap()
        };
        // Rank 0 in office: rank 1's task was refused by every unit.
        let c = judge(vec![
            lease(0, true),
            lease(1, true),
            keep_out_core(),
            into_core(1),
        ]);
        assert!(c.violations.is_empty(), "{:?}", c.violations);
        assert_eq!(c.refused, 1);
        // The holder's own task is judged.
        let c = judge(vec![lease(0, true), keep_out_core(), into_core(0)]);
        assert_eq!(c.violations.len(), 1, "{:?}", c.violations);
        // A task on rank 1's key in another rank's term: forged.
        let (key, schema, bytes) = into_core(0);
        let c = judge(vec![
            lease(1, true),
            keep_out_core(),
            (key.replace("task/0", "task/1"), schema, bytes),
        ]);
        assert_eq!((c.forged, c.violations.len()), (1, 0));
    }
}
