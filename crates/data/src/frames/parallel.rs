//! A video decoded by several single-threaded decoders at once, each on its own stretch of the
//! file between keyframes, with the frames handed out in order.
//!
//! FFmpeg's frame threading hands every frame from thread to thread; on a small video (320x240
//! decodes in a quarter of a millisecond) that handover costs as much as it saves, and two
//! threads decode barely faster than one. Independent stretches need no handover: each worker
//! seeks to its keyframe, decodes (and scales) alone, and the reader takes the stretches in
//! turn. Memory stays bounded: each worker queues at most one stretch of frames.
//!
//! Frame numbers come from a first pass over the packets (demuxing only, no decoding): a
//! frame's number is the rank of its timestamp among all packets' timestamps, so they match
//! what [`VideoFile`] counts. Files where that does not hold (packets without timestamps,
//! repeated timestamps, too few keyframes to split) are not opened this way: [`ParallelVideo::
//! open`] answers `None` and the caller reads them with [`VideoFile`].

use super::video::VideoFile;
use super::{Frame, FrameSource};
use crate::error::{DataError, Result};
use ffmpeg_next as ff;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

/// Least frames per stretch: seeking and restarting a decoder costs a few frames' time.
const STRETCH_FRAMES: usize = 48;

/// A stretch of the video: frames with timestamps in `[start, end)`, decoded from the keyframe
/// at `start` (`None`: the beginning of the file).
#[derive(Clone, Copy, Debug)]
struct Stretch {
    seek: Option<i64>,
    start: i64,
    end: i64,
}

enum Msg {
    Frame(Result<Frame>),
    EndOfStretch,
}

/// Frames of a video decoded in parallel stretches, in order (see the module doc).
pub struct ParallelVideo {
    path: PathBuf,
    fps: Option<f64>,
    frames: u64,
    frame_size: (u32, u32),
    size: Option<(u32, u32)>,
    fast: bool,
    workers: usize,
    stretches: Vec<Stretch>,
    /// Every packet's timestamp, sorted: a frame's number is its timestamp's rank.
    sorted_pts: std::sync::Arc<Vec<i64>>,
    running: Option<Running>,
    next_stretch: usize,
}

struct Running {
    receivers: Vec<Receiver<Msg>>,
    handles: Vec<JoinHandle<()>>,
}

impl std::fmt::Debug for ParallelVideo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParallelVideo")
            .field("path", &self.path)
            .field("frames", &self.frames)
            .field("stretches", &self.stretches.len())
            .field("workers", &self.workers)
            .finish_non_exhaustive()
    }
}

impl ParallelVideo {
    /// Plans the stretches of `path` for `workers` decoders (`fast`: skip the loop filter, as
    /// [`VideoFile::open_fast`]). `Ok(None)` when the file cannot be split this way (see the
    /// module doc) or `workers < 2`.
    ///
    /// # Errors
    /// The file cannot be opened as a video (as [`VideoFile::open`]).
    pub fn open(path: &Path, fast: bool, workers: usize) -> Result<Option<ParallelVideo>> {
        if workers < 2 {
            return Ok(None);
        }
        let probe = VideoFile::open_with(path, None, fast, 1)?;
        let (fps, frame_size) = (probe.fps(), probe.frame_size());
        drop(probe);
        let Some((mut pts, keyframes)) = packet_table(path)? else {
            return Ok(None);
        };
        pts.sort_unstable();
        if pts.windows(2).any(|w| w[0] == w[1]) {
            return Ok(None);
        }
        let stretches = plan(&pts, &keyframes);
        if stretches.len() < 2 {
            return Ok(None);
        }
        Ok(Some(ParallelVideo {
            path: path.to_path_buf(),
            fps,
            frames: pts.len() as u64,
            frame_size,
            size: None,
            fast,
            workers,
            stretches,
            sorted_pts: std::sync::Arc::new(pts),
            running: None,
            next_stretch: 0,
        }))
    }

    /// The video's coded size.
    pub fn frame_size(&self) -> (u32, u32) {
        self.frame_size
    }

    /// Scales every frame to `size` (area averaging when shrinking), as
    /// [`VideoFile::set_output_size`]; only before the first frame is read.
    pub fn set_output_size(&mut self, size: Option<(u32, u32)>) {
        if self.running.is_none() {
            self.size = size;
        }
    }

    fn start(&mut self) -> Running {
        let mut receivers = Vec::with_capacity(self.workers);
        let mut handles = Vec::with_capacity(self.workers);
        for w in 0..self.workers {
            let (tx, rx) = sync_channel(STRETCH_FRAMES + 16);
            let mine: Vec<Stretch> = self
                .stretches
                .iter()
                .skip(w)
                .step_by(self.workers)
                .copied()
                .collect();
            let (path, size, fast, pts) = (
                self.path.clone(),
                self.size,
                self.fast,
                self.sorted_pts.clone(),
            );
            handles.push(std::thread::spawn(move || {
                decode_stretches(&path, size, fast, &mine, &pts, &tx)
            }));
            receivers.push(rx);
        }
        Running { receivers, handles }
    }
}

/// One worker: its stretches in order, each ended by [`Msg::EndOfStretch`].
fn decode_stretches(
    path: &Path,
    size: Option<(u32, u32)>,
    fast: bool,
    stretches: &[Stretch],
    sorted_pts: &[i64],
    tx: &SyncSender<Msg>,
) {
    let mut video = match VideoFile::open_with(path, size, fast, 1) {
        Ok(v) => v,
        Err(e) => {
            let _ = tx.send(Msg::Frame(Err(e)));
            for _ in stretches {
                let _ = tx.send(Msg::EndOfStretch);
            }
            return;
        }
    };
    for s in stretches {
        if let Some(k) = s.seek
            && let Err(e) = video.seek_keyframe(k)
            && tx.send(Msg::Frame(Err(e))).is_err()
        {
            return;
        }
        while let Some(item) = video.next_frame() {
            let msg = match item {
                Ok(mut frame) => {
                    let Some(pts) = video.last_pts() else {
                        continue;
                    };
                    if pts < s.start {
                        continue; // leading frames of this keyframe belong to the stretch before
                    }
                    if pts >= s.end {
                        break;
                    }
                    let index = sorted_pts.partition_point(|&p| p < pts) as u64;
                    frame.index = index;
                    frame.name = format!("{index:06}");
                    Msg::Frame(Ok(frame))
                }
                Err(e) => Msg::Frame(Err(e)),
            };
            if tx.send(msg).is_err() {
                return;
            }
        }
        if tx.send(Msg::EndOfStretch).is_err() {
            return;
        }
    }
}

/// Timestamps of every packet of the best video stream (any order) and the keyframes' in
/// decoding order; `None` when a packet has no timestamp.
fn packet_table(path: &Path) -> Result<Option<(Vec<i64>, Vec<i64>)>> {
    let utf8 = path.to_str().unwrap_or_default();
    let mut input = ff::format::input(&format!("file:{utf8}")).map_err(|e| DataError::Frames {
        path: path.to_path_buf(),
        msg: format!("cannot open as a video: {e}"),
    })?;
    let Some(stream) = input.streams().best(ff::media::Type::Video) else {
        return Ok(None);
    };
    let index = stream.index();
    let (mut pts, mut keyframes) = (Vec::new(), Vec::new());
    for (s, packet) in input.packets() {
        if s.index() != index {
            continue;
        }
        let Some(p) = packet.pts() else {
            return Ok(None);
        };
        pts.push(p);
        if packet.is_key() {
            keyframes.push(p);
        }
    }
    Ok(Some((pts, keyframes)))
}

/// Stretches of at least [`STRETCH_FRAMES`] frames, each starting at a keyframe.
fn plan(sorted_pts: &[i64], keyframes: &[i64]) -> Vec<Stretch> {
    let rank = |p: i64| sorted_pts.partition_point(|&q| q < p);
    let mut starts: Vec<i64> = Vec::new();
    let mut last_rank = 0;
    for &k in keyframes {
        let r = rank(k);
        if r >= last_rank + STRETCH_FRAMES && sorted_pts.len() - r >= STRETCH_FRAMES / 2 {
            starts.push(k);
            last_rank = r;
        }
    }
    let mut stretches = Vec::with_capacity(starts.len() + 1);
    let mut start = i64::MIN;
    let mut seek = None;
    for &k in &starts {
        stretches.push(Stretch {
            seek,
            start,
            end: k,
        });
        start = k;
        seek = Some(k);
    }
    stretches.push(Stretch {
        seek,
        start,
        end: i64::MAX,
    });
    stretches
}

impl Iterator for ParallelVideo {
    type Item = Result<Frame>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.running.is_none() {
            self.running = Some(self.start());
        }
        let workers = self.workers;
        loop {
            if self.next_stretch >= self.stretches.len() {
                return None;
            }
            let running = self.running.as_ref()?;
            match running.receivers[self.next_stretch % workers].recv() {
                Ok(Msg::Frame(f)) => return Some(f),
                Ok(Msg::EndOfStretch) => self.next_stretch += 1,
                Err(_) => {
                    self.next_stretch = self.stretches.len();
                    return Some(Err(DataError::Frames {
                        path: self.path.clone(),
                        msg: "a decoding thread stopped unexpectedly".into(),
                    }));
                }
            }
        }
    }
}

impl Drop for ParallelVideo {
    fn drop(&mut self) {
        if let Some(running) = self.running.take() {
            // Dropping the receivers makes every pending send fail, so the workers return.
            drop(running.receivers);
            for h in running.handles {
                let _ = h.join();
            }
        }
    }
}

impl FrameSource for ParallelVideo {
    fn len_hint(&self) -> Option<u64> {
        Some(self.frames)
    }

    fn fps(&self) -> Option<f64> {
        self.fps
    }

    fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::shared_data as shared;

    /// Same frames, numbers and pixels as the one-decoder reading, on real footage: a
    /// constant-rate clip and a variable-frame-rate one (every third frame dropped).
    #[test]
    fn parallel_frames_match_the_sequential_ones() -> Result<()> {
        for (clip, frames, size) in [
            ("scenecut_real/opencv_samples_cuts.mp4", 475, (64, 48)),
            (
                "scenecut_pyscenedetect/goldeneye-vfr-drop3.mp4",
                160,
                (64, 27),
            ),
        ] {
            let path = shared(clip);
            let Some(mut par) = ParallelVideo::open(&path, true, 2)? else {
                return Err(DataError::Frames {
                    path,
                    msg: "expected a splittable video".into(),
                });
            };
            assert!(par.stretches.len() >= 2, "{clip}: {:?}", par.stretches);
            par.set_output_size(Some(size));
            let mut seq = VideoFile::open_with(&path, Some(size), true, 1)?;
            let mut n = 0;
            for (a, b) in (&mut par).zip(&mut seq) {
                let (a, b) = (a?, b?);
                assert_eq!((a.index, &a.name, a.t), (b.index, &b.name, b.t), "{clip}");
                assert!(a.image == b.image, "{clip}: frame {} differs", a.index);
                n += 1;
            }
            assert_eq!(n, frames, "{clip}");
            assert!(par.next().is_none() && seq.next().is_none(), "{clip}");
        }
        Ok(())
    }

    #[test]
    fn too_short_or_one_worker_is_not_split() -> Result<()> {
        let path = shared("scenecut_real/opencv_vtest_nocut.mp4");
        assert!(ParallelVideo::open(&path, true, 1)?.is_none());
        Ok(())
    }
}
