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
//! The other way, a body keeps the newest set-point of each command topic in one
//! [`Latest`], which its subscriptions write and its control loop takes from.
//!
//! Not here: which topics a robot has ([`crate::ground`], [`crate::monorail`]).

use std::sync::{Arc, Mutex, MutexGuard};

use firefleet_model::UnitId;
use firefleet_model::validate::Validate;
use firefleet_protocol::msg::SensorFrame;
use tokio::sync::mpsc;

/// What turns a robot's parts, in arrival order, into frames.
pub(crate) trait Assemble {
    /// One sample of any of the robot's topics.
    type Part;
    type Frame: Validate + SensorFrame;
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
    /// passed over for the newest valid one where [`SensorFrame::may_pass_over`] allows
    /// (a frame that must be seen is returned, the parts after it left queued), and an
    /// invalid one is logged and dropped. `None` once no subscription can feed the queue
    /// any more.
    pub(crate) async fn next_frame<A: Assemble<Part = P>>(
        &mut self,
        a: &mut A,
    ) -> Option<A::Frame> {
        loop {
            let first = self.rx.recv().await?;
            let mut frame = a.take(first).filter(|f| valid(a, f));
            while frame.as_ref().is_none_or(SensorFrame::may_pass_over) {
                let Ok(part) = self.rx.try_recv() else { break };
                if let Some(newer) = a.take(part).filter(|f| valid(a, f)) {
                    frame = Some(newer);
                }
            }
            if frame.is_some() {
                return frame;
            }
        }
    }
}

/// The newest of what a body's command subscriptions heard, shared with its loop.
pub(crate) struct Latest<R>(Arc<Mutex<R>>);

impl<R: Default + Send + 'static> Latest<R> {
    pub(crate) fn new() -> Self {
        Self(Arc::default())
    }

    /// A subscription callback that writes the message it takes into the record.
    pub(crate) fn to<M>(
        &self,
        write: impl Fn(&mut R, M) + Send + Sync + 'static,
    ) -> impl Fn(M) + Send + Sync + 'static {
        let shared = self.0.clone();
        move |m| write(&mut shared.lock().expect("not poisoned"), m)
    }

    /// The record, for the loop to take from.
    pub(crate) fn lock(&self) -> MutexGuard<'_, R> {
        self.0.lock().expect("not poisoned")
    }
}

/// Whether `frame` validates; why not is logged.
fn valid<A: Assemble>(a: &A, frame: &A::Frame) -> bool {
    frame
        .validate()
        .map_err(|e| tracing::warn!(unit = %a.unit(), "dropped a ROS 2 sensor frame: {e}"))
        .is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::validate::Invalid;

    /// A frame a clock tick makes; `keep` frames must be seen, `bad` ones do not validate.
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct Frame {
        t: u32,
        keep: bool,
        bad: bool,
    }

    impl Validate for Frame {
        fn validate(&self) -> Result<(), Invalid> {
            if self.bad {
                Err(Invalid::new("t", "bad"))
            } else {
                Ok(())
            }
        }
    }

    impl SensorFrame for Frame {
        fn may_pass_over(&self) -> bool {
            !self.keep
        }
    }

    /// Parts are frames whole: every part is a clock tick.
    struct Ticks(UnitId);

    impl Assemble for Ticks {
        type Part = Frame;
        type Frame = Frame;
        fn unit(&self) -> &UnitId {
            &self.0
        }
        fn take(&mut self, part: Frame) -> Option<Frame> {
            Some(part)
        }
    }

    fn frame(t: u32) -> Frame {
        Frame {
            t,
            keep: false,
            bad: false,
        }
    }

    #[tokio::test]
    async fn the_newest_frame_is_taken_but_none_that_must_be_seen_is_passed_over() {
        let (feed, mut parts) = parts();
        let push = feed.to(|f: Frame| f);
        let mut ticks = Ticks(UnitId::new("ugv-1").unwrap());
        for f in [
            frame(1),
            Frame {
                keep: true,
                ..frame(2)
            },
            frame(3),
            frame(4),
            Frame {
                bad: true,
                ..frame(5)
            },
        ] {
            push(f);
        }
        let mut next = async || parts.next_frame(&mut ticks).await.map(|f| f.t);
        assert_eq!(next().await, Some(2), "1 passed over, 2 kept");
        drop((feed, push));
        assert_eq!(
            next().await,
            Some(4),
            "3 passed over; 5 is invalid: 4 stands"
        );
        assert_eq!(next().await, None, "the queue has ended");
    }
}
