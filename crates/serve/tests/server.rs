//! The server over loopback: routes, malformed requests, the WebSocket stream, slow and
//! vanished clients, and a source that dies.

mod common;

use common::{get, http, pipeline, start};
use futures_util::StreamExt;
use serde_json::Value;
use std::time::{Duration, Instant};
use tokio_tungstenite::tungstenite::Message;

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// Waits until `/pose` answers 200.
async fn first_pose(addr: std::net::SocketAddr) -> Result<Value, Box<dyn std::error::Error>> {
    let t = Instant::now();
    loop {
        let (status, body) = get(addr, "/pose").await;
        if status == 200 {
            return Ok(serde_json::from_str(&body)?);
        }
        assert_eq!(status, 503, "{body}");
        if t.elapsed() > Duration::from_secs(10) {
            return Err("no pose within 10 s".into());
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Text messages of a client until the stream closes (or `limit` passes).
async fn collect(url: &str, limit: Duration) -> Result<Vec<Value>, Box<dyn std::error::Error>> {
    let (mut ws, _) = tokio_tungstenite::connect_async(url).await?;
    let mut out = Vec::new();
    let deadline = tokio::time::Instant::now() + limit;
    while let Ok(Some(msg)) = tokio::time::timeout_at(deadline, ws.next()).await {
        match msg? {
            Message::Text(t) => out.push(serde_json::from_str(t.as_str())?),
            Message::Close(_) => break,
            _ => {}
        }
    }
    Ok(out)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn routes_answer_and_malformed_requests_get_4xx() -> TestResult {
    let (_hub, addr) = start(pipeline(600, 30.0, false), serve::ServerConfig::default()).await;
    let pose = first_pose(addr).await?;
    assert_eq!(pose["event"], "pose");
    assert_eq!(pose["position"].as_array().map(Vec::len), Some(3));
    assert_eq!(pose["quaternion"].as_array().map(Vec::len), Some(4));
    assert!(pose["sigma_pos_m"].as_f64().is_some_and(|s| s > 0.0));
    assert_eq!(pose["measurements"][0]["estimator"], "painted");

    let (status, body) = get(addr, "/health").await;
    assert_eq!(status, 200);
    let health: Value = serde_json::from_str(&body)?;
    assert_eq!(health["status"], "ok");
    assert_eq!(health["source"], "running");

    let (status, body) = get(addr, "/pose?format=tum").await;
    assert_eq!(status, 200);
    assert_eq!(body.split_whitespace().count(), 8, "{body}");

    let (status, body) = get(addr, "/metrics").await;
    assert_eq!(status, 200);
    for line in [
        "# TYPE indoorloc_poses_total counter",
        "indoorloc_stage_latency_seconds_bucket{stage=\"total\",le=\"+Inf\"}",
        "indoorloc_stage_latency_seconds_count{stage=\"estimate\"}",
        "indoorloc_frames_dropped_total",
        "indoorloc_ws_clients 0",
    ] {
        assert!(body.contains(line), "missing {line} in\n{body}");
    }
    let (status, _) = get(addr, "/frame.jpg").await;
    assert_eq!(status, 200);
    let (status, body) = get(addr, "/").await;
    assert_eq!(status, 200);
    assert!(body.contains("new WebSocket"));
    let (status, body) = get(addr, "/map.json").await;
    assert_eq!(status, 200);
    assert!(serde_json::from_str::<Value>(&body)?["rects"].is_array());

    for (path, want) in [
        ("/pose?format=xml", 400),
        ("/pose?bogus=1", 400),
        ("/no/such/page", 404),
    ] {
        let (status, body) = get(addr, path).await;
        assert_eq!(status, want, "{path}: {body}");
        assert!(
            serde_json::from_str::<Value>(&body)?["error"].is_string(),
            "{path}: {body}"
        );
    }
    let (status, _) = http(
        addr,
        &format!(
            "POST /pose HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
        ),
    )
    .await;
    assert_eq!(status, 405);
    // A WebSocket route asked without the upgrade.
    let (status, _) = get(addr, "/ws").await;
    assert!((400..500).contains(&status), "{status}");
    // Not HTTP at all.
    let (status, _) = http(addr, "HELLO THERE\r\n\r\n").await;
    assert_eq!(status, 400);
    // The server still serves after all that.
    assert_eq!(get(addr, "/health").await.0, 200);
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_websocket_streams_every_pose_then_the_end() -> TestResult {
    let (_hub, addr) = start(pipeline(60, 40.0, false), serve::ServerConfig::default()).await;
    let events = collect(&format!("ws://{addr}/ws"), Duration::from_secs(10)).await?;
    let last = events.last().ok_or("no events")?;
    assert_eq!(last["event"], "end", "{last}");
    assert_eq!(last["frames"], 60);
    let poses: Vec<&Value> = events.iter().filter(|e| e["event"] == "pose").collect();
    // The client may connect a frame or two after the start.
    assert!(poses.len() >= 55, "{} poses", poses.len());
    let frames: Vec<u64> = poses.iter().filter_map(|p| p["frame"].as_u64()).collect();
    assert!(frames.windows(2).all(|w| w[1] == w[0] + 1), "{frames:?}");
    // The fused track follows the painted walk (x = frame / 10 m).
    for p in &poses[10..] {
        let (f, x) = (
            p["frame"].as_f64().unwrap_or(0.0),
            p["position"][0].as_f64().unwrap_or(f64::NAN),
        );
        assert!((x - f / 10.0).abs() < 0.1, "frame {f}: x {x}");
    }
    // A client that comes after the end hears how it ended.
    let late = collect(&format!("ws://{addr}/ws"), Duration::from_secs(5)).await?;
    assert_eq!(late.len(), 1);
    assert_eq!(late[0]["event"], "end");
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_stops_reading_is_dropped_and_the_others_go_on() -> TestResult {
    let cfg = serve::ServerConfig {
        ping_interval: Duration::from_millis(200),
        client_timeout: Duration::from_millis(1000),
        ..serve::ServerConfig::default()
    };
    let (hub, addr) = start(pipeline(3000, 30.0, false), cfg).await;
    first_pose(addr).await?;
    let url = format!("ws://{addr}/ws");
    // Connected, then never read again: it never answers a ping.
    let (_stalled, _) = tokio_tungstenite::connect_async(&url).await?;
    let reader = tokio::spawn(async move {
        collect(&url, Duration::from_secs(3))
            .await
            .map(|v| v.len())
            .unwrap_or(0)
    });
    let t = Instant::now();
    while hub
        .clients_dropped
        .load(std::sync::atomic::Ordering::Relaxed)
        == 0
    {
        assert!(
            t.elapsed() < Duration::from_secs(5),
            "the stalled client was not dropped"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let received = reader.await?;
    // 3 s at 30 poses per second.
    assert!(received >= 60, "the reading client got {received} messages");
    let (_, metrics) = get(addr, "/metrics").await;
    assert!(
        metrics.contains("indoorloc_ws_clients_dropped_total 1"),
        "{metrics}"
    );
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn many_clients_all_get_the_stream() -> TestResult {
    let (_hub, addr) = start(pipeline(3000, 30.0, false), serve::ServerConfig::default()).await;
    first_pose(addr).await?;
    let clients: Vec<_> = (0..20)
        .map(|_| {
            let url = format!("ws://{addr}/ws");
            tokio::spawn(async move {
                collect(&url, Duration::from_secs(2))
                    .await
                    .map(|v| v.len())
                    .unwrap_or(0)
            })
        })
        .collect();
    for c in clients {
        let n = c.await?;
        assert!(
            n >= 40,
            "a client got only {n} messages in 2 s at 30 per second"
        );
    }
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dying_source_ends_the_stream_with_an_error_and_health_still_answers() -> TestResult {
    let (_hub, addr) = start(pipeline(40, 20.0, true), serve::ServerConfig::default()).await;
    let events = collect(&format!("ws://{addr}/ws"), Duration::from_secs(10)).await?;
    let last = events.last().ok_or("no events")?;
    assert_eq!(last["event"], "error", "{last}");
    assert!(
        last["message"]
            .as_str()
            .is_some_and(|m| m.contains("camera unplugged")),
        "{last}"
    );
    assert!(events.iter().filter(|e| e["event"] == "pose").count() >= 30);
    let (status, body) = get(addr, "/health").await;
    assert_eq!(status, 200);
    let health: Value = serde_json::from_str(&body)?;
    assert_eq!(health["source"], "failed");
    assert!(
        health["error"]
            .as_str()
            .is_some_and(|m| m.contains("camera unplugged"))
    );
    // The last pose stays available.
    assert_eq!(get(addr, "/pose").await.0, 200);
    let late = collect(&format!("ws://{addr}/ws"), Duration::from_secs(5)).await?;
    assert_eq!(late.len(), 1);
    assert_eq!(late[0]["event"], "error");
    Ok(())
}

/// Pages of other origins cannot read the pose stream, names that are not this machine's are
/// refused (DNS rebinding), an allowed origin passes, and a client's oversized message closes
/// its connection instead of being buffered.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn foreign_origins_and_hosts_get_403_and_client_messages_are_capped() -> TestResult {
    use futures_util::SinkExt;
    let cfg = serve::ServerConfig {
        allow_origins: vec!["https://robot.example".into()],
        ..serve::ServerConfig::default()
    };
    let (_hub, addr) = start(pipeline(3000, 30.0, false), cfg).await;
    first_pose(addr).await?;
    let request = |path: &str, host: &str, origin: Option<&str>| {
        let origin = origin.map_or(String::new(), |o| format!("Origin: {o}\r\n"));
        format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n{origin}Connection: close\r\n\r\n")
    };
    let own = addr.to_string();
    let upgrade = |host: &str, origin: &str| {
        format!(
            "GET /ws HTTP/1.1\r\nHost: {host}\r\nOrigin: {origin}\r\nConnection: Upgrade\r\n\
             Upgrade: websocket\r\nSec-WebSocket-Version: 13\r\n\
             Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
        )
    };
    for (raw, want) in [
        (request("/pose", &own, Some("http://evil.example")), 403),
        (request("/pose", "evil.example:8080", None), 403),
        (request("/", "rebind.evil.example", None), 403),
        (upgrade(&own, "http://evil.example"), 403),
        (request("/pose", &own, None), 200),
        (request("/pose", &own, Some(&format!("http://{own}"))), 200),
        (request("/pose", &own, Some("https://robot.example")), 200),
        (upgrade(&own, &format!("http://{own}")), 101),
    ] {
        let (status, body) = http(addr, &raw).await;
        assert_eq!(status, want, "{raw}: {body}");
    }
    // a client that talks: 1 MiB in one message ends its connection
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws")).await?;
    let _ = ws.send(Message::Binary(vec![7u8; 1 << 20].into())).await;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    let mut closed = false;
    while let Ok(next) = tokio::time::timeout_at(deadline, ws.next()).await {
        match next {
            None | Some(Err(_)) | Some(Ok(Message::Close(_))) => {
                closed = true;
                break;
            }
            Some(Ok(_)) => {}
        }
    }
    assert!(closed, "the connection stayed open");
    Ok(())
}

/// A client that never finishes its request head is closed after the header timeout, and the
/// server goes on serving.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_request_head_that_never_ends_is_cut_off() -> TestResult {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let cfg = serve::ServerConfig {
        header_timeout: Duration::from_secs(1),
        ..serve::ServerConfig::default()
    };
    let (_hub, addr) = start(pipeline(600, 30.0, false), cfg).await;
    let mut slow = tokio::net::TcpStream::connect(addr).await?;
    slow.write_all(format!("GET /health HTTP/1.1\r\nHost: {addr}\r\nX-Slow:").as_bytes())
        .await?;
    let t = Instant::now();
    let mut buf = Vec::new();
    let read = tokio::time::timeout(Duration::from_secs(5), slow.read_to_end(&mut buf)).await;
    assert!(read.is_ok(), "still open after 5 s");
    assert!(t.elapsed() < Duration::from_secs(4), "{:?}", t.elapsed());
    assert_eq!(get(addr, "/health").await.0, 200);
    Ok(())
}
