//! Border following (Suzuki and Abe 1985) as OpenCV's `findContours(RETR_LIST,
//! CHAIN_APPROX_NONE)` runs it (`imgproc/src/contours_new.cpp`): the same raster scan, the same
//! start pixels and tracing directions and the same marks, so every contour has OpenCV's points
//! in OpenCV's order. That order matters: the polygon approximation that follows starts from a
//! contour's first point, and the corners it keeps are the ones the gold was made with.

/// Chain-code steps 0..8 (x right, y down): right, up-right, up, up-left, left, down-left,
/// down, down-right.
const CHAIN: [(i32, i32); 8] = [
    (1, 0),
    (1, -1),
    (0, -1),
    (-1, -1),
    (-1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];
/// A traced pixel whose right neighbour was examined and found 0 (`nbd | 0x80`; negative as
/// OpenCV's `schar`).
const RIGHT: u8 = 0x82;
/// A traced pixel otherwise (`nbd`, OpenCV's `MASK8_NEW` in list mode).
const NEW: u8 = 2;

/// OpenCV's `schar` test `value >= 1`.
fn positive(v: u8) -> bool {
    (1..0x80).contains(&v)
}

/// Traces every border of the 0/1 image `img` (`width x height` including a zero frame of one
/// pixel) and calls `on_contour` with its points in image coordinates (frame removed). `img` is
/// marked in place. `points` is scratch space.
///
/// # Panics
/// When `img` is shorter than `width * height` or its one-pixel frame is not all zero (the
/// tracer relies on the frame to stay inside the buffer).
pub(crate) fn find_contours(
    img: &mut [u8],
    width: usize,
    height: usize,
    points: &mut Vec<(i32, i32)>,
    mut on_contour: impl FnMut(&[(i32, i32)]),
) {
    if width < 3 || height < 3 {
        return;
    }
    assert!(
        img.len() >= width * height,
        "contour image smaller than its size"
    );
    let frame_is_zero = img[..width].iter().all(|&v| v == 0)
        && img[(height - 1) * width..height * width]
            .iter()
            .all(|&v| v == 0)
        && (1..height - 1).all(|y| img[y * width] == 0 && img[y * width + width - 1] == 0);
    assert!(frame_is_zero, "contour image needs a zero frame");
    let step = width as isize;
    let mut delta = [0isize; 16];
    for (s, &(dx, dy)) in CHAIN.iter().enumerate() {
        delta[s] = dx as isize + dy as isize * step;
        delta[s + 8] = delta[s];
    }
    let last_x = width - 1;
    for y in 1..height - 1 {
        let row = y * width;
        let mut x = 1;
        let mut prev: u8 = 0;
        while x < last_x {
            // Skip the run of pixels equal to `prev`, eight at a time where possible.
            let splat = u64::from_ne_bytes([prev; 8]);
            while x + 8 <= last_x {
                let chunk: [u8; 8] = img[row + x..row + x + 8].try_into().expect("8 bytes");
                if u64::from_ne_bytes(chunk) != splat {
                    break;
                }
                x += 8;
            }
            while x < last_x && img[row + x] == prev {
                x += 1;
            }
            if x >= last_x {
                break;
            }
            let p = img[row + x];
            let outer = prev == 0 && p == 1;
            let hole = !outer && p == 0 && positive(prev);
            if outer || hole {
                let start_x = x - usize::from(hole);
                points.clear();
                trace(
                    img,
                    row + start_x,
                    (start_x as i32, y as i32),
                    hole,
                    &delta,
                    points,
                );
                on_contour(points);
                // OpenCV resumes at x + 1 with `prev` = the (now marked) pixel at x.
                prev = img[row + x];
            } else {
                prev = p;
            }
            x += 1;
        }
    }
}

/// OpenCV's `icvFetchContourEx` for 8-bit images in list mode with `CHAIN_APPROX_NONE`.
fn trace(
    img: &mut [u8],
    i0: usize,
    origin: (i32, i32),
    is_hole: bool,
    delta: &[isize; 16],
    points: &mut Vec<(i32, i32)>,
) {
    let len = img.len();
    let at = |i: usize, s: u8| (i as isize + delta[(s & 15) as usize]) as usize;
    // Unchecked reads: the tracer only stands on nonzero pixels, which lie inside the zero
    // frame `find_contours` checked, so every neighbour it looks at is inside the buffer.
    let get = |img: &[u8], i: usize| {
        debug_assert!(i < len);
        // SAFETY: see above; `i` is a neighbour of a pixel inside the frame.
        unsafe { *img.get_unchecked(i) }
    };
    let s_start: u8 = if is_hole { 0 } else { 4 };
    let mut s = s_start;
    let mut i1;
    loop {
        s = (s + 7) & 7;
        i1 = at(i0, s);
        if get(img, i1) != 0 || s == s_start {
            break;
        }
    }
    let out = |(x, y): (i32, i32)| (x - 1, y - 1);
    if s == s_start {
        // A single pixel.
        img[i0] = RIGHT;
        points.push(out(origin));
        return;
    }
    let mut i3 = i0;
    let mut pt = origin;
    loop {
        let s_end = s;
        let mut i4 = i3;
        while s < 15 {
            s += 1;
            i4 = at(i3, s);
            if get(img, i4) != 0 {
                break;
            }
        }
        s &= 7;
        // `i3` is a traced (nonzero) pixel, so inside the buffer: checked access is cheap here.
        if s >= 1 && s - 1 < s_end {
            img[i3] = RIGHT;
        } else if img[i3] == 1 {
            img[i3] = NEW;
        }
        points.push(out(pt));
        let (dx, dy) = CHAIN[s as usize];
        pt = (pt.0 + dx, pt.1 + dy);
        if i4 == i0 && i3 == i1 {
            break;
        }
        i3 = i4;
        s = (s + 4) & 7;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn framed(rows: &[&str]) -> (Vec<u8>, usize, usize) {
        let w = rows[0].len() + 2;
        let h = rows.len() + 2;
        let mut img = vec![0u8; w * h];
        for (y, r) in rows.iter().enumerate() {
            for (x, c) in r.bytes().enumerate() {
                img[(y + 1) * w + x + 1] = u8::from(c == b'#');
            }
        }
        (img, w, h)
    }

    fn contours(rows: &[&str]) -> Vec<Vec<(i32, i32)>> {
        let (mut img, w, h) = framed(rows);
        let mut all = Vec::new();
        find_contours(&mut img, w, h, &mut Vec::new(), |c| all.push(c.to_vec()));
        all
    }

    #[test]
    fn a_filled_square_has_its_outer_border_counter_clockwise_from_the_top_left() {
        // cv2.findContours(img, RETR_LIST, CHAIN_APPROX_NONE) on this image gives exactly
        // [(1,1),(1,2),(1,3),(2,3),(3,3),(3,2),(3,1),(2,1)].
        let c = contours(&[".....", ".###.", ".###.", ".###.", "....."]);
        assert_eq!(
            c,
            vec![vec![
                (1, 1),
                (1, 2),
                (1, 3),
                (2, 3),
                (3, 3),
                (3, 2),
                (3, 1),
                (2, 1)
            ]]
        );
    }

    #[test]
    fn rings_and_blobs_match_opencv_point_for_point() {
        // OpenCV lists contours last-found first; `contours` gives them as found.
        let mut c = contours(&["#####", "#...#", "#...#", "#####"]);
        c.reverse();
        let want = vec![
            vec![
                (0, 1),
                (1, 0),
                (2, 0),
                (3, 0),
                (4, 1),
                (4, 2),
                (3, 3),
                (2, 3),
                (1, 3),
                (0, 2),
            ],
            vec![
                (0, 0),
                (0, 1),
                (0, 2),
                (0, 3),
                (1, 3),
                (2, 3),
                (3, 3),
                (4, 3),
                (4, 2),
                (4, 1),
                (4, 0),
                (3, 0),
                (2, 0),
                (1, 0),
            ],
        ];
        assert_eq!(c, want);
        let mut c = contours(&[".......", ".##.##.", ".##.##.", ".......", ".####.."]);
        c.reverse();
        let want = vec![
            vec![(1, 4), (2, 4), (3, 4), (4, 4), (3, 4), (2, 4)],
            vec![(4, 1), (4, 2), (5, 2), (5, 1)],
            vec![(1, 1), (1, 2), (2, 2), (2, 1)],
        ];
        assert_eq!(c, want);
    }

    #[test]
    fn single_pixels_and_empty_images() {
        assert_eq!(contours(&["...", ".#.", "..."]), vec![vec![(1, 1)]]);
        assert!(contours(&["...", "..."]).is_empty());
    }
}
