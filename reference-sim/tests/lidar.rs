//! Every lidar fidelity setting changes both the work done and the point cloud.
use nalgebra::{Point2, Point3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use savme_sim::lidar::{scan, LidarScan, ReturnKind};
use savme_sim::scene::{Scene, Surface};
use savme_sim::settings::Settings;
use savme_sim::vehicle::VehicleState;
use savme_sim::world::{Layout, World};

fn sweep(settings: &Settings) -> LidarScan {
    let world = World::shared(Layout::OneWay);
    // The intruder 12 m ahead in the ego's lane, slightly offset.
    let intruder = [VehicleState::from_center(Point2::new(12.0, -1.5), 0.1, 5.0)];
    let scene = Scene {
        world,
        vehicles: &intruder,
    };
    let mut rng = Pcg64::seed_from_u64(4);
    scan(
        &scene,
        Point3::new(1.0, -1.75, 1.9),
        0.0,
        settings,
        &mut rng,
    )
}

fn work(s: &LidarScan) -> u64 {
    s.rays + s.draws
}

#[test]
fn the_hf_sweep_sees_the_intruder_the_road_and_the_scenery() {
    let s = sweep(&Settings::hf());
    let on =
        |f: &dyn Fn(&Option<Surface>) -> bool| s.points.iter().filter(|p| f(&p.surface)).count();
    assert!(on(&|x| matches!(x, Some(Surface::Vehicle(0)))) > 20);
    assert!(on(&|x| *x == Some(Surface::Ground)) > 50);
    assert!(on(&|x| matches!(x, Some(Surface::Object(_)))) > 50);
    for kind in [
        ReturnKind::Transmitted,
        ReturnKind::MultiPath,
        ReturnKind::Ambient,
    ] {
        assert!(
            s.points.iter().any(|p| p.kind == kind),
            "no {kind:?} return at HF"
        );
    }
}

#[test]
fn each_setting_changes_work_and_output() {
    let hf = Settings::hf();
    let base = sweep(&hf);
    let cheap: [(&str, Settings); 6] = [
        (
            "shot noise",
            Settings {
                lidar_disable_shot_noise: true,
                ..hf
            },
        ),
        (
            "ambient",
            Settings {
                disable_ambient: true,
                ..hf
            },
        ),
        (
            "translucency",
            Settings {
                disable_translucency: true,
                ..hf
            },
        ),
        (
            "subsamples",
            Settings {
                subsamples: 1,
                ..hf
            },
        ),
        ("bounces", Settings { bounces: 0, ..hf }),
        (
            "near clipping",
            Settings {
                lidar_near_clip: 20.0,
                ..hf
            },
        ),
    ];
    for (name, s) in cheap {
        let lf = sweep(&s);
        assert!(
            work(&lf) < work(&base),
            "{name}: work {} vs HF {}",
            work(&lf),
            work(&base)
        );
        assert_ne!(lf.points, base.points, "{name}: same point cloud");
    }
}
