//! 2-D convolution (groups 1, dilation 1) and both of its gradients by im2col and one matrix
//! product per group of images (one image where an image has enough output pixels, more side
//! by side in deep layers, see [`GROUP_COLUMNS`]), groups in parallel.
//!
//! Written by hand because burn-flex 0.22 differentiates a convolution through generic ops: the
//! input gradient as a transposed convolution and the weight gradient as a convolution whose
//! batch is the input channels and whose kernel is the whole output gradient (one image wide
//! for a one-channel input, so it runs on one thread). On the small network at batch 32 that
//! made the backward pass 3-4x PyTorch's.
//!
//! One image at inference is cut further ([`Tiles`]): bands of output rows whose patches fit in
//! a core's L2, or slices of output channels where a map has too few rows for every thread,
//! with the bias and ReLU of a folded layer applied as each band is written. Before, one image
//! ran on one thread: 3x256x256 took 8.6 ms on two threads against 9.0 on one; now 4.8 against
//! 6.8 with the AVX2 microkernels, 3.3-3.7 against 4.5 with AVX-512 (ARCHITECTURE.md,
//! "Departures", has the commands and PyTorch's figures beside them).

use std::cell::Cell;
use std::ops::Range;

use rayon::prelude::*;

use super::gemm::{MatRef, matmul};

/// Shapes of one convolution: input `[batch, cin, h, w]`, weight `[cout, cin, kh, kw]`,
/// output `[batch, cout, oh, ow]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConvGeometry {
    /// Images.
    pub batch: usize,
    /// Input channels.
    pub cin: usize,
    /// Input height and width.
    pub input: [usize; 2],
    /// Output channels.
    pub cout: usize,
    /// Kernel height and width.
    pub kernel: [usize; 2],
    /// Stride along height and width.
    pub stride: [usize; 2],
    /// Zero padding on each side along height and width.
    pub padding: [usize; 2],
}

impl ConvGeometry {
    /// Output height and width (PyTorch's `floor((n + 2p - k) / s) + 1`).
    pub fn output(&self) -> [usize; 2] {
        [0, 1].map(|d| (self.input[d] + 2 * self.padding[d] - self.kernel[d]) / self.stride[d] + 1)
    }

    /// Rows of an image's column matrix: `cin * kh * kw`.
    fn rows(&self) -> usize {
        self.cin * self.kernel[0] * self.kernel[1]
    }

    /// Columns of an image's column matrix: output pixels.
    fn cols(&self) -> usize {
        let [oh, ow] = self.output();
        oh * ow
    }

    fn input_len(&self) -> usize {
        self.cin * self.input[0] * self.input[1]
    }

    fn output_len(&self) -> usize {
        self.cout * self.cols()
    }

    /// A 1x1 convolution with stride 1 and no padding reads the image itself as its columns.
    fn is_pointwise(&self) -> bool {
        self.kernel == [1, 1] && self.stride == [1, 1] && self.padding == [0, 0]
    }

    /// For kernel offset `k` along dimension `d`: the output positions whose input position
    /// `o * s + k - p` lies inside the image, as a half-open range.
    fn valid(&self, d: usize, k: usize) -> (usize, usize) {
        let (s, p, n, out) = (
            self.stride[d],
            self.padding[d],
            self.input[d],
            self.output()[d],
        );
        let lo = if k >= p { 0 } else { (p - k).div_ceil(s) };
        // o * s + k - p <= n - 1  <=>  o <= (n - 1 + p - k) / s
        let hi = if n + p > k {
            ((n - 1 + p - k) / s + 1).min(out)
        } else {
            0
        };
        (lo, hi.max(lo))
    }
}

/// Fewest columns (output pixels of all its images) a group's matrix product should have.
/// Deep layers of a small input have a handful of output pixels per image (4 for the last
/// stage at 64x48); a product per image would then repack the whole weight matrix for a few
/// columns and, for the weight gradient, read and write it once per image. Images are grouped
/// side by side in one column matrix until it is this wide.
const GROUP_COLUMNS: usize = 256;

/// How a batch is cut into groups of images that share one matrix product.
#[derive(Clone, Copy, Debug)]
struct Groups {
    /// Images per group (the last group may have fewer).
    size: usize,
    /// Groups in the batch.
    count: usize,
    /// Threads each product may use: all of them when there are fewer groups than threads,
    /// else 1 (the groups run in parallel instead).
    gemm_threads: usize,
}

impl Groups {
    fn of(g: &ConvGeometry) -> Groups {
        let threads = rayon::current_num_threads().max(1);
        let size = GROUP_COLUMNS
            .div_ceil(g.cols().max(1))
            .clamp(1, g.batch.max(1));
        let count = g.batch.div_ceil(size);
        let gemm_threads = if count < threads { threads } else { 1 };
        Groups {
            size,
            count,
            gemm_threads,
        }
    }

    /// The images `[first, first + n)` of group `k`.
    fn images(&self, g: &ConvGeometry, k: usize) -> (usize, usize) {
        let first = k * self.size;
        (first, self.size.min(g.batch - first))
    }
}

/// An image whose rows hold their columns in phases of the column stride: for stride `s`,
/// columns `0, s, 2s, ...` first, then `1, 1 + s, ...`, and so on. A strided convolution reads
/// every `s`-th column of a row; in this order those columns are side by side, so [`im2col`]
/// and [`col2im_add`] copy contiguous runs (vector moves) instead of gathering one value at a
/// time, which took a third of a stride-2 inference.
struct Phased {
    /// Start of each phase within a row.
    offsets: Vec<usize>,
    /// Row length.
    width: usize,
    stride: usize,
}

impl Phased {
    fn of(g: &ConvGeometry) -> Phased {
        let (w, s) = (g.input[1], g.stride[1]);
        let mut offsets = Vec::with_capacity(s);
        let mut at = 0;
        for p in 0..s {
            offsets.push(at);
            at += w.saturating_sub(p).div_ceil(s);
        }
        Phased {
            offsets,
            width: w,
            stride: s,
        }
    }

    /// Whether rows need reordering at all (stride 1 reads rows as they are).
    fn reorders(&self) -> bool {
        self.stride > 1
    }

    /// Where column `x` of a row lies in the phased row.
    fn at(&self, x: usize) -> usize {
        self.offsets[x % self.stride] + x / self.stride
    }

    /// `image` (whole rows) in phased order, into `dst`.
    fn reorder(&self, image: &[f32], dst: &mut [f32]) {
        for (src, out) in image
            .chunks_exact(self.width)
            .zip(dst.chunks_exact_mut(self.width))
        {
            if self.stride == 2 {
                // The common case, as pairs: the compiler turns this into vector shuffles.
                let (even, odd) = out.split_at_mut(self.offsets[1]);
                for ((pair, e), o) in src.chunks_exact(2).zip(even.iter_mut()).zip(odd.iter_mut()) {
                    *e = pair[0];
                    *o = pair[1];
                }
                if self.width % 2 == 1 {
                    even[self.width / 2] = src[self.width - 1];
                }
                continue;
            }
            for (p, &offset) in self.offsets.iter().enumerate() {
                for (o, v) in out[offset..]
                    .iter_mut()
                    .zip(src[p..].iter().step_by(self.stride))
                {
                    *o = *v;
                }
            }
        }
    }

    /// Adds phased rows `src` back onto `image` in natural order.
    fn add_back(&self, src: &[f32], image: &mut [f32]) {
        for (row, out) in src
            .chunks_exact(self.width)
            .zip(image.chunks_exact_mut(self.width))
        {
            for (p, &offset) in self.offsets.iter().enumerate() {
                for (o, v) in out[p..].iter_mut().step_by(self.stride).zip(&row[offset..]) {
                    *o += *v;
                }
            }
        }
    }
}

/// Fills the patches of output rows `oys` of one image (`image` in [`Phased`] order) into
/// `dst`: patch row `r` (one input channel and kernel offset) is the `oys.len() * ow` values
/// starting at `dst[r * row_stride]`, so the patches of several images can sit side by side in
/// one column matrix.
fn im2col(
    g: &ConvGeometry,
    phased: &Phased,
    image: &[f32],
    dst: &mut [f32],
    row_stride: usize,
    oys: Range<usize>,
) {
    let [h, w] = g.input;
    let ow = g.output()[1];
    let [kh, kw] = g.kernel;
    let [sh, sw] = g.stride;
    let [ph, pw] = g.padding;
    for row in 0..g.rows() {
        let out = &mut dst[row * row_stride..][..oys.len() * ow];
        let (ci, ky, kx) = (row / (kh * kw), row / kw % kh, row % kw);
        let plane = &image[ci * h * w..(ci + 1) * h * w];
        let (y0, y1) = g.valid(0, ky);
        let (x0, x1) = g.valid(1, kx);
        for (oy, out_row) in oys.clone().zip(out.chunks_exact_mut(ow)) {
            if oy < y0 || oy >= y1 || x0 == x1 {
                out_row.fill(0.0);
                continue;
            }
            out_row[..x0].fill(0.0);
            out_row[x1..].fill(0.0);
            let src = &plane[(oy * sh + ky - ph) * w..][..w];
            let first = phased.at(x0 * sw + kx - pw);
            out_row[x0..x1].copy_from_slice(&src[first..first + (x1 - x0)]);
        }
    }
}

/// Adds the patches laid out as [`im2col`] writes them (all output rows) back onto one
/// image's gradient in [`Phased`] order (its adjoint).
fn col2im_add(
    g: &ConvGeometry,
    phased: &Phased,
    src: &[f32],
    row_stride: usize,
    image: &mut [f32],
) {
    let [h, w] = g.input;
    let [oh, ow] = g.output();
    let [kh, kw] = g.kernel;
    let [sh, sw] = g.stride;
    let [ph, pw] = g.padding;
    for row in 0..g.rows() {
        let cols = &src[row * row_stride..][..oh * ow];
        let (ci, ky, kx) = (row / (kh * kw), row / kw % kh, row % kw);
        let plane = &mut image[ci * h * w..(ci + 1) * h * w];
        let (y0, y1) = g.valid(0, ky);
        let (x0, x1) = g.valid(1, kx);
        if x0 == x1 {
            continue;
        }
        let first = phased.at(x0 * sw + kx - pw);
        for oy in y0..y1 {
            let dst = &mut plane[(oy * sh + ky - ph) * w..][first..first + (x1 - x0)];
            for (d, v) in dst.iter_mut().zip(&cols[oy * ow + x0..oy * ow + x1]) {
                *d += *v;
            }
        }
    }
}

/// Scratch buffers one thread reuses across images, layers and calls: growing them zero-fills
/// only the new part, so a network's passes after the first neither allocate nor clear them.
#[derive(Default)]
struct Scratch {
    /// An image in [`Phased`] order.
    phased: Vec<f32>,
    /// A column matrix.
    patches: Vec<f32>,
    /// A product before it is regrouped or gathered.
    product: Vec<f32>,
}

thread_local! {
    static SCRATCH: Cell<Scratch> = Cell::new(Scratch::default());
}

/// Runs `f` with this thread's [`Scratch`]. It is taken out while `f` runs, so a task that
/// rayon runs on this thread meanwhile (work stealing inside `f`) starts from empty buffers
/// rather than sharing these.
fn with_scratch<T>(f: impl FnOnce(&mut Scratch) -> T) -> T {
    let mut s = SCRATCH.take();
    let out = f(&mut s);
    SCRATCH.set(s);
    out
}

/// The first `n` values of `buf`, grown (zero-filled) if it is shorter; the values are
/// whatever was there before.
fn sized(buf: &mut Vec<f32>, n: usize) -> &mut [f32] {
    if buf.len() < n {
        buf.resize(n, 0.0);
    }
    &mut buf[..n]
}

/// The image `image` in [`Phased`] order: itself for stride 1, else reordered into `buf`.
fn phased_image<'a>(phased: &Phased, image: &'a [f32], buf: &'a mut Vec<f32>) -> &'a [f32] {
    if phased.reorders() {
        let dst = sized(buf, image.len());
        phased.reorder(image, dst);
        dst
    } else {
        image
    }
}

/// The column matrix `[rows, n * cols]` of images `[first, first + n)` of the batch `x` (for a
/// pointwise convolution, the images themselves side by side) in `s.patches`.
fn group_patches(g: &ConvGeometry, x: &[f32], first: usize, n: usize, s: &mut Scratch) {
    let (rows, cols) = (g.rows(), g.cols());
    let patches = sized(&mut s.patches, rows * n * cols);
    let images = &x[first * g.input_len()..(first + n) * g.input_len()];
    if g.is_pointwise() {
        regroup(images, patches, rows, cols, n, false);
        return;
    }
    let phased = Phased::of(g);
    for (i, image) in images.chunks_exact(g.input_len()).enumerate() {
        let image = phased_image(&phased, image, &mut s.phased);
        im2col(
            g,
            &phased,
            image,
            &mut patches[i * cols..],
            n * cols,
            0..g.output()[0],
        );
    }
}

/// Images `[first, first + n)` of a `[batch, c, cols]` tensor as one `[c, n * cols]` matrix
/// (`channels` rows), or back (`to_batch`): the layout change between a group's product and the
/// batch.
fn regroup(src: &[f32], dst: &mut [f32], channels: usize, cols: usize, n: usize, to_batch: bool) {
    for i in 0..n {
        for c in 0..channels {
            let batch = (i * channels + c) * cols;
            let group = (c * n + i) * cols;
            let (from, to) = if to_batch {
                (group, batch)
            } else {
                (batch, group)
            };
            dst[to..to + cols].copy_from_slice(&src[from..from + cols]);
        }
    }
}

/// What is applied to each output value of a convolution as it is written: a bias per output
/// channel and a ReLU (a folded BatchNorm and its activation, in inference), fused so the map
/// is not read and written again by separate ops.
#[derive(Clone, Copy, Debug, Default)]
pub struct Epilogue<'a> {
    /// One value per output channel, added.
    pub bias: Option<&'a [f32]>,
    /// `max(., 0)` after the bias.
    pub relu: bool,
}

impl Epilogue<'_> {
    /// Applies the epilogue to `channels` consecutive planes of one image, the first being
    /// output channel `first`.
    fn apply(&self, planes: &mut [f32], first: usize, plane: usize) {
        if self.bias.is_none() && !self.relu {
            return;
        }
        for (c, values) in planes.chunks_exact_mut(plane.max(1)).enumerate() {
            let b = self.bias.map_or(0.0, |b| b[first + c]);
            if self.relu {
                values.iter_mut().for_each(|v| *v = (*v + b).max(0.0));
            } else {
                values.iter_mut().for_each(|v| *v += b);
            }
        }
    }

    /// Applies the epilogue to whole images `[cout, plane]` laid end to end.
    fn apply_images(&self, images: &mut [f32], cout: usize, plane: usize) {
        for image in images.chunks_exact_mut((cout * plane).max(1)) {
            self.apply(image, 0, plane);
        }
    }
}

/// Bytes of one band's column matrix that [`Tiles::Rows`] aims for: about half of a core's
/// L2 cache, so the matrix product reads the patches back from cache rather than memory.
const BAND_BYTES: usize = 256 * 1024;

/// How the product of one group is cut into tiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tiles {
    /// One image in bands of this many whole output rows: each band's patches are converted
    /// and multiplied while they are in cache, bands in parallel. Taken for an image with more
    /// output pixels than channels, where a band has at least as many columns as the weight
    /// has rows, so repacking the weight per band costs less than the band's own patches.
    Rows(usize),
    /// Slices of this many output channels (a multiple of 16, the matrix kernel's height), one
    /// per thread, when there are fewer groups than threads: each thread packs only its own
    /// slice of the weight.
    Channels(usize),
    /// The group's product in one piece.
    Whole,
}

impl Tiles {
    fn of(g: &ConvGeometry, n: usize, threads: usize) -> Tiles {
        let oh = g.output()[0];
        let patches = g.rows() * g.cols() * std::mem::size_of::<f32>();
        let by_cache = patches.div_ceil(BAND_BYTES);
        let by_weight = g.cols() / g.cout.max(1);
        let bands = by_cache.min(by_weight).max(threads).min(oh);
        if n == 1 && !g.is_pointwise() && g.cols() >= g.cout && bands > 1 {
            Tiles::Rows(oh.div_ceil(bands).max(1))
        } else if threads > 1 {
            Tiles::Channels(
                g.cout
                    .div_ceil(threads)
                    .next_multiple_of(16)
                    .min(g.cout.max(1)),
            )
        } else {
            Tiles::Whole
        }
    }
}

/// The convolution `y = w * x`, then the epilogue: `[batch, cout, oh, ow]`, row-major.
pub fn forward(g: &ConvGeometry, x: &[f32], weight: &[f32], epilogue: Epilogue) -> Vec<f32> {
    assert_eq!(x.len(), g.batch * g.input_len(), "input size");
    assert_eq!(weight.len(), g.cout * g.rows(), "weight size");
    if let Some(bias) = epilogue.bias {
        assert_eq!(bias.len(), g.cout, "bias size");
    }
    let groups = Groups::of(g);
    let mut y = vec![0.0; g.batch * g.output_len()];
    let chunk = (groups.size * g.output_len()).max(1);
    let threads = groups.gemm_threads;
    let group = |(k, out): (usize, &mut [f32])| {
        let images = groups.images(g, k);
        forward_group(g, x, weight, epilogue, images, out, threads);
    };
    if threads == 1 {
        y.par_chunks_mut(chunk).enumerate().for_each(group);
    } else {
        y.chunks_mut(chunk).enumerate().for_each(group);
    }
    y
}

/// One group's images `(first, n)` into `out`, on `threads` threads.
fn forward_group(
    g: &ConvGeometry,
    x: &[f32],
    weight: &[f32],
    epilogue: Epilogue,
    (first, n): (usize, usize),
    out: &mut [f32],
    threads: usize,
) {
    let (rows, cols) = (g.rows(), g.cols());
    let slice = match Tiles::of(g, n, threads) {
        Tiles::Rows(band) => {
            let image = &x[first * g.input_len()..(first + 1) * g.input_len()];
            return forward_bands(g, image, weight, epilogue, band, out);
        }
        Tiles::Channels(c) => c,
        Tiles::Whole => g.cout.max(1),
    };
    with_scratch(|s| {
        group_patches(g, x, first, n, s);
        let patches = MatRef::row_major(&s.patches[..rows * n * cols], rows, n * cols);
        let product = if n == 1 {
            &mut *out
        } else {
            sized(&mut s.product, g.cout * n * cols)
        };
        product
            .par_chunks_mut(slice * n * cols)
            .enumerate()
            .for_each(|(t, part)| {
                let c0 = t * slice;
                let c = part.len() / (n * cols).max(1);
                let w = MatRef::row_major(&weight[c0 * rows..(c0 + c) * rows], c, rows);
                matmul(part, w, patches, false, 1);
                if n == 1 {
                    epilogue.apply(part, c0, cols);
                }
            });
        if n > 1 {
            regroup(&s.product, out, g.cout, cols, n, true);
            epilogue.apply_images(out, g.cout, cols);
        }
    });
}

/// One image by bands of `band` output rows: each band's patches are converted, multiplied and
/// written (with the epilogue) into its own columns of `out` by one thread.
fn forward_bands(
    g: &ConvGeometry,
    image: &[f32],
    weight: &[f32],
    epilogue: Epilogue,
    band: usize,
    out: &mut [f32],
) {
    let (rows, [oh, ow]) = (g.rows(), g.output());
    let bands = oh.div_ceil(band);
    // Each band's slice of every output channel's plane, split off so the bands own them.
    let mut parts: Vec<Vec<&mut [f32]>> = (0..bands).map(|_| Vec::with_capacity(g.cout)).collect();
    for plane in out.chunks_exact_mut(g.cols().max(1)) {
        let mut rest = plane;
        for part in &mut parts {
            let (mine, tail) = rest.split_at_mut((band * ow).min(rest.len()));
            part.push(mine);
            rest = tail;
        }
    }
    let phased = Phased::of(g);
    // The reordered image is shared by the bands, so it lives outside their scratch.
    let mut buf = with_scratch(|s| std::mem::take(&mut s.phased));
    let image = phased_image(&phased, image, &mut buf);
    let w = MatRef::row_major(weight, g.cout, rows);
    parts
        .into_par_iter()
        .enumerate()
        .for_each(|(b, mut planes)| {
            let oys = b * band..((b + 1) * band).min(oh);
            let cols = oys.len() * ow;
            with_scratch(|s| {
                let patches = sized(&mut s.patches, rows * cols);
                im2col(g, &phased, image, patches, cols, oys);
                let product = sized(&mut s.product, g.cout * cols);
                matmul(product, w, MatRef::row_major(patches, rows, cols), false, 1);
                for (c, (plane, values)) in planes
                    .iter_mut()
                    .zip(product.chunks_exact(cols))
                    .enumerate()
                {
                    plane.copy_from_slice(values);
                    epilogue.apply(plane, c, cols);
                }
            });
        });
    with_scratch(|s| s.phased = buf);
}

/// The weight gradient `Σ_groups dy · colsᵀ`: `[cout, cin, kh, kw]`. Groups are split into one
/// run per thread, each summing into its own gradient; the runs are added at the end, always
/// in the same order.
pub fn backward_weight(g: &ConvGeometry, x: &[f32], dy: &[f32]) -> Vec<f32> {
    assert_eq!(x.len(), g.batch * g.input_len(), "input size");
    assert_eq!(dy.len(), g.batch * g.output_len(), "output gradient size");
    let (rows, cols) = (g.rows(), g.cols());
    let groups = Groups::of(g);
    let runs = rayon::current_num_threads().clamp(1, groups.count.max(1));
    let per_run = groups.count.div_ceil(runs);
    let partial = |run: usize| {
        let mut dw = vec![0.0; g.cout * rows];
        let (mut s, mut grads) = (Scratch::default(), Vec::new());
        for k in run * per_run..((run + 1) * per_run).min(groups.count) {
            let (first, n) = groups.images(g, k);
            group_patches(g, x, first, n, &mut s);
            let grad = &dy[first * g.output_len()..(first + n) * g.output_len()];
            grads.resize(g.cout * n * cols, 0.0);
            regroup(grad, &mut grads, g.cout, cols, n, false);
            matmul(
                &mut dw,
                MatRef::row_major(&grads, g.cout, n * cols),
                MatRef::row_major(&s.patches, rows, n * cols).t(),
                true,
                groups.gemm_threads,
            );
        }
        dw
    };
    (0..runs)
        .into_par_iter()
        .map(partial)
        .reduce_with(|mut a, b| {
            a.iter_mut().zip(&b).for_each(|(a, b)| *a += b);
            a
        })
        .unwrap_or_else(|| vec![0.0; g.cout * rows])
}

/// The input gradient: per group `wᵀ · dy`, folded back onto each image ([`col2im_add`]).
pub fn backward_input(g: &ConvGeometry, weight: &[f32], dy: &[f32]) -> Vec<f32> {
    assert_eq!(weight.len(), g.cout * g.rows(), "weight size");
    assert_eq!(dy.len(), g.batch * g.output_len(), "output gradient size");
    let (rows, cols) = (g.rows(), g.cols());
    let groups = Groups::of(g);
    let mut dx = vec![0.0; g.batch * g.input_len()];
    let wt = MatRef::row_major(weight, g.cout, rows).t();
    dx.par_chunks_mut((groups.size * g.input_len()).max(1))
        .enumerate()
        .for_each_init(
            || (Vec::new(), Vec::new(), Vec::new()),
            |(grads, patches, phased_grad), (k, images)| {
                let (first, n) = groups.images(g, k);
                let grad = &dy[first * g.output_len()..(first + n) * g.output_len()];
                grads.resize(g.cout * n * cols, 0.0);
                regroup(grad, grads, g.cout, cols, n, false);
                let grad = MatRef::row_major(grads, g.cout, n * cols);
                patches.resize(rows * n * cols, 0.0);
                matmul(patches, wt, grad, false, groups.gemm_threads);
                if g.is_pointwise() {
                    regroup(patches, images, rows, cols, n, true);
                } else {
                    let phased = Phased::of(g);
                    for (i, image) in images.chunks_exact_mut(g.input_len()).enumerate() {
                        let src = &patches[i * cols..];
                        if phased.reorders() {
                            phased_grad.clear();
                            phased_grad.resize(g.input_len(), 0.0);
                            col2im_add(g, &phased, src, n * cols, phased_grad);
                            phased.add_back(phased_grad, image);
                        } else {
                            col2im_add(g, &phased, src, n * cols, image);
                        }
                    }
                }
            },
        );
    dx
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The convolution straight from its definition.
    fn naive(g: &ConvGeometry, x: &[f32], w: &[f32]) -> Vec<f32> {
        let [h, wd] = g.input;
        let [oh, ow] = g.output();
        let [kh, kw] = g.kernel;
        let mut y = vec![0.0; g.batch * g.cout * oh * ow];
        for b in 0..g.batch {
            for co in 0..g.cout {
                for oy in 0..oh {
                    for ox in 0..ow {
                        let mut s = 0.0;
                        for ci in 0..g.cin {
                            for ky in 0..kh {
                                for kx in 0..kw {
                                    let iy =
                                        (oy * g.stride[0] + ky) as isize - g.padding[0] as isize;
                                    let ix =
                                        (ox * g.stride[1] + kx) as isize - g.padding[1] as isize;
                                    if iy < 0 || ix < 0 || iy >= h as isize || ix >= wd as isize {
                                        continue;
                                    }
                                    let xi =
                                        ((b * g.cin + ci) * h + iy as usize) * wd + ix as usize;
                                    s += x[xi] * w[((co * g.cin + ci) * kh + ky) * kw + kx];
                                }
                            }
                        }
                        y[((b * g.cout + co) * oh + oy) * ow + ox] = s;
                    }
                }
            }
        }
        y
    }

    fn values(n: usize, seed: f32) -> Vec<f32> {
        (0..n).map(|i| ((i as f32 + seed) * 0.618).sin()).collect()
    }

    fn geometries() -> Vec<ConvGeometry> {
        let g = |cin, input, cout, kernel, stride, padding| ConvGeometry {
            batch: 3,
            cin,
            input,
            cout,
            kernel,
            stride,
            padding,
        };
        vec![
            g(1, [9, 11], 4, [3, 3], [2, 2], [1, 1]),
            g(2, [8, 7], 3, [3, 3], [1, 1], [1, 1]),
            g(3, [10, 9], 2, [7, 7], [2, 2], [3, 3]),
            g(4, [6, 5], 5, [1, 1], [1, 1], [0, 0]),
            g(4, [7, 6], 5, [1, 1], [2, 2], [0, 0]),
            g(2, [5, 6], 3, [3, 2], [1, 2], [0, 1]),
            // 272 output pixels: a product per image.
            g(1, [16, 17], 2, [3, 3], [1, 1], [1, 1]),
            // 144 output pixels: groups of two images, the last one alone.
            g(2, [12, 12], 3, [3, 3], [1, 1], [1, 1]),
            // More channels than output pixels, stride 3: one image is cut by channels.
            g(3, [7, 8], 40, [3, 3], [3, 3], [1, 1]),
        ]
    }

    #[test]
    fn forward_matches_the_definition() {
        for g in geometries() {
            let x = values(g.batch * g.input_len(), 0.5);
            let w = values(g.cout * g.rows(), 3.0);
            let (got, want) = (forward(&g, &x, &w, Epilogue::default()), naive(&g, &x, &w));
            assert_eq!(got.len(), want.len(), "{g:?}");
            for (a, b) in got.iter().zip(&want) {
                assert!((a - b).abs() < 1e-4, "{g:?}: {a} vs {b}");
            }
        }
    }

    /// One image on several threads takes the band and channel tilings; the bias and ReLU
    /// are applied to every value.
    #[test]
    fn single_images_on_many_threads_match_the_definition_with_bias_and_relu() {
        for threads in [2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for g in geometries() {
                let g = ConvGeometry { batch: 1, ..g };
                let x = values(g.input_len(), 0.5);
                let w = values(g.cout * g.rows(), 3.0);
                let bias = values(g.cout, 9.0);
                let relu = g.cout % 2 == 1;
                let epilogue = Epilogue {
                    bias: Some(&bias),
                    relu,
                };
                let got = pool.install(|| forward(&g, &x, &w, epilogue));
                let plane = g.cols();
                for (i, (a, b)) in got.iter().zip(naive(&g, &x, &w)).enumerate() {
                    let b = b + bias[i / plane];
                    let b = if relu { b.max(0.0) } else { b };
                    assert!((a - b).abs() < 1e-4, "{g:?} on {threads}: {a} vs {b}");
                }
            }
        }
    }

    /// The convolution is linear in each argument, so each gradient element is the output
    /// gradient's inner product with the convolution of a unit tensor in that element's place.
    #[test]
    fn gradients_match_the_definition_element_by_element() {
        let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f32>();
        let unit = |n: usize, i: usize| (0..n).map(|j| f32::from(i == j)).collect::<Vec<_>>();
        for g in geometries() {
            let x = values(g.batch * g.input_len(), 0.5);
            let w = values(g.cout * g.rows(), 3.0);
            let dy = values(g.batch * g.output_len(), 7.0);
            for (j, got) in backward_weight(&g, &x, &dy).iter().enumerate() {
                let want = dot(&dy, &naive(&g, &x, &unit(w.len(), j)));
                assert!(
                    (got - want).abs() < 1e-3,
                    "{g:?} weight {j}: {got} vs {want}"
                );
            }
            for (i, got) in backward_input(&g, &w, &dy).iter().enumerate() {
                let want = dot(&dy, &naive(&g, &unit(x.len(), i), &w));
                assert!(
                    (got - want).abs() < 1e-3,
                    "{g:?} input {i}: {got} vs {want}"
                );
            }
        }
    }
}
