//! A ROS 2 node on a Zenoh session, the way rmw_zenoh declares one: a liveliness token for
//! the node and one per publisher and subscription, samples in CDR with the attachment.
//!
//! Publishing never waits (Zenoh's default congestion control drops under pressure, as a
//! best-effort ROS 2 publisher would); a subscription decodes in Zenoh's callback and
//! hands the message to a closure, so that several topics can feed one queue in the order
//! their samples arrived. A sample that is not the type's CDR is dropped and counted.
//!
//! Not here: which topics a robot has ([`crate::ground`]).

use std::marker::PhantomData;
use std::sync::Arc;
use std::sync::atomic::{AtomicI64, AtomicU32, AtomicU64, Ordering};

/// The Zenoh session a robot's nodes are declared on ([`robot_session`] opens one).
pub use zenoh::Session;
use zenoh::Wait;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher as ZPublisher, Subscriber};
use zenoh::sample::SampleKind;

use crate::cdr;
use crate::graph::{
    Attachment, Domain, Entity, Gid, NameError, Namespace, NodeName, Topic, gid_of,
};
use crate::msg::RosMessage;

/// Why a node or one of its entities could not be declared.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error(transparent)]
    Name(#[from] NameError),
    #[error("zenoh: {0}")]
    Zenoh(String),
}

fn zenoh_err(e: zenoh::Error) -> NodeError {
    NodeError::Zenoh(e.to_string())
}

/// A session of the robot's own: a peer of its rmw_zenoh router at `router` (e.g.
/// `tcp/127.0.0.1:7447`), as ROS 2 nodes are, with multicast scouting off.
pub async fn robot_session(router: &str) -> Result<Session, NodeError> {
    let mut config = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, key: &str, value: &str| {
        c.insert_json5(key, value)
            .map_err(|e| NodeError::Zenoh(format!("{key}: {e}")))
    };
    set(&mut config, "mode", "\"peer\"")?;
    set(&mut config, "scouting/multicast/enabled", "false")?;
    let endpoints =
        serde_json::to_string(&[router]).map_err(|e| NodeError::Zenoh(e.to_string()))?;
    set(&mut config, "connect/endpoints", &endpoints)?;
    zenoh::open(config).await.map_err(zenoh_err)
}

/// A ROS 2 node: announced while it lives.
pub struct Node {
    session: Session,
    name: NodeName,
    next_entity: AtomicU32,
    rejected: Arc<AtomicU64>,
    _token: LivelinessToken,
}

impl Node {
    /// Node `name` in `namespace` on `domain`, announced on `session`.
    pub async fn new(
        session: &Session,
        domain: Domain,
        namespace: Namespace,
        name: &str,
    ) -> Result<Self, NodeError> {
        let name = NodeName::new(domain, session.zid().to_string(), 0, namespace, name)?;
        let token = session
            .liveliness()
            .declare_token(name.token())
            .await
            .map_err(zenoh_err)?;
        Ok(Self {
            session: session.clone(),
            name,
            next_entity: AtomicU32::new(1),
            rejected: Arc::default(),
            _token: token,
        })
    }

    pub fn namespace(&self) -> &Namespace {
        &self.name.namespace
    }

    /// Samples dropped so far because they were not their topic's CDR.
    pub fn rejected(&self) -> u64 {
        self.rejected.load(Ordering::Relaxed)
    }

    async fn announce(
        &self,
        kind: Entity,
        topic: &Topic,
    ) -> Result<(String, LivelinessToken), NodeError> {
        let id = self.next_entity.fetch_add(1, Ordering::Relaxed);
        let token = self.name.entity_token(id, kind, topic);
        let declared = self
            .session
            .liveliness()
            .declare_token(token.clone())
            .await
            .map_err(zenoh_err)?;
        Ok((token, declared))
    }

    /// A publisher on `topic` (relative to the node's namespace).
    pub async fn publisher<M: RosMessage>(&self, topic: &str) -> Result<Publisher<M>, NodeError> {
        let topic = Topic::new(&self.name.namespace, topic, M::TYPE)?;
        let (token, declared) = self.announce(Entity::Publisher, &topic).await?;
        let publisher = self
            .session
            .declare_publisher(topic.key(self.name.domain))
            .await
            .map_err(zenoh_err)?;
        Ok(Publisher {
            publisher,
            gid: gid_of(&token),
            sequence: AtomicI64::new(0),
            topic,
            _token: declared,
            _m: PhantomData,
        })
    }

    /// Take `topic` (relative to the node's namespace): `on` gets each message.
    pub async fn subscribe<M: RosMessage>(
        &self,
        topic: &str,
        on: impl Fn(M) + Send + Sync + 'static,
    ) -> Result<Subscription, NodeError> {
        let topic = Topic::new(&self.name.namespace, topic, M::TYPE)?;
        let (_, declared) = self.announce(Entity::Subscription, &topic).await?;
        let rejected = self.rejected.clone();
        let name = topic.name.clone();
        let subscriber = self
            .session
            .declare_subscriber(topic.key(self.name.domain))
            .callback(move |sample| {
                if sample.kind() == SampleKind::Delete {
                    return;
                }
                match cdr::decode::<M>(&sample.payload().to_bytes()) {
                    Ok(m) => on(m),
                    Err(e) => {
                        // Counted, and logged once per hundred so a flood cannot flood the log.
                        if rejected.fetch_add(1, Ordering::Relaxed).is_multiple_of(100) {
                            tracing::warn!(topic = %name, "dropped a sample that is not {}: {e}", M::TYPE);
                        }
                    }
                }
            })
            .await
            .map_err(zenoh_err)?;
        Ok(Subscription {
            _subscriber: subscriber,
            _token: declared,
        })
    }
}

/// A typed publisher: each `put` is one CDR sample with its attachment.
pub struct Publisher<M> {
    publisher: ZPublisher<'static>,
    gid: Gid,
    sequence: AtomicI64,
    topic: Topic,
    _token: LivelinessToken,
    _m: PhantomData<fn(M)>,
}

impl<M: RosMessage> Publisher<M> {
    pub fn put(&self, m: &M) -> Result<(), NodeError> {
        let seq = self.sequence.fetch_add(1, Ordering::Relaxed) + 1;
        self.publisher
            .put(cdr::encode(m))
            .attachment(Attachment::now(seq, self.gid).encode().to_vec())
            .wait()
            .map_err(zenoh_err)
    }

    pub fn topic(&self) -> &Topic {
        &self.topic
    }
}

/// A live subscription; dropping it undeclares it and its token.
pub struct Subscription {
    _subscriber: Subscriber<()>,
    _token: LivelinessToken,
}
