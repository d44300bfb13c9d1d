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
//! POST   /api/goals/preview     a goal's form -> what it would do (`GoalPreview`)      [login]
//! DELETE /api/goals/{zone}      clear the login's goals on the zone          [login]
//! POST   /api/alerts/{id}/ack   acknowledge an alert                         [login]
//! GET    /api/audit[?format=csv] who issued, cleared, acknowledged what, when [read]
//! ```
//!
//! Who may do what. With a users file, reading needs a login (a viewer's or a
//! commander's) and steering a commander's; without one nobody can log in, and the console
//! serves reads to anyone only if it is bound to loopback (a developer's machine: the
//! `serve` command refuses anything wider). A goal's `issued_by` is the session's
//! commander: the form has no such field, and one sent is refused.
//! Errors are JSON `{"error": "..."}` naming what was wrong.
//!
//! Under attack, as the console must hold during an incident:
//! - logins are throttled per client address and per name ([`crate::throttle`]); password
//!   checks run [`HASHING`] at a time on threads of their own with a bounded queue (Argon2
//!   takes 19 MiB each: 64 at once took the console to 5.9 GB; see [`Checker`]), and cost
//!   the same for unknown names ([`crate::auth`]);
//! - each login holds at most [`MAX_STREAMS_PER_LOGIN`] streams;
//! - a state-changing request whose `Origin` (or `Sec-Fetch-Site`) says another site made
//!   it is refused (403): the cookie is `SameSite=Strict` too, but an old browser or a
//!   sibling subdomain is not stopped by that alone;
//! - every answer carries a Content-Security-Policy that allows nothing but this console's
//!   own script and style, no framing (`frame-ancestors 'none'`, `X-Frame-Options: DENY`),
//!   `nosniff`, no referrer, and, over HTTPS, HSTS.
//!
//! Goals leave through [`GoalRequest`]s that the binary carries to the bus and answers,
//! so this module never touches Zenoh and its tests run without one.

use std::collections::HashMap;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use axum::extract::rejection::JsonRejection;
use axum::extract::{ConnectInfo, FromRequestParts, Path, Query, State};
use axum::http::request::Parts;
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{delete, get, post};
use axum::{Json, Router};
use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::msg::{GoalAck, GoalForm, GoalPreview, ZoneGoal};
use serde::Deserialize;
use serde_json::json;
use tokio::sync::{broadcast, mpsc, oneshot};

use crate::alarm_file::AlarmFile;
use crate::audit::{Action, Audit, Entry as AuditEntry};
use crate::auth::{CheckRefused, Checker, Role, Sessions, Users};
use crate::history::{History, Snapshot};
use crate::picture::{Event, Picture};
use crate::throttle::Throttle;

/// How often changes are sent to pages: a unit's move shows within this, and a thousand
/// units' states coalesce into one message per unit per tick.
pub const TICK: Duration = Duration::from_millis(100);
/// The session cookie.
const COOKIE: &str = "ff_session";
/// Deltas a slow page may fall behind before it is sent the whole picture again.
const BACKLOG: usize = 64;
/// Streams one login may hold open at once: a page in a few tabs.
pub const MAX_STREAMS_PER_LOGIN: usize = 4;
/// Password checks at once ([`Checker`]): each takes Argon2's 19 MiB and a core for some
/// 20 ms, so a crowd of logins queues instead of taking the memory.
pub const HASHING: usize = 2;
/// The page's Content-Security-Policy: its own script, style and API, nothing else, never
/// in a frame. Images are the SVG the script draws, which is markup, not a fetch.
const CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; connect-src 'self'; img-src 'self' data:; base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

/// How often the stream beats while it has nothing else to say.
pub const BEAT: std::time::Duration = std::time::Duration::from_secs(1);

/// A goal on its way to the coordinator, answered by whoever carries it to the bus.
#[derive(Debug)]
pub enum GoalRequest {
    /// Put the goal; reply with the coordinator's ack (or why there is none).
    Set {
        goal: ZoneGoal,
        reply: oneshot::Sender<Result<GoalAck, String>>,
    },
    /// What the goal would do if it were put now: the coordinator's preview.
    Preview {
        goal: ZoneGoal,
        reply: oneshot::Sender<Result<GoalPreview, String>>,
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
    passwords: Checker,
    sessions: Sessions,
    goals: mpsc::Sender<GoalRequest>,
    /// Whether the page is served over TLS (the cookie is then `Secure`, and HSTS sent).
    secure: bool,
    /// Reads need no login (no users file, on loopback).
    open_reads: bool,
    throttle: Throttle,
    /// Streams open, by session token.
    streams: Mutex<HashMap<String, usize>>,
    /// Who did what through this console.
    audit: Audit,
    /// The alarms as they stand, for a restart.
    alarms: AlarmFile,
    /// The timeline, for a late page and a restart.
    history: Mutex<History>,
}

/// What a console keeps of the incident beside its picture, in its state directory or
/// only in memory.
#[derive(Debug)]
pub struct Records {
    /// Who did what through it.
    pub audit: Audit,
    /// The alarms as they stand.
    pub alarms: AlarmFile,
    /// The timeline.
    pub history: History,
}

impl Records {
    /// Records a restart loses (a console with no state directory).
    pub fn in_memory() -> Self {
        Self {
            audit: Audit::in_memory(),
            alarms: AlarmFile::in_memory(),
            history: History::in_memory(),
        }
    }
}

/// How a console is served.
#[derive(Debug, Clone, Copy)]
pub struct Serving {
    /// Over TLS.
    pub secure: bool,
    /// Reads need no login: only for a console with no users file bound to loopback.
    pub open_reads: bool,
}

/// Wall time, ms since the Unix epoch: what a page compares freshness against.
pub fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

impl Console {
    /// A console over `picture`, keeping what commanders do, its alarms and the timeline
    /// in `records`; the receiver gets the goals commanders issue.
    pub fn new(
        picture: Picture,
        users: Users,
        sessions: Sessions,
        serving: Serving,
        records: Records,
    ) -> (Arc<Self>, mpsc::Receiver<GoalRequest>) {
        let Records {
            audit,
            alarms,
            history,
        } = records;
        let (goals, requests) = mpsc::channel(16);
        let (deltas, _) = broadcast::channel(BACKLOG);
        let console = Arc::new(Self {
            picture: Mutex::new(picture),
            deltas,
            passwords: Checker::new(users, HASHING),
            sessions,
            goals,
            secure: serving.secure,
            open_reads: serving.open_reads,
            throttle: Throttle::default(),
            streams: Mutex::new(HashMap::new()),
            audit,
            alarms,
            history: Mutex::new(history),
        });
        (console, requests)
    }

    /// Keep in the audit log that `who` did `action` about `what`, with `outcome`.
    fn audited(&self, who: &CommanderId, action: Action, what: String, outcome: String) {
        let t = self.picture().t();
        self.audit.note(AuditEntry {
            wall_ms: now_ms(),
            t,
            who: who.to_string(),
            action,
            what,
            outcome,
        });
    }

    /// Change alert `id` (a path's text) by `change`, which says whether it did; the
    /// alarms are kept before the commander is answered (an acknowledged or shelved alarm
    /// must not sound again after a restart). The alert's number and text; `None` if there
    /// is no such alert to change ([`no_alert`]).
    fn change_alert(
        &self,
        id: &str,
        change: impl FnOnce(&mut Picture, u64) -> bool,
    ) -> Option<(u64, String)> {
        let n = id.parse::<u64>().ok()?;
        let (text, alarms) = {
            let mut picture = self.picture();
            let text = picture.alert_text(n)?;
            if !change(&mut picture, n) {
                return None;
            }
            (text, picture.alerts())
        };
        self.alarms.keep(&alarms, now_ms());
        Some((n, text))
    }

    fn picture(&self) -> std::sync::MutexGuard<'_, Picture> {
        self.picture.lock().expect("picture lock")
    }

    fn history(&self) -> std::sync::MutexGuard<'_, History> {
        self.history.lock().expect("history lock")
    }

    /// The units of the site this console shows.
    pub fn units(&self) -> Vec<firefleet_model::UnitId> {
        let picture = self.picture();
        picture
            .site()
            .units
            .iter()
            .filter_map(|u| firefleet_model::UnitId::new(u.id.as_str()).ok())
            .collect()
    }

    /// Take in what the bus said.
    pub fn observe(&self, event: Event) {
        self.picture().observe(now_ms(), event);
    }

    /// Send pages what changed since the last tick, and keep a snapshot for the timeline
    /// when one is due; the binary calls it every [`TICK`].
    pub fn tick(&self) {
        let now = now_ms();
        let (delta, alarms, snap, unshelved) = {
            let mut picture = self.picture();
            let unshelved = picture.unshelve_due(now);
            let delta = picture.delta(now);
            let changed = delta.as_ref().is_some_and(|d| !d.alerts.is_empty());
            let due = self.alarms.due(changed, now);
            let snap = self
                .history()
                .due(picture.t())
                .then(|| Snapshot::of(&picture.incident()))
                // Nothing heard yet: nothing to draw.
                .filter(|s| !s.units.is_empty() || !s.fires.is_empty());
            let alarms = (due || !unshelved.is_empty()).then(|| picture.alerts());
            (delta, alarms, snap, unshelved)
        };
        if let Some(alarms) = alarms {
            self.alarms.keep(&alarms, now);
        }
        for a in unshelved {
            let by = a
                .shelved
                .as_ref()
                .and_then(|s| CommanderId::new(&s.by).ok());
            if let Some(by) = by {
                let what = format!("alarm {}: {}", a.id, a.text);
                self.audited(
                    &by,
                    Action::Unshelve,
                    what,
                    "back: its time on the shelf is up".into(),
                );
            }
        }
        if let Some(snap) = snap {
            self.history().record(snap);
        }
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
            .route(
                "/report.css",
                get(|| async { asset("text/css; charset=utf-8", REPORT_STYLE) }),
            )
            .route("/report", get(report))
            .route("/api/incident", get(incident))
            .route("/api/stream", get(stream))
            .route("/api/login", post(login))
            .route("/api/logout", post(logout))
            .route("/api/me", get(me))
            .route("/api/goals", post(set_goal))
            .route("/api/goals/preview", post(preview_goal))
            .route("/api/goals/{zone}", delete(clear_goals))
            .route("/api/alerts/{id}/ack", post(ack_alert))
            .route("/api/alerts/{id}/shelve", post(shelve_alert))
            .route("/api/alerts/{id}/unshelve", post(unshelve_alert))
            .route("/api/audit", get(audit))
            .route("/api/history", get(history))
            .layer(axum::middleware::from_fn_with_state(self.clone(), guard))
            .with_state(self)
    }

    fn session(&self, headers: &HeaderMap) -> Option<(String, CommanderId, Role)> {
        let token = cookie(headers, COOKIE)?;
        let (who, role) = self.sessions.who(&token, Instant::now())?;
        Some((token, who, role))
    }

    /// The commander logged in, if a commander is (a viewer steers nothing).
    fn commander(&self, headers: &HeaderMap) -> Option<CommanderId> {
        self.session(headers)
            .filter(|(_, _, role)| *role == Role::Commander)
            .map(|(_, who, _)| who)
    }

    /// Whether the request may read the incident.
    fn may_read(&self, headers: &HeaderMap) -> bool {
        self.open_reads || self.session(headers).is_some()
    }
}

/// Every request: a state-changing one from another site is refused; every answer gets the
/// security headers.
async fn guard(
    State(c): State<Arc<Console>>,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let changes = !matches!(
        *request.method(),
        Method::GET | Method::HEAD | Method::OPTIONS
    );
    let mut response = match foreign(request.headers()) {
        Some(why) if changes => {
            tracing::warn!(
                "console: refused a {} from another site: {why}",
                request.method()
            );
            error(
                StatusCode::FORBIDDEN,
                format!("cross-site request refused: {why}"),
            )
        }
        _ => next.run(request).await,
    };
    let h = response.headers_mut();
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CSP),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    if c.secure {
        h.insert(
            header::STRICT_TRANSPORT_SECURITY,
            HeaderValue::from_static("max-age=31536000"),
        );
    }
    response
}

/// Why a request comes from another site, if its headers say it does: an `Origin` whose
/// host is not the `Host` it was sent to, or `Sec-Fetch-Site: cross-site`. A request with
/// neither (curl, a script on the console's host) is not a browser's cross-site request.
fn foreign(headers: &HeaderMap) -> Option<String> {
    let text = |name| {
        headers
            .get(name)
            .and_then(|v: &HeaderValue| v.to_str().ok())
    };
    if let Some(site) = text(header::HeaderName::from_static("sec-fetch-site"))
        && site == "cross-site"
    {
        return Some("Sec-Fetch-Site: cross-site".into());
    }
    let origin = text(header::ORIGIN)?;
    let host = text(header::HOST).unwrap_or("");
    let origin_host = origin
        .split_once("://")
        .map_or("", |(_, rest)| rest.trim_end_matches('/'));
    (origin == "null" || origin_host != host).then(|| format!("Origin {origin} is not {host}"))
}

/// The peer address of a connection, as the server hands it to the router
/// (`Console::router().into_make_service_with_connect_info::<Peer>()`), over plain TCP or
/// TLS alike.
#[derive(Debug, Clone, Copy)]
pub struct Peer(pub SocketAddr);

impl
    axum::extract::connect_info::Connected<axum::serve::IncomingStream<'_, tokio::net::TcpListener>>
    for Peer
{
    fn connect_info(stream: axum::serve::IncomingStream<'_, tokio::net::TcpListener>) -> Self {
        Peer(*stream.remote_addr())
    }
}

impl
    axum::extract::connect_info::Connected<axum::serve::IncomingStream<'_, crate::tls::TlsListener>>
    for Peer
{
    fn connect_info(stream: axum::serve::IncomingStream<'_, crate::tls::TlsListener>) -> Self {
        Peer(*stream.remote_addr())
    }
}

/// The client's address, where the server knows it (not in tests that call the router
/// directly).
struct Client(Option<std::net::IpAddr>);

impl<S: Send + Sync> FromRequestParts<S> for Client {
    type Rejection = Infallible;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, Self::Rejection> {
        Ok(Client(
            parts
                .extensions
                .get::<ConnectInfo<Peer>>()
                .map(|c| c.0.0.ip()),
        ))
    }
}

const PAGE: &str = include_str!("../../assets/index.html");
const SCRIPT: &str = include_str!("../../assets/console.js");
const REPORT_STYLE: &str = include_str!("../../assets/report.css");
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
    error(
        StatusCode::UNAUTHORIZED,
        "log in as a commander to steer the incident",
    )
}

fn login_to_read() -> Response {
    error(StatusCode::UNAUTHORIZED, "log in to see the incident")
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

async fn incident(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    if !c.may_read(&headers) {
        return login_to_read();
    }
    let incident = c.picture().incident();
    Json(incident).into_response()
}

/// One stream counted against its login while it is open.
struct StreamSlot {
    console: Arc<Console>,
    token: Option<String>,
}

impl StreamSlot {
    /// A slot for a stream of session `token` (none for open reads without a login); none
    /// if the login holds [`MAX_STREAMS_PER_LOGIN`] already.
    fn take(console: &Arc<Console>, token: Option<String>) -> Option<Self> {
        if let Some(t) = &token {
            let mut open = console.streams.lock().expect("streams lock");
            let n = open.entry(t.clone()).or_insert(0);
            if *n >= MAX_STREAMS_PER_LOGIN {
                return None;
            }
            *n += 1;
        }
        Some(Self {
            console: console.clone(),
            token,
        })
    }
}

impl Drop for StreamSlot {
    fn drop(&mut self) {
        if let Some(t) = &self.token {
            let mut open = self.console.streams.lock().expect("streams lock");
            if let Some(n) = open.get_mut(t) {
                *n -= 1;
                if *n == 0 {
                    open.remove(t);
                }
            }
        }
    }
}

async fn stream(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    let token = match c.session(&headers) {
        Some((token, ..)) => Some(token),
        None if c.open_reads => None,
        None => return login_to_read(),
    };
    let Some(slot) = StreamSlot::take(&c, token) else {
        return error(
            StatusCode::TOO_MANY_REQUESTS,
            format!("this login has {MAX_STREAMS_PER_LOGIN} streams open already"),
        );
    };
    // Subscribe before taking the picture: a delta made in between is then both in the
    // picture and in the stream, which the page applies harmlessly (it skips deltas the
    // picture's number already covers).
    let deltas = c.deltas.subscribe();
    let first = whole(&c);
    let events = futures_util::stream::unfold(
        (Some(first), deltas, slot),
        |(first, mut deltas, slot)| async move {
            if let Some(first) = first {
                return Some((Ok::<_, Infallible>(first), (None, deltas, slot)));
            }
            let event = match deltas.recv().await {
                Ok(json) => SseEvent::default().event("delta").data(&*json),
                Err(broadcast::error::RecvError::Lagged(_)) => whole(&slot.console),
                Err(broadcast::error::RecvError::Closed) => return None,
            };
            Some((Ok(event), (None, deltas, slot)))
        },
    );
    // A beat every second, as an event the page hears (a comment it would not): a page
    // whose console is gone says so within [`BEAT`] three times over, not when the
    // browser's connection times out (15 s and more).
    Sse::new(events)
        .keep_alive(
            KeepAlive::new()
                .interval(BEAT)
                .event(SseEvent::default().event("beat").data("")),
        )
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
    Client(ip): Client,
    body: Result<Json<Login>, JsonRejection>,
) -> Response {
    let Json(form) = match body {
        Ok(b) => b,
        Err(e) => return bad_json(e),
    };
    // Keyed by the name as sent, known or not: a closed name tells nothing either way.
    let name: String = form.name.chars().take(64).collect();
    let mut keys = vec![format!("name:{name}")];
    if let Some(ip) = ip {
        keys.push(format!("ip:{ip}"));
    }
    if let Some(wait) = c.throttle.closed_for(&keys, Instant::now()) {
        let secs = wait.as_secs_f64().ceil() as u64;
        let mut r = error(
            StatusCode::TOO_MANY_REQUESTS,
            format!("too many failed logins: try again in {secs} s"),
        );
        if let Ok(v) = HeaderValue::from_str(&secs.to_string()) {
            r.headers_mut().insert(header::RETRY_AFTER, v);
        }
        return r;
    }
    // Argon2 is deliberately slow and large: on the checker's threads, a few at a time.
    let verified = match c.passwords.verify(form.name, form.password).await {
        Ok(v) => v,
        Err(e @ CheckRefused::Busy) => {
            let mut r = error(StatusCode::SERVICE_UNAVAILABLE, e.to_string());
            r.headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from_static("1"));
            return r;
        }
        Err(CheckRefused::Gone) => return shutting_down(),
    };
    let Some((who, role)) = verified else {
        c.throttle.failed(&keys, Instant::now());
        tracing::warn!(ip = ?ip, "console: a failed login");
        return error(StatusCode::UNAUTHORIZED, "wrong name or password");
    };
    c.throttle.succeeded(&keys);
    tracing::info!("console: {who} logged in as {role:?}");
    let token = c.sessions.open(who.clone(), role, Instant::now());
    let cookie = format!(
        "{COOKIE}={token}; HttpOnly; SameSite=Strict; Path=/; Max-Age={}{}",
        c.sessions.ttl().as_secs(),
        if c.secure { "; Secure" } else { "" }
    );
    let mut response = Json(json!({ "name": who, "role": role })).into_response();
    if let Ok(v) = HeaderValue::from_str(&cookie) {
        response.headers_mut().insert(header::SET_COOKIE, v);
    }
    response
}

async fn logout(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    if let Some((token, who, _)) = c.session(&headers) {
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
    match c.session(&headers) {
        Some((_, who, role)) => Json(json!({ "name": who, "role": role })).into_response(),
        None => error(
            StatusCode::UNAUTHORIZED,
            if c.open_reads {
                "nobody is logged in"
            } else {
                "log in to see the incident"
            },
        ),
    }
}

/// The goal a logged-in commander's form states, checked as every tool checks one, or the
/// answer that says why there is none.
fn goal_of(
    c: &Console,
    headers: &HeaderMap,
    body: Result<Json<GoalForm>, JsonRejection>,
) -> Result<(CommanderId, ZoneGoal), Box<Response>> {
    let who = c
        .commander(headers)
        .ok_or_else(|| Box::new(unauthorized()))?;
    let Json(form) = body.map_err(|e| Box::new(bad_json(e)))?;
    if !c.picture().site().zones.iter().any(|z| z.id == form.zone) {
        return Err(Box::new(error(
            StatusCode::BAD_REQUEST,
            format!("zone: the site has no zone '{}'", form.zone),
        )));
    }
    let goal = form
        .issued_by(who.clone())
        .map_err(|e| Box::new(error(StatusCode::BAD_REQUEST, e.to_string())))?;
    Ok((who, goal))
}

async fn preview_goal(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    body: Result<Json<GoalForm>, JsonRejection>,
) -> Response {
    let goal = match goal_of(&c, &headers, body) {
        Ok((_, g)) => g,
        Err(r) => return *r,
    };
    let Some(answer) = ask(&c, |reply| GoalRequest::Preview { goal, reply }).await else {
        return shutting_down();
    };
    match answer {
        Ok(preview) => Json(preview).into_response(),
        Err(why) => error(StatusCode::GATEWAY_TIMEOUT, why),
    }
}

async fn set_goal(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    body: Result<Json<GoalForm>, JsonRejection>,
) -> Response {
    let (who, goal) = match goal_of(&c, &headers, body) {
        Ok(g) => g,
        Err(r) => return *r,
    };
    tracing::info!(
        "console: {who} sets goal '{}' on zone {}",
        goal.id,
        goal.zone
    );
    let what = format!("{} on zone {} (goal '{}')", goal.goal, goal.zone, goal.id);
    let Some(answer) = ask(&c, |reply| GoalRequest::Set { goal, reply }).await else {
        return shutting_down();
    };
    let outcome = match &answer {
        Ok(ack) if ack.accepted => format!("accepted: {}", ack.reason),
        Ok(ack) => format!("rejected: {}", ack.reason),
        Err(why) => format!("no answer: {why}"),
    };
    c.audited(&who, Action::Goal, what, outcome);
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
    // The clear waits until the goals in force hold none of theirs (`goal::clear`).
    let outcome = match &answer {
        Ok(()) => "cleared".to_owned(),
        Err(why) => format!("not cleared: {why}"),
    };
    c.audited(
        &who,
        Action::Clear,
        format!("their goals on zone {zone}"),
        outcome,
    );
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
    match c.change_alert(&id, |p, id| p.acknowledge(id, who.as_str())) {
        Some((id, text)) => {
            c.audited(
                &who,
                Action::Acknowledge,
                format!("alarm {id}: {text}"),
                "acknowledged".into(),
            );
            Json(json!({ "id": id, "acked_by": who })).into_response()
        }
        None => no_alert(&id),
    }
}

/// The answer for a path's alert `id` there is nothing to do to.
fn no_alert(id: &str) -> Response {
    error(StatusCode::NOT_FOUND, format!("no such alert: '{id}'"))
}

/// The longest an alarm may be shelved, minutes: a shift. An alarm that must be quiet for
/// longer is a fault to repair or a setting to change, not a shelf's (EEMUA 191).
pub const MAX_SHELVE_MIN: f64 = 480.0;
/// The longest reason, characters.
pub const MAX_SHELVE_REASON: usize = 200;

/// What a commander sends to shelve an alarm.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShelveForm {
    reason: String,
    minutes: f64,
}

/// A commander shelves an alarm: off the banner and silent, for a reason, for a time.
async fn shelve_alert(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    Path(id): Path<String>,
    form: Result<Json<ShelveForm>, JsonRejection>,
) -> Response {
    let Some(who) = c.commander(&headers) else {
        return unauthorized();
    };
    let Json(form) = match form {
        Ok(f) => f,
        Err(e) => return bad_json(e),
    };
    let reason = form.reason.trim();
    if reason.is_empty() || reason.chars().count() > MAX_SHELVE_REASON {
        return error(
            StatusCode::UNPROCESSABLE_ENTITY,
            format!("reason: say why, in 1 to {MAX_SHELVE_REASON} characters"),
        );
    }
    if !(form.minutes > 0.0 && form.minutes <= MAX_SHELVE_MIN) {
        return error(
            StatusCode::UNPROCESSABLE_ENTITY,
            format!(
                "minutes: {} is not a time on the shelf (more than 0, at most {MAX_SHELVE_MIN}: a shift)",
                form.minutes
            ),
        );
    }
    let until_ms = now_ms() + (form.minutes * 60_000.0) as u64;
    match c.change_alert(&id, |p, id| p.shelve(id, who.as_str(), reason, until_ms)) {
        Some((id, text)) => {
            c.audited(
                &who,
                Action::Shelve,
                format!("alarm {id}: {text}"),
                format!("shelved for {} min: {reason}", form.minutes),
            );
            Json(json!({ "id": id, "shelved_by": who, "until_ms": until_ms })).into_response()
        }
        None => no_alert(&id),
    }
}

/// A commander takes an alarm back from the shelf before its time is up.
async fn unshelve_alert(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Response {
    let Some(who) = c.commander(&headers) else {
        return unauthorized();
    };
    match c.change_alert(&id, |p, id| p.unshelve(id)) {
        Some((id, text)) => {
            c.audited(
                &who,
                Action::Unshelve,
                format!("alarm {id}: {text}"),
                "taken back from the shelf".into(),
            );
            Json(json!({ "id": id })).into_response()
        }
        None => no_alert(&id),
    }
}

/// The audit log as JSON (`?format=csv`: as CSV, for a spreadsheet or the report).
async fn audit(
    State(c): State<Arc<Console>>,
    headers: HeaderMap,
    Query(q): Query<HashMap<String, String>>,
) -> Response {
    if !c.may_read(&headers) {
        return login_to_read();
    }
    if q.get("format").is_some_and(|f| f == "csv") {
        return (
            [
                (header::CONTENT_TYPE, "text/csv; charset=utf-8"),
                (
                    header::CONTENT_DISPOSITION,
                    "attachment; filename=\"firefleet-audit.csv\"",
                ),
            ],
            c.audit.csv(),
        )
            .into_response();
    }
    Json(c.audit.entries()).into_response()
}

/// The after-action report ([`crate::report`]), printed now.
async fn report(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    if !c.may_read(&headers) {
        return login_to_read();
    }
    let (site, alerts, decisions) = {
        let picture = c.picture();
        let incident = picture.incident();
        (incident.site, incident.alerts, incident.decisions)
    };
    let audit = c.audit.entries();
    let printed = crate::report::utc(now_ms());
    let page = {
        let history = c.history();
        crate::report::render(&crate::report::Records {
            site: &site,
            snaps: &history.served(),
            alerts: &alerts,
            audit: &audit,
            decisions: &decisions,
            printed: &printed,
        })
    };
    ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], page).into_response()
}

/// The timeline's snapshots, oldest first ([`History::served`]).
async fn history(State(c): State<Arc<Console>>, headers: HeaderMap) -> Response {
    if !c.may_read(&headers) {
        return login_to_read();
    }
    let body = {
        let history = c.history();
        serde_json::to_string(&history.served()).expect("snapshots serialise")
    };
    ([(header::CONTENT_TYPE, "application/json")], body).into_response()
}

#[cfg(test)]
mod tests;
