//! The camera's post-processing, applied to a rendered frame in this order by
//! [`super::Camera`]: depth of field, lens distortion, bloom, shot noise. Each effect counts its
//! work units.

use super::{Image, ACCEPTABLE_COC, APERTURE, DOF_SAMPLES, FOCAL, FOCUS, HEIGHT, K1, NOISE, WIDTH};
use crate::settings::BloomLevel;
use rand::Rng;
use rand_distr::{Distribution, Normal};

/// Photon noise: one draw per pixel, growing with the square root of its brightness.
pub(super) fn shot_noise<R: Rng + ?Sized>(pixels: &mut [[f32; 3]], rng: &mut R, work: &mut u64) {
    let table = noise_table();
    for p in pixels {
        let z = table[(rng.next_u32() >> (32 - NOISE_TABLE_BITS)) as usize];
        for c in p.iter_mut() {
            *c += z * (0.25 + c.max(0.0)).sqrt();
        }
        *work += 1;
    }
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
            *o = acc.map(|a| a * third);
        }
    }
    *work += depth.len() as u64;
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
