//! Renders one camera frame of the same scene with θ_HF and with a cheap θ_LF and saves both as
//! PNG (like the paper's camera figure), plus the lidar sweep as a top view.
//!
//! `cargo run --release -p savme-sim --example camera_frames -- [OUT_DIR]`  (default: docs)
use rand::SeedableRng;
use rand_pcg::Pcg64;
use savme_sim::camera::{reference_shot, render, Image, HEIGHT, WIDTH};
use savme_sim::scene::Scene;
use savme_sim::settings::{BloomLevel, Settings};
use std::path::Path;

fn save(img: &Image, path: &Path, scale: usize) -> Result<(), Box<dyn std::error::Error>> {
    let rgb = img.to_rgb8();
    let (w, h) = (WIDTH * scale, HEIGHT * scale);
    let mut big = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let s = ((y / scale) * WIDTH + x / scale) * 3;
            big[(y * w + x) * 3..][..3].copy_from_slice(&rgb[s..s + 3]);
        }
    }
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w as u32, h as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()?.write_image_data(&big)?;
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "docs".into());
    // Scenario 3-like: the ego approaching the intersection, an oncoming intruder turning left.
    let (world, intruder, pose) = reference_shot();
    let scene = Scene {
        world,
        vehicles: &intruder,
    };
    let hf = Settings::hf();
    // The cheap setting the paper learned for C_budget = 0.3 (Table IV), camera part.
    let lf = Settings {
        rate_hz: 2.0,
        bloom_level: BloomLevel::High,
        disable_bloom: true,
        disable_lighting: false,
        disable_shadows: true,
        disable_lens_model: false,
        disable_depth_of_field: false,
        camera_disable_shot_noise: true,
        view_distance: 285.97,
        camera_near_clip: 7.22,
        ..hf
    };
    for (name, s) in [("camera_hf.png", hf), ("camera_lf.png", lf)] {
        let mut rng = Pcg64::seed_from_u64(1);
        let frame = render(&scene, &pose, &s, &mut rng);
        save(&frame.image, &Path::new(&out).join(name), 4)?;
        println!("{name}: {} work units", frame.work);
    }
    Ok(())
}
