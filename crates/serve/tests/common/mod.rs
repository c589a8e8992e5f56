//! A pipeline for the server tests: raw frames from a byte stream (track's real stdin source)
//! through an estimator that reads the pose painted into each frame, so the poses a test
//! receives are known exactly. The network and markers estimators are tested in their own
//! crates and end to end in `indoorloc`'s tests (`serve --jsonl`, the dashboard in Chromium).

#![allow(dead_code)]

use std::sync::Arc;
use track::source::RawFrames;
use track::{Estimation, Estimator, Pipeline, PipelineConfig};

/// Frame size of the test streams.
pub const W: u32 = 32;
/// Frame size of the test streams.
pub const H: u32 = 24;

/// Frames whose first pixel's red value is the x position in decimetres: a walk along x.
pub fn walk_bytes(frames: usize) -> Vec<u8> {
    let mut out = Vec::new();
    for i in 0..frames {
        let mut f = vec![90u8; (W * H * 3) as usize];
        f[0] = (i % 200) as u8;
        out.extend_from_slice(&f);
    }
    out
}

/// Reads the position painted into the frame.
pub struct PaintedPose;

impl Estimator for PaintedPose {
    fn name(&self) -> &'static str {
        "painted"
    }

    fn estimate(
        &mut self,
        image: &image::DynamicImage,
        _prior: Option<&Estimation>,
    ) -> track::Result<Option<Estimation>> {
        let x = f64::from(image.to_rgb8().get_pixel(0, 0)[0]) / 10.0;
        Ok(Some(Estimation::isotropic(
            geom::Pose::new(
                nalgebra::UnitQuaternion::identity(),
                nalgebra::Vector3::new(x, 1.0, 1.5),
            ),
            0.2,
            0.05,
        )))
    }
}

/// A byte stream that fails after `ok` bytes (a camera pipe that dies).
pub struct DyingReader {
    data: std::io::Cursor<Vec<u8>>,
}

impl std::io::Read for DyingReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self.data.read(buf)? {
            0 => Err(std::io::Error::other("camera unplugged")),
            n => Ok(n),
        }
    }
}

/// A pipeline over `frames` painted frames at `fps`, played in real time; with `dies` the
/// stream then fails instead of ending.
pub fn pipeline(frames: usize, fps: f64, dies: bool) -> Pipeline {
    let bytes = walk_bytes(frames);
    let reader: Box<dyn std::io::Read + Send> = if dies {
        Box::new(DyingReader {
            data: std::io::Cursor::new(bytes),
        })
    } else {
        Box::new(std::io::Cursor::new(bytes))
    };
    let source = RawFrames::new(reader, "test-stream", W, H, 3, fps);
    let cfg = PipelineConfig {
        realtime: true,
        detect_cuts: false,
        ..PipelineConfig::default()
    };
    Pipeline::new(Box::new(source), vec![Box::new(PaintedPose)], cfg).expect("pipeline")
}

/// Starts `pipeline` into a new hub and a server on a free loopback port; returns the hub and
/// the address.
pub async fn start(
    pipeline: Pipeline,
    cfg: serve::ServerConfig,
) -> (Arc<serve::Hub>, std::net::SocketAddr) {
    let hub = serve::Hub::new(pipeline.metrics(), serve::FloorMap::default());
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let addr = listener.local_addr().expect("addr");
    {
        let hub = Arc::clone(&hub);
        std::thread::spawn(move || {
            pipeline.run(|e, f| hub.publish(e, f));
        });
    }
    let h = Arc::clone(&hub);
    tokio::spawn(async move {
        let _ = serve::serve(listener, h, cfg, std::future::pending()).await;
    });
    (hub, addr)
}

/// A plain HTTP/1.1 request on a fresh connection; returns status and body.
pub async fn http(addr: std::net::SocketAddr, raw_request: &str) -> (u16, String) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut s = tokio::net::TcpStream::connect(addr).await.expect("connect");
    s.write_all(raw_request.as_bytes()).await.expect("write");
    let mut buf = Vec::new();
    let _ = tokio::time::timeout(std::time::Duration::from_secs(5), s.read_to_end(&mut buf)).await;
    let text = String::from_utf8_lossy(&buf).into_owned();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (status, body)
}

/// `GET path` with `Connection: close`.
pub async fn get(addr: std::net::SocketAddr, path: &str) -> (u16, String) {
    http(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"),
    )
    .await
}
