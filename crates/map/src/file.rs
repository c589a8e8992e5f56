//! The map on disk: one binary file, little-endian, versioned and checksummed, written
//! atomically.
//!
//! ```text
//! "ILMAP\0\r\n"                      magic (8 bytes; the CR LF catches text-mode mangling)
//! u32 version                        FORMAT_VERSION
//! u32 width, u32 height, f64 fx fy cx cy, f64 dist[5]         the camera
//! u32 max_features, u32 levels, f32 scale_factor, u8 threshold, u8 min_threshold, u32 cell
//! u32 keyframes, u32 descriptor width
//! per keyframe: u32 name length, name (UTF-8), f64 position[3], f64 quaternion[4] (w x y z),
//!               f32 descriptor[width], u32 features,
//!               per feature: f32 pixel[2], f32 point[3], u64 descriptor[4]
//! u32 CRC-32 of everything before it
//! ```
//! A 640x480 keyframe with a thousand lifted features takes about 52 kB.
//!
//! Written by hand rather than through serde: the layout is flat arrays of numbers, a reader
//! must check every count against the file's length before allocating (a corrupt count must not
//! ask for terabytes), and no binary serde format is among the workspace's dependencies.

use crate::keyframes::{KeyframeMap, MappedFeatures};
use crate::retrieval::{Keyframe, RetrievalIndex};
use crate::{MapError, Result};
use features::ExtractConfig;
use geom::{Camera, Distortion, Pose};
use std::path::Path;

/// The file's first bytes.
pub const MAGIC: &[u8; 8] = b"ILMAP\0\r\n";
/// The layout version this build reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// Writes the map to `path` atomically (temporary file, then rename).
pub fn save(map: &KeyframeMap, path: &Path) -> Result<()> {
    let bytes = encode(map);
    data::io::write_atomic(path, |w| w.write_all(&bytes)).map_err(|e| MapError::File {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })
}

/// Reads a map; errors name the file and say what is wrong (not a map, another version,
/// truncated, corrupt).
pub fn load(path: &Path) -> Result<KeyframeMap> {
    let bytes = std::fs::read(path).map_err(|e| MapError::File {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    decode(&bytes).map_err(|msg| MapError::File {
        path: path.to_path_buf(),
        msg,
    })
}

fn encode(map: &KeyframeMap) -> Vec<u8> {
    let mut b = Vec::with_capacity(64 + map.points() * 52 + map.len() * 3200);
    b.extend_from_slice(MAGIC);
    put_u32(&mut b, FORMAT_VERSION);
    let c = &map.camera;
    put_u32(&mut b, c.width);
    put_u32(&mut b, c.height);
    for v in [c.fx, c.fy, c.cx, c.cy]
        .into_iter()
        .chain(c.dist.to_array())
    {
        put_f64(&mut b, v);
    }
    let e = &map.extract;
    put_u32(&mut b, e.max_features as u32);
    put_u32(&mut b, e.levels as u32);
    b.extend_from_slice(&e.scale_factor.to_le_bytes());
    b.push(e.threshold);
    b.push(e.min_threshold);
    put_u32(&mut b, e.cell);
    put_u32(&mut b, map.len() as u32);
    let width = if map.is_empty() {
        0
    } else {
        map.retrieval.descriptor(0).len()
    };
    put_u32(&mut b, width as u32);
    for (i, (kf, f)) in map
        .retrieval
        .keyframes
        .iter()
        .zip(&map.features)
        .enumerate()
    {
        put_u32(&mut b, kf.name.len() as u32);
        b.extend_from_slice(kf.name.as_bytes());
        for v in kf.pose.position().into_iter().chain(kf.pose.quat_wxyz()) {
            put_f64(&mut b, v);
        }
        for v in map.retrieval.descriptor(i) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        put_u32(&mut b, f.len() as u32);
        for k in 0..f.len() {
            for v in f.keypoints[k].iter().chain(&f.points[k]) {
                b.extend_from_slice(&v.to_le_bytes());
            }
            for w in f.descriptors[k] {
                b.extend_from_slice(&w.to_le_bytes());
            }
        }
    }
    let crc = crc32fast::hash(&b);
    put_u32(&mut b, crc);
    b
}

fn put_u32(b: &mut Vec<u8>, v: u32) {
    b.extend_from_slice(&v.to_le_bytes());
}

fn put_f64(b: &mut Vec<u8>, v: f64) {
    b.extend_from_slice(&v.to_le_bytes());
}

/// A cursor over the file's bytes that refuses to read past the end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> std::result::Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| format!("truncated: needs {n} bytes at offset {}", self.at))?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    fn u8(&mut self) -> std::result::Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn f32(&mut self) -> std::result::Result<f32, String> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn f64(&mut self) -> std::result::Result<f64, String> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    /// A count of items of `size` bytes each, checked against what is left.
    fn count(&mut self, size: usize) -> std::result::Result<usize, String> {
        let n = self.u32()? as usize;
        let left = self.bytes.len() - self.at;
        if n.saturating_mul(size) > left {
            return Err(format!(
                "truncated or corrupt: a count of {n} at offset {} does not fit in the {left} bytes left",
                self.at - 4
            ));
        }
        Ok(n)
    }
}

fn decode(bytes: &[u8]) -> std::result::Result<KeyframeMap, String> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(
            "not an indoorloc map (no ILMAP header); build one with `indoorloc map build`".into(),
        );
    }
    if bytes.len() < MAGIC.len() + 8 {
        return Err("truncated map file".into());
    }
    let mut r = Reader {
        bytes: &bytes[..bytes.len() - 4],
        at: MAGIC.len(),
    };
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "map format version {version}; this build reads version {FORMAT_VERSION}: build the map again with `indoorloc map build`"
        ));
    }
    let stored = u32::from_le_bytes(bytes[bytes.len() - 4..].try_into().expect("4 bytes"));
    if crc32fast::hash(&bytes[..bytes.len() - 4]) != stored {
        return Err(
            "corrupt: the checksum does not match (a damaged or partly written file)".into(),
        );
    }
    let (width, height) = (r.u32()?, r.u32()?);
    let (fx, fy, cx, cy) = (r.f64()?, r.f64()?, r.f64()?, r.f64()?);
    let mut dist = [0.0; 5];
    for d in &mut dist {
        *d = r.f64()?;
    }
    let camera = Camera {
        width,
        height,
        fx,
        fy,
        cx,
        cy,
        dist: Distortion::from_array(dist),
    };
    camera.validate().map_err(|e| format!("its camera: {e}"))?;
    let extract = ExtractConfig {
        max_features: r.u32()? as usize,
        levels: r.u32()? as usize,
        scale_factor: r.f32()?,
        threshold: r.u8()?,
        min_threshold: r.u8()?,
        cell: r.u32()?,
    };
    let n = r.count(8)?;
    let width_d = r.u32()? as usize;
    let mut keyframes = Vec::with_capacity(n);
    let mut thumbs = Vec::with_capacity(n);
    let mut features = Vec::with_capacity(n);
    for _ in 0..n {
        let len = r.count(1)?;
        let name = String::from_utf8(r.take(len)?.to_vec())
            .map_err(|_| "corrupt: a keyframe name is not UTF-8".to_string())?;
        let t = [r.f64()?, r.f64()?, r.f64()?];
        let q = [r.f64()?, r.f64()?, r.f64()?, r.f64()?];
        let pose = Pose::from_t_wxyz(t, q).map_err(|e| format!("keyframe {name}: {e}"))?;
        let mut thumb = Vec::with_capacity(width_d.min(r.bytes.len() / 4));
        for _ in 0..width_d {
            thumb.push(r.f32()?);
        }
        let m = r.count(52)?;
        let mut f = MappedFeatures {
            keypoints: Vec::with_capacity(m),
            points: Vec::with_capacity(m),
            descriptors: Vec::with_capacity(m),
        };
        for _ in 0..m {
            f.keypoints.push([r.f32()?, r.f32()?]);
            f.points.push([r.f32()?, r.f32()?, r.f32()?]);
            f.descriptors.push([r.u64()?, r.u64()?, r.u64()?, r.u64()?]);
        }
        keyframes.push(Keyframe { name, pose });
        thumbs.push(thumb);
        features.push(f);
    }
    if r.at != r.bytes.len() {
        return Err(format!(
            "corrupt: {} bytes after the last keyframe",
            r.bytes.len() - r.at
        ));
    }
    let retrieval =
        RetrievalIndex::from_descriptors(keyframes, thumbs).map_err(|e| e.to_string())?;
    Ok(KeyframeMap {
        camera,
        extract,
        retrieval,
        features,
    })
}
