//! Every camera fidelity setting changes both the work done and the image; the perception finds
//! the intruder; sensor frames are kept only when asked for.
use rand::SeedableRng;
use rand_pcg::Pcg64;
use savme_kernel::Assignment;
use savme_sim::camera::{reference_shot, render, Frame};
use savme_sim::fidelity;
use savme_sim::perception::{detect, paint_mask};
use savme_sim::scene::Scene;
use savme_sim::settings::{BloomLevel, Settings};
use savme_sim::sim::DrivingSimulator;

fn frame(settings: &Settings) -> Frame {
    // The oncoming intruder turning left, 24 m ahead and to the left of the image centre.
    let (world, intruder, pose) = reference_shot();
    let scene = Scene {
        world,
        vehicles: &intruder,
    };
    render(&scene, &pose, settings, &mut Pcg64::seed_from_u64(2))
}

#[test]
fn each_setting_changes_work_and_image() {
    let hf = Settings::hf();
    let base = frame(&hf);
    let cheap: [(&str, Settings); 9] = [
        (
            "lighting",
            Settings {
                disable_lighting: true,
                ..hf
            },
        ),
        (
            "shadows",
            Settings {
                disable_shadows: true,
                ..hf
            },
        ),
        (
            "bloom",
            Settings {
                disable_bloom: true,
                ..hf
            },
        ),
        (
            "bloom level",
            Settings {
                bloom_level: BloomLevel::Low,
                ..hf
            },
        ),
        (
            "lens model",
            Settings {
                disable_lens_model: true,
                ..hf
            },
        ),
        (
            "depth of field",
            Settings {
                disable_depth_of_field: true,
                ..hf
            },
        ),
        (
            "shot noise",
            Settings {
                camera_disable_shot_noise: true,
                ..hf
            },
        ),
        (
            "view distance",
            Settings {
                view_distance: 10.0,
                ..hf
            },
        ),
        (
            "near clipping",
            Settings {
                camera_near_clip: 20.0,
                ..hf
            },
        ),
    ];
    for (name, s) in cheap {
        let lf = frame(&s);
        assert!(
            lf.work < base.work,
            "{name}: work {} vs HF {}",
            lf.work,
            base.work
        );
        assert_ne!(lf.image, base.image, "{name}: same image");
    }
}

#[test]
fn the_detector_finds_the_intruder_at_hf() {
    let f = frame(&Settings::hf());
    let bb = detect(&paint_mask(&f.image)).expect("intruder detected");
    // Left of centre (it is to the left of the ego's lane), in the middle band of the image.
    assert!(bb.u1 < 64 && bb.v0 > 30 && bb.v1 < 70, "{bb:?}");
    // With a 10 m view distance it is gone.
    let near_sighted = frame(&Settings {
        view_distance: 10.0,
        ..Settings::hf()
    });
    assert!(detect(&paint_mask(&near_sighted.image)).is_none());
}

#[test]
fn sensor_frames_are_kept_only_when_asked() {
    let sim = DrivingSimulator::default();
    let phi = Assignment::new()
        .with("ego_speed", 15.0)
        .with("lead_speed", 10.0)
        .with("gap", 20.0)
        .with("lead_decel", 4.0)
        .with("brake_time", 2.0);
    let low = fidelity::theta_hf().with("simulation_rate_hz", 2);
    let with = sim.run("7", &phi, &low, true).unwrap();
    let frames = with.sensor_frames.expect("frames recorded");
    assert_eq!(frames.len() as u64, with.steps);
    assert!(frames
        .iter()
        .any(|f| f.detection.is_some() && f.measured.is_some()));
    assert!(frames.iter().all(|f| !f.cloud.is_empty()));
    let without = sim.run("7", &phi, &low, false).unwrap();
    assert!(without.sensor_frames.is_none() && without.trajectory.is_none());
    assert_eq!((with.failure, with.work), (without.failure, without.work));
}
