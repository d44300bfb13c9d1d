//! The Foxglove WebSocket server, driven by a real WebSocket client over loopback TCP as
//! Foxglove drives it: handshake with the subprotocol, server info, advertised channels,
//! subscriptions, Message Data frames, and errors for what a client gets wrong.

use std::sync::Arc;

use firefleet_recorder::live::{Live, SUBPROTOCOL};
use futures_util::{SinkExt, StreamExt};
use serde_json::Value;
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::{Error, Message};
use tokio_tungstenite::{MaybeTlsStream, WebSocketStream};

type Ws = WebSocketStream<MaybeTlsStream<TcpStream>>;

fn schema() -> schemars::Schema {
    schemars::schema_for!(Value)
}

async fn server() -> (Arc<Live>, String) {
    let live = Live::new();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("ws://{}/", listener.local_addr().unwrap());
    tokio::spawn(live.clone().serve(listener, std::future::pending()));
    (live, url)
}

async fn connect(url: &str) -> Ws {
    let mut request = url.into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", SUBPROTOCOL.parse().unwrap());
    let (ws, response) = tokio_tungstenite::connect_async(request).await.unwrap();
    assert_eq!(
        response.headers()["Sec-WebSocket-Protocol"],
        SUBPROTOCOL,
        "the server selects the subprotocol"
    );
    ws
}

async fn json(ws: &mut Ws) -> Value {
    match ws.next().await.unwrap().unwrap() {
        Message::Text(t) => serde_json::from_str(t.as_str()).unwrap(),
        other => panic!("expected a JSON message, got {other:?}"),
    }
}

/// A Message Data frame: (subscription id, timestamp, payload).
async fn data(ws: &mut Ws) -> (u32, u64, Vec<u8>) {
    match ws.next().await.unwrap().unwrap() {
        Message::Binary(b) => {
            assert_eq!(b[0], 0x01, "Message Data opcode");
            let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
            let t = u64::from_le_bytes(b[5..13].try_into().unwrap());
            (sub, t, b[13..].to_vec())
        }
        other => panic!("expected Message Data, got {other:?}"),
    }
}

async fn send(ws: &mut Ws, v: Value) {
    ws.send(Message::Text(v.to_string().into())).await.unwrap();
}

fn channel_id(advertise: &Value, topic: &str) -> u64 {
    assert_eq!(advertise["op"], "advertise");
    advertise["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["topic"] == topic)
        .unwrap_or_else(|| panic!("{topic} not advertised: {advertise}"))["id"]
        .as_u64()
        .unwrap()
}

#[tokio::test]
async fn a_client_gets_the_channels_subscribes_and_receives_each_message_once() {
    let (live, url) = server().await;
    live.publish(
        "/scene/site",
        "foxglove.SceneUpdate",
        schema,
        b"{\"site\":1}",
        5,
    );

    let mut ws = connect(&url).await;
    let info = json(&mut ws).await;
    assert_eq!(info["op"], "serverInfo");
    assert_eq!(info["capabilities"], serde_json::json!([]));
    let advertise = json(&mut ws).await;
    let site = channel_id(&advertise, "/scene/site");
    let c = &advertise["channels"][0];
    assert_eq!(c["encoding"], "json");
    assert_eq!(c["schemaName"], "foxglove.SceneUpdate");
    assert_eq!(c["schemaEncoding"], "jsonschema");
    serde_json::from_str::<Value>(c["schema"].as_str().unwrap()).expect("the schema is JSON");

    // Subscribing hands over the channel's newest message at once.
    send(
        &mut ws,
        serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": site}]}),
    )
    .await;
    assert_eq!(data(&mut ws).await, (7, 5, b"{\"site\":1}".to_vec()));

    // A topic first published now is advertised to the connected client.
    live.publish("/scene", "foxglove.SceneUpdate", schema, b"{\"n\":1}", 6);
    let scene = channel_id(&json(&mut ws).await, "/scene");
    assert_ne!(scene, site);
    send(
        &mut ws,
        serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 8, "channelId": scene}]}),
    )
    .await;
    assert_eq!(data(&mut ws).await, (8, 6, b"{\"n\":1}".to_vec()));
    live.publish("/scene", "foxglove.SceneUpdate", schema, b"{\"n\":2}", 7);
    assert_eq!(data(&mut ws).await, (8, 7, b"{\"n\":2}".to_vec()));

    // After unsubscribing, the channel's messages stop; the others' go on, in order.
    send(
        &mut ws,
        serde_json::json!({"op": "unsubscribe", "subscriptionIds": [8]}),
    )
    .await;
    // Requests are carried out in order: the second unsubscribe's warning says the first
    // has taken effect.
    send(
        &mut ws,
        serde_json::json!({"op": "unsubscribe", "subscriptionIds": [8]}),
    )
    .await;
    let status = json(&mut ws).await;
    assert_eq!(
        (status["op"].as_str(), status["level"].as_u64()),
        (Some("status"), Some(1))
    );
    assert!(
        status["message"]
            .as_str()
            .unwrap()
            .contains("no subscription 8")
    );
    live.publish("/scene", "foxglove.SceneUpdate", schema, b"{\"n\":3}", 9);
    live.publish(
        "/scene/site",
        "foxglove.SceneUpdate",
        schema,
        b"{\"site\":3}",
        10,
    );
    assert_eq!(data(&mut ws).await, (7, 10, b"{\"site\":3}".to_vec()));
}

#[tokio::test]
async fn what_a_client_gets_wrong_is_answered_with_an_error_and_the_connection_goes_on() {
    let (live, url) = server().await;
    live.publish("/log", "foxglove.Log", schema, b"{}", 1);
    let mut ws = connect(&url).await;
    json(&mut ws).await;
    let log = channel_id(&json(&mut ws).await, "/log");

    for (request, says) in [
        ("{not json".to_string(), "not understood"),
        (
            r#"{"op":"setParameters","parameters":[]}"#.to_string(),
            "not understood",
        ),
        (
            serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 999}]})
                .to_string(),
            "no channel 999",
        ),
    ] {
        ws.send(Message::Text(request.into())).await.unwrap();
        let status = json(&mut ws).await;
        assert_eq!(status["op"], "status");
        assert_eq!(status["level"], 2);
        let message = status["message"].as_str().unwrap();
        assert!(message.contains(says), "{message}");
    }
    ws.send(Message::Binary(vec![1, 0, 0, 0, 0].into()))
        .await
        .unwrap();
    assert!(
        json(&mut ws).await["message"]
            .as_str()
            .unwrap()
            .contains("clientPublish")
    );

    send(
        &mut ws,
        serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": log}]}),
    )
    .await;
    assert_eq!(data(&mut ws).await.0, 1);
    send(
        &mut ws,
        serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": log}]}),
    )
    .await;
    assert!(
        json(&mut ws).await["message"]
            .as_str()
            .unwrap()
            .contains("already in use")
    );
    live.publish("/log", "foxglove.Log", schema, b"{\"after\":true}", 2);
    assert_eq!(data(&mut ws).await, (1, 2, b"{\"after\":true}".to_vec()));
}

#[tokio::test]
async fn a_client_not_speaking_the_protocol_is_refused_at_the_handshake() {
    let (_live, url) = server().await;
    match tokio_tungstenite::connect_async(url.as_str()).await {
        Err(Error::Http(response)) => {
            assert_eq!(response.status(), 400);
            let body = String::from_utf8(response.body().clone().unwrap_or_default()).unwrap();
            assert!(body.contains(SUBPROTOCOL), "{body}");
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
}
