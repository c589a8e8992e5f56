//! Who may read the pose stream: a guard in front of every route against web pages the user
//! happens to have open.
//!
//! A browser sends any page's requests to `localhost` with the page's `Origin`, and lets a page
//! open a WebSocket to any host; without a check, a page from anywhere could read the live
//! pose of the user's camera (`/ws`, `/pose`), or reach the server through DNS rebinding (a
//! name of the attacker's that resolves to the user's machine, sent as `Host`). So:
//! - `Host` must name this machine: an IP address, `localhost`, or an allowed origin's host;
//!   any other name is answered 403 (DNS rebinding).
//! - On the routes that carry poses, `Origin`, when there is one (browsers send it, command-line
//!   clients do not), must be the server's own (`http://` + `Host`) or an allowed origin; else
//!   403. The dashboard served from `/` is same-origin, so it keeps working.

use crate::routes::{App, error};
use axum::extract::{Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::Next;
use axum::response::Response;

/// Routes whose content a foreign page must not read.
const GUARDED: [&str; 2] = ["/ws", "/pose"];

/// The middleware (see the module docs).
pub(crate) async fn guard(State(app): State<App>, request: Request, next: Next) -> Response {
    let headers = request.headers();
    let text = |name| headers.get(name).and_then(|v| v.to_str().ok());
    let host = text(header::HOST).unwrap_or_default();
    if !host_allowed(host, &app.cfg.allow_origins) {
        return error(
            StatusCode::FORBIDDEN,
            "Host is not this machine (an IP address, localhost or an --allow-origin host)",
        );
    }
    if GUARDED.contains(&request.uri().path())
        && let Some(origin) = text(header::ORIGIN)
        && !origin_allowed(origin, host, &app.cfg.allow_origins)
    {
        return error(
            StatusCode::FORBIDDEN,
            "a page of another origin may not read the pose stream (see serve --allow-origin)",
        );
    }
    next.run(request).await
}

/// The host part of `host[:port]` (brackets kept off an IPv6 literal).
fn host_name(host_port: &str) -> &str {
    if let Some(rest) = host_port.strip_prefix('[') {
        return rest.split(']').next().unwrap_or_default();
    }
    host_port.rsplit_once(':').map_or(host_port, |(h, _)| h)
}

/// Whether the `Host` header names this machine (empty: an HTTP/1.0 client, allowed).
fn host_allowed(host: &str, allow: &[String]) -> bool {
    let name = host_name(host);
    host.is_empty()
        || name.eq_ignore_ascii_case("localhost")
        || name.parse::<std::net::IpAddr>().is_ok()
        || allow.iter().any(|o| {
            let allowed = o.split_once("://").map_or(o.as_str(), |(_, rest)| rest);
            host_name(allowed).eq_ignore_ascii_case(name)
        })
}

/// Whether a page of `origin` may read the stream of the server at `host`.
fn origin_allowed(origin: &str, host: &str, allow: &[String]) -> bool {
    let own = ["http://", "https://"]
        .iter()
        .any(|scheme| origin.eq_ignore_ascii_case(&format!("{scheme}{host}")));
    own || allow
        .iter()
        .any(|o| o.trim_end_matches('/').eq_ignore_ascii_case(origin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_this_machine_and_its_own_pages_pass() {
        let allow = vec!["https://robot.example".to_string()];
        for host in [
            "127.0.0.1:8080",
            "localhost:8080",
            "[::1]:8080",
            "10.0.0.5",
            "",
        ] {
            assert!(host_allowed(host, &allow), "{host}");
        }
        assert!(host_allowed("robot.example:443", &allow));
        assert!(!host_allowed("evil.example:8080", &allow));
        assert!(!host_allowed("localhost.evil.example", &allow));
        assert!(origin_allowed(
            "http://127.0.0.1:8080",
            "127.0.0.1:8080",
            &allow
        ));
        assert!(origin_allowed(
            "https://robot.example",
            "127.0.0.1:8080",
            &allow
        ));
        assert!(!origin_allowed(
            "http://evil.example",
            "127.0.0.1:8080",
            &allow
        ));
        assert!(!origin_allowed(
            "http://127.0.0.1:9999",
            "127.0.0.1:8080",
            &[]
        ));
    }
}
