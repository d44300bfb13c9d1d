//! What a role does on the bus besides putting and subscribing to typed messages:
//! liveliness tokens, questions and answers, samples read before decoding, deletes.
//!
//! Every role needs some of these (a unit's token says it is alive; a starting coordinator
//! asks the recorders for the tracks they hold; the recorder keeps every sample as it
//! came). They live here, beside [`Bus::put`] and [`Bus::subscribe`], so that no role
//! reaches past the bus for the Zenoh session and each thing is done one way: tokens
//! watched with their history, answers that do not decode counted like any other
//! message, a question's answer on the key it was asked on.
//!
//! Not here: which keys exist ([`firefleet_protocol::keys`]) or what the answers mean.

use std::time::Duration;

use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::{ConsolidationMode, Query, Queryable, Reply};
use zenoh::sample::{Locality, Sample, SampleKind};

use firefleet_protocol::codec;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{Message, Seal};

use crate::bus::{Bus, BusError};

/// A sample as it arrived: its key, whether it was a put or a delete, its bytes, and its
/// attachment (a seal's, where there is one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Raw {
    pub key: String,
    pub deleted: bool,
    pub bytes: Vec<u8>,
    pub attachment: Option<Vec<u8>>,
}

impl Raw {
    fn of(s: &Sample) -> Self {
        Self {
            key: s.key_expr().as_str().to_owned(),
            deleted: s.kind() == SampleKind::Delete,
            bytes: s.payload().to_bytes().into_owned(),
            attachment: s.attachment().map(|a| a.to_bytes().into_owned()),
        }
    }

    /// The topic of the key, if it is one of the site's.
    pub fn topic(&self) -> Option<Topic> {
        keys::parse(&self.key).ok().map(|(_, t)| t)
    }
}

/// A liveliness token: the key stays alive on the bus until this is dropped (or the
/// process dies, which is what a token is for).
pub struct Token {
    _held: LivelinessToken,
}

/// Samples of one or more subscriptions, undecoded, in the order they came.
///
/// Zenoh hands samples over from its own threads: a full queue there would stall every
/// subscription of the session, so this one never blocks Zenoh. What a reader slower than
/// the bus cannot take (more than [`RAW_QUEUE`] waiting) is dropped and counted as
/// `overflow` in [`Bus::rejects`], with a warning.
pub struct RawInbox {
    queue: tokio::sync::mpsc::Receiver<Raw>,
    _subscribers: Vec<Subscriber<()>>,
}

/// Samples a [`RawInbox`] holds before it drops new ones: seconds of a large fleet's
/// states.
pub const RAW_QUEUE: usize = 16_384;

impl RawInbox {
    /// The next sample; `None` once the session is closed.
    pub async fn recv(&mut self) -> Option<Raw> {
        self.queue.recv().await
    }
}

/// Tokens appearing and vanishing under a key expression, those alive when the watch
/// began first.
pub struct Tokens {
    sub: Subscriber<FifoChannelHandler<Sample>>,
    bus: Bus,
}

impl Tokens {
    /// The next change: the token's topic and whether it is alive now. A token on a key
    /// that is no topic of the site is counted and skipped. `None` once the session is
    /// closed.
    pub async fn recv(&self) -> Option<(Topic, bool)> {
        loop {
            let s = self.sub.recv_async().await.ok()?;
            let key = s.key_expr().as_str();
            match keys::parse(key) {
                Ok((_, topic)) => return Some((topic, s.kind() == SampleKind::Put)),
                Err(e) => self.bus.rejects().refuse_invalid(key, &e),
            }
        }
    }
}

/// How a question is asked.
#[derive(Debug, Clone, Copy)]
pub struct Ask {
    /// How long answers are waited for.
    pub timeout: Duration,
    /// Every answerer's answer, not one per key: where several hold a copy (the
    /// coordinator and each recorder), the asker picks the newest itself.
    pub every_answer: bool,
    /// Not this process's own queryables (one that answers only once the process runs
    /// would hold the question open for the whole timeout).
    pub remote_only: bool,
}

impl Ask {
    /// One answer per key, from anyone, within `timeout`.
    pub fn within(timeout: Duration) -> Self {
        Self {
            timeout,
            every_answer: false,
            remote_only: false,
        }
    }
}

/// The answers to a question as they come, until its timeout.
pub struct Answers(FifoChannelHandler<Reply>);

impl Answers {
    /// The next answer; error replies are skipped. `None` when no more will come.
    pub async fn recv(&self) -> Option<Raw> {
        loop {
            let reply = self.0.recv_async().await.ok()?;
            if let Ok(s) = reply.result() {
                return Some(Raw::of(s));
            }
        }
    }

    /// The next answer, or an answerer's refusal (an error reply) with its text. `None`
    /// when no more will come.
    pub async fn recv_or_refusal(&self) -> Option<Result<Raw, String>> {
        let reply = self.0.recv_async().await.ok()?;
        Some(match reply.result() {
            Ok(s) => Ok(Raw::of(s)),
            Err(e) => Err(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned()),
        })
    }

    /// Every answer, once the question has closed.
    pub async fn all(self) -> Vec<Raw> {
        let mut out = Vec::new();
        while let Some(a) = self.recv().await {
            out.push(a);
        }
        out
    }
}

/// Questions asked of a queryable this process serves.
pub struct Questions(Queryable<FifoChannelHandler<Query>>);

impl Questions {
    /// The next question; `None` once the session is closed.
    pub async fn recv(&self) -> Option<Question> {
        self.0.recv_async().await.ok().map(Question)
    }
}

/// One question: answer it on the key it names (the key asked may be a pattern, the
/// answer's is one key).
pub struct Question(Query);

impl Question {
    /// The key expression asked.
    pub fn key(&self) -> &str {
        self.0.key_expr().as_str()
    }

    /// The topic asked, if the key is one of the site's.
    pub fn topic(&self) -> Option<Topic> {
        keys::parse(self.key()).ok().map(|(_, t)| t)
    }

    /// A parameter the question was asked with (`key?name=value`).
    pub fn parameter(&self, name: &str) -> Option<&str> {
        self.0.parameters().get(name)
    }

    /// What the question carries (empty if nothing).
    pub fn payload(&self) -> Vec<u8> {
        self.0
            .payload()
            .map(|p| p.to_bytes().into_owned())
            .unwrap_or_default()
    }

    /// Refuse the question, saying why: the asker gets an error reply with the text.
    pub async fn refuse(&self, why: &str) -> Result<(), BusError> {
        self.0
            .reply_err(why.as_bytes().to_vec())
            .await
            .map_err(BusError::from)
    }

    /// Answer with `bytes` on `key`.
    pub async fn answer(&self, key: &str, bytes: Vec<u8>) -> Result<(), BusError> {
        self.reply(key.to_owned(), bytes, None).await
    }

    /// Answer with `bytes` on `key`, sealed by `bus`'s identity on a secure site (as
    /// [`Question::answer`] on an open one): an answer the asker believes only from a
    /// coordinator ([`crate::seal::by_coordinator`]).
    pub async fn answer_sealed_by(
        &self,
        bus: &crate::Bus,
        key: &str,
        bytes: Vec<u8>,
    ) -> Result<(), BusError> {
        let seal = bus.seal_of(key, &bytes);
        self.reply(key.to_owned(), bytes, seal).await
    }

    /// Answer with a message as it was heard: its key, its bytes and its attachment (the
    /// seal of whoever put it, which the asker checks: a recorder passes on the
    /// coordinator's seal of a fire track).
    pub async fn answer_as_heard(&self, heard: &Raw) -> Result<(), BusError> {
        self.reply(
            heard.key.clone(),
            heard.bytes.clone(),
            heard.attachment.clone(),
        )
        .await
    }

    async fn reply(
        &self,
        key: String,
        bytes: Vec<u8>,
        attachment: Option<Vec<u8>>,
    ) -> Result<(), BusError> {
        self.0
            .reply(key, bytes)
            .attachment(attachment)
            .await
            .map_err(BusError::from)
    }
}

impl Bus {
    /// Declare the liveliness token of `topic` (a unit's or the coordinator's `alive`).
    pub async fn token(&self, topic: &Topic) -> Result<Token, BusError> {
        let key = self.keys().expr(topic);
        Ok(Token {
            _held: self.zenoh().liveliness().declare_token(key).await?,
        })
    }

    /// Watch the tokens under `key_expr`, starting with those alive now.
    pub async fn watch_tokens(&self, key_expr: &str) -> Result<Tokens, BusError> {
        let sub = self
            .zenoh()
            .liveliness()
            .declare_subscriber(key_expr.to_owned())
            .history(true)
            .await?;
        Ok(Tokens {
            sub,
            bus: self.clone(),
        })
    }

    /// The topics of the tokens alive under `key_expr` now.
    pub async fn tokens_alive(&self, key_expr: &str) -> Result<Vec<Topic>, BusError> {
        let replies = self.zenoh().liveliness().get(key_expr.to_owned()).await?;
        Ok(Answers(replies)
            .all()
            .await
            .iter()
            .filter_map(Raw::topic)
            .collect())
    }

    /// Subscribe to every key expression of `key_exprs` without decoding: samples as they
    /// came, deletes included, into one inbox. With `remote_only`, not this process's own
    /// puts.
    pub async fn subscribe_raw(
        &self,
        key_exprs: &[&str],
        remote_only: bool,
    ) -> Result<RawInbox, BusError> {
        let origin = if remote_only {
            Locality::Remote
        } else {
            Locality::Any
        };
        let (tx, queue) = tokio::sync::mpsc::channel(RAW_QUEUE);
        let mut subscribers = Vec::new();
        for key in key_exprs {
            let (tx, rejects) = (tx.clone(), self.rejects().clone());
            let sub = self
                .zenoh()
                .declare_subscriber(key.to_string())
                .allowed_origin(origin)
                .callback(move |s| {
                    if tx.try_send(Raw::of(&s)).is_err() {
                        rejects.refuse_overflow(s.key_expr().as_str());
                    }
                })
                .await?;
            subscribers.push(sub);
        }
        Ok(RawInbox {
            queue,
            _subscribers: subscribers,
        })
    }

    /// Declare `keys` (concrete keys this session will hear often) to Zenoh while the
    /// answer is kept: their samples then come named by a number, and reach this session's
    /// subscribers through a cache, where an undeclared key is matched against the whole
    /// key table and every subscriber on each sample (a console following 1000 units spent
    /// over a core on that alone).
    pub async fn declare_keys(&self, keys: &[String]) -> Result<DeclaredKeys, BusError> {
        let mut declared = Vec::with_capacity(keys.len());
        for key in keys {
            declared.push(self.zenoh().declare_keyexpr(key.clone()).await?);
        }
        Ok(DeclaredKeys(declared))
    }

    /// Ask `key_expr` and receive the answers as they come.
    pub async fn ask(&self, key_expr: &str, ask: Ask) -> Result<Answers, BusError> {
        self.ask_with(key_expr, ask, None).await
    }

    /// [`Bus::ask`] with `payload` carried by the question (what a preview is asked of).
    pub async fn ask_with(
        &self,
        key_expr: &str,
        ask: Ask,
        payload: Option<Vec<u8>>,
    ) -> Result<Answers, BusError> {
        let consolidation = if ask.every_answer {
            ConsolidationMode::None
        } else {
            ConsolidationMode::Auto
        };
        let destination = if ask.remote_only {
            Locality::Remote
        } else {
            Locality::Any
        };
        let get = self
            .zenoh()
            .get(key_expr.to_owned())
            .consolidation(consolidation)
            .allowed_destination(destination)
            .timeout(ask.timeout);
        let replies = match payload {
            Some(p) => get.payload(p).await?,
            None => get.await?,
        };
        Ok(Answers(replies))
    }

    /// Answer questions on `key_expr`.
    pub async fn serve(&self, key_expr: &str) -> Result<Questions, BusError> {
        Ok(Questions(
            self.zenoh().declare_queryable(key_expr.to_owned()).await?,
        ))
    }

    /// Delete `key` (a commander's goals on a zone are cleared so), with `seal` in the
    /// attachment if there is one.
    pub async fn delete(&self, key: &str, seal: Option<&Seal>) -> Result<(), BusError> {
        let delete = self.zenoh().delete(key.to_owned());
        match seal {
            Some(s) => delete.attachment(s.to_attachment()).await?,
            None => delete.await?,
        }
        Ok(())
    }

    /// Put bytes as they are on `key` with `seal` in the attachment (a commander's goal).
    pub async fn put_sealed(&self, key: &str, bytes: Vec<u8>, seal: &Seal) -> Result<(), BusError> {
        Ok(self
            .zenoh()
            .put(key.to_owned(), bytes)
            .attachment(seal.to_attachment())
            .await?)
    }

    /// Put bytes as they are on `key`: for tools that must send what no typed message
    /// would (the fuzzing and forging tests, the nemesis).
    pub async fn put_raw(&self, key: &str, bytes: Vec<u8>) -> Result<(), BusError> {
        Ok(self.zenoh().put(key.to_owned(), bytes).await?)
    }

    /// Whether the session reaches a router or a peer now.
    pub async fn connected(&self) -> bool {
        let info = self.zenoh().info();
        info.routers_zid().await.next().is_some() || info.peers_zid().await.next().is_some()
    }

    /// The Zenoh sessions this process holds with others, by what is at the far end. A
    /// router reads them from its own admin space, which [`crate::Connect`] turns on for
    /// routers (every client, peer and router linked to it); any other process knows only
    /// its routers and peers, which is all it links to.
    pub async fn linked(&self) -> Linked {
        let session = self.zenoh();
        let mut linked = Linked::default();
        let own = format!("@/{}/router", session.zid());
        // The admin space is the runtime's, not a queryable of this session: asked as
        // any key is (only this process's admin space has its id). A process that does
        // not route has none, and its question would only go out to its router.
        let reply = if self.routes() {
            match session.get(own).timeout(Duration::from_secs(1)).await {
                Ok(replies) => replies.recv_async().await.ok(),
                Err(_) => None,
            }
        } else {
            None
        };
        if let Some(reply) = reply {
            let sessions = reply.result().ok().and_then(|s| {
                let v: serde_json::Value = serde_json::from_slice(&s.payload().to_bytes()).ok()?;
                v["sessions"].as_array().cloned()
            });
            if let Some(sessions) = sessions {
                for far in sessions {
                    match far["whatami"].as_str() {
                        Some("router") => linked.routers += 1,
                        Some("peer") => linked.peers += 1,
                        Some("client") => linked.clients += 1,
                        _ => {}
                    }
                }
                return linked;
            }
        }
        let info = session.info();
        linked.routers = info.routers_zid().await.count();
        linked.peers = info.peers_zid().await.count();
        linked
    }

    /// Whether the session is linked through the router whose Zenoh id is `zid` (hex, as
    /// [`crate::render::router_zid`] gives a site router's).
    pub async fn linked_to(&self, zid: &str) -> bool {
        let Ok(want) = zid.parse::<zenoh::session::ZenohId>() else {
            return false;
        };
        self.zenoh().info().routers_zid().await.any(|z| z == want)
    }

    /// Decode `raw` as an `M`, counting and logging it (`what` names it) if it does not.
    pub fn decode<M: Message>(&self, raw: &Raw, what: &str) -> Option<M> {
        match codec::decode::<M>(&raw.bytes) {
            Ok(m) => Some(m),
            Err(e) => {
                self.rejects().refuse(&format!("{} ({what})", raw.key), &e);
                None
            }
        }
    }
}

/// The sessions a process holds with others ([`Bus::linked`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Linked {
    pub routers: usize,
    pub peers: usize,
    pub clients: usize,
}

/// Keys declared to Zenoh ([`Bus::declare_keys`]); dropped, Zenoh forgets them.
pub struct DeclaredKeys(
    #[allow(dead_code, reason = "held: a declaration lives as long as its key")]
    Vec<zenoh::key_expr::KeyExpr<'static>>,
);
