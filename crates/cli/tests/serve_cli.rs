//! `indoorloc study track` and `indoorloc serve` end to end on a toy demo: the fused track
//! against the raw network, the JSON-lines stream, and the dashboard in a real headless
//! Chromium (Debian's, installed by `scripts/install-deps.sh`).

use crate::util::{TOY, TestResult, indoorloc, json_of};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Renders and trains the toy demo in `out` through `study track`, checking its rows.
fn toy_demo_with_study_track(out: &Path) -> TestResult {
    let mut args = vec!["study", "track", "--out", out.to_str().ok_or("path")?];
    args.extend(TOY);
    args.extend(["--mc", "2", "--json"]);
    let o = json_of(&indoorloc(&args)?)?;
    let rows = o["rows"].as_array().ok_or("rows")?;
    let models: Vec<(&str, u64)> = rows
        .iter()
        .filter_map(|r| Some((r["model"].as_str()?, r["mc"].as_u64()?)))
        .collect();
    assert_eq!(
        models,
        [("network", 0), ("fused", 0), ("network", 2), ("fused", 2)]
    );
    for r in rows {
        for key in [
            "median_pos_m",
            "median_rot_deg",
            "jitter_m",
            "frames_per_s",
            "p99_ms",
        ] {
            let v = r[key].as_f64().ok_or(key)?;
            assert!(v.is_finite() && v >= 0.0, "{key} = {v}");
        }
    }
    assert_eq!(o["frames"], 24);
    assert!(out.join("report.html").is_file());
    Ok(())
}

/// A running `indoorloc serve`, killed when dropped.
struct Server {
    child: Child,
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `indoorloc serve ARGS --port 0` and reads the address it prints.
fn start_server(args: &[&str]) -> TestResult<Server> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_indoorloc"))
        .arg("serve")
        .args(args)
        .args(["--port", "0"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()?;
    let stderr = child.stderr.take().ok_or("stderr")?;
    let mut lines = BufReader::new(stderr).lines();
    let url = loop {
        let line = lines
            .next()
            .ok_or("serve ended before printing its address")??;
        if let Some(rest) = line.split("dashboard at ").nth(1) {
            break rest.split_whitespace().next().ok_or("address")?.to_string();
        }
    };
    // Keep draining stderr so the server never blocks on it.
    std::thread::spawn(move || lines.for_each(drop));
    Ok(Server { child, url })
}

#[test]
fn the_live_pipeline_streams_and_the_dashboard_shows_it_in_chromium() -> TestResult {
    let dir = tempfile::tempdir()?;
    let demo = dir.path().join("demo");
    let demo_s = demo.to_str().ok_or("path")?;
    toy_demo_with_study_track(&demo)?;

    // JSON lines: one pose per test frame, with its truth and raw estimate, then the end.
    let out = indoorloc(&["serve", "--demo", "--demo-dir", demo_s, "--jsonl"])?;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let events: Vec<serde_json::Value> = String::from_utf8(out.stdout)?
        .lines()
        .map(serde_json::from_str)
        .collect::<Result<_, _>>()?;
    let (last, poses) = events.split_last().ok_or("no events")?;
    assert_eq!(last["event"], "end", "{last}");
    assert_eq!(poses.len(), 24);
    for p in poses {
        assert_eq!(p["event"], "pose");
        assert!(p["truth"]["position"].is_array());
        assert_eq!(p["measurements"][0]["estimator"], "network");
        assert!(p["latency_ms"]["total"].as_f64().is_some_and(|t| t > 0.0));
    }

    // The dashboard in a real browser: it connects, draws the map, and the pose moves.
    let server = start_server(&["--demo", "--demo-dir", demo_s])?;
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dashboard.png");
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?
        .block_on(check_dashboard(
            &server.url,
            &dir.path().join("chromium"),
            &shot,
        ))?;
    eprintln!("dashboard screenshot: {}", shot.display());
    Ok(())
}

/// A running chromedriver, killed when dropped.
struct Driver {
    child: Child,
    url: String,
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Debian's chromedriver on a free port and waits until it listens.
fn start_driver() -> TestResult<Driver> {
    let driver = Path::new("/usr/bin/chromedriver");
    assert!(
        driver.is_file() && Path::new("/usr/bin/chromium").is_file(),
        "the dashboard test needs Debian's chromium and chromium-driver (scripts/install-deps.sh)"
    );
    let port = std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port();
    let child = Command::new(driver)
        .arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()?;
    let d = Driver {
        child,
        url: format!("http://127.0.0.1:{port}"),
    };
    let t = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "chromedriver did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(d)
}

/// Opens the dashboard at `url` in headless Chromium (profile in `profile`), checks that it
/// connects, draws the floor map and that the pose moves, and saves a screenshot to `shot`.
async fn check_dashboard(url: &str, profile: &Path, shot: &Path) -> TestResult {
    let driver = start_driver()?;
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        serde_json::json!({
            "binary": "/usr/bin/chromium",
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--window-size=1280,800",
                format!("--user-data-dir={}", profile.display()),
            ],
        }),
    );
    let connector = hyper_util::client::legacy::connect::HttpConnector::new();
    let client = fantoccini::ClientBuilder::new(connector)
        .capabilities(caps)
        .connect(&driver.url)
        .await?;
    let result = async {
        client.goto(url).await?;
        let js = |script: &'static str| client.execute(script, Vec::new());
        let t = Instant::now();
        while js("return Number(document.body.dataset.poses)")
            .await?
            .as_u64()
            .unwrap_or(0)
            < 5
        {
            assert!(
                t.elapsed() < Duration::from_secs(20),
                "the page got no poses in 20 s"
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        let first = js("return JSON.stringify(latest.position)").await?;
        tokio::time::sleep(Duration::from_millis(1500)).await;
        let later = js("return JSON.stringify(latest.position)").await?;
        assert_ne!(first, later, "the pose did not move");
        let status = js("return document.getElementById('status').textContent").await?;
        assert_eq!(status, "live");
        let rects = js("return map.rects.length").await?;
        assert!(rects.as_u64().unwrap_or(0) > 0, "no floor map");
        let trail = js("return trail.length").await?;
        assert!(trail.as_u64().unwrap_or(0) >= 5, "trail {trail}");
        let png = client.screenshot().await?;
        assert!(png.starts_with(b"\x89PNG") && png.len() > 10_000);
        std::fs::write(shot, &png)?;
        TestResult::Ok(())
    }
    .await;
    let _ = client.close().await;
    result
}

#[test]
fn serve_refuses_bad_input_with_exit_2() -> TestResult {
    let dir = tempfile::tempdir()?;
    let missing = dir.path().join("no-such-model");
    let m = missing.to_str().ok_or("path")?;
    for (args, needle) in [
        (vec!["serve", "--model", m, "--source", m], "no-such-model"),
        (vec!["serve", "--model", m], "--source"),
        (
            vec!["serve", "--source", "stdin:0x3", "--model", m],
            "stdin:0x3",
        ),
    ] {
        let out = indoorloc(&args)?;
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    Ok(())
}
