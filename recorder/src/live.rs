//! The recording, live: every channel the recorder writes, served over the Foxglove
//! WebSocket protocol (`foxglove.websocket.v1`) so that Foxglove (or Lichtblick, or any
//! client of the protocol) follows the incident while it happens.
//!
//! The recorder hands each message it writes to [`Live::publish`] as well; the first
//! message on a topic advertises a channel (JSON encoding, its JSON Schema). A client gets
//! the server's info and every channel on connecting, subscribes to what it wants, and on
//! subscribing receives the newest message of that channel at once: the site's geometry is
//! drawn once per recording part, and a viewer joining mid-incident must not wait for it.
//!
//! Every client has its own queue ([`QUEUE`] messages). A client slower than the fleet
//! loses the oldest messages, is told so with a warning status, and stays connected; it
//! never slows the recorder or the other clients. Client input is validated: unknown ops,
//! malformed JSON, unknown channels and reused subscription ids are answered with an error
//! status naming what was wrong, and the connection goes on.
//!
//! Implemented from the protocol's specification (foxglove/ws-protocol, `docs/spec.md`)
//! over axum's WebSockets, which the console already builds: the `foxglove` crate's server
//! would bring its own WebSocket stack and protobuf schemas for the one feature we use.
//! Capabilities: none (no client publishing, parameters, services or time); the fleet is
//! steered through goals, never through the viewer.
//!
//! Not here: what the channels carry ([`crate::record`](mod@crate::record),
//! [`crate::scene`]).

use std::collections::{HashMap, HashSet};
use std::future::Future;
use std::sync::{Arc, Mutex};

use axum::Router;
use axum::extract::State;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde::{Deserialize, Serialize};
use tokio::sync::broadcast;

/// The protocol's WebSocket subprotocol.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Messages queued for one client before it starts losing the oldest.
pub const QUEUE: usize = 8192;
/// The largest message a client may send: its requests are small JSON objects.
const MAX_CLIENT_MESSAGE: usize = 64 * 1024;
/// The Message Data opcode.
const MESSAGE_DATA: u8 = 0x01;

/// A channel as the Advertise message describes it.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "camelCase")]
struct Channel {
    id: u32,
    topic: String,
    encoding: &'static str,
    schema_name: String,
    schema: String,
    schema_encoding: &'static str,
}

#[derive(Debug, Clone)]
enum Event {
    Advertise(Arc<Channel>),
    Message(Arc<Sample>),
}

#[derive(Debug)]
struct Sample {
    channel: u32,
    t_ns: u64,
    data: Vec<u8>,
}

#[derive(Default)]
struct Channels {
    by_topic: HashMap<String, Arc<Channel>>,
    /// The newest message of each channel, sent to a client as it subscribes.
    latest: HashMap<u32, Arc<Sample>>,
}

/// The live server's state: the channels so far and a broadcast of what happens on them.
pub struct Live {
    channels: Mutex<Channels>,
    events: broadcast::Sender<Event>,
    session: String,
}

impl Live {
    pub fn new() -> Arc<Self> {
        let session = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos().to_string())
            .unwrap_or_default();
        Arc::new(Self {
            channels: Mutex::default(),
            events: broadcast::channel(QUEUE).0,
            session,
        })
    }

    /// Send `json` (a message of schema `schema_name`) on `topic` to every subscriber,
    /// advertising the topic's channel first if it is new.
    pub fn publish(
        &self,
        topic: &str,
        schema_name: &str,
        schema: fn() -> schemars::Schema,
        json: &[u8],
        t_ns: u64,
    ) {
        let mut channels = self.channels.lock().unwrap_or_else(|e| e.into_inner());
        let channel = match channels.by_topic.get(topic) {
            Some(c) => c.id,
            None => {
                let c = Arc::new(Channel {
                    id: channels.by_topic.len() as u32 + 1,
                    topic: topic.to_owned(),
                    encoding: "json",
                    schema_name: schema_name.to_owned(),
                    schema: serde_json::to_string(&schema()).expect("a schema serialises"),
                    schema_encoding: "jsonschema",
                });
                channels.by_topic.insert(topic.to_owned(), c.clone());
                let _ = self.events.send(Event::Advertise(c.clone()));
                c.id
            }
        };
        let sample = Arc::new(Sample {
            channel,
            t_ns,
            data: json.to_vec(),
        });
        channels.latest.insert(channel, sample.clone());
        // Sent under the lock, so that a client joining sees each message either in its
        // snapshot or in its queue, never in both or neither.
        let _ = self.events.send(Event::Message(sample));
    }

    /// The router serving the protocol on `/`.
    pub fn router(self: Arc<Self>) -> Router {
        Router::new().route("/", get(upgrade)).with_state(self)
    }

    /// Serve clients coming to `listener` until `shutdown` completes.
    pub async fn serve(
        self: Arc<Self>,
        listener: tokio::net::TcpListener,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> std::io::Result<()> {
        axum::serve(listener, self.router())
            .with_graceful_shutdown(shutdown)
            .await
    }

    /// A client's starting point: its queue, then every channel and newest message as of
    /// now (taken under the lock [`Live::publish`] sends under).
    fn join(&self) -> Joined {
        let channels = self.channels.lock().unwrap_or_else(|e| e.into_inner());
        let queue = self.events.subscribe();
        let mut list: Vec<_> = channels.by_topic.values().cloned().collect();
        list.sort_by_key(|c| c.id);
        Joined {
            queue,
            channels: list,
            latest: channels.latest.clone(),
        }
    }
}

struct Joined {
    queue: broadcast::Receiver<Event>,
    channels: Vec<Arc<Channel>>,
    latest: HashMap<u32, Arc<Sample>>,
}

async fn upgrade(State(live): State<Arc<Live>>, ws: WebSocketUpgrade) -> Response {
    let ws = ws.protocols([SUBPROTOCOL]);
    if ws.selected_protocol().is_none() {
        return (
            StatusCode::BAD_REQUEST,
            format!("this is a Foxglove WebSocket server: ask for the subprotocol {SUBPROTOCOL}"),
        )
            .into_response();
    }
    ws.max_message_size(MAX_CLIENT_MESSAGE)
        .on_upgrade(move |socket| async move {
            if let Err(e) = Client::new(live, socket).run().await {
                tracing::debug!("Foxglove client gone: {e}");
            }
        })
}

/// What a client may ask.
#[derive(Debug, Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
enum Request {
    Subscribe {
        subscriptions: Vec<Subscription>,
    },
    #[serde(rename_all = "camelCase")]
    Unsubscribe {
        subscription_ids: Vec<u32>,
    },
}

#[derive(Debug, Deserialize)]
#[serde(rename_all = "camelCase")]
struct Subscription {
    id: u32,
    channel_id: u32,
}

/// Status levels of the protocol.
#[derive(Debug, Clone, Copy)]
enum Level {
    Warning = 1,
    Error = 2,
}

struct Client {
    live: Arc<Live>,
    socket: WebSocket,
    /// Channel id by subscription id, and the reverse.
    subscriptions: HashMap<u32, u32>,
    by_channel: HashMap<u32, u32>,
    advertised: HashSet<u32>,
}

impl Client {
    fn new(live: Arc<Live>, socket: WebSocket) -> Self {
        Self {
            live,
            socket,
            subscriptions: HashMap::new(),
            by_channel: HashMap::new(),
            advertised: HashSet::new(),
        }
    }

    async fn run(mut self) -> Result<(), axum::Error> {
        let Joined {
            mut queue,
            channels,
            mut latest,
        } = self.live.join();
        let info = serde_json::json!({
            "op": "serverInfo",
            "name": concat!("firefleet ", env!("CARGO_PKG_VERSION")),
            "capabilities": [],
            "metadata": {},
            "sessionId": self.live.session,
        });
        self.send_json(&info).await?;
        self.advertised = channels.iter().map(|c| c.id).collect();
        self.send_json(&serde_json::json!({"op": "advertise", "channels": channels}))
            .await?;
        loop {
            tokio::select! {
                m = self.socket.recv() => match m {
                    None | Some(Ok(Message::Close(_))) => return Ok(()),
                    Some(Err(e)) => return Err(e),
                    Some(Ok(Message::Text(text))) => {
                        let latched = self.request(text.as_str()).await?;
                        for channel in latched {
                            if let Some(sample) = latest.get(&channel).cloned() {
                                self.data(&sample).await?;
                            }
                        }
                    }
                    Some(Ok(Message::Binary(_))) => {
                        self.status(Level::Error, "this server takes no client messages: it advertises no clientPublish".into()).await?;
                    }
                    Some(Ok(Message::Ping(_) | Message::Pong(_))) => {}
                },
                e = queue.recv() => match e {
                    Ok(Event::Advertise(c)) => {
                        if self.advertised.insert(c.id) {
                            self.send_json(&serde_json::json!({"op": "advertise", "channels": [c]})).await?;
                        }
                    }
                    Ok(Event::Message(sample)) => {
                        latest.insert(sample.channel, sample.clone());
                        self.data(&sample).await?;
                    }
                    Err(broadcast::error::RecvError::Lagged(n)) => {
                        self.status(Level::Warning, format!("{n} messages dropped: this connection is slower than the fleet")).await?;
                    }
                    Err(broadcast::error::RecvError::Closed) => return Ok(()),
                },
            }
        }
    }

    /// Carry out a client's request; the channels newly subscribed, whose newest message
    /// the client gets at once.
    async fn request(&mut self, text: &str) -> Result<Vec<u32>, axum::Error> {
        let request = match serde_json::from_str::<Request>(text) {
            Ok(r) => r,
            Err(e) => {
                self.status(
                    Level::Error,
                    format!(
                        "request not understood ({e}): this server takes subscribe and unsubscribe"
                    ),
                )
                .await?;
                return Ok(Vec::new());
            }
        };
        let mut latched = Vec::new();
        match request {
            Request::Subscribe { subscriptions } => {
                for s in subscriptions {
                    let problem = if !self.advertised.contains(&s.channel_id) {
                        Some(format!(
                            "subscription {}: no channel {}",
                            s.id, s.channel_id
                        ))
                    } else if self.subscriptions.contains_key(&s.id) {
                        Some(format!("subscription {}: id already in use", s.id))
                    } else if self.by_channel.contains_key(&s.channel_id) {
                        Some(format!(
                            "subscription {}: channel {} already subscribed",
                            s.id, s.channel_id
                        ))
                    } else {
                        None
                    };
                    match problem {
                        Some(p) => self.status(Level::Error, p).await?,
                        None => {
                            self.subscriptions.insert(s.id, s.channel_id);
                            self.by_channel.insert(s.channel_id, s.id);
                            latched.push(s.channel_id);
                        }
                    }
                }
            }
            Request::Unsubscribe { subscription_ids } => {
                for id in subscription_ids {
                    match self.subscriptions.remove(&id) {
                        Some(channel) => {
                            self.by_channel.remove(&channel);
                        }
                        None => {
                            self.status(Level::Warning, format!("no subscription {id}"))
                                .await?
                        }
                    }
                }
            }
        }
        Ok(latched)
    }

    /// A Message Data frame of `sample`, if the client subscribed its channel.
    async fn data(&mut self, sample: &Sample) -> Result<(), axum::Error> {
        let Some(&subscription) = self.by_channel.get(&sample.channel) else {
            return Ok(());
        };
        let mut frame = Vec::with_capacity(13 + sample.data.len());
        frame.push(MESSAGE_DATA);
        frame.extend_from_slice(&subscription.to_le_bytes());
        frame.extend_from_slice(&sample.t_ns.to_le_bytes());
        frame.extend_from_slice(&sample.data);
        self.socket.send(Message::Binary(frame.into())).await
    }

    async fn status(&mut self, level: Level, message: String) -> Result<(), axum::Error> {
        let status = serde_json::json!({"op": "status", "level": level as u8, "message": message});
        self.send_json(&status).await
    }

    async fn send_json(&mut self, v: &serde_json::Value) -> Result<(), axum::Error> {
        self.socket.send(Message::Text(v.to_string().into())).await
    }
}
