//! The live server of indoorloc: the pose stream of a [`track::Pipeline`] over HTTP and
//! WebSocket, with Prometheus metrics and a dashboard page served by the binary itself.
//!
//! The pipeline runs on its own threads and hands every event to a [`Hub`]; the axum
//! [`router`] reads the hub:
//!
//! | route | what |
//! |---|---|
//! | `GET /` | the dashboard: floor map, live pose, uncertainty ellipse, trail, frame, latency |
//! | `GET /health` | always answers while the server runs: the source's state and counters |
//! | `GET /pose` | the latest fused pose (JSON; `?format=tum` for a TUM line); 503 before the first |
//! | `GET /frame.jpg` | the latest frame |
//! | `GET /map.json` | the floor map the dashboard draws |
//! | `GET /metrics` | Prometheus text: frames, drops, clients, per-stage latency histograms |
//! | `GET /ws` | WebSocket: every event as JSON (`pose`, then `end` or `error`) |
//!
//! Slow clients cannot hold memory: every client reads from one bounded broadcast buffer; a
//! client that falls behind it, blocks a send past the timeout, or stops answering pings is
//! dropped (counted in `indoorloc_ws_dropped_total`).

mod hub;
mod map;
mod origin;
mod prometheus;
#[cfg(feature = "ros2")]
pub mod ros2;
mod routes;
mod ws;

pub use hub::{Hub, SourceState};
pub use map::FloorMap;
pub use routes::{ServerConfig, router};

/// Serves `hub` on `listener` until `shutdown` resolves.
///
/// The accept loop is ours rather than `axum::serve`'s so that every connection gets
/// `cfg.header_timeout` to send its request head (axum's has none: a client sending one header
/// byte a minute held a connection for ever). A failed accept (no file descriptors left) waits
/// a moment and goes on, as axum's does.
///
/// # Errors
/// None today; the signature keeps room for a listener that fails for good.
pub async fn serve(
    listener: tokio::net::TcpListener,
    hub: std::sync::Arc<Hub>,
    cfg: ServerConfig,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let header_timeout = cfg.header_timeout;
    let app = router(hub, cfg);
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(_) => {
                    tokio::time::sleep(std::time::Duration::from_millis(100)).await;
                    continue;
                }
            },
            () = &mut shutdown => return Ok(()),
        };
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        tokio::spawn(async move {
            let _ = hyper::server::conn::http1::Builder::new()
                .timer(hyper_util::rt::TokioTimer::new())
                .header_read_timeout(header_timeout)
                .serve_connection(hyper_util::rt::TokioIo::new(stream), service)
                .with_upgrades()
                .await;
        });
    }
}
