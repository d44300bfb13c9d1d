//! Sensor frames put together from a robot's topics, on the agent's side.
//!
//! A ROS 2 robot publishes each sensor on a topic of its own; the agent acts on whole
//! frames. Every subscription of a robot feeds one queue, in the order the samples
//! arrived, and an [`Assemble`] takes the parts in that order: it keeps the newest of each
//! and makes a frame when the robot's clocking topic arrives (odometry for a ground unit,
//! joint states for a carriage). The queue is unbounded so that Zenoh's callbacks never
//! wait; [`Parts::next_frame`] drains it every frame, so it holds one frame's parts at most
//! while the agent keeps up.
//!
//! Not here: which topics a robot has ([`crate::ground`], [`crate::monorail`]).

use firefleet_model::UnitId;
use firefleet_model::validate::Validate;
use tokio::sync::mpsc;

/// What turns a robot's parts, in arrival order, into frames.
pub(crate) trait Assemble {
    /// One sample of any of the robot's topics.
    type Part;
    type Frame: Validate;
    /// The unit the robot is, for the log.
    fn unit(&self) -> &UnitId;
    /// Take `part`; a frame once the clocking part completes one.
    fn take(&mut self, part: Self::Part) -> Option<Self::Frame>;
}

/// The queue every subscription of a robot feeds, read by the agent.
pub(crate) struct Parts<P> {
    rx: mpsc::UnboundedReceiver<P>,
}

/// The feeding end of [`Parts`], held only while the robot's subscriptions are declared:
/// once their callbacks are gone (the session closed), the queue ends.
pub(crate) struct Feed<P> {
    tx: mpsc::UnboundedSender<P>,
}

/// A robot's queue and its feeding end.
pub(crate) fn parts<P>() -> (Feed<P>, Parts<P>) {
    let (tx, rx) = mpsc::unbounded_channel();
    (Feed { tx }, Parts { rx })
}

impl<P: Send + 'static> Feed<P> {
    /// A subscription callback that queues the message it takes, wrapped as a part.
    pub(crate) fn to<M>(
        &self,
        wrap: impl Fn(M) -> P + Send + Sync + 'static,
    ) -> impl Fn(M) + Send + Sync + 'static {
        let tx = self.tx.clone();
        // A send fails only once the robot is dropped, when nothing is waiting for it.
        move |m| drop(tx.send(wrap(m)))
    }
}

impl<P> Parts<P> {
    /// The next valid frame `a` makes; frames that queued up while the agent was busy are
    /// passed over for the newest, and an invalid one is logged and dropped. `None` once
    /// no subscription can feed the queue any more.
    pub(crate) async fn next_frame<A: Assemble<Part = P>>(
        &mut self,
        a: &mut A,
    ) -> Option<A::Frame> {
        loop {
            let first = self.rx.recv().await?;
            let mut frame = a.take(first);
            while let Ok(part) = self.rx.try_recv() {
                if let Some(newer) = a.take(part) {
                    frame = Some(newer);
                }
            }
            if let Some(f) = frame {
                match f.validate() {
                    Ok(()) => return Some(f),
                    Err(e) => tracing::warn!(unit = %a.unit(), "dropped a ROS 2 sensor frame: {e}"),
                }
            }
        }
    }
}
