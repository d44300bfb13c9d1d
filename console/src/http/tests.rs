//! The API as a page uses it, without a network: requests through the router.

use super::*;
use crate::site::SiteMap;
use axum::body::Body;
use axum::http::Request;
use firefleet_model::scenario::Scenario;
use tower::ServiceExt;

struct Fixture {
    console: Arc<Console>,
    requests: mpsc::Receiver<GoalRequest>,
    _dir: tempfile::TempDir,
}

fn fixture() -> Fixture {
    fixture_serving(Serving {
        secure: false,
        open_reads: false,
    })
}

/// A console with commander rossi and viewer ferri, served as `serving` says.
fn fixture_serving(serving: Serving) -> Fixture {
    let text = include_str!("../../../model/scenarios/rail-tunnel.toml");
    let scenario = Scenario::from_toml(text, "rail-tunnel.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("users.toml");
    let add = |name, password, role| {
        Users::add(&path, CommanderId::new(name).unwrap(), password, role).unwrap();
    };
    add("rossi", "correct horse", Role::Commander);
    add("ferri", "battery staple", Role::Viewer);
    let users = Users::load(&path).unwrap();
    let (console, requests) = Console::new(
        Picture::new(SiteMap::new(&scenario)),
        users,
        Sessions::new(Duration::from_secs(3600)),
        serving,
        crate::http::Records::in_memory(),
    );
    Fixture {
        console,
        requests,
        _dir: dir,
    }
}

async fn call(
    c: &Arc<Console>,
    method: &str,
    uri: &str,
    cookie: Option<&str>,
    body: Option<serde_json::Value>,
) -> (StatusCode, HeaderMap, serde_json::Value) {
    call_with(c, method, uri, cookie, body, &[]).await
}

/// [`call`] with extra request headers.
async fn call_with(
    c: &Arc<Console>,
    method: &str,
    uri: &str,
    cookie: Option<&str>,
    body: Option<serde_json::Value>,
    extra: &[(&str, &str)],
) -> (StatusCode, HeaderMap, serde_json::Value) {
    let mut req = Request::builder().method(method).uri(uri);
    for (k, v) in extra {
        req = req.header(*k, *v);
    }
    if let Some(cookie) = cookie {
        req = req.header(header::COOKIE, cookie);
    }
    let req = match body {
        Some(b) => req
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(b.to_string())),
        None => req.body(Body::empty()),
    }
    .unwrap();
    let response = c.clone().router().oneshot(req).await.unwrap();
    let (parts, body) = response.into_parts();
    let bytes = axum::body::to_bytes(body, 1 << 24).await.unwrap();
    let json = serde_json::from_slice(&bytes).unwrap_or(serde_json::Value::Null);
    (parts.status, parts.headers, json)
}

async fn log_in(c: &Arc<Console>) -> String {
    log_in_as(c, "rossi", "correct horse").await
}

async fn log_in_as(c: &Arc<Console>, name: &str, password: &str) -> String {
    let (status, headers, body) = call(
        c,
        "POST",
        "/api/login",
        None,
        Some(json!({"name": name, "password": password})),
    )
    .await;
    assert_eq!(status, StatusCode::OK, "{body}");
    let set = headers[header::SET_COOKIE].to_str().unwrap();
    assert!(
        set.contains("HttpOnly") && set.contains("SameSite=Strict"),
        "{set}"
    );
    set.split(';').next().unwrap().to_owned()
}

#[tokio::test]
async fn the_page_is_served_to_anyone_and_the_picture_to_a_login() {
    let f = fixture();
    for uri in ["/api/incident", "/api/stream"] {
        let (status, _, body) = call(&f.console, "GET", uri, None, None).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED, "{uri}");
        assert_eq!(body["error"], "log in to see the incident");
    }
    let viewer = log_in_as(&f.console, "ferri", "battery staple").await;
    let (status, _, incident) = call(&f.console, "GET", "/api/incident", Some(&viewer), None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(incident["site"]["scenario"], "rail-tunnel");
    assert!(incident["units"].as_array().unwrap().len() >= 2);
    let req = Request::get("/").body(Body::empty()).unwrap();
    let page = f.console.clone().router().oneshot(req).await.unwrap();
    assert_eq!(page.status(), StatusCode::OK);
    let req = Request::get("/console.js").body(Body::empty()).unwrap();
    let script = f.console.clone().router().oneshot(req).await.unwrap();
    assert_eq!(
        script.headers()[header::CONTENT_TYPE],
        "text/javascript; charset=utf-8"
    );
    // A viewer reads and steers nothing.
    let (_, _, me) = call(&f.console, "GET", "/api/me", Some(&viewer), None).await;
    assert_eq!(me["role"], "viewer");
    let goal = json!({"zone": "deep", "goal": "keep-out"});
    let (status, _, _) = call(&f.console, "POST", "/api/goals", Some(&viewer), Some(goal)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    // A console with no users file on loopback serves reads to anyone.
    let open = fixture_serving(Serving {
        secure: false,
        open_reads: true,
    });
    let (status, _, _) = call(&open.console, "GET", "/api/incident", None, None).await;
    assert_eq!(status, StatusCode::OK);
}

#[tokio::test]
async fn every_answer_forbids_framing_and_foreign_code_and_https_adds_hsts() {
    for secure in [false, true] {
        let f = fixture_serving(Serving {
            secure,
            open_reads: false,
        });
        for uri in ["/", "/api/incident"] {
            let (_, h, _) = call(&f.console, "GET", uri, None, None).await;
            let csp = h[header::CONTENT_SECURITY_POLICY].to_str().unwrap();
            assert!(csp.contains("frame-ancestors 'none'") && csp.contains("script-src 'self'"));
            assert_eq!(h[header::X_FRAME_OPTIONS], "DENY");
            assert_eq!(h[header::X_CONTENT_TYPE_OPTIONS], "nosniff");
            assert_eq!(
                h.contains_key(header::STRICT_TRANSPORT_SECURITY),
                secure,
                "{uri}"
            );
        }
    }
}

#[tokio::test]
async fn a_goal_from_another_site_is_refused_even_with_the_cookie() {
    let f = fixture();
    let cookie = log_in(&f.console).await;
    let goal = json!({"zone": "deep", "goal": "keep-out"});
    for extra in [
        [
            ("host", "console.site:8443"),
            ("origin", "https://evil.example"),
        ],
        [
            ("host", "console.site:8443"),
            ("sec-fetch-site", "cross-site"),
        ],
    ] {
        let (status, _, body) = call_with(
            &f.console,
            "POST",
            "/api/goals",
            Some(&cookie),
            Some(goal.clone()),
            &extra,
        )
        .await;
        assert_eq!(status, StatusCode::FORBIDDEN, "{extra:?}");
        assert!(body["error"].as_str().unwrap().contains("cross-site"));
    }
    // The page's own origin passes the guard (and, logged in, reaches the handler).
    let (status, _, _) = call_with(
        &f.console,
        "DELETE",
        "/api/goals/nowhere",
        Some(&cookie),
        None,
        &[
            ("host", "console.site:8443"),
            ("origin", "https://console.site:8443"),
        ],
    )
    .await;
    assert_eq!(
        status,
        StatusCode::NOT_FOUND,
        "past the guard to the zone check"
    );
}

#[tokio::test]
async fn failed_logins_are_throttled_and_a_login_holds_a_bounded_number_of_streams() {
    let f = fixture();
    let wrong = json!({"name": "rossi", "password": "wrong horse!"});
    let mut statuses = Vec::new();
    for _ in 0..6 {
        let (status, h, _) =
            call(&f.console, "POST", "/api/login", None, Some(wrong.clone())).await;
        if status == StatusCode::TOO_MANY_REQUESTS {
            assert!(h.contains_key(header::RETRY_AFTER));
        }
        statuses.push(status.as_u16());
    }
    assert_eq!(statuses, [401, 401, 401, 401, 429, 429]);
    // Closed for the name: the right password waits too.
    let right = json!({"name": "rossi", "password": "correct horse"});
    let (status, _, _) = call(&f.console, "POST", "/api/login", None, Some(right)).await;
    assert_eq!(status, StatusCode::TOO_MANY_REQUESTS);

    let viewer = log_in_as(&f.console, "ferri", "battery staple").await;
    let open = |c: Arc<Console>, cookie: String| async move {
        let req = Request::get("/api/stream")
            .header(header::COOKIE, cookie)
            .body(Body::empty())
            .unwrap();
        c.router().oneshot(req).await.unwrap()
    };
    let mut held = Vec::new();
    for _ in 0..MAX_STREAMS_PER_LOGIN {
        let r = open(f.console.clone(), viewer.clone()).await;
        assert_eq!(r.status(), StatusCode::OK);
        held.push(r);
    }
    let r = open(f.console.clone(), viewer.clone()).await;
    assert_eq!(r.status(), StatusCode::TOO_MANY_REQUESTS);
    held.pop();
    let r = open(f.console.clone(), viewer.clone()).await;
    assert_eq!(r.status(), StatusCode::OK, "a closed stream frees its slot");
}

#[tokio::test]
async fn a_wrong_password_is_refused_and_steering_needs_a_login() {
    let f = fixture();
    let wrong = json!({"name": "rossi", "password": "wrong horse!"});
    let (status, headers, body) = call(&f.console, "POST", "/api/login", None, Some(wrong)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    assert!(headers.get(header::SET_COOKIE).is_none());
    assert_eq!(body["error"], "wrong name or password");
    let goal = json!({"zone": "deep", "goal": "keep-out"});
    let (status, _, _) = call(&f.console, "POST", "/api/goals", None, Some(goal.clone())).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let forged = "ff_session=00112233";
    let (status, _, _) = call(&f.console, "POST", "/api/goals", Some(forged), Some(goal)).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let (status, _, _) = call(&f.console, "GET", "/api/me", None, None).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn a_goal_is_issued_under_the_login_and_answered_with_the_ack() {
    let mut f = fixture();
    let cookie = log_in(&f.console).await;
    let (_, _, me) = call(&f.console, "GET", "/api/me", Some(&cookie), None).await;
    assert_eq!(me["name"], "rossi");
    let coordinator = tokio::spawn(async move {
        let Some(GoalRequest::Set { goal, reply }) = f.requests.recv().await else {
            panic!("a goal was expected");
        };
        let ack = GoalAck {
            id: goal.id.clone(),
            zone: goal.zone.clone(),
            issued_by: goal.issued_by.clone(),
            accepted: true,
            reason: format!("keep-out by {}", goal.issuer()),
        };
        reply.send(Ok(ack)).unwrap();
        goal
    });
    let form = json!({"zone": "deep", "goal": "keep-out"});
    let (status, _, ack) = call(&f.console, "POST", "/api/goals", Some(&cookie), Some(form)).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(ack["accepted"], true);
    assert_eq!(ack["id"], "rossi-deep-keep-out");
    let goal = coordinator.await.unwrap();
    assert_eq!(goal.issuer(), "rossi");
    // Kept in the audit log, for any reader.
    let (_, _, audit) = call(&f.console, "GET", "/api/audit", Some(&cookie), None).await;
    assert_eq!(audit[0]["who"], "rossi", "{audit}");
    assert_eq!(audit[0]["action"], "goal");
    assert_eq!(
        audit[0]["what"],
        "keep-out on zone deep (goal 'rossi-deep-keep-out')"
    );
    assert_eq!(audit[0]["outcome"], "accepted: keep-out by rossi");
}

#[tokio::test]
async fn a_bad_goal_is_refused_naming_what_is_wrong() {
    let f = fixture();
    let cookie = log_in(&f.console).await;
    let cases = [
        (json!({"zone": "nowhere", "goal": "keep-out"}), "nowhere"),
        (json!({"zone": "deep", "goal": "bonfire"}), "goal"),
        (
            json!({"zone": "deep", "goal": "keep-out", "issued_by": "verdi"}),
            "issued_by",
        ),
        (
            json!({"zone": "deep", "goal": "contain", "before_m": "far"}),
            "before_m",
        ),
    ];
    for (form, names) in cases {
        let (status, _, body) = call(
            &f.console,
            "POST",
            "/api/goals",
            Some(&cookie),
            Some(form.clone()),
        )
        .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{form}");
        let e = body["error"].as_str().unwrap();
        assert!(e.contains(names), "{form}: {e}");
    }
    let (status, _, _) = call(
        &f.console,
        "DELETE",
        "/api/goals/nowhere",
        Some(&cookie),
        None,
    )
    .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn an_alert_is_acknowledged_by_the_login() {
    let f = fixture();
    let cookie = log_in(&f.console).await;
    f.console
        .observe(Event::Message(firefleet_protocol::payload::Payload::Ack(
            GoalAck {
                id: "g".into(),
                zone: firefleet_model::ZoneId::new("deep").unwrap(),
                issued_by: None,
                accepted: false,
                reason: "conflicts".into(),
            },
        )));
    let (_, _, incident) = call(&f.console, "GET", "/api/incident", Some(&cookie), None).await;
    let id = incident["alerts"][0]["id"].as_u64().unwrap();
    let uri = format!("/api/alerts/{id}/ack");
    let (status, _, _) = call(&f.console, "POST", &uri, None, None).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let (status, _, body) = call(&f.console, "POST", &uri, Some(&cookie), None).await;
    assert_eq!(status, StatusCode::OK, "{body}");
    let (_, _, incident) = call(&f.console, "GET", "/api/incident", Some(&cookie), None).await;
    assert_eq!(incident["alerts"][0]["acked_by"], "rossi");
    let (_, _, audit) = call(&f.console, "GET", "/api/audit", Some(&cookie), None).await;
    assert_eq!(audit[0]["action"], "acknowledge", "{audit}");
    assert!(
        audit[0]["what"]
            .as_str()
            .unwrap()
            .contains("goal 'g' on zone deep rejected: conflicts"),
        "{audit}"
    );
    let (status, _, _) = call(
        &f.console,
        "POST",
        "/api/alerts/77/ack",
        Some(&cookie),
        None,
    )
    .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}

/// A page opened late (or reloaded) is sent the timeline from the start: a snapshot a
/// second of site time, each with where the units were.
#[tokio::test]
async fn a_late_page_gets_the_timeline_from_the_start() {
    let f = fixture();
    for k in 0..30 {
        let t = f64::from(k) * 0.5;
        let mut s = firefleet_protocol::testing::ground_state("ugv-1", 10.0 + t, -2.5);
        s.t = t;
        f.console.observe(Event::Message(
            firefleet_protocol::payload::Payload::UnitState(s),
        ));
        f.console.tick();
    }
    let (status, _, _) = call(&f.console, "GET", "/api/history", None, None).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let cookie = log_in(&f.console).await;
    let (status, _, snaps) = call(&f.console, "GET", "/api/history", Some(&cookie), None).await;
    assert_eq!(status, StatusCode::OK);
    let ts: Vec<f64> = snaps
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["t"].as_f64().unwrap())
        .collect();
    assert_eq!(ts, (0..15).map(f64::from).collect::<Vec<_>>());
    assert_eq!(snaps[0]["units"][0]["id"], "ugv-1");
    assert_eq!(snaps[0]["units"][0]["x"], 10.0);
    assert_eq!(snaps[14]["units"][0]["x"], 24.0);
}

/// A commander shelves an alarm for a reason and a time (a viewer may not; a reason and a
/// time on the shelf within a shift are required); it comes back by a commander's word or
/// by itself when its time is up, every step in the audit log.
#[tokio::test]
async fn an_alarm_is_shelved_for_a_reason_and_a_time_and_comes_back() {
    let f = fixture();
    f.console
        .observe(Event::Message(firefleet_protocol::payload::Payload::Ack(
            GoalAck {
                id: "g".into(),
                zone: firefleet_model::ZoneId::new("deep").unwrap(),
                issued_by: None,
                accepted: false,
                reason: "conflicts".into(),
            },
        )));
    let cookie = log_in(&f.console).await;
    let viewer = log_in_as(&f.console, "ferri", "battery staple").await;
    let (_, _, incident) = call(&f.console, "GET", "/api/incident", Some(&cookie), None).await;
    let id = incident["alerts"][0]["id"].as_u64().unwrap();
    let uri = format!("/api/alerts/{id}/shelve");
    let shelve = |reason: &str, minutes: f64| json!({"reason": reason, "minutes": minutes});
    let (status, _, _) = call(
        &f.console,
        "POST",
        &uri,
        Some(&viewer),
        Some(shelve("x", 5.0)),
    )
    .await;
    assert_eq!(status, StatusCode::UNAUTHORIZED, "a viewer");
    for (bad, minutes) in [("  ", 5.0), ("known fault", 0.0), ("known fault", 481.0)] {
        let (status, _, body) = call(
            &f.console,
            "POST",
            &uri,
            Some(&cookie),
            Some(shelve(bad, minutes)),
        )
        .await;
        assert_eq!(
            status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{bad:?} {minutes}: {body}"
        );
    }
    let (status, _, body) = call(
        &f.console,
        "POST",
        &uri,
        Some(&cookie),
        Some(shelve("the zone's goal is being redrawn", 15.0)),
    )
    .await;
    assert_eq!(status, StatusCode::OK, "{body}");
    let (_, _, incident) = call(&f.console, "GET", "/api/incident", Some(&cookie), None).await;
    let shelved = &incident["alerts"][0]["shelved"];
    assert_eq!(shelved["by"], "rossi");
    assert_eq!(shelved["reason"], "the zone's goal is being redrawn");
    let unshelve = format!("/api/alerts/{id}/unshelve");
    let (status, _, _) = call(&f.console, "POST", &unshelve, Some(&cookie), None).await;
    assert_eq!(status, StatusCode::OK);
    let (status, _, _) = call(&f.console, "POST", &unshelve, Some(&cookie), None).await;
    assert_eq!(status, StatusCode::NOT_FOUND, "not shelved any more");
    // Shelved for 60 ms: the console's tick brings it back once the time is up.
    call(
        &f.console,
        "POST",
        &uri,
        Some(&cookie),
        Some(shelve("a moment", 0.001)),
    )
    .await;
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    loop {
        f.console.tick();
        let (_, _, incident) = call(&f.console, "GET", "/api/incident", Some(&cookie), None).await;
        if incident["alerts"][0]["shelved"].is_null() {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "never back from the shelf"
        );
        tokio::task::yield_now().await;
    }
    let (_, _, audit) = call(&f.console, "GET", "/api/audit", Some(&cookie), None).await;
    let actions: Vec<&str> = audit
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["action"].as_str().unwrap())
        .collect();
    assert_eq!(
        actions,
        ["shelve", "unshelve", "shelve", "unshelve"],
        "{audit}"
    );
    assert!(
        audit[3]["outcome"]
            .as_str()
            .unwrap()
            .contains("time on the shelf is up")
    );
}
