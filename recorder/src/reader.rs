//! Reading recordings back: the fire tracks and the commanders' goals a recording holds,
//! for a coordinator resumed from the file of a recorder that is gone.
//!
//! A recording cut short (a recorder killed mid-write) is read up to the cut, and one the
//! recorder did not live to merge from its parts, part by part ([`crate::parts`]). Not here:
//! the timeline for people ([`crate::replay`]).

use firefleet_model::SiteId;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{FireTrack, GoalsInForce, latest_per_fire};

use crate::parts::Recording;

/// Why a recording could not be read at all.
#[derive(Debug, thiserror::Error)]
#[error("not an MCAP recording: {0}")]
pub struct NotARecording(#[from] mcap::McapError);

/// What a coordinator resumes from a recording.
#[derive(Debug, Clone, Default)]
pub struct Recorded {
    /// The latest track of every fire, by its site time.
    pub tracks: Vec<FireTrack>,
    /// The newest goals in force the coordinator published, by its site time: without
    /// them a coordinator restarted with no recorder running would lift every keep-out.
    pub goals: Option<GoalsInForce>,
    /// Records on a fire or goals channel that do not decode as one, with why.
    pub refused: Vec<String>,
    /// Where the file stopped being readable, if it did before its end (a recorder
    /// killed before it could finish the file): what came before is still used.
    pub cut_short: Option<String>,
}

/// The latest track of every fire of `site` in a recording made by [`crate::record()`] (a JSON
/// record on each `ff/<site>/fire/f<n>` channel), and the newest goals in force (on
/// `ff/<site>/coord/goals`).
pub fn incident_in(recording: &Recording, site: &SiteId) -> Result<Recorded, NotARecording> {
    let mut out = Recorded::default();
    let mut tracks = Vec::new();
    for (k, m) in recording.messages().enumerate() {
        let m = match m {
            Ok(m) => m,
            // Nothing readable at all: not a recording (a recording's first records are
            // the recorder's scene).
            Err(e) if k == 0 => return Err(NotARecording(e)),
            // A file cut short ends there; the next part (if any) follows.
            Err(e) => {
                out.cut_short = Some(e.to_string());
                continue;
            }
        };
        let refuse =
            |e: serde_json::Error| format!("{} at {} ns: {e}", m.channel.topic, m.log_time);
        match keys::parse(&m.channel.topic) {
            Ok((s, Topic::Fire(_))) if s == *site => {
                match serde_json::from_slice::<FireTrack>(&m.data) {
                    Ok(track) => tracks.push(track),
                    Err(e) => out.refused.push(refuse(e)),
                }
            }
            Ok((s, Topic::CoordGoals)) if s == *site => {
                match serde_json::from_slice::<GoalsInForce>(&m.data) {
                    Ok(g) => out.goals = GoalsInForce::newer(Some(g), out.goals.take()),
                    Err(e) => out.refused.push(refuse(e)),
                }
            }
            _ => {}
        }
    }
    out.tracks = latest_per_fire(tracks);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::McapSink;
    use firefleet_model::FireId;
    use firefleet_model::geometry::Point2;
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
    fn recording(records: &[(&str, Vec<u8>)]) -> Recording {
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
        Recording::load(&path).unwrap()
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
        let r = incident_in(&bytes, &site).unwrap();
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
    fn a_recording_gives_back_the_newest_goals_in_force_of_its_site() {
        let site = SiteId::new("tunnel-a").unwrap();
        let goals = |t: f64| {
            serde_json::to_vec(&GoalsInForce {
                t,
                ..GoalsInForce::default()
            })
            .unwrap()
        };
        let bytes = recording(&[
            ("ff/tunnel-a/coord/goals", goals(5.0)),
            ("ff/tunnel-a/coord/goals", goals(9.0)),
            // Late, another site's, and corrupt.
            ("ff/tunnel-a/coord/goals", goals(7.0)),
            ("ff/tunnel-b/coord/goals", goals(20.0)),
            (
                "ff/tunnel-a/coord/goals",
                b"{\"t\": 30.0, \"goals\": 3}".to_vec(),
            ),
        ]);
        let r = incident_in(&bytes, &site).unwrap();
        assert_eq!(r.goals.map(|g| g.t), Some(9.0));
        assert_eq!(r.refused.len(), 1, "{:?}", r.refused);
        assert!(r.tracks.is_empty());
        let none = recording(&[("ff/tunnel-a/fire/f1", json(&track(1, 1.0)))]);
        assert!(incident_in(&none, &site).unwrap().goals.is_none());
    }

    #[test]
    fn a_recording_cut_short_gives_back_what_comes_before_the_cut() {
        let site = SiteId::new("tunnel-a").unwrap();
        let mut records: Vec<(&str, Vec<u8>)> = (0..200)
            .map(|k| ("ff/tunnel-a/fire/f1", json(&track(1, f64::from(k)))))
            .collect();
        records.push(("ff/tunnel-a/fire/f2", json(&track(2, 500.0))));
        let whole = &recording(&records).files[0].1;
        // A recorder killed mid-write: no summary, no footer, half a chunk.
        let cut = Recording::from_bytes(whole[..whole.len() / 2].to_vec());
        let r = incident_in(&cut, &site).unwrap();
        assert!(r.cut_short.is_some());
        assert_eq!(r.tracks.len(), 1, "{:?}", r.tracks);
        assert!(r.tracks[0].t > 50.0, "up to the cut: {:?}", r.tracks);
        assert!(r.tracks.iter().all(|t| t.id == FireId(1)), "{:?}", r.tracks);
        assert!(
            incident_in(&Recording::from_bytes(b"not an mcap file".to_vec()), &site).is_err(),
            "not a recording at all"
        );
    }
}
