//! The robot's body as the agent sees it.
//!
//! A [`Platform`] delivers sensor frames (pose from localisation, cannon state, tank level,
//! heat flux, flame detections from the detector node) and accepts actuator set-points.
//! A real robot implements it over its drivers; [`SimPlatform`] implements it over the
//! simulator's `ff/<site>/sim/unit/<id>/...` keys, so the agent code is the same for both.

use std::future::Future;

use firefleet_protocol::UnitId;
use firefleet_protocol::bus::{Bus, BusError, Inbox};
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{UnitCommand, UnitSensors};
use firefleet_protocol::spec::GroundSpec;

/// A robot body: sensors in, set-points out.
pub trait Platform {
    /// The body's datasheet: limits and geometry.
    fn spec(&self) -> &GroundSpec;
    /// The next sensor frame; `None` when the body is gone for good.
    fn sense(&mut self) -> impl Future<Output = Option<UnitSensors>> + Send;
    /// Send set-points; the body applies its own rate limits.
    fn actuate(&mut self, cmd: UnitCommand) -> impl Future<Output = Result<(), BusError>> + Send;
}

/// A simulated body, reached over the bus.
pub struct SimPlatform {
    spec: GroundSpec,
    bus: Bus,
    sensors: Inbox<UnitSensors>,
    cmd_key: String,
}

impl SimPlatform {
    pub async fn connect(bus: &Bus, unit: &UnitId, spec: GroundSpec) -> Result<Self, BusError> {
        let keys = bus.keys();
        let sensors = bus
            .subscribe(&keys.key(&Topic::SimSensors(unit.clone())))
            .await?;
        Ok(Self {
            spec,
            bus: bus.clone(),
            sensors,
            cmd_key: keys.key(&Topic::SimCmd(unit.clone())),
        })
    }
}

impl Platform for SimPlatform {
    fn spec(&self) -> &GroundSpec {
        &self.spec
    }

    async fn sense(&mut self) -> Option<UnitSensors> {
        let (_, mut frame) = self.sensors.recv().await?;
        // Frames queue up if the agent falls behind; act on the newest.
        while let Some((_, newer)) = self.sensors.try_recv() {
            frame = newer;
        }
        Some(frame)
    }

    async fn actuate(&mut self, cmd: UnitCommand) -> Result<(), BusError> {
        self.bus.put(&self.cmd_key, &cmd).await
    }
}
