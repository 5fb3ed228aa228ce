//! The camera's post-processing, applied to a rendered frame in this order by
//! [`super::Camera`]: depth of field, lens distortion, bloom, shot noise. Each effect counts its
//! work units.

use super::{Image, ACCEPTABLE_COC, APERTURE, DOF_SAMPLES, FOCAL, FOCUS, HEIGHT, K1, NOISE, WIDTH};
use crate::settings::BloomLevel;
use rand::Rng;
use rand_distr::{Distribution, Normal};

/// Photon noise: one draw per pixel, growing with the square root of its brightness.
///
/// The draws first (in pixel order, one per pixel: the generator's sequence as before), each
/// written for the pixel's three channels; then the channels as one flat array, which the
/// compiler vectorises (the same operations on each value: the same image bit for bit).
/// `noise` is a buffer to reuse (its contents are overwritten).
pub(super) fn shot_noise<R: Rng + ?Sized>(
    pixels: &mut [[f32; 3]],
    rng: &mut R,
    noise: &mut Vec<[f32; 3]>,
    work: &mut u64,
) {
    let table = noise_table();
    noise.clear();
    noise.extend(
        (0..pixels.len()).map(|_| [table[(rng.next_u32() >> (32 - NOISE_TABLE_BITS)) as usize]; 3]),
    );
    for (c, z) in pixels
        .as_flattened_mut()
        .iter_mut()
        .zip(noise.as_flattened())
    {
        *c += z * (0.25 + c.max(0.0)).sqrt();
    }
    *work += pixels.len() as u64;
}

/// A bilinear tap: the top-left pixel index of the 2×2 block around it and the weights.
#[derive(Debug, Clone, Copy)]
struct Tap {
    index: usize,
    fu: f32,
    fv: f32,
}

impl Tap {
    /// The tap at pixel coordinates (u, v) (pixel centres at integers), clamped to the image.
    #[inline]
    fn at(u: f32, v: f32) -> Tap {
        let u = u.clamp(0.0, (WIDTH - 1) as f32);
        let v = v.clamp(0.0, (HEIGHT - 1) as f32);
        // The 2×2 block always lies inside the image: at the last column or row the weight of
        // the block's far side is 1.
        let u0 = (u as i32).min(WIDTH as i32 - 2);
        let v0 = (v as i32).min(HEIGHT as i32 - 2);
        Tap {
            index: v0 as usize * WIDTH + u0 as usize,
            fu: u - u0 as f32,
            fv: v - v0 as f32,
        }
    }

    #[inline]
    fn read(self, img: &[[f32; 3]]) -> [f32; 3] {
        let i = self.index;
        let (a, b) = (img[i], img[i + 1]);
        let (c, d) = (img[i + WIDTH], img[i + WIDTH + 1]);
        let mut out = [0.0; 3];
        for k in 0..3 {
            let top = a[k] + (b[k] - a[k]) * self.fu;
            let bottom = c[k] + (d[k] - c[k]) * self.fu;
            out[k] = top + (bottom - top) * self.fv;
        }
        out
    }
}

/// log2 of the size of the shot-noise table.
const NOISE_TABLE_BITS: u32 = 12;

/// Gaussian shot noise (standard deviation [`NOISE`]) as a table of 4,096 draws made once with a
/// fixed seed: a pixel's noise is one uniformly chosen entry, a cheap exact draw from that
/// empirical distribution.
fn noise_table() -> &'static [f32] {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        use rand::SeedableRng;
        let n = Normal::new(0.0f32, NOISE).expect("valid noise");
        let mut rng = rand_pcg::Pcg64::seed_from_u64(0x5eed);
        (0..1usize << NOISE_TABLE_BITS)
            .map(|_| n.sample(&mut rng))
            .collect()
    })
}

/// Applies the barrel distortion of the lens: every output pixel samples the pinhole image
/// where the lens maps it from.
pub(super) fn distort(src: &[[f32; 3]], out: &mut Vec<[f32; 3]>, work: &mut u64) {
    // Where each output pixel samples the pinhole image: distorted normalised coordinates
    // undistorted by fixed-point iteration, computed once.
    static MAP: std::sync::OnceLock<Vec<Tap>> = std::sync::OnceLock::new();
    let map = MAP.get_or_init(|| {
        (0..WIDTH * HEIGHT)
            .map(|i| {
                let (u, v) = (i % WIDTH, i / WIDTH);
                let xd = (u as f32 + 0.5 - WIDTH as f32 / 2.0) / FOCAL;
                let yd = (v as f32 + 0.5 - HEIGHT as f32 / 2.0) / FOCAL;
                let (mut x, mut y) = (xd, yd);
                for _ in 0..4 {
                    let s = 1.0 + K1 * (x * x + y * y);
                    x = xd / s;
                    y = yd / s;
                }
                Tap::at(
                    WIDTH as f32 / 2.0 + FOCAL * x - 0.5,
                    HEIGHT as f32 / 2.0 + FOCAL * y - 0.5,
                )
            })
            .collect()
    });
    *work += map.len() as u64;
    out.clear();
    out.extend(map.iter().map(|t| t.read(src)));
}

/// Depth of field with a thin lens of radius [`APERTURE`] focused at [`FOCUS`]: each pixel
/// averages [`DOF_SAMPLES`] samples of the sharp image, one per aperture point, each displaced
/// by the parallax that aperture point gives a surface at the pixel's depth
/// (`FOCAL · a · (1/depth − 1/FOCUS)` pixels, zero in the focal plane). This is the gather form
/// of rendering the scene once per aperture point, as real-time engines do it. Pixels whose
/// parallax is below [`ACCEPTABLE_COC`] are in focus and copied.
pub(super) fn depth_of_field(
    src: &[[f32; 3]],
    depth: &[f32],
    out: &mut Vec<[f32; 3]>,
    work: &mut u64,
) {
    let offsets: [(f32, f32); DOF_SAMPLES] = std::array::from_fn(|k| {
        let a = k as f32 * std::f32::consts::TAU / DOF_SAMPLES as f32 + 0.4;
        (FOCAL * APERTURE * a.cos(), FOCAL * APERTURE * a.sin())
    });
    out.clear();
    out.extend_from_slice(src);
    // Beyond the focus the parallax never exceeds FOCAL · APERTURE / FOCUS (0.13 px), below the
    // acceptable circle; in front of it, surfaces nearer than this are out of focus.
    let near_limit = 1.0 / (1.0 / FOCUS + ACCEPTABLE_COC / (FOCAL * APERTURE));
    const { assert!(FOCAL * APERTURE / FOCUS < ACCEPTABLE_COC) };
    let third = 1.0 / DOF_SAMPLES as f32;
    // The taps of a depth, relative to the pixel: whole-pixel offset and bilinear weights.
    // Consecutive pixels often share a depth (a ground row has one), so they are reused.
    let taps_of = |z: f32| {
        let blur = 1.0 / z - 1.0 / FOCUS;
        offsets.map(|(du, dv)| {
            let (x, y) = (du * blur, dv * blur);
            let (x0, y0) = (x.floor(), y.floor());
            (x0 as isize, y0 as isize, x - x0, y - y0)
        })
    };
    let mut cached = (f32::NAN, taps_of(1.0));
    for (v, (row_depth, row_out)) in depth
        .chunks_exact(WIDTH)
        .zip(out.chunks_exact_mut(WIDTH))
        .enumerate()
    {
        let mut u = 0;
        while u < WIDTH {
            let z = row_depth[u];
            if z >= near_limit {
                u += 1;
                continue; // in focus: the sharp pixel
            }
            // A run of pixels at this depth (a ground row is one): they share their taps.
            let end = u + 1 + row_depth[u + 1..].iter().take_while(|&&d| d == z).count();
            if z != cached.0 {
                cached = (z, taps_of(z));
            }
            let taps = &cached.1;
            *work += (DOF_SAMPLES * (end - u)) as u64;
            // Where every tap's 2×2 block lies inside the image: the whole span at once.
            let (lo, hi) = interior(taps, v, u, end);
            for x in (u..lo).chain(hi.max(lo)..end) {
                row_out[x] = blurred_pixel(src, taps, x, v, third);
            }
            if lo < hi {
                blurred_span(src, taps, &mut row_out[lo..hi], lo, v, third);
            }
            u = end;
        }
    }
    *work += depth.len() as u64;
}

/// A depth-of-field tap relative to a pixel: whole-pixel offset and bilinear weights.
type DofTap = (isize, isize, f32, f32);

/// The pixels of `u..end` in row `v` whose taps all read 2×2 blocks inside the image
/// (`lo..hi`, empty when none).
fn interior(taps: &[DofTap], v: usize, u: usize, end: usize) -> (usize, usize) {
    let (mut lo, mut hi) = (u as isize, end as isize);
    for &(dx, dy, _, _) in taps {
        let y = v as isize + dy;
        if y < 0 || y >= HEIGHT as isize - 1 {
            return (u, u);
        }
        lo = lo.max(-dx);
        hi = hi.min(WIDTH as isize - 1 - dx);
    }
    if lo >= hi {
        return (u, u);
    }
    (lo as usize, hi as usize)
}

/// One blurred pixel: the mean of its taps (each clamped to the image).
#[inline]
fn blurred_pixel(src: &[[f32; 3]], taps: &[DofTap], u: usize, v: usize, third: f32) -> [f32; 3] {
    let mut acc = [0.0f32; 3];
    for &(dx, dy, fu, fv) in taps {
        let (x, y) = (u as isize + dx, v as isize + dy);
        let tap = if x >= 0 && y >= 0 && x < WIDTH as isize - 1 && y < HEIGHT as isize - 1 {
            Tap {
                index: y as usize * WIDTH + x as usize,
                fu,
                fv,
            }
        } else {
            Tap::at(x as f32 + fu, y as f32 + fv)
        };
        let p = tap.read(src);
        for k in 0..3 {
            acc[k] += p[k];
        }
    }
    acc.map(|a| a * third)
}

/// [`blurred_pixel`] for the span of row `v` starting at column `lo` that `out` covers, every
/// tap inside the image: the same operations per channel, over the span's channels as one
/// array (a pixel's right neighbour is three floats on), which the compiler vectorises.
fn blurred_span(
    src: &[[f32; 3]],
    taps: &[DofTap],
    out: &mut [[f32; 3]],
    lo: usize,
    v: usize,
    third: f32,
) {
    let out = out.as_flattened_mut();
    let n = out.len();
    out.fill(0.0);
    let src = src.as_flattened();
    for &(dx, dy, fu, fv) in taps {
        let index = 3 * ((v as isize + dy) as usize * WIDTH + (lo as isize + dx) as usize);
        let top = &src[index..index + n + 3];
        let bottom = &src[index + 3 * WIDTH..index + 3 * WIDTH + n + 3];
        for ((o, (a, b)), (c, d)) in out
            .iter_mut()
            .zip(top.iter().zip(&top[3..]))
            .zip(bottom.iter().zip(&bottom[3..]))
        {
            let upper = a + (b - a) * fu;
            let lower = c + (d - c) * fu;
            *o += upper + (lower - upper) * fv;
        }
    }
    for o in out {
        *o *= third;
    }
}

/// Bloom: bright pixels glow into their neighbours. The glow pass is a box blur of the bright
/// pass (running sums, separable): at full resolution with a 9-pixel box for the high level, at
/// half resolution with a 5-pixel box for the low one.
pub(super) fn bloom(
    img: &mut Image,
    level: BloomLevel,
    buffers: &mut [Vec<[f32; 3]>; 2],
    work: &mut u64,
) {
    let (scale, radius) = match level {
        BloomLevel::High => (1, 4),
        BloomLevel::Low => (2, 2),
    };
    let blur = BoxBlur {
        w: WIDTH / scale,
        h: HEIGHT / scale,
        radius,
        norm: 1.0 / (2 * radius + 1) as f32,
    };
    let [bright, across] = buffers;
    bright_pass(img, scale, bright, work);
    blur.across_rows(bright, across, work);
    blur.down_columns(across, bright, work);
    let glow = bright;
    let w = blur.w;
    // Each glow pixel brightens a `scale` × `scale` block of the image.
    if scale == 1 {
        let pixels = img.pixels.as_flattened_mut();
        for (p, g) in pixels.iter_mut().zip(glow.as_flattened()) {
            *p += 1.5 * g;
        }
        return;
    }
    for (v, row) in img.pixels.chunks_exact_mut(WIDTH).enumerate() {
        let glow_row = &glow[(v / scale) * w..(v / scale + 1) * w];
        for (block, g) in row.chunks_exact_mut(scale).zip(glow_row) {
            for p in block {
                for c in 0..3 {
                    p[c] += 1.5 * g[c];
                }
            }
        }
    }
}

/// The bright pass of the bloom into `bright`: the part of each pixel's colour above the
/// luminance threshold, averaged over `scale` × `scale` blocks.
#[inline]
fn bright_pass(img: &Image, scale: usize, bright: &mut Vec<[f32; 3]>, work: &mut u64) {
    let (w, h) = (WIDTH / scale, HEIGHT / scale);
    bright.clear();
    if scale == 1 {
        // The same operations per channel, in two passes the compiler vectorises: each
        // pixel's luminance, then every channel's share above the threshold.
        let luminance = |p: &[f32; 3]| 0.3 * p[0] + 0.59 * p[1] + 0.11 * p[2];
        bright.extend(img.pixels.iter().map(|p| [luminance(p); 3]));
        for (b, &c) in bright
            .as_flattened_mut()
            .iter_mut()
            .zip(img.pixels.as_flattened())
        {
            let l = *b;
            let share = if l > 0.62 {
                0.0 + c * (l - 0.62) / l
            } else {
                0.0
            };
            *b = share / 1.0;
        }
        *work += (WIDTH * HEIGHT) as u64;
        return;
    }
    bright.resize(w * h, [0.0; 3]);
    for y in 0..h {
        for x in 0..w {
            let mut acc = [0.0f32; 3];
            for dy in 0..scale {
                for dx in 0..scale {
                    let p = img.pixels[(y * scale + dy) * WIDTH + x * scale + dx];
                    let l = 0.3 * p[0] + 0.59 * p[1] + 0.11 * p[2];
                    if l > 0.62 {
                        for c in 0..3 {
                            acc[c] += p[c] * (l - 0.62) / l;
                        }
                    }
                }
            }
            bright[y * w + x] = acc.map(|a| a / (scale * scale) as f32);
        }
    }
    *work += (WIDTH * HEIGHT) as u64;
}

/// A box blur of a `w` × `h` image with a box of `2 · radius + 1` pixels (`norm` is one over
/// that), in two running-sum passes: along each row, then down the columns (row by row, with
/// one running sum per column, so that memory is read in order).
struct BoxBlur {
    w: usize,
    h: usize,
    radius: usize,
    norm: f32,
}

impl BoxBlur {
    /// The pass along each row (in groups of [`ROWS`] rows, whose running sums are independent:
    /// one row's chain of additions would leave the processor waiting on each).
    #[inline]
    fn across_rows(&self, src: &[[f32; 3]], out: &mut Vec<[f32; 3]>, work: &mut u64) {
        const ROWS: usize = 4;
        let (w, radius, norm) = (self.w, self.radius, self.norm);
        out.clear();
        out.resize(src.len(), [0.0; 3]);
        let mut groups = src
            .chunks_exact(w * ROWS)
            .zip(out.chunks_exact_mut(w * ROWS));
        for (rows, o) in groups.by_ref() {
            let mut acc = [[0.0f32; 3]; ROWS];
            for k in 0..radius.min(w) {
                for (r, a) in acc.iter_mut().enumerate() {
                    for c in 0..3 {
                        a[c] += rows[r * w + k][c];
                    }
                }
            }
            for k in 0..w {
                for (r, a) in acc.iter_mut().enumerate() {
                    let row = &rows[r * w..(r + 1) * w];
                    if k + radius < w {
                        for c in 0..3 {
                            a[c] += row[k + radius][c];
                        }
                    }
                    if k > radius {
                        for c in 0..3 {
                            a[c] -= row[k - radius - 1][c];
                        }
                    }
                    o[r * w + k] = a.map(|x| x * norm);
                }
            }
        }
        let rest = src.len() / (w * ROWS) * (w * ROWS);
        for (row, o) in src[rest..]
            .chunks_exact(w)
            .zip(out[rest..].chunks_exact_mut(w))
        {
            let mut acc = [0.0f32; 3];
            for p in &row[..radius.min(w)] {
                for c in 0..3 {
                    acc[c] += p[c];
                }
            }
            for k in 0..w {
                if k + radius < w {
                    for c in 0..3 {
                        acc[c] += row[k + radius][c];
                    }
                }
                if k > radius {
                    for c in 0..3 {
                        acc[c] -= row[k - radius - 1][c];
                    }
                }
                o[k] = acc.map(|a| a * norm);
            }
        }
        *work += src.len() as u64;
    }

    /// The pass down the columns.
    #[inline]
    fn down_columns(&self, src: &[[f32; 3]], out: &mut Vec<[f32; 3]>, work: &mut u64) {
        let (w, h, radius, norm) = (self.w, self.h, self.radius, self.norm);
        out.clear();
        out.resize(src.len(), [0.0; 3]);
        *work += src.len() as u64;
        // One running sum per column and channel, over rows of 3·w floats (vectorised).
        let (src, out) = (src.as_flattened(), out.as_flattened_mut());
        let row = |k: usize| &src[k * 3 * w..(k + 1) * 3 * w];
        let mut acc = vec![0.0f32; 3 * w];
        for k in 0..radius.min(h) {
            for (a, p) in acc.iter_mut().zip(row(k)) {
                *a += p;
            }
        }
        for (k, o) in out.chunks_exact_mut(3 * w).enumerate() {
            if k + radius < h {
                for (a, p) in acc.iter_mut().zip(row(k + radius)) {
                    *a += p;
                }
            }
            if k > radius {
                for (a, p) in acc.iter_mut().zip(row(k - radius - 1)) {
                    *a -= p;
                }
            }
            for (o, a) in o.iter_mut().zip(&acc) {
                *o = a * norm;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! The rewritten passes against the code they replaced (commit 9b3ca2f, kept here
    //! verbatim as `reference`): the same pixels bit for bit, and the same work, on random
    //! frames whose depth comes in runs (as a ground row's) with pixels near every border.
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[allow(clippy::needless_range_loop)]
    mod reference {
        use super::super::{
            Image, Tap, ACCEPTABLE_COC, APERTURE, DOF_SAMPLES, FOCAL, FOCUS, HEIGHT, WIDTH,
        };
        use crate::settings::BloomLevel;

        pub(super) fn depth_of_field(
            src: &[[f32; 3]],
            depth: &[f32],
            out: &mut Vec<[f32; 3]>,
            work: &mut u64,
        ) {
            let offsets: [(f32, f32); DOF_SAMPLES] = std::array::from_fn(|k| {
                let a = k as f32 * std::f32::consts::TAU / DOF_SAMPLES as f32 + 0.4;
                (FOCAL * APERTURE * a.cos(), FOCAL * APERTURE * a.sin())
            });
            out.clear();
            out.extend_from_slice(src);
            // Beyond the focus the parallax never exceeds FOCAL · APERTURE / FOCUS (0.13 px), below the
            // acceptable circle; in front of it, surfaces nearer than this are out of focus.
            let near_limit = 1.0 / (1.0 / FOCUS + ACCEPTABLE_COC / (FOCAL * APERTURE));
            const { assert!(FOCAL * APERTURE / FOCUS < ACCEPTABLE_COC) };
            let third = 1.0 / DOF_SAMPLES as f32;
            // The taps of a depth, relative to the pixel: whole-pixel offset and bilinear weights.
            // Consecutive pixels often share a depth (a ground row has one), so they are reused.
            let taps_of = |z: f32| {
                let blur = 1.0 / z - 1.0 / FOCUS;
                offsets.map(|(du, dv)| {
                    let (x, y) = (du * blur, dv * blur);
                    let (x0, y0) = (x.floor(), y.floor());
                    (x0 as isize, y0 as isize, x - x0, y - y0)
                })
            };
            let mut cached = (f32::NAN, taps_of(1.0));
            for (v, (row_depth, row_out)) in depth
                .chunks_exact(WIDTH)
                .zip(out.chunks_exact_mut(WIDTH))
                .enumerate()
            {
                for (u, (&z, o)) in row_depth.iter().zip(row_out).enumerate() {
                    if z >= near_limit {
                        continue; // in focus: the sharp pixel
                    }
                    if z != cached.0 {
                        cached = (z, taps_of(z));
                    }
                    *work += DOF_SAMPLES as u64;
                    let mut acc = [0.0f32; 3];
                    for &(dx, dy, fu, fv) in &cached.1 {
                        let (x, y) = (u as isize + dx, v as isize + dy);
                        let tap = if x >= 0
                            && y >= 0
                            && x < WIDTH as isize - 1
                            && y < HEIGHT as isize - 1
                        {
                            Tap {
                                index: y as usize * WIDTH + x as usize,
                                fu,
                                fv,
                            }
                        } else {
                            Tap::at(x as f32 + fu, y as f32 + fv)
                        };
                        let p = tap.read(src);
                        for k in 0..3 {
                            acc[k] += p[k];
                        }
                    }
                    *o = acc.map(|a| a * third);
                }
            }
            *work += depth.len() as u64;
        }

        pub(super) fn bloom(
            img: &mut Image,
            level: BloomLevel,
            buffers: &mut [Vec<[f32; 3]>; 2],
            work: &mut u64,
        ) {
            let (scale, radius) = match level {
                BloomLevel::High => (1, 4),
                BloomLevel::Low => (2, 2),
            };
            let blur = BoxBlur {
                w: WIDTH / scale,
                h: HEIGHT / scale,
                radius,
                norm: 1.0 / (2 * radius + 1) as f32,
            };
            let [bright, across] = buffers;
            bright_pass(img, scale, bright, work);
            blur.across_rows(bright, across, work);
            blur.down_columns(across, bright, work);
            let glow = bright;
            let w = blur.w;
            for (i, p) in img.pixels.iter_mut().enumerate() {
                let g = glow[(i / WIDTH / scale) * w + (i % WIDTH) / scale];
                for c in 0..3 {
                    p[c] += 1.5 * g[c];
                }
            }
        }

        fn bright_pass(img: &Image, scale: usize, bright: &mut Vec<[f32; 3]>, work: &mut u64) {
            let (w, h) = (WIDTH / scale, HEIGHT / scale);
            bright.clear();
            bright.resize(w * h, [0.0; 3]);
            for y in 0..h {
                for x in 0..w {
                    let mut acc = [0.0f32; 3];
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let p = img.pixels[(y * scale + dy) * WIDTH + x * scale + dx];
                            let l = 0.3 * p[0] + 0.59 * p[1] + 0.11 * p[2];
                            if l > 0.62 {
                                for c in 0..3 {
                                    acc[c] += p[c] * (l - 0.62) / l;
                                }
                            }
                        }
                    }
                    bright[y * w + x] = acc.map(|a| a / (scale * scale) as f32);
                }
            }
            *work += (WIDTH * HEIGHT) as u64;
        }

        struct BoxBlur {
            w: usize,
            h: usize,
            radius: usize,
            norm: f32,
        }

        impl BoxBlur {
            /// The pass along each row.
            #[inline]
            fn across_rows(&self, src: &[[f32; 3]], out: &mut Vec<[f32; 3]>, work: &mut u64) {
                let (w, radius, norm) = (self.w, self.radius, self.norm);
                out.clear();
                out.resize(src.len(), [0.0; 3]);
                for (row, o) in src.chunks_exact(w).zip(out.chunks_exact_mut(w)) {
                    let mut acc = [0.0f32; 3];
                    for p in &row[..radius.min(w)] {
                        for c in 0..3 {
                            acc[c] += p[c];
                        }
                    }
                    for k in 0..w {
                        if k + radius < w {
                            for c in 0..3 {
                                acc[c] += row[k + radius][c];
                            }
                        }
                        if k > radius {
                            for c in 0..3 {
                                acc[c] -= row[k - radius - 1][c];
                            }
                        }
                        o[k] = acc.map(|a| a * norm);
                    }
                }
                *work += src.len() as u64;
            }

            /// The pass down the columns.
            #[inline]
            fn down_columns(&self, src: &[[f32; 3]], out: &mut Vec<[f32; 3]>, work: &mut u64) {
                let (w, h, radius, norm) = (self.w, self.h, self.radius, self.norm);
                out.clear();
                out.resize(src.len(), [0.0; 3]);
                let mut acc = vec![[0.0f32; 3]; w];
                for row in src.chunks_exact(w).take(radius.min(h)) {
                    for (a, p) in acc.iter_mut().zip(row) {
                        for c in 0..3 {
                            a[c] += p[c];
                        }
                    }
                }
                for k in 0..h {
                    if k + radius < h {
                        for (a, p) in acc
                            .iter_mut()
                            .zip(&src[(k + radius) * w..(k + radius + 1) * w])
                        {
                            for c in 0..3 {
                                a[c] += p[c];
                            }
                        }
                    }
                    if k > radius {
                        let gone = k - radius - 1;
                        for (a, p) in acc.iter_mut().zip(&src[gone * w..(gone + 1) * w]) {
                            for c in 0..3 {
                                a[c] -= p[c];
                            }
                        }
                    }
                    for (o, a) in out[k * w..(k + 1) * w].iter_mut().zip(&acc) {
                        *o = a.map(|x| x * norm);
                    }
                }
                *work += src.len() as u64;
            }
        }
    }

    /// A random frame: colours in [0, 1.5) (bloom's threshold is crossed), depths in runs of
    /// 1–40 pixels, from 0.2 m (far out of focus: taps off the image) to beyond the focus and
    /// the sky's infinity.
    fn frame(rng: &mut rand_pcg::Pcg64) -> (Vec<[f32; 3]>, Vec<f32>) {
        let pixels = (0..WIDTH * HEIGHT)
            .map(|_| [(); 3].map(|_| rng.random_range(0.0f32..1.5)))
            .collect();
        let mut depth = Vec::with_capacity(WIDTH * HEIGHT);
        while depth.len() < WIDTH * HEIGHT {
            let z = match rng.random_range(0..4) {
                0 => f32::INFINITY,
                1 => rng.random_range(7.0f32..100.0),
                _ => rng.random_range(0.2f32..7.0),
            };
            let run = rng
                .random_range(1..=40usize)
                .min(WIDTH * HEIGHT - depth.len());
            depth.extend(std::iter::repeat_n(z, run));
        }
        (pixels, depth)
    }

    fn bits(pixels: &[[f32; 3]]) -> Vec<u32> {
        pixels.as_flattened().iter().map(|c| c.to_bits()).collect()
    }

    #[test]
    fn depth_of_field_gives_the_pixels_and_work_of_the_per_pixel_gather() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(39);
        for _ in 0..60 {
            let (src, depth) = frame(&mut rng);
            let (mut out, mut expected) = (Vec::new(), Vec::new());
            let (mut work, mut expected_work) = (0, 0);
            depth_of_field(&src, &depth, &mut out, &mut work);
            reference::depth_of_field(&src, &depth, &mut expected, &mut expected_work);
            assert_eq!(bits(&out), bits(&expected));
            assert_eq!(work, expected_work);
        }
    }

    #[test]
    fn bloom_gives_the_pixels_and_work_of_the_per_pixel_passes() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(39);
        for level in [BloomLevel::High, BloomLevel::Low] {
            for _ in 0..30 {
                let (pixels, _) = frame(&mut rng);
                let mut image = Image { pixels };
                let mut expected = image.clone();
                let (mut work, mut expected_work) = (0, 0);
                bloom(&mut image, level, &mut Default::default(), &mut work);
                reference::bloom(
                    &mut expected,
                    level,
                    &mut Default::default(),
                    &mut expected_work,
                );
                assert_eq!(bits(&image.pixels), bits(&expected.pixels));
                assert_eq!(work, expected_work);
            }
        }
    }
}
