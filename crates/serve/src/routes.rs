//! The HTTP routes.

use crate::hub::{Hub, SourceState};
use crate::{prometheus, ws};
use axum::Router;
use axum::extract::{Query, State};
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;

/// Settings of the server.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// A WebSocket send that takes longer than this drops the client.
    pub send_timeout: Duration,
    /// How often the server pings each WebSocket client.
    pub ping_interval: Duration,
    /// A client silent for this long (no pong, no message) is dropped.
    pub client_timeout: Duration,
    /// A connection that has not sent a whole request head in this time is closed (slowloris).
    pub header_timeout: Duration,
    /// Origins besides the server's own whose pages may read the pose stream (`/ws`,
    /// `/pose`), e.g. `https://robot.example`; see the `origin` module.
    pub allow_origins: Vec<String>,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            send_timeout: Duration::from_secs(2),
            ping_interval: Duration::from_secs(2),
            client_timeout: Duration::from_secs(10),
            header_timeout: Duration::from_secs(10),
            allow_origins: Vec::new(),
        }
    }
}

/// The state every handler gets.
#[derive(Clone)]
pub(crate) struct App {
    pub hub: Arc<Hub>,
    pub cfg: ServerConfig,
}

/// The server's routes over `hub`.
pub fn router(hub: Arc<Hub>, cfg: ServerConfig) -> Router {
    let app = App { hub, cfg };
    Router::new()
        .route("/", get(dashboard))
        .route("/health", get(health))
        .route("/pose", get(pose))
        .route("/frame.jpg", get(frame))
        .route("/map.json", get(map))
        .route("/metrics", get(metrics))
        .route("/ws", get(ws::upgrade))
        .fallback(not_found)
        .layer(axum::middleware::from_fn_with_state(
            app.clone(),
            crate::origin::guard,
        ))
        .with_state(app)
}

/// A JSON error body with its status.
pub(crate) fn error(status: StatusCode, message: &str) -> Response {
    (status, axum::Json(serde_json::json!({ "error": message }))).into_response()
}

async fn not_found() -> Response {
    error(
        StatusCode::NOT_FOUND,
        "no such route; try /, /health, /pose, /frame.jpg, /map.json, /metrics or /ws",
    )
}

async fn dashboard() -> Html<&'static str> {
    Html(include_str!("dashboard.html"))
}

#[derive(Serialize)]
struct Health {
    status: &'static str,
    source: SourceState,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    frames: u64,
    poses: u64,
    dropped: u64,
    clients: u64,
    uptime_s: f64,
}

async fn health(State(app): State<App>) -> axum::Json<Health> {
    let (source, error) = app.hub.source_state();
    let m = app.hub.metrics().snapshot();
    axum::Json(Health {
        status: "ok",
        source,
        error,
        frames: m.frames_read,
        poses: m.poses,
        dropped: m.frames_dropped,
        clients: app.hub.client_count(),
        uptime_s: app.hub.uptime_s(),
    })
}

/// Query of `/pose`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseQuery {
    #[serde(default)]
    format: Option<String>,
}

async fn pose(
    State(app): State<App>,
    query: Result<Query<PoseQuery>, axum::extract::rejection::QueryRejection>,
) -> Response {
    let Ok(Query(q)) = query else {
        return error(
            StatusCode::BAD_REQUEST,
            "the only query parameter is format=json|tum",
        );
    };
    let Some(latest) = app.hub.latest() else {
        return error(StatusCode::SERVICE_UNAVAILABLE, "no pose yet");
    };
    match q.format.as_deref() {
        None | Some("json") => (
            [(header::CONTENT_TYPE, "application/json")],
            latest.json.as_str().to_owned(),
        )
            .into_response(),
        Some("tum") => ([(header::CONTENT_TYPE, "text/plain")], latest.tum).into_response(),
        Some(_) => error(StatusCode::BAD_REQUEST, "format must be json or tum"),
    }
}

async fn frame(State(app): State<App>) -> Response {
    let Some(img) = app.hub.frame() else {
        return error(StatusCode::SERVICE_UNAVAILABLE, "no frame yet");
    };
    let jpeg = tokio::task::spawn_blocking(move || {
        let mut buf = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 80)
            .encode_image(&*img)
            .map(|()| buf)
    })
    .await;
    match jpeg {
        Ok(Ok(bytes)) => (
            [
                (header::CONTENT_TYPE, "image/jpeg"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            bytes,
        )
            .into_response(),
        _ => error(StatusCode::INTERNAL_SERVER_ERROR, "cannot encode the frame"),
    }
}

async fn map(State(app): State<App>) -> Response {
    let m = app.hub.map();
    axum::Json(serde_json::json!({
        "title": m.title,
        "rects": m.rects,
        "path": m.path,
        "bounds": m.bounds(1.0),
    }))
    .into_response()
}

async fn metrics(State(app): State<App>) -> Response {
    (
        [(header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        prometheus::render(&app.hub),
    )
        .into_response()
}
