//! The tunnel's own senses on the bus (postcard), as `firefleet scada` reads them from the
//! tunnel's SCADA: every DTS zone, the ventilation, and the state of the link itself.
//!
//! A reading the bridge could not renew is sent again marked `stale`, with the site time it
//! was taken: the bridge never invents a value, and a receiver never mistakes an old
//! reading for a new one.
//!
//! Not here: the register map ([`firefleet_model::infra`]) or what the coordinator makes
//! of an alarm.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use firefleet_model::infra::{
    AIR_RANGE_M_S, DTS_RANGE_C, DTS_RISE_RANGE_C_MIN, DtsReading, MAX_DTS_ZONES, MAX_FANS,
    VentReading,
};
use firefleet_model::validate::{Invalid, Validate, finite, in_range, max_len};

/// `ff/<site>/infra/dts/<zone>`: one DTS zone.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct DtsZone {
    /// The zone's index in the site's map.
    pub zone: u16,
    /// Its chainage span, m.
    pub start_m: f64,
    pub end_m: f64,
    /// Site time the reading was taken.
    pub t: f64,
    pub reading: DtsReading,
    /// The reading could not be renewed (the link is down, or its registers failed):
    /// this is the last good one, from `t`.
    pub stale: bool,
}

impl Validate for DtsZone {
    fn validate(&self) -> Result<(), Invalid> {
        if usize::from(self.zone) >= MAX_DTS_ZONES {
            return Err(Invalid::new(
                "zone",
                format!("at most {MAX_DTS_ZONES} zones"),
            ));
        }
        in_range("start_m", self.start_m, 0.0, 1e5)?;
        in_range("end_m", self.end_m, self.start_m, 1e5)?;
        in_range("t", self.t, 0.0, 1e10)?;
        let r = &self.reading;
        if r.fault {
            finite("reading.max_c", r.max_c)?;
            finite("reading.rise_c_min", r.rise_c_min)
        } else {
            in_range("reading.max_c", r.max_c, DTS_RANGE_C.0, DTS_RANGE_C.1)?;
            in_range(
                "reading.rise_c_min",
                r.rise_c_min,
                -DTS_RISE_RANGE_C_MIN,
                DTS_RISE_RANGE_C_MIN,
            )
        }
    }
}

/// `ff/<site>/infra/vent`: the ventilation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Vent {
    /// Site time the reading was taken.
    pub t: f64,
    pub reading: VentReading,
    /// As [`DtsZone::stale`].
    pub stale: bool,
}

impl Validate for Vent {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("t", self.t, 0.0, 1e10)?;
        in_range(
            "reading.air_m_s",
            self.reading.air_m_s,
            -AIR_RANGE_M_S,
            AIR_RANGE_M_S,
        )?;
        max_len("reading.fans", &self.reading.fans, MAX_FANS)
    }
}

/// `ff/<site>/infra/link`: the bridge's link to the SCADA, every poll.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ScadaLink {
    pub t: f64,
    /// The last poll read every register (a zone whose registers make no sense is counted
    /// in `out_of_range` and goes stale; the link still holds).
    pub up: bool,
    /// Site time of the last poll that did.
    pub last_ok: Option<f64>,
    /// Polls so far, and those that failed, by why.
    pub polls: u64,
    pub timeouts: u64,
    pub disconnects: u64,
    pub exceptions: u64,
    pub out_of_range: u64,
    /// What went wrong last, empty while up.
    pub problem: String,
}

/// Longest problem text a link message carries.
pub const MAX_PROBLEM: usize = 256;

impl Validate for ScadaLink {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("t", self.t, 0.0, 1e10)?;
        if let Some(t) = self.last_ok {
            in_range("last_ok", t, 0.0, self.t)?;
        }
        if self.problem.len() > MAX_PROBLEM {
            return Err(Invalid::new(
                "problem",
                format!("at most {MAX_PROBLEM} bytes"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::infra::DtsAlarm;

    #[test]
    fn readings_out_of_the_detectors_range_are_refused_unless_faulted() {
        let mut z = DtsZone {
            zone: 3,
            start_m: 30.0,
            end_m: 40.0,
            t: 12.0,
            reading: DtsReading {
                max_c: 85.0,
                rise_c_min: 20.0,
                alarm: DtsAlarm {
                    max: true,
                    ..DtsAlarm::default()
                },
                fault: false,
            },
            stale: false,
        };
        z.validate().unwrap();
        z.reading.max_c = 5000.0;
        assert_eq!(z.validate().unwrap_err().field, "reading.max_c");
        z.reading.fault = true;
        z.validate().unwrap();
        z.end_m = 20.0;
        assert_eq!(z.validate().unwrap_err().field, "end_m");
    }
}
