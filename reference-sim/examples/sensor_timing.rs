use nalgebra::{Point2, Point3};
use rand::SeedableRng;
use savme_sim::camera::{render, CameraPose};
use savme_sim::lidar::scan;
use savme_sim::scene::Scene;
use savme_sim::settings::Settings;
use savme_sim::vehicle::VehicleState;
use savme_sim::world::{Layout, World};
fn main() {
    let world = World::shared(Layout::Intersection);
    let intruder = [VehicleState::from_center(Point2::new(-1.0, 6.0), -1.2, 6.0)];
    let scene = Scene {
        world,
        vehicles: &intruder,
    };
    let pose = CameraPose {
        eye: Point3::new(1.75, -18.0, 1.3),
        heading: std::f32::consts::FRAC_PI_2,
    };
    let hf = Settings::hf();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    let n = 200;
    for (name, s) in [
        ("hf", hf),
        (
            "no dof",
            Settings {
                disable_depth_of_field: true,
                ..hf
            },
        ),
        (
            "no shadows",
            Settings {
                disable_shadows: true,
                ..hf
            },
        ),
        (
            "no bloom",
            Settings {
                disable_bloom: true,
                ..hf
            },
        ),
        (
            "no lens",
            Settings {
                disable_lens_model: true,
                ..hf
            },
        ),
    ] {
        let t = std::time::Instant::now();
        for _ in 0..n {
            std::hint::black_box(render(&scene, &pose, &s, &mut rng));
        }
        println!(
            "camera {name}: {:.3} ms",
            t.elapsed().as_secs_f64() * 1e3 / n as f64
        );
    }
    let t = std::time::Instant::now();
    let mut rays = 0;
    for _ in 0..n {
        rays += scan(
            &scene,
            Point3::new(1.75, -19.0, 1.9),
            std::f32::consts::FRAC_PI_2,
            &hf,
            &mut rng,
        )
        .rays;
    }
    println!(
        "lidar hf: {:.3} ms, {} rays/sweep",
        t.elapsed().as_secs_f64() * 1e3 / n as f64,
        rays / n as u64
    );
}
