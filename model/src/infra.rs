//! The tunnel's own equipment as the site file describes it: its longitudinal ventilation
//! and the register map through which its SCADA serves the linear heat detector (DTS) and
//! the ventilation over Modbus TCP.
//!
//! A road or rail tunnel's fibre-optic linear heat detector measures the ceiling's
//! temperature every metre or so and groups the metres into alarm zones; the tunnel's
//! SCADA lists the zones (maximum, rate of rise, alarm state) and the ventilation (air
//! velocity, jet fans) as Modbus registers for other systems. The map is the contract
//! between whoever serves those registers (the simulator, or the site's SCADA) and
//! `firefleet scada`, which reads them: both encode and decode through this module, so the
//! two cannot disagree.
//!
//! ```toml
//! [ventilation]              # optional: longitudinal ventilation
//! air_m_s = 2.0              # air velocity the running fans give; + towards the end
//! fans = [{ name = "jf-1", chainage_m = 40.0 }, { name = "jf-2", chainage_m = 260.0 }]
//!
//! [scada]                    # optional: the tunnel's SCADA over Modbus TCP
//! unit_id = 1                # Modbus unit identifier (default 1)
//! [scada.dts]
//! zone_length_m = 10.0       # zone k spans [k L, (k + 1) L) from chainage 0
//! first_register = 0         # input register of zone 0 (default 0)
//! temperature_scale_c = 0.1  # degrees C per count (default 0.1)
//! rise_scale_c_min = 0.1     # K/min per count (default 0.1)
//! period_s = 10.0            # how often the detector measures (default 10)
//! alarm_max_c = 60.0         # alarm criteria (defaults as shown)
//! alarm_rise_c_min = 10.0
//! alarm_differential_c = 15.0
//! [scada.vent]
//! first_register = 1000      # default 1000
//! velocity_scale_m_s = 0.01  # m/s per count (default 0.01)
//! ```
//!
//! The registers, all Modbus input registers (function 4), 16 bits, signed where a value
//! may be negative:
//!
//! | register | holds |
//! | --- | --- |
//! | `dts.first_register + 3k` | zone k's maximum temperature, signed, `temperature_scale_c` |
//! | `dts.first_register + 3k + 1` | zone k's rate of rise, signed, `rise_scale_c_min` |
//! | `dts.first_register + 3k + 2` | zone k's state: bit 0 maximum alarm, bit 1 rate-of-rise alarm, bit 2 differential alarm, bit 15 fault |
//! | `vent.first_register` | air velocity along the tunnel, signed, `velocity_scale_m_s`; + towards the end |
//! | `vent.first_register + 1` | number of jet fans (must match the site file) |
//! | `vent.first_register + 2 + i` | fan i's state: 0 off, 1 blowing towards the end, 2 towards chainage 0, 3 fault |
//!
//! The alarm criteria are the three a DTS zone is commonly configured with (EN 54-22 lists
//! maximum and rate-of-rise classes; vendors add the differential): the zone's maximum at
//! or above `alarm_max_c`, its rise at or above `alarm_rise_c_min` over the last
//! measurement, or its maximum `alarm_differential_c` above the mean of all zones.
//!
//! Not here: computing temperatures (`firefleet-sim`) or Modbus itself (the simulator's
//! server and the bridge).

use serde::{Deserialize, Serialize};

use crate::validate::{Invalid, in_range};

/// Most DTS zones a site may map: 25 km of tunnel in 10 m zones.
pub const MAX_DTS_ZONES: usize = 2500;
/// Most jet fans a site may list.
pub const MAX_FANS: usize = 256;
/// Registers per DTS zone.
pub const DTS_REGISTERS_PER_ZONE: u16 = 3;
/// Most registers one Modbus read may ask for (the protocol's own limit).
pub const MAX_READ: u16 = 125;
/// Temperatures a DTS fibre reports, degrees C: beyond this a reading is a fault.
pub const DTS_RANGE_C: (f64, f64) = (-40.0, 1200.0);
/// Rates of rise a reading may have, K/min.
pub const DTS_RISE_RANGE_C_MIN: f64 = 2000.0;
/// Air velocities along a tunnel a reading may have, m/s.
pub const AIR_RANGE_M_S: f64 = 20.0;

const BIT_MAX: u16 = 1;
const BIT_RISE: u16 = 1 << 1;
const BIT_DIFF: u16 = 1 << 2;
const BIT_FAULT: u16 = 1 << 15;

/// The tunnel's longitudinal ventilation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ventilation {
    /// Air velocity along the tunnel that the running fans give, m/s, positive towards
    /// the tunnel's end (away from chainage 0). The simulator takes it as given: the
    /// momentum balance of fans, fire and portals is commissioning's to measure, not ours.
    pub air_m_s: f64,
    #[serde(default)]
    pub fans: Vec<JetFan>,
}

/// A jet fan under the ceiling.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JetFan {
    pub name: String,
    pub chainage_m: f64,
}

/// What a jet fan is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum FanState {
    Off,
    /// Blowing towards the tunnel's end.
    Forward,
    /// Blowing towards chainage 0.
    Reverse,
    Fault,
}

impl Ventilation {
    /// The fans' state as the air says: all blowing with it, or off in still air.
    pub fn fan_state(&self) -> FanState {
        if self.air_m_s > 0.0 {
            FanState::Forward
        } else if self.air_m_s < 0.0 {
            FanState::Reverse
        } else {
            FanState::Off
        }
    }

    pub fn validate(&self, length_m: f64) -> Result<(), Invalid> {
        in_range("air_m_s", self.air_m_s, -AIR_RANGE_M_S, AIR_RANGE_M_S)?;
        if self.fans.len() > MAX_FANS {
            return Err(Invalid::new("fans", format!("at most {MAX_FANS} fans")));
        }
        for (i, f) in self.fans.iter().enumerate() {
            if f.name.trim().is_empty() || f.name.len() > 32 {
                return Err(Invalid::new(
                    format!("fans[{i}].name"),
                    "must have 1 to 32 characters",
                ));
            }
            in_range(
                &format!("fans[{i}].chainage_m"),
                f.chainage_m,
                0.0,
                length_m,
            )?;
        }
        Ok(())
    }
}

/// Where the SCADA serves what, and the DTS's alarm criteria.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScadaMap {
    #[serde(default = "default_unit_id")]
    pub unit_id: u8,
    pub dts: DtsMap,
    #[serde(default)]
    pub vent: VentMap,
}

fn default_unit_id() -> u8 {
    1
}

/// The DTS's zones, registers and alarm criteria.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DtsMap {
    pub zone_length_m: f64,
    #[serde(default)]
    pub first_register: u16,
    #[serde(default = "default_tenth")]
    pub temperature_scale_c: f64,
    #[serde(default = "default_tenth")]
    pub rise_scale_c_min: f64,
    #[serde(default = "default_period")]
    pub period_s: f64,
    #[serde(default = "default_alarm_max")]
    pub alarm_max_c: f64,
    #[serde(default = "default_alarm_rise")]
    pub alarm_rise_c_min: f64,
    #[serde(default = "default_alarm_diff")]
    pub alarm_differential_c: f64,
}

fn default_tenth() -> f64 {
    0.1
}
fn default_period() -> f64 {
    10.0
}
fn default_alarm_max() -> f64 {
    60.0
}
fn default_alarm_rise() -> f64 {
    10.0
}
fn default_alarm_diff() -> f64 {
    15.0
}

/// The ventilation's registers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VentMap {
    #[serde(default = "default_vent_register")]
    pub first_register: u16,
    #[serde(default = "default_velocity_scale")]
    pub velocity_scale_m_s: f64,
}

impl Default for VentMap {
    fn default() -> Self {
        Self {
            first_register: default_vent_register(),
            velocity_scale_m_s: default_velocity_scale(),
        }
    }
}

fn default_vent_register() -> u16 {
    1000
}
fn default_velocity_scale() -> f64 {
    0.01
}

/// Which alarm criteria a zone meets.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
pub struct DtsAlarm {
    pub max: bool,
    pub rise: bool,
    pub differential: bool,
}

impl DtsAlarm {
    pub fn any(&self) -> bool {
        self.max || self.rise || self.differential
    }
}

/// One zone's reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct DtsReading {
    /// Highest temperature along the zone, degrees C.
    pub max_c: f64,
    /// Rate of rise of that maximum since the detector's previous measurement (one
    /// sweep, [`DtsMap::period_s`], before), K/min. The coordinator holds readings to it:
    /// two that one detector cannot give in a row are two voices on the bridge's key.
    pub rise_c_min: f64,
    pub alarm: DtsAlarm,
    /// The detector flags the zone (a broken fibre, a failed channel): its values mean
    /// nothing.
    pub fault: bool,
}

/// The ventilation's reading.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct VentReading {
    /// Air velocity along the tunnel, m/s, positive towards the end.
    pub air_m_s: f64,
    pub fans: Vec<FanState>,
}

/// `v` in counts of `scale`, as a 16-bit signed register.
fn to_i16(v: f64, scale: f64) -> u16 {
    // Saturating: a value off the scale reads as its end, as a transmitter's would.
    ((v / scale)
        .round()
        .clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16) as u16
}

/// A 16-bit signed register in counts of `scale`.
fn from_i16(r: u16, scale: f64) -> f64 {
    f64::from(r as i16) * scale
}

impl ScadaMap {
    pub fn validate(&self, length_m: f64, fans: usize) -> Result<(), Invalid> {
        let d = &self.dts;
        in_range("dts.zone_length_m", d.zone_length_m, 1.0, 1000.0)?;
        let zones = self.zone_count(length_m);
        if zones > MAX_DTS_ZONES {
            return Err(Invalid::new(
                "dts.zone_length_m",
                format!("{zones} zones: at most {MAX_DTS_ZONES}"),
            ));
        }
        // Scales must let the range a reading may take fit 16 signed bits.
        in_range(
            "dts.temperature_scale_c",
            d.temperature_scale_c,
            DTS_RANGE_C.1 / f64::from(i16::MAX),
            10.0,
        )?;
        in_range(
            "dts.rise_scale_c_min",
            d.rise_scale_c_min,
            DTS_RISE_RANGE_C_MIN / f64::from(i16::MAX),
            10.0,
        )?;
        in_range("dts.period_s", d.period_s, 0.1, 600.0)?;
        in_range("dts.alarm_max_c", d.alarm_max_c, 30.0, 500.0)?;
        in_range("dts.alarm_rise_c_min", d.alarm_rise_c_min, 0.5, 500.0)?;
        in_range(
            "dts.alarm_differential_c",
            d.alarm_differential_c,
            1.0,
            500.0,
        )?;
        in_range(
            "vent.velocity_scale_m_s",
            self.vent.velocity_scale_m_s,
            AIR_RANGE_M_S / f64::from(i16::MAX),
            1.0,
        )?;
        let dts = self.dts_block(length_m);
        let vent = self.vent_block(fans);
        if dts.end > 0x1_0000 {
            return Err(Invalid::new(
                "dts.first_register",
                format!("{zones} zones run past register 65535"),
            ));
        }
        if vent.end > 0x1_0000 {
            return Err(Invalid::new(
                "vent.first_register",
                "the fans run past register 65535",
            ));
        }
        if dts.start < vent.end && vent.start < dts.end {
            return Err(Invalid::new(
                "vent.first_register",
                format!(
                    "registers {}..{} overlap the DTS zones' {}..{}",
                    vent.start, vent.end, dts.start, dts.end
                ),
            ));
        }
        Ok(())
    }

    /// How many zones cover a tunnel `length_m` long.
    pub fn zone_count(&self, length_m: f64) -> usize {
        (length_m / self.dts.zone_length_m).ceil().max(1.0) as usize
    }

    /// Zone `k`'s chainage span, m (the last ends at the tunnel's end).
    pub fn zone_span(&self, k: usize, length_m: f64) -> (f64, f64) {
        let l = self.dts.zone_length_m;
        (k as f64 * l, ((k + 1) as f64 * l).min(length_m))
    }

    /// The zone holding chainage `s`.
    pub fn zone_at(&self, s: f64, length_m: f64) -> usize {
        ((s / self.dts.zone_length_m).floor().max(0.0) as usize).min(self.zone_count(length_m) - 1)
    }

    /// The DTS's registers, as addresses (a block of `u32` so its end may be 65536).
    pub fn dts_block(&self, length_m: f64) -> std::ops::Range<u32> {
        let start = u32::from(self.dts.first_register);
        start..start + self.zone_count(length_m) as u32 * u32::from(DTS_REGISTERS_PER_ZONE)
    }

    /// The ventilation's registers.
    pub fn vent_block(&self, fans: usize) -> std::ops::Range<u32> {
        let start = u32::from(self.vent.first_register);
        start..start + 2 + fans as u32
    }

    /// Which criteria a zone whose maximum is `max_c`, rising `rise_c_min`, meets when the
    /// mean of all zones is `mean_c`.
    pub fn alarm(&self, max_c: f64, rise_c_min: f64, mean_c: f64) -> DtsAlarm {
        let d = &self.dts;
        DtsAlarm {
            max: max_c >= d.alarm_max_c,
            rise: rise_c_min >= d.alarm_rise_c_min,
            differential: max_c - mean_c >= d.alarm_differential_c,
        }
    }

    /// The registers of `zones`' readings, from the DTS block's first.
    pub fn encode_dts(&self, zones: &[DtsReading]) -> Vec<u16> {
        let d = &self.dts;
        zones
            .iter()
            .flat_map(|z| {
                let bits = [
                    (z.alarm.max, BIT_MAX),
                    (z.alarm.rise, BIT_RISE),
                    (z.alarm.differential, BIT_DIFF),
                    (z.fault, BIT_FAULT),
                ]
                .iter()
                .filter(|(on, _)| *on)
                .fold(0, |acc, (_, bit)| acc | bit);
                [
                    to_i16(z.max_c, d.temperature_scale_c),
                    to_i16(z.rise_c_min, d.rise_scale_c_min),
                    bits,
                ]
            })
            .collect()
    }

    /// Zone readings from the registers of the DTS block (from its first); a register
    /// that cannot hold what the map says is an error naming the zone and field.
    pub fn decode_dts(&self, regs: &[u16]) -> Result<Vec<DtsReading>, Invalid> {
        regs.chunks_exact(usize::from(DTS_REGISTERS_PER_ZONE))
            .enumerate()
            .map(|(k, r)| self.decode_zone(k, r))
            .collect()
    }

    /// Zone `k`'s reading from its three registers.
    pub fn decode_zone(&self, k: usize, r: &[u16]) -> Result<DtsReading, Invalid> {
        let d = &self.dts;
        let f = |n: &str| format!("dts zone {k} {n}");
        let [max, rise, bits] = r else {
            return Err(Invalid::new(
                f("registers"),
                format!("{} registers, not 3", r.len()),
            ));
        };
        let bits = *bits;
        if bits & !(BIT_MAX | BIT_RISE | BIT_DIFF | BIT_FAULT) != 0 {
            return Err(Invalid::new(
                f("state"),
                format!("{bits:#06x} sets bits the map does not define"),
            ));
        }
        let fault = bits & BIT_FAULT != 0;
        let max_c = from_i16(*max, d.temperature_scale_c);
        let rise_c_min = from_i16(*rise, d.rise_scale_c_min);
        if !fault {
            in_range(&f("maximum"), max_c, DTS_RANGE_C.0, DTS_RANGE_C.1)?;
            in_range(
                &f("rate of rise"),
                rise_c_min,
                -DTS_RISE_RANGE_C_MIN,
                DTS_RISE_RANGE_C_MIN,
            )?;
        }
        Ok(DtsReading {
            max_c,
            rise_c_min,
            alarm: DtsAlarm {
                max: bits & BIT_MAX != 0,
                rise: bits & BIT_RISE != 0,
                differential: bits & BIT_DIFF != 0,
            },
            fault,
        })
    }

    /// The ventilation's registers, from its block's first.
    pub fn encode_vent(&self, v: &VentReading) -> Vec<u16> {
        let mut regs = vec![
            to_i16(v.air_m_s, self.vent.velocity_scale_m_s),
            v.fans.len() as u16,
        ];
        regs.extend(v.fans.iter().map(|f| match f {
            FanState::Off => 0,
            FanState::Forward => 1,
            FanState::Reverse => 2,
            FanState::Fault => 3,
        }));
        regs
    }

    /// The ventilation's reading from its registers; the fan count must be the site's.
    pub fn decode_vent(&self, regs: &[u16], fans: usize) -> Result<VentReading, Invalid> {
        let [air, count, states @ ..] = regs else {
            return Err(Invalid::new("vent", "fewer than two registers"));
        };
        if usize::from(*count) != fans || states.len() != fans {
            return Err(Invalid::new(
                "vent fan count",
                format!("{count} fans, the site file lists {fans}"),
            ));
        }
        let air_m_s = from_i16(*air, self.vent.velocity_scale_m_s);
        in_range("vent air velocity", air_m_s, -AIR_RANGE_M_S, AIR_RANGE_M_S)?;
        let fans = states
            .iter()
            .enumerate()
            .map(|(i, s)| match s {
                0 => Ok(FanState::Off),
                1 => Ok(FanState::Forward),
                2 => Ok(FanState::Reverse),
                3 => Ok(FanState::Fault),
                v => Err(Invalid::new(
                    format!("vent fan {i} state"),
                    format!("{v} is not 0 to 3"),
                )),
            })
            .collect::<Result<_, _>>()?;
        Ok(VentReading { air_m_s, fans })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn map() -> ScadaMap {
        toml::from_str("[dts]\nzone_length_m = 10.0\n").unwrap()
    }

    #[test]
    fn defaults_and_zones() {
        let m = map();
        assert_eq!(m.unit_id, 1);
        assert_eq!(m.vent.first_register, 1000);
        m.validate(240.0, 2).unwrap();
        assert_eq!(m.zone_count(240.0), 24);
        assert_eq!(m.zone_count(245.0), 25);
        assert_eq!(m.zone_span(24, 245.0), (240.0, 245.0));
        assert_eq!(m.zone_at(118.0, 240.0), 11);
        assert_eq!(m.zone_at(240.0, 240.0), 23);
    }

    #[test]
    fn overlapping_blocks_and_bad_scales_are_named() {
        let mut m = map();
        m.vent.first_register = 30;
        let e = m.validate(240.0, 2).unwrap_err();
        assert_eq!(e.field, "vent.first_register");
        assert!(e.reason.contains("overlap"), "{e}");
        let mut m = map();
        m.dts.temperature_scale_c = 0.01;
        assert_eq!(
            m.validate(240.0, 0).unwrap_err().field,
            "dts.temperature_scale_c"
        );
        let mut m = map();
        m.dts.first_register = 65000;
        assert_eq!(
            m.validate(10_000.0, 0).unwrap_err().field,
            "dts.first_register"
        );
    }

    #[test]
    fn undefined_bits_unknown_fan_states_and_wrong_fan_counts_are_refused() {
        let m = map();
        let e = m.decode_dts(&[200, 0, 1 << 4]).unwrap_err();
        assert!(e.field.contains("zone 0 state"), "{e}");
        let e = m.decode_vent(&[100, 1, 7], 1).unwrap_err();
        assert_eq!(e.field, "vent fan 0 state");
        let e = m.decode_vent(&[100, 2, 1, 1], 1).unwrap_err();
        assert!(e.reason.contains("site file lists 1"), "{e}");
        // 25 000 counts of 0.01 m/s: 250 m/s is no tunnel's air.
        assert!(m.decode_vent(&[25_000, 0], 0).is_err());
    }

    #[test]
    fn alarm_criteria() {
        let m = map();
        assert_eq!(m.alarm(25.0, 0.0, 22.0), DtsAlarm::default());
        assert!(m.alarm(61.0, 0.0, 55.0).max);
        assert!(m.alarm(30.0, 12.0, 29.0).rise);
        assert!(m.alarm(40.0, 0.0, 22.0).differential);
    }

    proptest! {
        #[test]
        fn readings_round_trip_through_registers(
            max in -40.0..1200.0f64, rise in -500.0..500.0f64,
            a in any::<(bool, bool, bool, bool)>(), air in -20.0..20.0f64, n in 0..5usize,
        ) {
            let m = map();
            let z = DtsReading {
                max_c: max, rise_c_min: rise,
                alarm: DtsAlarm { max: a.0, rise: a.1, differential: a.2 }, fault: a.3,
            };
            let back = m.decode_dts(&m.encode_dts(&[z, z])).unwrap();
            prop_assert_eq!(back.len(), 2);
            prop_assert!((back[0].max_c - max).abs() <= 0.05 + 1e-9);
            prop_assert!((back[0].rise_c_min - rise).abs() <= 0.05 + 1e-9);
            prop_assert_eq!(back[0].alarm, z.alarm);
            prop_assert_eq!(back[0].fault, z.fault);
            let v = VentReading { air_m_s: air, fans: vec![FanState::Reverse; n] };
            let back = m.decode_vent(&m.encode_vent(&v), n).unwrap();
            prop_assert!((back.air_m_s - air).abs() <= 0.005 + 1e-9);
            prop_assert_eq!(back.fans, v.fans);
        }
    }
}
