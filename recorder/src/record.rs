//! Recording the whole fleet's traffic to MCAP.
//!
//! Every message on `ff/<site>/**` is decoded by its key's type and written as JSON on a
//! channel named after its key, with a JSON Schema per message type, so any MCAP reader
//! (Foxglove, Lichtblick, the `mcap` CLI and libraries) can open and decode the file.
//! Liveliness changes go to `<site>/liveliness`. A Foxglove scene ([`crate::scene`]) shows
//! the tunnel, the units and fires as the fleet knows them, zones by their goals, the heat
//! field, and the simulator's truth as a layer of its own. Undecodable messages are counted
//! and skipped, never written as garbage. The same channels can be served live
//! ([`crate::live`]), with or without a file.
//!
//! The recorder also keeps the latest track of every fire and answers queries on
//! `fire/*` with them, each with the coordinator's seal it came with: that is how a
//! restarted coordinator recalls the fires the previous one tracked (the recording is the
//! incident's memory, on the bus as well as on disk).
//! It answers queries on `coord/barred` and `coord/goals` with the newest barred space and
//! goals in force the same way, so that a unit restarted while the coordinator is gone
//! still learns what commanders barred, and a restarted coordinator takes their goals back.
//! With no recorder left running, [`crate::reader::incident_in`] reads the same tracks
//! and goals back from the file (the coordinator's `--resume`).
//!
//! Chunks are zstd-compressed at its default level: a recording is JSON, about ten times
//! smaller compressed, and every MCAP reader reads zstd. One compression thread: the
//! recorder shares its machine with the fleet, and a second's chunk compresses in
//! milliseconds. The file is written in parts that survive the recorder being killed at
//! any instant, merged when it stops ([`crate::parts`]).

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::future::Future;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use firefleet_bus::{Bus, BusError, Raw};
use firefleet_model::FireId;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::codec::PROTOCOL_VERSION;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{BarredSpace, GoalsInForce};
use serde::Serialize;

use crate::budget::{BYTES_PER_CHANNEL_S, Budget};
use crate::live::Live;
use crate::parts::{Index, Part, Recording, part_path, parts_dir};
use crate::scene::{self, Fleet};
use firefleet_protocol::payload::{GoalClear, Liveliness, Payload};

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
    #[error("the site file does not serialise as TOML: {0}")]
    SiteFile(toml::ser::Error),
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("reading back the parts: {0}")]
    Load(#[from] crate::parts::LoadError),
    #[error(
        "{0} holds the parts of an earlier recording that was never merged: read it with `firefleet replay`, then move it away"
    )]
    PartsLeft(String),
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// The name of the metadata record every recording starts with ([`McapSink::describe`]).
pub const METADATA_NAME: &str = "firefleet";

/// What a recording holds.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RecordSummary {
    pub messages: u64,
    pub channels: usize,
    pub skipped: u64,
    /// Samples that arrived faster than the recorder could take them and were dropped
    /// before it saw them (`firefleet_bus::RawInbox`).
    pub dropped: u64,
    /// Samples not written for being over their channel's byte budget
    /// ([`crate::budget::BYTES_PER_CHANNEL_S`]).
    pub over_budget: u64,
}

/// How often the recording is written out (a chunk closed): what a recorder killed
/// outright loses at most.
const FLUSH_EVERY: std::time::Duration = std::time::Duration::from_secs(1);
/// Simulated seconds between two updates of the truth layer.
const SCENE_PERIOD_S: f64 = 0.5;
/// How often the fleet's layer and its heat field are redrawn when they changed.
const FLEET_PERIOD: std::time::Duration = std::time::Duration::from_millis(500);

/// An MCAP file being written.
pub(crate) struct McapSink {
    writer: mcap::Writer<BufWriter<File>>,
    schemas: HashMap<String, u16>,
    /// By topic and schema: a key can carry two kinds of record (a goal, and a
    /// commander's delete as [`GoalClear`]), and a reader tells them apart by the schema.
    channels: HashMap<(String, u16), (u16, u32)>,
    summary: RecordSummary,
}

impl McapSink {
    pub(crate) fn create(path: &Path) -> Result<Self, RecordError> {
        let file = File::create(path).map_err(|source| RecordError::Create {
            path: path.display().to_string(),
            source,
        })?;
        let writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .compression_threads(0)
            .profile("firefleet")
            .create(BufWriter::new(file))?;
        Ok(Self {
            writer,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            summary: RecordSummary::default(),
        })
    }

    /// The recording's metadata record (`firefleet`): the version of the build that made
    /// it, the protocol version, the site and the site file as TOML, so that a recording
    /// read years later says what it is of.
    pub(crate) fn describe(&mut self, scenario: &Scenario) -> Result<(), RecordError> {
        let site_file = toml::to_string(scenario).map_err(RecordError::SiteFile)?;
        let metadata = BTreeMap::from([
            (
                "firefleet_version".to_owned(),
                env!("CARGO_PKG_VERSION").to_owned(),
            ),
            ("protocol_version".to_owned(), PROTOCOL_VERSION.to_string()),
            ("site".to_owned(), scenario.site.to_string()),
            ("site_file".to_owned(), site_file),
        ]);
        self.writer.write_metadata(&mcap::records::Metadata {
            name: METADATA_NAME.to_owned(),
            metadata,
        })?;
        Ok(())
    }

    pub(crate) fn write(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema: fn() -> schemars::Schema,
        json: &[u8],
        t_ns: u64,
    ) -> Result<(), RecordError> {
        let schema = || serde_json::to_vec(&schema()).expect("a schema serialises");
        self.write_with(topic, schema_name, schema, json, t_ns)
    }

    /// Write `m`, read from another recording, on a channel of this one.
    pub(crate) fn copy(&mut self, m: &mcap::Message) -> Result<(), RecordError> {
        let (name, data) = match &m.channel.schema {
            Some(s) => (s.name.as_str(), s.data.to_vec()),
            None => ("", Vec::new()),
        };
        self.write_with(&m.channel.topic, name, || data, &m.data, m.log_time)
    }

    fn write_with(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema: impl FnOnce() -> Vec<u8>,
        json: &[u8],
        t_ns: u64,
    ) -> Result<(), RecordError> {
        let schema_id = match self.schemas.get(schema_name) {
            Some(id) => *id,
            None => {
                let id = self
                    .writer
                    .add_schema(schema_name, "jsonschema", &schema())?;
                self.schemas.insert(schema_name.to_owned(), id);
                id
            }
        };
        let key = (topic.to_owned(), schema_id);
        let (channel_id, seq) = match self.channels.get_mut(&key) {
            Some(c) => c,
            None => {
                let id = self
                    .writer
                    .add_channel(schema_id, topic, "json", &BTreeMap::new())?;
                self.channels.entry(key).or_insert((id, 0))
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
    pub(crate) fn flush(&mut self) -> Result<(), RecordError> {
        self.writer.flush()?;
        Ok(())
    }

    pub(crate) fn finish(mut self) -> Result<RecordSummary, RecordError> {
        self.writer.finish()?;
        self.summary.channels = self.channels.len();
        Ok(self.summary)
    }
}

/// The recording being written, in parts ([`crate::parts`]): every message goes to the
/// current part, which is finished and replaced every [`crate::parts::PART_EVERY`].
struct Parts<'a> {
    out: PathBuf,
    dir: PathBuf,
    scenario: &'a Scenario,
    /// The current part's number, and the part.
    n: u32,
    sink: McapSink,
    index: Index,
}

impl<'a> Parts<'a> {
    fn begin(out: &Path, scenario: &'a Scenario) -> Result<Self, RecordError> {
        let dir = parts_dir(out);
        if dir.exists() {
            return Err(RecordError::PartsLeft(dir.display().to_string()));
        }
        std::fs::create_dir_all(&dir).map_err(io_error(&dir))?;
        let sink = Self::part(&dir, 0, scenario)?;
        Ok(Self {
            out: out.to_owned(),
            dir,
            scenario,
            n: 0,
            sink,
            index: Index::default(),
        })
    }

    /// Part `n`, begun: what every part starts with, so that each stands alone.
    fn part(dir: &Path, n: u32, scenario: &Scenario) -> Result<McapSink, RecordError> {
        let mut sink = McapSink::create(&part_path(dir, n, false))?;
        sink.describe(scenario)?;
        let (json, t) = site_scene(scenario);
        sink.write(
            scene::SITE_TOPIC,
            scene::SCHEMA_NAME,
            scene_schema,
            &json,
            t,
        )?;
        Ok(sink)
    }

    /// Finish the current part and begin the next.
    fn rotate(&mut self) -> Result<(), RecordError> {
        let next = Self::part(&self.dir, self.n + 1, self.scenario)?;
        let done = std::mem::replace(&mut self.sink, next);
        close(&self.dir, self.n, &mut self.index, done)?;
        self.n += 1;
        Ok(())
    }

    /// Finish the last part and merge the parts into the recording's one file (written
    /// aside and renamed into place); the parts are removed once it is.
    fn finish(self) -> Result<RecordSummary, RecordError> {
        let Self {
            out,
            dir,
            scenario,
            n,
            sink,
            mut index,
        } = self;
        close(&dir, n, &mut index, sink)?;
        let mut aside = out.as_os_str().to_owned();
        aside.push(".partial");
        let aside = PathBuf::from(aside);
        let mut merged = McapSink::create(&aside)?;
        merged.describe(scenario)?;
        let parts = Recording::load(&dir)?;
        for m in parts.messages() {
            merged.copy(&m?)?;
        }
        let summary = merged.finish()?;
        std::fs::rename(&aside, &out).map_err(io_error(&out))?;
        std::fs::remove_dir_all(&dir).map_err(io_error(&dir))?;
        Ok(summary)
    }
}

/// Finish part `n` of `dir`, put it in place and list it in the index.
fn close(dir: &Path, n: u32, index: &mut Index, sink: McapSink) -> Result<(), RecordError> {
    let summary = sink.finish()?;
    let (from, to) = (part_path(dir, n, false), part_path(dir, n, true));
    std::fs::rename(&from, &to).map_err(io_error(&to))?;
    index.parts.push(Part {
        file: to
            .file_name()
            .expect("a part has a name")
            .to_string_lossy()
            .into_owned(),
        messages: summary.messages,
    });
    index.store(dir).map_err(io_error(dir))
}

fn scene_schema() -> schemars::Schema {
    schemars::schema_for!(scene::SceneUpdate)
}

/// The site's geometry as a scene update, and its time.
fn site_scene(scenario: &Scenario) -> (Vec<u8>, u64) {
    let t = now_ns();
    let statics = scene::static_scene(scenario, scene::Time::from_nanos(t));
    (serde_json::to_vec(&statics).expect("serialises"), t)
}

/// Where the recording goes: a file in parts, the live server, or both.
struct Out<'a> {
    file: Option<Parts<'a>>,
    live: Option<Arc<Live>>,
    messages: u64,
    skipped: u64,
}

impl<'a> Out<'a> {
    fn begin(
        file: Option<&Path>,
        live: Option<Arc<Live>>,
        scenario: &'a Scenario,
    ) -> Result<Self, RecordError> {
        let file = file.map(|path| Parts::begin(path, scenario)).transpose()?;
        if let Some(live) = &live {
            let (json, t) = site_scene(scenario);
            live.publish(
                scene::SITE_TOPIC,
                scene::SCHEMA_NAME,
                scene_schema,
                &json,
                t,
            );
        }
        Ok(Self {
            file,
            live,
            messages: 0,
            skipped: 0,
        })
    }

    fn write(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema: fn() -> schemars::Schema,
        json: &[u8],
        t_ns: u64,
    ) -> Result<(), RecordError> {
        if let Some(file) = &mut self.file {
            file.sink.write(topic, schema_name, schema, json, t_ns)?;
        }
        if let Some(live) = &self.live {
            live.publish(topic, schema_name, schema, json, t_ns);
        }
        self.messages += 1;
        Ok(())
    }

    fn flush(&mut self) -> Result<(), RecordError> {
        self.file.as_mut().map_or(Ok(()), |f| f.sink.flush())
    }

    /// Begin the file's next part; true if there is a file.
    fn rotate(&mut self) -> Result<bool, RecordError> {
        self.file
            .as_mut()
            .map(Parts::rotate)
            .transpose()
            .map(|r| r.is_some())
    }

    fn finish(self) -> Result<RecordSummary, RecordError> {
        let mut summary = match self.file {
            Some(file) => file.finish()?,
            None => RecordSummary {
                messages: self.messages,
                ..RecordSummary::default()
            },
        };
        summary.skipped = self.skipped;
        Ok(summary)
    }
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// Record everything on the site until `shutdown` completes: to the file `path` if there
/// is one (in parts finished every `part_every`, [`crate::parts::PART_EVERY`] unless there
/// is a reason, merged into the one file when it does), and to `live`'s clients if there
/// is a live server.
pub async fn record(
    bus: &Bus,
    scenario: &Scenario,
    path: Option<&Path>,
    live: Option<Arc<Live>>,
    part_every: std::time::Duration,
    shutdown: impl Future<Output = ()>,
) -> Result<RecordSummary, RecordError> {
    let keys = bus.keys().clone();
    let mut sink = Out::begin(path, live, scenario)?;
    let mut budget = Budget::new(BYTES_PER_CHANNEL_S);
    let result = async {
        let mut samples = bus.subscribe_raw(&[&keys.all()], false).await?;
        let tokens = bus.watch_tokens(&keys.all()).await?;
        let recall = bus.serve(keys.every_fire().as_str()).await?;
        // The coordinator's state that outlives it: `coord/*` queries are answered with the
        // newest of `coord/barred` and `coord/goals` seen (by their site time).
        let coord_q = bus.serve(&keys.every_coord()).await?;
        // The latest track of every fire, as received (its time, and the message with the
        // coordinator's seal, which a recall checks).
        let mut fires: BTreeMap<FireId, (f64, Raw)> = BTreeMap::new();
        // Newest by key: its time, and the message as heard (the barred space with the
        // coordinator's seal, which a unit checks).
        let mut newest: BTreeMap<String, (f64, Raw)> = BTreeMap::new();
        let liveliness_topic = format!("{}/liveliness", keys.site());
        let mut next_scene = 0.0;
        let mut fleet = Fleet::default();
        let mut flush = tokio::time::interval(FLUSH_EVERY);
        let mut rotate = tokio::time::interval_at(tokio::time::Instant::now() + part_every, part_every);
        let mut redraw = tokio::time::interval(FLEET_PERIOD);
        // A new part stands alone: it gets the fleet's layer and heat whether they changed
        // or not.
        let mut new_part = false;
        tokio::pin!(shutdown);
        loop {
            tokio::select! {
                _ = &mut shutdown => break,
                _ = flush.tick() => sink.flush()?,
                _ = rotate.tick() => new_part |= sink.rotate()?,
                _ = redraw.tick() => {
                    let (drawn, heat) = fleet.take_changes();
                    let t = now_ns();
                    let ts = scene::Time::from_nanos(t);
                    if drawn || new_part {
                        let update = serde_json::to_vec(&scene::fleet_scene(scenario, &fleet, ts)).expect("serialises");
                        sink.write(scene::SCENE_TOPIC, scene::SCHEMA_NAME, scene_schema, &update, t)?;
                    }
                    if fleet.take_infra_change() || (new_part && fleet.has_infra()) {
                        let update = serde_json::to_vec(&scene::infra_scene(scenario, &fleet, ts)).expect("serialises");
                        sink.write(scene::INFRA_TOPIC, scene::SCHEMA_NAME, scene_schema, &update, t)?;
                    }
                    if heat || new_part {
                        let grid = serde_json::to_vec(&scene::heat_grid(scenario, &fleet, ts)).expect("serialises");
                        sink.write(scene::HEAT_TOPIC, scene::GRID_SCHEMA_NAME, || schemars::schema_for!(scene::Grid), &grid, t)?;
                    }
                    new_part = false;
                }
                Some((topic, alive)) = tokens.recv() => {
                    let key = keys.expr(&topic);
                    if let Topic::UnitAlive(unit) = topic {
                        fleet.token(unit, alive);
                    }
                    let l = Liveliness { key, alive };
                    let json = serde_json::to_vec(&l).expect("serialises");
                    sink.write(&liveliness_topic, Liveliness::NAME, || schemars::schema_for!(Liveliness), &json, now_ns())?;
                }
                Some(query) = recall.recv() => {
                    for (_, heard) in fires.values() {
                        if let Err(e) = query.answer_as_heard(heard).await {
                            tracing::warn!("fire track reply failed: {e}");
                        }
                    }
                }
                Some(query) = coord_q.recv() => {
                    let key = query.key().to_owned();
                    if let Some((_, heard)) = newest.get(&key)
                        && let Err(e) = query.answer_as_heard(heard).await
                    {
                        tracing::warn!(key, "reply failed: {e}");
                    }
                }
                Some(s) = samples.recv() => {
                    let key = s.key.as_str();
                    if s.deleted
                        && let Some(Topic::ZoneGoal(zone, by)) = s.topic()
                    {
                        let json = serde_json::to_vec(&GoalClear { zone, by }).expect("serialises");
                        sink.write(key, GoalClear::NAME, || schemars::schema_for!(GoalClear), &json, now_ns())?;
                        continue;
                    }
                    let bytes = &s.bytes;
                    let parsed = keys::parse(key).map_err(|e| e.to_string())
                        .and_then(|(_, topic)| Payload::from_wire(&topic, bytes).map_err(|e| e.to_string()));
                    let mut p = match parsed {
                        Ok(p) => p,
                        Err(reason) => {
                            sink.skipped += 1;
                            bus.rejects().refuse_invalid(key, &format_args!("not recorded: {reason}"));
                            continue;
                        }
                    };
                    // A thermal core's frame (115 kB at 8.7 Hz a unit) is the unit's to look
                    // at, not the incident's record: what it found is in the unit's reports.
                    if let Payload::UnitSensors(s) = &mut p {
                        s.thermal = None;
                    }
                    let t = now_ns();
                    let json = p.to_json();
                    // Over its channel's budget, a message is not written, but still
                    // counts for what the recorder answers and draws.
                    if budget.admit(key, json.len(), std::time::Instant::now()) {
                        sink.write(key, p.name(), p.schema(), &json, t)?;
                    }
                    fleet.observe(&p);
                    let log = |log: scene::Log| serde_json::to_vec(&log).expect("serialises");
                    match p {
                        Payload::SimTruth(truth) if truth.t >= next_scene => {
                            next_scene = truth.t + SCENE_PERIOD_S;
                            let update = scene::truth_scene(scenario, &truth, scene::Time::from_nanos(t));
                            sink.write(scene::TRUTH_TOPIC, scene::SCHEMA_NAME, scene_schema, &serde_json::to_vec(&update).expect("serialises"), t)?;
                        }
                        Payload::Decision(decision) => {
                            let entry = log(scene::Log::info("coordinator", &decision, scene::Time::from_nanos(t)));
                            sink.write(scene::LOG_TOPIC, scene::LOG_SCHEMA_NAME, || schemars::schema_for!(scene::Log), &entry, t)?;
                        }
                        Payload::Ack(ack) => {
                            let entry = log(scene::Log::ack(&ack, scene::Time::from_nanos(t)));
                            sink.write(scene::LOG_TOPIC, scene::LOG_SCHEMA_NAME, || schemars::schema_for!(scene::Log), &entry, t)?;
                        }
                        Payload::Barred(BarredSpace { t: at, .. }) | Payload::Goals(GoalsInForce { t: at, .. })
                            if newest.get(key).is_none_or(|(old, _)| *old <= at) =>
                        {
                            newest.insert(key.to_owned(), (at, s.clone()));
                        }
                        Payload::Fire(track) if fires.get(&track.id).is_none_or(|(old, _)| *old <= track.t) => {
                            fires.insert(track.id, (track.t, s.clone()));
                        }
                        _ => {}
                    }
                }
            }
        }
        Ok::<(), RecordError>(())
    }
    .await;
    // Finish the file whatever happened above, so that what was recorded stays readable.
    let mut summary = sink.finish()?;
    summary.dropped = bus.rejects().overflow();
    summary.over_budget = budget.dropped();
    result.map(|_| summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_recording_says_what_site_file_and_build_it_is_of() {
        let dir = tempfile::tempdir().unwrap();
        let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/scenarios");
        let mut files: Vec<_> = std::fs::read_dir(&examples)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        assert!(files.len() >= 5, "{files:?}");
        for file in files {
            let scenario = Scenario::load(&file).unwrap();
            let path = dir.path().join("run.mcap");
            let mut sink = McapSink::create(&path).unwrap();
            sink.describe(&scenario).unwrap();
            sink.finish().unwrap();
            let bytes = std::fs::read(&path).unwrap();
            let summary = mcap::read::Summary::read(&bytes).unwrap().unwrap();
            assert_eq!(summary.metadata_indexes.len(), 1);
            let m = mcap::read::metadata(&bytes, &summary.metadata_indexes[0]).unwrap();
            assert_eq!(m.name, METADATA_NAME);
            assert_eq!(m.metadata["firefleet_version"], env!("CARGO_PKG_VERSION"));
            assert_eq!(m.metadata["protocol_version"], PROTOCOL_VERSION.to_string());
            assert_eq!(m.metadata["site"], scenario.site.to_string());
            let back = Scenario::from_toml(&m.metadata["site_file"], "metadata").unwrap();
            assert_eq!(back, scenario, "{}", file.display());
        }
    }
}
