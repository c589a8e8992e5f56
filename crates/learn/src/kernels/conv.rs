//! 2-D convolution (groups 1, dilation 1) and both of its gradients by im2col and one matrix
//! product per group of images (one image where an image has enough output pixels, more side
//! by side in deep layers, see [`GROUP_COLUMNS`]), groups in parallel.
//!
//! Written by hand because burn-flex 0.22 differentiates a convolution through generic ops: the
//! input gradient as a transposed convolution and the weight gradient as a convolution whose
//! batch is the input channels and whose kernel is the whole output gradient (one image wide
//! for a one-channel input, so it runs on one thread). On the small network at batch 32 that
//! made the backward pass 3-4x PyTorch's.

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

/// Fills the patches of one image into `dst`: patch row `r` (one input channel and kernel
/// offset) is the `oh * ow` values starting at `dst[r * row_stride]`, so the patches of several
/// images can sit side by side in one column matrix.
fn im2col(g: &ConvGeometry, image: &[f32], dst: &mut [f32], row_stride: usize) {
    let [h, w] = g.input;
    let [oh, ow] = g.output();
    let [kh, kw] = g.kernel;
    let [sh, sw] = g.stride;
    let [ph, pw] = g.padding;
    for row in 0..g.rows() {
        let out = &mut dst[row * row_stride..][..oh * ow];
        let (ci, ky, kx) = (row / (kh * kw), row / kw % kh, row % kw);
        let plane = &image[ci * h * w..(ci + 1) * h * w];
        let (y0, y1) = g.valid(0, ky);
        let (x0, x1) = g.valid(1, kx);
        for (oy, out_row) in out.chunks_exact_mut(ow).enumerate() {
            if oy < y0 || oy >= y1 {
                out_row.fill(0.0);
                continue;
            }
            out_row[..x0].fill(0.0);
            out_row[x1..].fill(0.0);
            let src = &plane[(oy * sh + ky - ph) * w..][..w];
            let first = x0 * sw + kx - pw;
            if sw == 1 {
                out_row[x0..x1].copy_from_slice(&src[first..first + (x1 - x0)]);
            } else {
                for (o, v) in out_row[x0..x1]
                    .iter_mut()
                    .zip(src[first..].iter().step_by(sw))
                {
                    *o = *v;
                }
            }
        }
    }
}

/// Adds the patches laid out as [`im2col`] writes them back onto one image's gradient (its
/// adjoint).
fn col2im_add(g: &ConvGeometry, src: &[f32], row_stride: usize, image: &mut [f32]) {
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
        for oy in y0..y1 {
            let dst = &mut plane[(oy * sh + ky - ph) * w..][..w];
            let first = x0 * sw + kx - pw;
            let src_row = &cols[oy * ow + x0..oy * ow + x1];
            for (d, v) in dst[first..].iter_mut().step_by(sw).zip(src_row) {
                *d += *v;
            }
        }
    }
}

/// The column matrix `[rows, n * cols]` of images `[first, first + n)` of the batch `x` (for a
/// pointwise convolution, the images themselves side by side).
fn group_patches(g: &ConvGeometry, x: &[f32], first: usize, n: usize, buf: &mut Vec<f32>) {
    let (rows, cols) = (g.rows(), g.cols());
    buf.resize(rows * n * cols, 0.0);
    let images = &x[first * g.input_len()..(first + n) * g.input_len()];
    if g.is_pointwise() {
        regroup(images, buf, rows, cols, n, false);
        return;
    }
    for (i, image) in images.chunks_exact(g.input_len()).enumerate() {
        im2col(g, image, &mut buf[i * cols..], n * cols);
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

/// The convolution `y = w * x` (no bias): `[batch, cout, oh, ow]`, row-major.
pub fn forward(g: &ConvGeometry, x: &[f32], weight: &[f32]) -> Vec<f32> {
    assert_eq!(x.len(), g.batch * g.input_len(), "input size");
    assert_eq!(weight.len(), g.cout * g.rows(), "weight size");
    let (rows, cols) = (g.rows(), g.cols());
    let groups = Groups::of(g);
    let mut y = vec![0.0; g.batch * g.output_len()];
    let w = MatRef::row_major(weight, g.cout, rows);
    y.par_chunks_mut((groups.size * g.output_len()).max(1))
        .enumerate()
        .for_each_init(
            || (Vec::new(), Vec::new()),
            |(patches, product), (k, out)| {
                let (first, n) = groups.images(g, k);
                group_patches(g, x, first, n, patches);
                let p = MatRef::row_major(patches, rows, n * cols);
                if n == 1 {
                    matmul(out, w, p, false, groups.gemm_threads);
                } else {
                    product.resize(g.cout * n * cols, 0.0);
                    matmul(product, w, p, false, groups.gemm_threads);
                    regroup(product, out, g.cout, cols, n, true);
                }
            },
        );
    y
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
        let (mut patches, mut grads) = (Vec::new(), Vec::new());
        for k in run * per_run..((run + 1) * per_run).min(groups.count) {
            let (first, n) = groups.images(g, k);
            group_patches(g, x, first, n, &mut patches);
            let grad = &dy[first * g.output_len()..(first + n) * g.output_len()];
            grads.resize(g.cout * n * cols, 0.0);
            regroup(grad, &mut grads, g.cout, cols, n, false);
            matmul(
                &mut dw,
                MatRef::row_major(&grads, g.cout, n * cols),
                MatRef::row_major(&patches, rows, n * cols).t(),
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
            || (Vec::new(), Vec::new()),
            |(grads, patches), (k, images)| {
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
                    for (i, image) in images.chunks_exact_mut(g.input_len()).enumerate() {
                        col2im_add(g, &patches[i * cols..], n * cols, image);
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
        ]
    }

    #[test]
    fn forward_matches_the_definition() {
        for g in geometries() {
            let x = values(g.batch * g.input_len(), 0.5);
            let w = values(g.cout * g.rows(), 3.0);
            let (got, want) = (forward(&g, &x, &w), naive(&g, &x, &w));
            assert_eq!(got.len(), want.len(), "{g:?}");
            for (a, b) in got.iter().zip(&want) {
                assert!((a - b).abs() < 1e-4, "{g:?}: {a} vs {b}");
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
