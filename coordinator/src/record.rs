//! Recording the whole fleet's traffic to MCAP.
//!
//! Every message on `ff/<site>/**` is decoded by its key's type and written as JSON on a
//! channel named after its key, with a JSON Schema per message type, so any MCAP reader
//! (Foxglove, Lichtblick, the `mcap` CLI and libraries) can open and decode the file.
//! Liveliness changes go to `<site>/liveliness`. A Foxglove scene (`/scene`) shows the
//! tunnel, the parked vehicles, the units and the fires. Undecodable messages are counted
//! and skipped, never written as garbage.
//!
//! The recorder also keeps the latest track of every fire and answers queries on
//! `fire/*` with them: that is how a restarted coordinator recalls the fires the previous
//! one tracked (the recording is the incident's memory, on the bus as well as on disk).
//! With no recorder left running, [`fire_tracks_in`] reads the same tracks back from the
//! file (the coordinator's `--resume`).
//!
//! Chunks are not compressed: compression would pull C libraries into the build, and
//! uncompressed MCAP is readable everywhere.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::future::Future;
use std::io::BufWriter;
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

use firefleet_protocol::bus::{Bus, BusError};
use firefleet_protocol::codec::{self, CodecError};
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{
    BtTransitions, Decision, FireTrack, FlameReport, GoalAck, Message, RailCommand, RailSensors,
    SimClock, SimTruth, Task, UnitCommand, UnitSensors, UnitState, ZoneGoal,
};
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::{FireId, SiteId};
use serde::Serialize;
use zenoh::sample::SampleKind;

use crate::scene;

/// Why recording failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("cannot create {path}: {source}")]
    Create {
        path: String,
        source: std::io::Error,
    },
    #[error("writing MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    #[error(transparent)]
    Bus(#[from] BusError),
}

/// What a recording holds.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RecordSummary {
    pub messages: u64,
    pub channels: usize,
    pub skipped: u64,
}

/// How often the recording is written out (a chunk closed): what a recorder killed
/// outright loses at most.
const FLUSH_EVERY: std::time::Duration = std::time::Duration::from_secs(1);
/// Simulated seconds between two scene updates.
const SCENE_PERIOD_S: f64 = 0.5;

/// The JSON form of a message with its type's schema name and JSON Schema.
struct Decoded {
    schema_name: &'static str,
    schema: fn() -> schemars::Schema,
    json: Vec<u8>,
}

fn decoded<M: Message>(
    bytes: &[u8],
    schema_name: &'static str,
) -> Result<(Decoded, M), CodecError> {
    let m: M = codec::decode(bytes)?;
    let json = serde_json::to_vec(&m)?;
    Ok((
        Decoded {
            schema_name,
            schema: || schemars::schema_for!(M),
            json,
        },
        m,
    ))
}

/// An MCAP file being written.
struct McapSink {
    writer: mcap::Writer<BufWriter<File>>,
    schemas: HashMap<&'static str, u16>,
    channels: HashMap<String, (u16, u32)>,
    summary: RecordSummary,
}

impl McapSink {
    fn create(path: &Path) -> Result<Self, RecordError> {
        let file = File::create(path).map_err(|source| RecordError::Create {
            path: path.display().to_string(),
            source,
        })?;
        let writer = mcap::WriteOptions::new()
            .compression(None)
            .profile("firefleet")
            .create(BufWriter::new(file))?;
        Ok(Self {
            writer,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            summary: RecordSummary::default(),
        })
    }

    fn write(
        &mut self,
        topic: &str,
        schema_name: &'static str,
        schema: fn() -> schemars::Schema,
        json: &[u8],
        t_ns: u64,
    ) -> Result<(), RecordError> {
        let schema_id = match self.schemas.get(schema_name) {
            Some(id) => *id,
            None => {
                let data = serde_json::to_vec(&schema()).expect("a schema serialises");
                let id = self.writer.add_schema(schema_name, "jsonschema", &data)?;
                self.schemas.insert(schema_name, id);
                id
            }
        };
        let (channel_id, seq) = match self.channels.get_mut(topic) {
            Some(c) => c,
            None => {
                let id = self
                    .writer
                    .add_channel(schema_id, topic, "json", &BTreeMap::new())?;
                self.channels.entry(topic.to_owned()).or_insert((id, 0))
            }
        };
        *seq += 1;
        let header = mcap::records::MessageHeader {
            channel_id: *channel_id,
            sequence: *seq,
            log_time: t_ns,
            publish_time: t_ns,
        };
        self.writer.write_to_known_channel(&header, json)?;
        self.summary.messages += 1;
        Ok(())
    }

    /// Close the current chunk and write it out: a recorder killed after this loses
    /// nothing before it.
    fn flush(&mut self) -> Result<(), RecordError> {
        self.writer.flush()?;
        Ok(())
    }

    fn finish(mut self) -> Result<RecordSummary, RecordError> {
        self.writer.finish()?;
        self.summary.channels = self.channels.len();
        Ok(self.summary)
    }
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// What a decoded message adds to the recording besides its own channel.
enum Derived {
    None,
    /// Ground truth: the scene is redrawn from it.
    Truth(SimTruth),
    /// A coordinator decision: also a `foxglove.Log` entry.
    Decision(Decision),
    /// An answer to a zone goal: also a `foxglove.Log` entry.
    Ack(GoalAck),
    /// A fire track: kept (the latest of each fire) for a restarted coordinator to recall.
    Fire(FireTrack),
}

fn decode(topic: &Topic, bytes: &[u8]) -> Result<(Decoded, Derived), CodecError> {
    fn plain<M: Message>(
        bytes: &[u8],
        name: &'static str,
    ) -> Result<(Decoded, Derived), CodecError> {
        decoded::<M>(bytes, name).map(|(d, _)| (d, Derived::None))
    }
    match topic {
        Topic::UnitState(_) => plain::<UnitState>(bytes, "firefleet.UnitState"),
        Topic::UnitReport(_) => plain::<FlameReport>(bytes, "firefleet.FlameReport"),
        Topic::UnitTask(_) => plain::<Task>(bytes, "firefleet.Task"),
        Topic::UnitBt(_) => plain::<BtTransitions>(bytes, "firefleet.BtTransitions"),
        Topic::Fire(_) => {
            decoded::<FireTrack>(bytes, "firefleet.FireTrack").map(|(d, m)| (d, Derived::Fire(m)))
        }
        Topic::ZoneGoal(_) => plain::<ZoneGoal>(bytes, "firefleet.ZoneGoal"),
        Topic::ZoneAck(_) => {
            decoded::<GoalAck>(bytes, "firefleet.GoalAck").map(|(d, m)| (d, Derived::Ack(m)))
        }
        Topic::SimClock => plain::<SimClock>(bytes, "firefleet.SimClock"),
        Topic::SimSensors(_) => plain::<UnitSensors>(bytes, "firefleet.UnitSensors"),
        Topic::SimCmd(_) => plain::<UnitCommand>(bytes, "firefleet.UnitCommand"),
        Topic::SimRailSensors(_) => plain::<RailSensors>(bytes, "firefleet.RailSensors"),
        Topic::SimRailCmd(_) => plain::<RailCommand>(bytes, "firefleet.RailCommand"),
        Topic::SimTruth => {
            decoded::<SimTruth>(bytes, "firefleet.SimTruth").map(|(d, m)| (d, Derived::Truth(m)))
        }
        Topic::CoordLog => {
            decoded::<Decision>(bytes, "firefleet.Decision").map(|(d, m)| (d, Derived::Decision(m)))
        }
        Topic::UnitAlive(_) | Topic::CoordAlive | Topic::CoordStatus => Err(CodecError::Empty),
    }
}

/// Why a recording could not be read at all.
#[derive(Debug, thiserror::Error)]
#[error("not an MCAP recording: {0}")]
pub struct NotARecording(#[from] mcap::McapError);

/// The fire tracks a recording holds.
#[derive(Debug, Clone, Default)]
pub struct Recorded {
    /// The latest track of every fire, by its site time.
    pub tracks: Vec<FireTrack>,
    /// Records on a fire channel that are not a fire track, with why.
    pub refused: Vec<String>,
    /// Where the file stopped being readable, if it did before its end (a recorder
    /// killed before it could finish the file): what came before is still used.
    pub cut_short: Option<String>,
}

/// The latest track of every fire of `site` in a recording made by [`record`] (a JSON
/// record on each `ff/<site>/fire/f<n>` channel).
pub fn fire_tracks_in(bytes: &[u8], site: &SiteId) -> Result<Recorded, NotARecording> {
    let mut out = Recorded::default();
    let mut tracks = Vec::new();
    for (k, m) in mcap::MessageStream::new(bytes)?.enumerate() {
        let m = match m {
            Ok(m) => m,
            // Nothing readable at all: not a recording (a recording's first records are
            // the recorder's scene).
            Err(e) if k == 0 => return Err(NotARecording(e)),
            Err(e) => {
                out.cut_short = Some(e.to_string());
                break;
            }
        };
        if !matches!(keys::parse(&m.channel.topic), Ok((s, Topic::Fire(_))) if s == *site) {
            continue;
        }
        match serde_json::from_slice::<FireTrack>(&m.data) {
            Ok(track) => tracks.push(track),
            Err(e) => out
                .refused
                .push(format!("{} at {} ns: {e}", m.channel.topic, m.log_time)),
        }
    }
    out.tracks = latest_per_fire(tracks);
    Ok(out)
}

/// The newest of each fire's tracks (by site time; the later one of a tie).
pub fn latest_per_fire(tracks: impl IntoIterator<Item = FireTrack>) -> Vec<FireTrack> {
    let mut latest: BTreeMap<FireId, FireTrack> = BTreeMap::new();
    for f in tracks {
        if latest.get(&f.id).is_none_or(|old| old.t <= f.t) {
            latest.insert(f.id, f);
        }
    }
    latest.into_values().collect()
}

#[derive(Serialize, schemars::JsonSchema)]
struct Liveliness {
    key: String,
    alive: bool,
}

/// Record everything on the site until `shutdown` completes; the file is finished (summary
/// and index written) however the recording ends.
pub async fn record(
    bus: &Bus,
    scenario: &Scenario,
    path: &Path,
    shutdown: impl Future<Output = ()>,
) -> Result<RecordSummary, RecordError> {
    let keys = bus.keys().clone();
    let session = bus.session();
    let mut sink = McapSink::create(path)?;
    let result = async {
        let samples = session.declare_subscriber(keys.all()).await.map_err(BusError::from)?;
        let tokens = session.liveliness().declare_subscriber(keys.all()).history(true).await.map_err(BusError::from)?;
        let recall = session.declare_queryable(keys.every_fire().as_str()).await.map_err(BusError::from)?;
        // The latest track of every fire, as received: (its time, its key, its bytes).
        let mut fires: BTreeMap<FireId, (f64, String, Vec<u8>)> = BTreeMap::new();
        let scene_schema = || schemars::schema_for!(scene::SceneUpdate);
        let statics = serde_json::to_vec(&scene::static_scene(scenario, scene::Time::from_nanos(now_ns()))).expect("serialises");
        sink.write("/scene", scene::SCHEMA_NAME, scene_schema, &statics, now_ns())?;
        let liveliness_topic = format!("{}/liveliness", keys.site());
        let mut next_scene = 0.0;
        let mut flush = tokio::time::interval(FLUSH_EVERY);
        tokio::pin!(shutdown);
        loop {
            tokio::select! {
                _ = &mut shutdown => break,
                _ = flush.tick() => sink.flush()?,
                Ok(s) = tokens.recv_async() => {
                    let l = Liveliness { key: s.key_expr().to_string(), alive: s.kind() == SampleKind::Put };
                    let json = serde_json::to_vec(&l).expect("serialises");
                    sink.write(&liveliness_topic, "firefleet.Liveliness", || schemars::schema_for!(Liveliness), &json, now_ns())?;
                }
                Ok(query) = recall.recv_async() => {
                    for (_, key, bytes) in fires.values() {
                        if let Err(e) = query.reply(key, bytes.clone()).await {
                            tracing::warn!("fire track reply failed: {e}");
                        }
                    }
                }
                Ok(s) = samples.recv_async() => {
                    let key = s.key_expr().as_str();
                    let bytes = s.payload().to_bytes();
                    let parsed = keys::parse(key).map_err(|e| e.to_string())
                        .and_then(|(_, topic)| decode(&topic, &bytes).map_err(|e| e.to_string()));
                    match parsed {
                        Ok((d, derived)) => {
                            let t = now_ns();
                            sink.write(key, d.schema_name, d.schema, &d.json, t)?;
                            match derived {
                                Derived::Truth(truth) if truth.t >= next_scene => {
                                    next_scene = truth.t + SCENE_PERIOD_S;
                                    let update = scene::truth_scene(scenario, &truth, scene::Time::from_nanos(t));
                                    sink.write("/scene", scene::SCHEMA_NAME, scene_schema, &serde_json::to_vec(&update).expect("serialises"), t)?;
                                }
                                Derived::Decision(decision) => {
                                    let log = scene::Log::info("coordinator", &decision, scene::Time::from_nanos(t));
                                    sink.write("/log", scene::LOG_SCHEMA_NAME, || schemars::schema_for!(scene::Log), &serde_json::to_vec(&log).expect("serialises"), t)?;
                                }
                                Derived::Ack(ack) => {
                                    let log = scene::Log::ack(&ack, scene::Time::from_nanos(t));
                                    sink.write("/log", scene::LOG_SCHEMA_NAME, || schemars::schema_for!(scene::Log), &serde_json::to_vec(&log).expect("serialises"), t)?;
                                }
                                Derived::Fire(track) if fires.get(&track.id).is_none_or(|(old, _, _)| *old <= track.t) => {
                                    fires.insert(track.id, (track.t, key.to_owned(), bytes.to_vec()));
                                }
                                _ => {}
                            }
                        }
                        Err(reason) => {
                            sink.summary.skipped += 1;
                            tracing::warn!(key, "not recorded: {reason}");
                        }
                    }
                }
            }
        }
        Ok::<(), RecordError>(())
    }
    .await;
    // Finish the file whatever happened above, so that what was recorded stays readable.
    let summary = sink.finish()?;
    result.map(|_| summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_protocol::geometry::Point2;
    use firefleet_protocol::msg::FireState;

    fn track(id: u32, t: f64) -> FireTrack {
        FireTrack {
            id: FireId(id),
            t,
            position: Point2::new(50.0 + f64::from(id), 1.0),
            cov: [0.3, 0.0, 0.3],
            confidence: 0.9,
            state: FireState::Confirmed,
            assigned: Vec::new(),
            seen_by: Vec::new(),
            hrr_kw: None,
        }
    }

    /// A recording as `record` writes it, of the given (topic, JSON) records.
    fn recording(records: &[(&str, Vec<u8>)]) -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.mcap");
        let mut sink = McapSink::create(&path).unwrap();
        for (k, (topic, json)) in records.iter().enumerate() {
            let schema = || schemars::schema_for!(FireTrack);
            sink.write(topic, "firefleet.FireTrack", schema, json, k as u64)
                .unwrap();
            // As the recorder does once a second.
            if k % 20 == 19 {
                sink.flush().unwrap();
            }
        }
        sink.finish().unwrap();
        std::fs::read(&path).unwrap()
    }

    fn json(t: &FireTrack) -> Vec<u8> {
        serde_json::to_vec(t).unwrap()
    }

    #[test]
    fn a_recording_gives_back_the_latest_track_of_each_of_its_sites_fires() {
        let site = SiteId::new("tunnel-a").unwrap();
        let bytes = recording(&[
            ("ff/tunnel-a/fire/f3", json(&track(3, 10.0))),
            ("ff/tunnel-a/fire/f4", json(&track(4, 5.0))),
            ("ff/tunnel-a/fire/f3", json(&track(3, 20.0))),
            // Another site's fire, a state on another channel, a corrupt record.
            ("ff/tunnel-b/fire/f9", json(&track(9, 30.0))),
            ("ff/tunnel-a/unit/u1/state", b"{}".to_vec()),
            ("ff/tunnel-a/fire/f5", b"{\"id\": 5".to_vec()),
        ]);
        let r = fire_tracks_in(&bytes, &site).unwrap();
        let got: Vec<(u32, f64)> = r.tracks.iter().map(|t| (t.id.0, t.t)).collect();
        assert_eq!(got, vec![(3, 20.0), (4, 5.0)]);
        assert_eq!(r.refused.len(), 1, "{:?}", r.refused);
        assert!(
            r.refused[0].contains("ff/tunnel-a/fire/f5"),
            "{:?}",
            r.refused
        );
        assert_eq!(r.cut_short, None);
    }

    #[test]
    fn a_recording_cut_short_gives_back_what_comes_before_the_cut() {
        let site = SiteId::new("tunnel-a").unwrap();
        let mut records: Vec<(&str, Vec<u8>)> = (0..200)
            .map(|k| ("ff/tunnel-a/fire/f1", json(&track(1, f64::from(k)))))
            .collect();
        records.push(("ff/tunnel-a/fire/f2", json(&track(2, 500.0))));
        let whole = recording(&records);
        // A recorder killed mid-write: no summary, no footer, half a chunk.
        let cut = &whole[..whole.len() / 2];
        let r = fire_tracks_in(cut, &site).unwrap();
        assert!(r.cut_short.is_some());
        assert_eq!(r.tracks.len(), 1, "{:?}", r.tracks);
        assert!(r.tracks[0].t > 50.0, "up to the cut: {:?}", r.tracks);
        assert!(r.tracks.iter().all(|t| t.id == FireId(1)), "{:?}", r.tracks);
        assert!(
            fire_tracks_in(b"not an mcap file", &site).is_err(),
            "not a recording at all"
        );
    }
}
