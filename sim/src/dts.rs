//! The tunnel's linear heat detector (DTS): a sensing fibre along the ceiling, read every
//! metre, grouped into the alarm zones of the site's SCADA map ([`firefleet_model::infra`]).
//!
//! Each measurement (every `period_s`, as a real DTS sweeps its fibre in 10 to 30 s) takes
//! every zone's maximum, its rate of rise since the previous measurement, and the alarm
//! criteria of the map. The temperatures come from the world's ceiling-gas model
//! ([`crate::physics::ceiling_rise_c`]), the same the monorail's thermometer reads.
//!
//! Not here: Modbus ([`crate::scada`]) or the temperature model itself.

use firefleet_model::infra::{DtsReading, ScadaMap};

/// Metres of fibre between two temperature samples: the resolution DTS vendors quote.
pub const SAMPLE_M: f64 = 1.0;

/// The detector and its latest measurement.
#[derive(Debug, Clone)]
pub struct Dts {
    map: ScadaMap,
    length_m: f64,
    /// Site time of the latest measurement and each zone's maximum then.
    last: Option<(f64, Vec<f64>)>,
    readings: Vec<DtsReading>,
}

/// What of the detector changes as it measures: its latest measurement (each zone's
/// maximum, for the next rate of rise) and the readings it gives.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct DtsState {
    last: Option<(f64, Vec<f64>)>,
    readings: Vec<DtsReading>,
}

impl Dts {
    pub fn new(map: ScadaMap, length_m: f64) -> Self {
        Self {
            map,
            length_m,
            last: None,
            readings: Vec::new(),
        }
    }

    pub fn map(&self) -> &ScadaMap {
        &self.map
    }

    /// What changes as it measures ([`crate::world::Snapshot`]).
    pub fn state(&self) -> DtsState {
        DtsState {
            last: self.last.clone(),
            readings: self.readings.clone(),
        }
    }

    /// Carry on from what [`Self::state`] gave.
    pub fn restore(&mut self, s: DtsState) {
        self.last = s.last;
        self.readings = s.readings;
    }

    /// A measurement is due at `t`.
    pub fn due(&self, t: f64) -> bool {
        self.last
            .as_ref()
            .is_none_or(|(at, _)| t - at >= self.map.dts.period_s - 1e-9)
    }

    /// Measure at `t` with `temperature_c(chainage)` the ceiling's temperature.
    pub fn measure(&mut self, t: f64, temperature_c: impl Fn(f64) -> f64) {
        let zones = self.map.zone_count(self.length_m);
        let maxima: Vec<f64> = (0..zones)
            .map(|k| {
                let (a, b) = self.map.zone_span(k, self.length_m);
                let n = ((b - a) / SAMPLE_M).ceil().max(1.0) as usize;
                (0..=n)
                    .map(|i| temperature_c(a + (b - a) * i as f64 / n as f64))
                    .fold(f64::NEG_INFINITY, f64::max)
            })
            .collect();
        let mean = maxima.iter().sum::<f64>() / zones as f64;
        self.readings = maxima
            .iter()
            .enumerate()
            .map(|(k, &max_c)| {
                let rise_c_min = match &self.last {
                    Some((at, before)) if t > *at => (max_c - before[k]) / (t - at) * 60.0,
                    _ => 0.0,
                };
                DtsReading {
                    max_c,
                    rise_c_min,
                    alarm: self.map.alarm(max_c, rise_c_min, mean),
                    fault: false,
                }
            })
            .collect();
        self.last = Some((t, maxima));
    }

    /// The latest measurement: its site time and the zones' readings.
    pub fn readings(&self) -> Option<(f64, &[DtsReading])> {
        self.last
            .as_ref()
            .map(|(t, _)| (*t, self.readings.as_slice()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_zone_over_a_hot_spot_alarms_and_its_rise_is_per_minute() {
        let map: ScadaMap =
            toml::from_str("[dts]\nzone_length_m = 10.0\nperiod_s = 10.0\n").expect("a map");
        let mut dts = Dts::new(map, 100.0);
        assert!(dts.due(0.0));
        dts.measure(0.0, |_| 20.0);
        assert!(!dts.due(5.0));
        let (_, r) = dts.readings().unwrap();
        assert!(r.iter().all(|z| !z.alarm.any()));
        // A hot spot at 47 m, 5 K a metre either side, from 20 C to 120 C in 10 s.
        dts.measure(10.0, |s| 20.0 + (100.0 - 5.0 * (s - 47.0).abs()).max(0.0));
        let (t, r) = dts.readings().unwrap();
        assert_eq!(t, 10.0);
        assert_eq!(r.len(), 10);
        assert!((r[4].max_c - 120.0).abs() < 1e-9);
        assert!((r[4].rise_c_min - 600.0).abs() < 1e-9);
        assert!(r[4].alarm.max && r[4].alarm.rise && r[4].alarm.differential);
        assert!(!r[0].alarm.any() && !r[9].alarm.any());
    }
}
