//! The unit's behavior tree, served to Groot2 as BehaviorTree.CPP's `Groot2Publisher`
//! serves one: ZeroMQ REQ/REP on the port asked for, the tree's XML with node uids, the
//! status of every node, the blackboards, and recorded transitions.
//!
//! The agent's loop owns the tree and ticks it; after each step it hands the new
//! transitions to [`Groot2::update`], which keeps a [`View`] (the status buffer) and a
//! copy of the blackboard that a task of its own answers requests from. The blackboard
//! copy is made only while someone asks: a step of a unit nobody watches costs one lock.
//!
//! Requests are checked as any network input is: a wrong header, an unknown type, a
//! missing part gets BT.CPP's error reply (`error`, then why) and the server goes on.
//! Breakpoints and hooks (Groot2's "interactive" mode, on BT.CPP's port + 1) are not
//! implemented: those requests are answered with an error saying so.
//!
//! Not here: the protocol's bytes ([`firefleet_bt::groot2`]) or the `.btlog` file
//! ([`crate::btlog`]).

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use firefleet_bt::groot2::{self, Request, RequestHeader, View};
use firefleet_bt::{Transition, Tree, Value};
use zeromq::{Socket, SocketRecv, SocketSend, ZmqMessage};

/// How long after the last request the blackboard copy is still refreshed each step
/// (Groot2 polls a watched tree several times a second).
const WATCHED_FOR: Duration = Duration::from_secs(5);
/// Transitions kept while recording, as BT.CPP keeps them.
const RECORDED: usize = 1000;

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
#[error("serving Groot2 on {addr}: {source}")]
pub struct ServeError {
    addr: SocketAddr,
    source: zeromq::ZmqError,
}

struct Shared {
    view: View,
    /// The blackboards as JSON: `{instance: {key: value}}`, the main tree's under its id.
    blackboards: serde_json::Map<String, serde_json::Value>,
    main_id: String,
    /// The tree time of the last step.
    now: f64,
    last_request: Option<Instant>,
    /// Tree time recording started at, while recording.
    recording: Option<f64>,
    recorded: VecDeque<[u8; 9]>,
}

/// A unit's tree as served to Groot2; cloning shares it.
#[derive(Clone)]
pub struct Groot2 {
    shared: Arc<Mutex<Shared>>,
    addr: SocketAddr,
}

impl Groot2 {
    /// Serve `tree` on `addr` (port 0: any free one, see [`Groot2::addr`]) from a task of
    /// its own, until the returned handle and its clones are dropped.
    pub async fn serve<C>(addr: SocketAddr, tree: &Tree<C>) -> Result<Self, ServeError> {
        let mut socket = zeromq::RepSocket::new();
        let bound = socket
            .bind(&format!("tcp://{addr}"))
            .await
            .map_err(|source| ServeError { addr, source })?;
        let addr = match bound {
            zeromq::Endpoint::Tcp(_, port) => SocketAddr::new(addr.ip(), port),
            _ => addr,
        };
        let shared = Arc::new(Mutex::new(Shared {
            view: View::new(tree),
            blackboards: serde_json::Map::new(),
            main_id: tree.id().to_owned(),
            now: 0.0,
            last_request: None,
            recording: None,
            recorded: VecDeque::new(),
        }));
        let weak = Arc::downgrade(&shared);
        let tree_id = tree_id();
        tokio::spawn(async move {
            loop {
                let request = match socket.recv().await {
                    Ok(r) => r,
                    Err(e) => {
                        // A client gone mid-request; never a reason to stop serving, nor
                        // to spin on a socket that keeps failing.
                        tracing::debug!("Groot2 request: {e}");
                        if weak.strong_count() == 0 {
                            break;
                        }
                        tokio::time::sleep(Duration::from_millis(50)).await;
                        continue;
                    }
                };
                let Some(shared) = weak.upgrade() else { break };
                let reply = answer(&shared, &request, &tree_id);
                drop(shared);
                if let Err(e) = socket.send(reply).await {
                    tracing::warn!("Groot2 reply: {e}");
                }
            }
        });
        tracing::info!(%addr, "serving the behavior tree to Groot2");
        Ok(Self { shared, addr })
    }

    /// Where the server listens.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// After a step at tree time `now`: the transitions it made, and the blackboard as it
    /// is now.
    pub fn update<C>(&self, tree: &Tree<C>, fresh: &[Transition], now: f64) {
        let mut s = self.shared.lock().unwrap_or_else(PoisonError::into_inner);
        s.now = now;
        for t in fresh {
            s.view.apply(t);
            if let Some(t0) = s.recording {
                let record = groot2::record(s.view.uid(t.node), t, t0);
                s.recorded.push_back(record);
                if s.recorded.len() > RECORDED {
                    s.recorded.pop_front();
                }
            }
        }
        if s.last_request.is_some_and(|at| at.elapsed() < WATCHED_FOR) {
            let main = s.main_id.clone();
            s.blackboards = blackboards(tree, &main);
        }
    }
}

/// A fresh 16-byte tree id (a version-4 UUID's layout, as BT.CPP's).
fn tree_id() -> [u8; 16] {
    use std::hash::{BuildHasher, Hasher};
    let mut out = [0u8; 16];
    for (k, half) in out.chunks_mut(8).enumerate() {
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_usize(k);
        half.copy_from_slice(&h.finish().to_le_bytes());
    }
    out[6] = (out[6] & 0x0F) | 0x40;
    out[8] = (out[8] & 0x3F) | 0x80;
    out
}

fn json(v: &Value) -> serde_json::Value {
    match v {
        Value::Bool(b) => (*b).into(),
        Value::Int(i) => (*i).into(),
        Value::Double(d) => (*d).into(),
        Value::String(s) => s.as_str().into(),
        Value::Point([x, y]) => format!("{x};{y}").into(),
    }
}

/// Every blackboard of `tree`: the main tree's entries under `main`, a subtree instance's
/// under its path (the entry's name up to its last `/`).
fn blackboards<C>(tree: &Tree<C>, main: &str) -> serde_json::Map<String, serde_json::Value> {
    let mut out = serde_json::Map::new();
    for (name, _, value) in tree.blackboard().entries() {
        let Some(value) = value else { continue };
        let (instance, key) = name.rsplit_once('/').unwrap_or((main, name));
        let entry = out
            .entry(instance.to_owned())
            .or_insert_with(|| serde_json::Value::Object(serde_json::Map::new()));
        if let serde_json::Value::Object(m) = entry {
            m.insert(key.to_owned(), json(value));
        }
    }
    out
}

fn error(why: &str) -> ZmqMessage {
    let mut m = ZmqMessage::from("error");
    m.push_back(why.as_bytes().to_vec().into());
    m
}

/// The reply to one request, as BT.CPP's `Groot2Publisher::serverLoop` makes it.
fn answer(shared: &Mutex<Shared>, request: &ZmqMessage, tree_id: &[u8; 16]) -> ZmqMessage {
    let Some(first) = request.get(0) else {
        return error("empty request");
    };
    let header = match RequestHeader::parse(first) {
        Ok(h) => h,
        Err(e) => return error(&e.to_string()),
    };
    let second = request
        .get(1)
        .map(|b| String::from_utf8_lossy(b).into_owned());
    let mut s = shared.lock().unwrap_or_else(PoisonError::into_inner);
    s.last_request = Some(Instant::now());
    let body: Vec<u8> = match header.request {
        Request::FullTree => s.view.xml().as_bytes().to_vec(),
        Request::Status => s.view.status_buffer().to_vec(),
        Request::Blackboard => {
            let Some(names) = second else {
                return error("must be 2 parts message");
            };
            let main = s.main_id.clone();
            let mut dump = serde_json::Map::new();
            for name in names.split(';').filter(|n| !n.is_empty()) {
                // The main tree answers to its id and to its empty path.
                let key = if name == main { main.as_str() } else { name };
                if let Some(bb) = s.blackboards.get(key) {
                    dump.insert(name.to_owned(), bb.clone());
                }
            }
            match rmp_serde::to_vec(&serde_json::Value::Object(dump)) {
                Ok(b) => b,
                Err(e) => return error(&format!("encoding the blackboard: {e}")),
            }
        }
        Request::ToggleRecording => match second.as_deref() {
            Some("start") => {
                s.recording = Some(s.now);
                s.recorded.clear();
                let since_epoch = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_micros());
                since_epoch.to_string().into_bytes()
            }
            Some("stop") => {
                s.recording = None;
                Vec::new()
            }
            _ => return error("must be 2 parts message: start or stop"),
        },
        Request::Transitions => s.recorded.drain(..).flatten().collect(),
        Request::Hooks(_) => {
            return error("breakpoints are not supported by this publisher");
        }
    };
    let mut reply = ZmqMessage::from(header.reply(tree_id).to_vec());
    reply.push_back(body.into());
    reply
}

/// A Groot2-protocol client: what Groot2 asks a publisher, for tests and tools.
pub struct Client {
    socket: zeromq::ReqSocket,
    next_id: u32,
}

/// Why a request to a publisher failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error(transparent)]
    Zmq(#[from] zeromq::ZmqError),
    #[error("the publisher answered an error: {0}")]
    Refused(String),
    #[error("the reply is not Groot2's: {0}")]
    Reply(String),
}

impl Client {
    pub async fn connect(addr: SocketAddr) -> Result<Self, ClientError> {
        let mut socket = zeromq::ReqSocket::new();
        socket.connect(&format!("tcp://{addr}")).await?;
        Ok(Self { socket, next_id: 1 })
    }

    /// Send request `letter` (with `second` as its second part), check the reply's header
    /// and return its body.
    pub async fn ask(&mut self, letter: u8, second: Option<&str>) -> Result<Vec<u8>, ClientError> {
        let header = RequestHeader {
            request: Request::Status,
            letter,
            id: self.next_id,
        };
        self.next_id = self.next_id.wrapping_add(1);
        let mut m = ZmqMessage::from(header.to_bytes().to_vec());
        if let Some(s) = second {
            m.push_back(s.as_bytes().to_vec().into());
        }
        self.socket.send(m).await?;
        let reply = self.socket.recv().await?;
        let first = reply.get(0).map(|b| b.to_vec()).unwrap_or_default();
        if first == b"error" {
            let why = reply
                .get(1)
                .map(|b| String::from_utf8_lossy(b).into_owned());
            return Err(ClientError::Refused(why.unwrap_or_default()));
        }
        if first.len() != groot2::REPLY_HEADER || first[..6] != header.to_bytes() {
            return Err(ClientError::Reply(format!(
                "a {}-byte header that does not echo the request",
                first.len()
            )));
        }
        Ok(reply.get(1).map(|b| b.to_vec()).unwrap_or_default())
    }

    /// The tree's XML.
    pub async fn tree(&mut self) -> Result<String, ClientError> {
        let b = self.ask(b'T', None).await?;
        String::from_utf8(b).map_err(|e| ClientError::Reply(e.to_string()))
    }

    /// `(uid, status byte)` of every node.
    pub async fn statuses(&mut self) -> Result<Vec<(u16, u8)>, ClientError> {
        let b = self.ask(b'S', None).await?;
        if b.len() % 3 != 0 {
            return Err(ClientError::Reply(format!(
                "a status buffer of {} bytes",
                b.len()
            )));
        }
        Ok(b.chunks(3)
            .map(|c| (u16::from_le_bytes([c[0], c[1]]), c[2]))
            .collect())
    }

    /// The blackboards named (`;`-separated), as JSON.
    pub async fn blackboards(&mut self, names: &str) -> Result<serde_json::Value, ClientError> {
        let b = self.ask(b'B', Some(names)).await?;
        rmp_serde::from_slice(&b).map_err(|e| ClientError::Reply(e.to_string()))
    }
}
