//! The WebSocket feed: every pipeline event as one JSON text message.
//!
//! Each client task reads the shared broadcast buffer; the client is dropped when it falls
//! more than the buffer behind, when one send takes longer than the send timeout, or when it
//! has been silent (no pong to the server's pings, no message) for the client timeout. So a
//! client that stops reading costs at most the buffer and its socket, never a growing queue.
//! The stream ends with the pipeline's `end` or `error` event and a close frame.

use crate::hub::Broadcast;
use crate::routes::App;
use axum::extract::State;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::response::Response;
use futures_util::stream::SplitSink;
use futures_util::{SinkExt, StreamExt};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use tokio::sync::broadcast::error::RecvError;

/// Close code for a client dropped for being slow (RFC 6455: policy violation).
const CLOSE_POLICY: u16 = 1008;
/// Close code at the end of the stream.
const CLOSE_NORMAL: u16 = 1000;
/// Close code after a source error.
const CLOSE_ERROR: u16 = 1011;

/// The largest message a client may send: the server reads none (clients only listen), so
/// anything past a close frame's worth is refused rather than buffered (64 MiB by default: eight
/// clients each sending an unfinished 61 MB message held 710 MB).
const MAX_CLIENT_MESSAGE: usize = 4096;

pub(crate) async fn upgrade(State(app): State<App>, ws: WebSocketUpgrade) -> Response {
    ws.max_message_size(MAX_CLIENT_MESSAGE)
        .max_frame_size(MAX_CLIENT_MESSAGE)
        .on_upgrade(move |socket| client(socket, app))
}

/// Why a client's feed ended.
enum Ending {
    /// The stream ended (the message was the last event).
    Stream(bool),
    /// The client closed or the connection broke.
    Gone,
    /// Dropped: too slow or silent.
    Dropped(&'static str),
}

async fn client(socket: WebSocket, app: App) {
    let hub = app.hub.clone();
    hub.clients.fetch_add(1, Ordering::Relaxed);
    hub.clients_total.fetch_add(1, Ordering::Relaxed);
    let (mut tx, mut rx) = socket.split();
    let (mut feed, ended) = hub.subscribe();

    // The client's messages (pongs, closes) are read in a task of their own, which notes when
    // the client was last heard from.
    let heard = std::sync::Arc::new(std::sync::Mutex::new(Instant::now()));
    let mut reader = {
        let heard = heard.clone();
        tokio::spawn(async move {
            while let Some(Ok(msg)) = rx.next().await {
                if matches!(msg, Message::Close(_)) {
                    break;
                }
                *heard.lock().unwrap_or_else(|p| p.into_inner()) = Instant::now();
            }
        })
    };

    let timeout = app.cfg.send_timeout;
    let ending = if let Some(last) = ended {
        // The stream is over already: say how it ended.
        match send(&mut tx, timeout, Message::Text(last.text.clone())).await {
            Sent::Yes => Ending::Stream(is_error(&last)),
            _ => Ending::Gone,
        }
    } else {
        let mut ping = tokio::time::interval(app.cfg.ping_interval);
        ping.tick().await;
        loop {
            tokio::select! {
                msg = feed.recv() => match msg {
                    Ok(b) => {
                        let sent = send(&mut tx, timeout, Message::Text(b.text.clone())).await;
                        if sent != Sent::Yes {
                            break failed(sent);
                        }
                        if b.terminal {
                            break Ending::Stream(is_error(&b));
                        }
                    }
                    Err(RecvError::Lagged(_)) => break Ending::Dropped("too slow: fell behind the stream"),
                    Err(RecvError::Closed) => break Ending::Gone,
                },
                _ = ping.tick() => {
                    let silent = heard.lock().unwrap_or_else(|p| p.into_inner()).elapsed();
                    if silent > app.cfg.client_timeout {
                        break Ending::Dropped("no answer to pings");
                    }
                    let sent = send(&mut tx, timeout, Message::Ping(Default::default())).await;
                    if sent != Sent::Yes {
                        break failed(sent);
                    }
                }
                _ = &mut reader => break Ending::Gone,
            }
        }
    };

    let close = |code: u16, reason: &'static str| {
        Message::Close(Some(CloseFrame {
            code,
            reason: reason.into(),
        }))
    };
    match ending {
        Ending::Stream(error) => {
            let m = if error {
                close(CLOSE_ERROR, "source failed")
            } else {
                close(CLOSE_NORMAL, "end of stream")
            };
            let _ = send(&mut tx, timeout, m).await;
        }
        Ending::Dropped(why) => {
            hub.clients_dropped.fetch_add(1, Ordering::Relaxed);
            // Best effort: a client that does not read will not see it either.
            let _ =
                tokio::time::timeout(app.cfg.send_timeout, tx.send(close(CLOSE_POLICY, why))).await;
        }
        Ending::Gone => {}
    }
    reader.abort();
    hub.clients.fetch_sub(1, Ordering::Relaxed);
}

/// How a send went.
#[derive(PartialEq)]
enum Sent {
    Yes,
    /// The connection is closed or broken: the client left.
    Gone,
    /// The send did not finish within the timeout: the client is not reading.
    TimedOut,
}

/// Sends `m` within `timeout`.
async fn send(tx: &mut SplitSink<WebSocket, Message>, timeout: Duration, m: Message) -> Sent {
    match tokio::time::timeout(timeout, tx.send(m)).await {
        Ok(Ok(())) => Sent::Yes,
        Ok(Err(_)) => Sent::Gone,
        Err(_) => Sent::TimedOut,
    }
}

/// Why a feed ends when a send did not go.
fn failed(s: Sent) -> Ending {
    match s {
        Sent::TimedOut => Ending::Dropped("send timed out"),
        _ => Ending::Gone,
    }
}

fn is_error(b: &Broadcast) -> bool {
    b.text.as_str().starts_with("{\"event\":\"error\"")
}
