//! The console's web page and API.
//!
//! ```text
//! GET    /                      the page (HTML, JS and CSS built into the binary: no
//!                               JS build chain, nothing fetched from the internet)
//! GET    /api/incident          the whole picture (picture::Incident), JSON
//! GET    /api/stream            server-sent events: `incident` (the whole picture) first
//!                               and again whenever this client fell behind, then a
//!                               `delta` (picture::Delta) every TICK with changes
//! POST   /api/login             {"name", "password"} -> a session cookie
//! POST   /api/logout
//! GET    /api/me                who is logged in (401 if nobody)
//! POST   /api/goals             a goal (`firefleet_protocol::msg::GoalForm`) -> the ack   [login]
//! DELETE /api/goals/{zone}      clear the login's goals on the zone          [login]
//! POST   /api/alerts/{id}/ack   acknowledge an alert                         [login]
//! ```
//!
//! Reading needs no login (the console binds to loopback unless told otherwise; a site
//! that serves it wider puts TLS in front); steering does. A goal's `issued_by` is the
//! session's commander: the form has no such field, and one sent is refused.
//! Errors are JSON `{"error": "..."}` naming what was wrong.
//!
//! Goals leave through [`GoalRequest`]s that the binary carries to the bus and answers,
//! so this module never touches Zenoh and its tests run without one.

use std::convert::Infallible;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use axum::extract::rejection::JsonRejection;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{delete, get, post};
use axum::{Json, Router};
use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::msg::{GoalAck, GoalForm, ZoneGoal};
use serde::Deserialize;
use serde_json::json;
use tokio::sync::{broadcast, mpsc, oneshot};

use crate::auth::{Sessions, Users};
use crate::picture::{Event, Picture};

/// How often changes are sent to pages: a unit's move shows within this, and a thousand
/// units' states coalesce into one message per unit per tick.
pub const TICK: Duration = Duration::from_millis(100);
/// The session cookie.
const COOKIE: &str = "ff_session";
/// Deltas a slow page may fall behind before it is sent the whole picture again.
const BACKLOG: usize = 64;

/// A goal on its way to the coordinator, answered by whoever carries it to the bus.
#[derive(Debug)]
pub enum GoalRequest {
    /// Put the goal; reply with the coordinator's ack (or why there is none).
    Set {
        goal: ZoneGoal,
        reply: oneshot::Sender<Result<GoalAck, String>>,
    },
    /// Clear `by`'s goals on `zone`.
    Clear {
        zone: ZoneId,
        by: CommanderId,
        reply: oneshot::Sender<Result<(), String>>,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Login {
    name: String,
    password: String,
}

/// The console's state, shared by the bus feed, the ticker and the HTTP handlers.
pub struct Console {
    picture: Mutex<Picture>,
    deltas: broadcast::Sender<Arc<str>>,
    users: Users,
    sessions: Sessions,
    goals: mpsc::Sender<GoalRequest>,
    /// Whether the page is served over TLS (the cookie is then `Secure`).
    secure: bool,
}

/// Wall time, ms since the Unix epoch: what a page compares freshness against.
pub fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

impl Console {
    /// A console over `picture`; the receiver gets the goals commanders issue.
    pub fn new(
        picture: Picture,
        users: Users,
        sessions: Sessions,
        secure: bool,
    ) -> (Arc<Self>, mpsc::Receiver<GoalRequest>) {
        let (goals, requests) = mpsc::channel(16);
        let (deltas, _) = broadcast::channel(BACKLOG);
        let console = Arc::new(Self {
            picture: Mutex::new(picture),
            deltas,
            users,
            sessions,
            goals,
            secure,
        });
        (console, requests)
    }

    fn picture(&self) -> std::sync::MutexGuard<'_, Picture> {
        self.picture.lock().expect("picture lock")
    }

    /// Take in what the bus said.
    pub fn observe(&self, event: Event) {
        self.picture().observe(now_ms(), event);
    }

    /// Send pages what changed since the last tick; the binary calls it every [`TICK`].
    pub fn tick(&self) {
        let delta = self.picture().delta(now_ms());
        if let Some(delta) = delta
            && self.deltas.receiver_count() > 0
        {
            let json = serde_json::to_string(&delta).expect("a delta serialises");
            let _ = self.deltas.send(json.into());
        }
    }

    /// The page and the API.
    pub fn router(self: Arc<Self>) -> Router {
        Router::new()
            .route(
                "/",
                get(|| async { asset("text/html; charset=utf-8", PAGE) }),
            )
            .route(
                "/console.js",
                get(|| async { asset("text/javascript; charset=utf-8", SCRIPT) }),
            )
            .route(
                "/console.css",
                get(|| async { asset("text/css; charset=utf-8", STYLE) }),
            )
            .route("/api/incident", get(incident))
            .route("/api/stream", get(stream))
            .route("/api/login", post(login))
            .route("/api/logout", post(logout))
            .route("/api/me", get(me))
            .route("/api/goals", post(set_goal))
            .route("/api/goals/{zone}", delete(clear_goals))
            .route("/api/alerts/{id}/ack", post(ack_alert))
            .with_state(self)
    }

    fn session(&self, headers: &HeaderMap) -> Option<(String, CommanderId)> {
        let token = cookie(headers, COOKIE)?;
        let who = self.sessions.who(&token, Instant::now())?;
        Some((token, who))
    }

    fn commander(&self, headers: &HeaderMap) -> Option<CommanderId> {
        self.session(headers).map(|(_, who)| who)
    }
}

const PAGE: &str = include_str!("../../assets/index.html");
const SCRIPT: &str = include_str!("../../assets/console.js");
const STYLE: &str = include_str!("../../assets/console.css");

fn asset(content_type: &'static str, body: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

fn error(status: StatusCode, message: impl Into<String>) -> Response {
    (status, Json(json!({ "error": message.into() }))).into_response()
}

fn unauthorized() -> Response {
    error(StatusCode::UNAUTHORIZED, "log in to steer the incident")
}

fn bad_json(e: JsonRejection) -> Response {
    error(StatusCode::BAD_REQUEST, e.body_text())
}

/// The value of cookie `name`, if the request carries it.
fn cookie(headers: &HeaderMap, name: &str) -> Option<String> {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|kv| kv.trim().split_once('='))
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v.to_owned())
}

async fn incident(State(c): State<Arc<Console>>) -> Response {
    let incident = c.picture().incident();
    Json(incident).into_response()
}

async fn stream(State(c): State<Arc<Console>>) -> Response {
    // Subscribe before taking the picture: a delta made in between is then both in the
    // picture and in the stream, which the page applies harmlessly (it skips deltas the
    // picture's number already covers).
    let deltas = c.deltas.subscribe();
    let first = whole(&c);
    let events = futures_util::stream::unfold(
        (Some(first), deltas, c),
        |(first, mut deltas, c)| async move {
            if let Some(first) = first {
                return Some((Ok::<_, Infallible>(first), (None, deltas, c)));
            }
            let event = match deltas.recv().await {
                Ok(json) => SseEvent::default().event("delta").data(&*json),
                Err(broadcast::error::RecvError::Lagged(_)) => whole(&c),
                Err(broadcast::error::RecvError::Closed) => return None,
            };
            Some((Ok(event), (None, deltas, c)))
        },
    );
    Sse::new(events)
        .keep_alive(KeepAlive::default())
        .into_response()
}

/// The whole picture as a stream event.
fn whole(c: &Console) -> SseEvent {
    // Copied under the lock, serialised outside it.
    let incident = c.picture().incident();
    let json = serde_json::to_string(&incident).expect("a picture serialises");
    SseEvent::default().event("incident").data(json)
}

async fn login(
    State(c): State<Arc<Console>>,
    body: Result<Json<Login>, JsonRejection>,
) -> Response {
    let Json(form) = match body {
        Ok(b) => b,
        Err(e) => return bad_json(e),
    };
    // Argon2 is deliberately slow: off the async workers.
    let console = c.clone();
    let who = tokio::task::spawn_blocking(move || console.users.verify(&form.name, &form.password))
        .await
        .ok()
        .flatten();
    let Some(who) = who else {
        tracing::warn!("console: a failed login");
        return error(StatusCode::UNAUTHORIZED, "wrong name or password");
    };
    tracing::info!("console: {who} logged in");
    let token = c.sessions.open(who.clone(), Instant::now());
    let cookie = format!(
        "{COOKIE}={token}; HttpOnly; SameSite=Strict; Path=/; Max-Age={}{}",
        c.sessions.ttl().as_secs(),
        if c.secure { "; Secure" } else { "" }
    );
    let mut response = Json(json!({ "name": who })).into_response();
    if let Ok(v) = HeaderValue::from_str(&cookie) {
        response.headers_mut().insert(header::SET_COOKIE, v);
    }
    response
}

async fn logout(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    if let Some((token, who)) = c.session(&headers) {
        c.sessions.close(&token);
        tracing::info!("console: {who} logged out");
    }
    let mut response = Json(json!({})).into_response();
    response.headers_mut().insert(
        header::SET_COOKIE,
        HeaderValue::from_static("ff_session=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0"),
    );
    response
}

async fn me(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    match c.commander(&headers) {
        Some(who) => Json(json!({ "name": who })).into_response(),
        None => unauthorized(),
    }
}

async fn set_goal(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    body: Result<Json<GoalForm>, JsonRejection>,
) -> Response {
    let Some(who) = c.commander(&headers) else {
        return unauthorized();
    };
    let Json(form) = match body {
        Ok(b) => b,
        Err(e) => return bad_json(e),
    };
    if !c.picture().site().zones.iter().any(|z| z.id == form.zone) {
        return error(
            StatusCode::BAD_REQUEST,
            format!("zone: the site has no zone '{}'", form.zone),
        );
    }
    let goal = match form.issued_by(who.clone()) {
        Ok(g) => g,
        Err(e) => return error(StatusCode::BAD_REQUEST, e.to_string()),
    };
    tracing::info!(
        "console: {who} sets goal '{}' on zone {}",
        goal.id,
        goal.zone
    );
    let Some(answer) = ask(&c, |reply| GoalRequest::Set { goal, reply }).await else {
        return shutting_down();
    };
    match answer {
        Ok(ack) => {
            let status = if ack.accepted {
                StatusCode::OK
            } else {
                StatusCode::CONFLICT
            };
            (status, Json(ack)).into_response()
        }
        Err(why) => error(StatusCode::GATEWAY_TIMEOUT, why),
    }
}

/// Hand a request to whoever carries goals to the bus and wait for the answer; none if the
/// console is going away.
async fn ask<T>(
    c: &Console,
    request: impl FnOnce(oneshot::Sender<Result<T, String>>) -> GoalRequest,
) -> Option<Result<T, String>> {
    let (reply, answer) = oneshot::channel();
    c.goals.send(request(reply)).await.ok()?;
    answer.await.ok()
}

fn shutting_down() -> Response {
    error(
        StatusCode::SERVICE_UNAVAILABLE,
        "the console is shutting down",
    )
}

async fn clear_goals(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    Path(zone): Path<String>,
) -> Response {
    let Some(who) = c.commander(&headers) else {
        return unauthorized();
    };
    let zone = match ZoneId::new(zone.as_str()) {
        Ok(z) if c.picture().site().zones.iter().any(|s| s.id == z) => z,
        _ => {
            return error(
                StatusCode::NOT_FOUND,
                format!("zone: the site has no zone '{zone}'"),
            );
        }
    };
    tracing::info!("console: {who} clears their goals on zone {zone}");
    let request = |reply| GoalRequest::Clear {
        zone: zone.clone(),
        by: who.clone(),
        reply,
    };
    let Some(answer) = ask(&c, request).await else {
        return shutting_down();
    };
    match answer {
        Ok(()) => Json(json!({ "zone": zone, "cleared_by": who })).into_response(),
        Err(why) => error(StatusCode::BAD_GATEWAY, why),
    }
}

async fn ack_alert(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Response {
    let Some(who) = c.commander(&headers) else {
        return unauthorized();
    };
    let Ok(id) = id.parse::<u64>() else {
        return error(StatusCode::NOT_FOUND, format!("no alert '{id}'"));
    };
    if c.picture().acknowledge(id, who.as_str()) {
        Json(json!({ "id": id, "acked_by": who })).into_response()
    } else {
        error(StatusCode::NOT_FOUND, format!("no alert {id}"))
    }
}

#[cfg(test)]
mod tests;
