//! Sensor throughput against the practical limit: one HF camera frame, one HF lidar sweep, and
//! a bare parry3d loop casting the same rays (same directions, same scenery in a parry
//! `Compound`, ground as a thin cuboid) without any sensor logic.
//!
//! `cargo bench -p savme-sim --bench sensors`
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::{Compound, SharedShape};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use savme_sim::camera::{reference_shot, render};
use savme_sim::lidar::{scan, AZIMUTH_STEP_DEG, ELEVATIONS_DEG, HALF_FOV_DEG, MAX_RANGE};
use savme_sim::scene::Scene;
use savme_sim::settings::Settings;
use savme_sim::vehicle;
use savme_sim::world::ObjectShape;
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    // Scenario 3-like: the ego approaching the intersection, an oncoming intruder turning left.
    let (world, intruder, pose) = reference_shot();
    let scene = Scene {
        world,
        vehicles: &intruder,
    };
    let heading = pose.heading;
    let origin = Point3::new(1.75, -18.7, 1.9);
    let hf = Settings::hf();
    let mut rng = Pcg64::seed_from_u64(1);
    let rays_per_sweep = scan(&scene, origin, heading, &hf, &mut rng).rays;
    println!("lidar HF sweep: {rays_per_sweep} rays");

    // The same scene as a plain parry compound.
    let mut parts: Vec<(Isometry3<f32>, SharedShape)> = world
        .objects()
        .iter()
        .map(|o| {
            let ObjectShape::Box(h) = o.shape;
            (o.pose, SharedShape::cuboid(h.x, h.y, h.z))
        })
        .collect();
    let b = vehicle::body().half_extents;
    parts.push((intruder[0].pose(), SharedShape::cuboid(b.x, b.y, b.z)));
    parts.push((
        Isometry3::from_parts(
            Translation3::new(0.0, 0.0, -0.05),
            UnitQuaternion::identity(),
        ),
        SharedShape::cuboid(400.0, 400.0, 0.05),
    ));
    let compound = Compound::new(parts);
    // The HF sweep's primary rays: every beam, five subsample rays.
    let mut dirs = Vec::new();
    let steps = (2.0 * HALF_FOV_DEG / AZIMUTH_STEP_DEG).round() as i32;
    let div = 0.3f32.to_radians();
    for el in ELEVATIONS_DEG {
        for k in 0..=steps {
            let az = heading + (-HALF_FOV_DEG + k as f32 * AZIMUTH_STEP_DEG).to_radians();
            for (da, de) in [
                (0.0, 0.0),
                (0.5, 0.5),
                (-0.5, -0.5),
                (0.5, -0.5),
                (-0.5, 0.5),
            ] {
                let (a, e) = (az + da * div, el.to_radians() + de * div);
                dirs.push(Vector3::new(a.cos() * e.cos(), a.sin() * e.cos(), e.sin()));
            }
        }
    }
    println!("bare loop: {} rays", dirs.len());

    let mut g = c.benchmark_group("sensors");
    g.bench_function("camera_frame_hf", |b| {
        b.iter(|| black_box(render(&scene, &pose, &hf, &mut rng)))
    });
    g.bench_function("lidar_sweep_hf", |b| {
        b.iter(|| black_box(scan(&scene, origin, heading, &hf, &mut rng)))
    });
    g.bench_function("bare_parry_rays", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for d in &dirs {
                let ray = Ray::new(origin, *d);
                if compound
                    .cast_ray_and_get_normal(&Isometry3::identity(), &ray, MAX_RANGE, true)
                    .is_some()
                {
                    hits += 1;
                }
            }
            black_box(hits)
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(30)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    targets = bench
}
criterion_main!(benches);
