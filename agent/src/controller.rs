//! A unit's control loop, whatever its kind: a behavior tree ticking over the unit's
//! services.
//!
//! Every sensor frame goes to the services; the tree is ticked at its own rate on the
//! frame's clock (simulated time in the simulator); the services then produce the actuator
//! set-points. Ground units ([`crate::ground`]) and monorail units ([`crate::monorail`])
//! differ only in their services and trees, which is what [`Services`] abstracts.
//!
//! Pure: no I/O, no clock of its own.

use firefleet_bt::{Status, Tree};
use firefleet_protocol::msg::{
    BarredSpace, FlameDetection, FlameReport, TASK_SEQ_LEAD_S, TaskKind, UnitState,
    task_seq_ceiling,
};

use crate::mission::{Responder, review};

/// What a unit kind's services provide to the control loop.
pub trait Services: Responder {
    type Sensors;
    type Command;
    /// Take in a sensor frame.
    fn sense(&mut self, s: &Self::Sensors);
    /// Set-points for the frame just sensed.
    fn command(&mut self) -> Self::Command;
    /// Site time of a frame.
    fn time(s: &Self::Sensors) -> f64;
    /// Set-points that stop the body where the frame says it is, valve shut.
    fn halt(s: &Self::Sensors) -> Self::Command;
    fn state(&self) -> UnitState;
    /// Flames seen since the last report, if any.
    fn report(&mut self) -> Option<FlameReport>;
    /// The barred space in the mission changed: the services enforce the new one.
    fn barred_changed(&mut self);
    /// The flames the unit's own detector found in the frame just sensed, in its sensor's
    /// pixels; `None` when the frame gave it nothing to look at (no thermal image).
    fn found(&self) -> Option<&[FlameDetection]> {
        None
    }
}

/// The control loop of one unit.
pub struct Controller<U> {
    tree: Tree<U>,
    unit: U,
    tick_period_s: f64,
    next_tick: f64,
    /// Site time of the latest frame; `None` before the first.
    now: Option<f64>,
    /// A barred space heard before the first frame, judged when the clock is known.
    pending: Option<BarredSpace>,
}

/// A barred space dated beyond what the site clock allows, refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("barred space dated t = {t:.1} s, ahead of the site clock (t = {now:.1} s): refused")]
pub struct BarredAhead {
    pub t: f64,
    pub now: f64,
}

/// A task the unit refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TaskRefused {
    /// Numbered beyond what the site clock allows ([`task_seq_ceiling`]).
    #[error(
        "task {seq} is numbered ahead of the site clock (t = {t:.1} s takes at most {ceiling}): refused"
    )]
    Ahead { seq: u64, t: f64, ceiling: u64 },
    /// From a term of the coordinator in office older than one the unit has taken a task
    /// from since it took office: that coordinator before a restart.
    #[error(
        "task {seq} of epoch {epoch} is of an older term than the unit obeys (epoch {obeyed}): refused"
    )]
    Fenced { seq: u64, epoch: u64, obeyed: u64 },
}

impl<U: Services> Controller<U> {
    /// `tree` over `unit`, ticked every `tick_period_s` of site time (0: every frame).
    pub fn from_parts(tree: Tree<U>, unit: U, tick_period_s: f64) -> Self {
        Self {
            tree,
            unit,
            tick_period_s,
            next_tick: f64::NEG_INFINITY,
            now: None,
            pending: None,
        }
    }

    /// One control step for sensor frame `s`.
    pub fn step(&mut self, s: &U::Sensors) -> U::Command {
        self.unit.sense(s);
        let t = U::time(s);
        self.now = Some(t);
        if let Some(b) = self.pending.take()
            && let Err(e) = self.on_barred(b)
        {
            tracing::warn!(unit = %self.unit.id(), "{e}");
        }
        if t >= self.next_tick {
            self.next_tick = t + self.tick_period_s;
            self.tick(t);
        }
        self.unit.command()
    }

    pub(crate) fn unit_mut(&mut self) -> &mut U {
        &mut self.unit
    }

    /// Tick the tree once at site time `t` over the unit as it is.
    pub fn tick(&mut self, t: f64) -> Status {
        self.tree.tick(t, &mut self.unit)
    }

    /// A task of coordinator term `epoch` arrived. Older or repeated tasks are ignored;
    /// one numbered ahead of the site clock, or from a term older than the newest the unit
    /// obeys, is refused.
    pub fn on_task(&mut self, epoch: u64, seq: u64, kind: TaskKind) -> Result<(), TaskRefused> {
        let now = self.now.unwrap_or(0.0);
        let ceiling = task_seq_ceiling(now);
        if seq > ceiling {
            return Err(TaskRefused::Ahead {
                seq,
                t: now,
                ceiling,
            });
        }
        self.unit
            .mission()
            .on_task(epoch, seq, kind)
            .map_err(|obeyed| TaskRefused::Fenced { seq, epoch, obeyed })?;
        review(&mut self.unit);
        Ok(())
    }

    /// The coordinator's barred space arrived: kept if newer, then the unit's services and
    /// its task are held to it. One dated ahead of the site clock (by more than the task
    /// numbers' lead) is refused: kept, it would shut out every real one after it. One
    /// heard before the first frame waits for the clock.
    pub fn on_barred(&mut self, barred: BarredSpace) -> Result<(), BarredAhead> {
        let Some(now) = self.now else {
            if self.pending.as_ref().is_none_or(|p| p.t <= barred.t) {
                self.pending = Some(barred);
            }
            return Ok(());
        };
        if barred.t > now + TASK_SEQ_LEAD_S as f64 {
            return Err(BarredAhead { t: barred.t, now });
        }
        if self.unit.mission().on_barred(barred) {
            self.unit.barred_changed();
            review(&mut self.unit);
        }
        Ok(())
    }

    /// Another coordinator holds office (`present`), or none does
    /// ([`firefleet_protocol::office`]).
    pub fn office_changed(&mut self, present: bool) {
        self.unit.mission().office_changed(present);
    }

    pub fn state(&self) -> UnitState {
        self.unit.state()
    }

    /// Flames seen since the last report, if any.
    pub fn report(&mut self) -> Option<FlameReport> {
        self.unit.report()
    }

    /// What the unit's own detector found in the frame just sensed ([`Services::found`]).
    pub fn found(&self) -> Option<&[FlameDetection]> {
        self.unit.found()
    }

    /// The unit's services, for inspection.
    pub fn unit(&self) -> &U {
        &self.unit
    }

    pub fn tree(&self) -> &Tree<U> {
        &self.tree
    }

    pub fn tree_mut(&mut self) -> &mut Tree<U> {
        &mut self.tree
    }
}
