//! The figures of docs/vision.md: resampling error of the panorama against the exact render
//! as the omnidirectional image grows, and time per image of each descriptor.
//!
//! cargo run --release -p omnisim-vision --example vision_figures

use std::path::PathBuf;
use std::time::Instant;

use glam::dvec3;
use omnisim::{BackendChoice, Camera, Catadioptric, Planes, Pose, Renderer, Scene};
use omnisim_vision::fourier::{FourierParams, FourierSignature};
use omnisim_vision::gist::{GistParams, gist};
use omnisim_vision::hog::{BlockHogParams, PanoramicHogParams, block_hog, panoramic_hog};
use omnisim_vision::radon::{Radon, RadonParams};
use omnisim_vision::{Interpolation, Raster, Remap, View};

fn main() {
    let scene = Scene::load(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/env1.ron")).unwrap();
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene).unwrap();
    let pose = Pose::from_degrees(dvec3(0.5, 0.2, 0.4), dvec3(0.0, 0.0, 30.0));
    let render = |camera: &Camera| {
        let frame = renderer.render(&prepared, camera, &pose, Planes::COLOUR).unwrap();
        let (w, h) = camera.size();
        Raster::from_rgb8(w as usize, h as usize, frame.colour().unwrap()).unwrap()
    };
    let view = View::panorama(512, 128, (-45f64).to_radians(), 15f64.to_radians()).unwrap();
    let View::Camera {
        camera: panorama_camera,
        ..
    } = &view
    else {
        unreachable!()
    };
    let exact = render(panorama_camera);
    println!("| omni image | interpolation | mean abs colour error (0-255) | pixels > 32 off |");
    println!("|---|---|---|---|");
    let mut omni_250 = None;
    for size in [250u32, 500, 1000, 2000] {
        let omni = Catadioptric::hyperbolic(size, size, 0.04, 0.16, Some(20f64.to_radians()));
        let image = render(&Camera::Catadioptric(omni.clone()));
        let remap = Remap::new(&omni, &view).unwrap();
        for interpolation in [Interpolation::Bilinear, Interpolation::Bicubic] {
            let resampled = remap.apply(&image, interpolation).unwrap();
            let (mut sum, mut far, mut count) = (0.0, 0, 0);
            for ((a, b), valid) in resampled.data.chunks(3).zip(exact.data.chunks(3)).zip(remap.valid()) {
                if valid {
                    let d = a.iter().zip(b).map(|(x, y)| (x - y).abs() as f64 * 255.0).sum::<f64>() / 3.0;
                    sum += d;
                    far += usize::from(d > 32.0);
                    count += 1;
                }
            }
            println!(
                "| {size}² | {interpolation:?} | {:.2} | {:.2} % |",
                sum / count as f64,
                100.0 * far as f64 / count as f64
            );
        }
        if size == 250 {
            omni_250 = Some((omni, image));
        }
    }
    let (omni, omni_image) = omni_250.unwrap();
    let time = |name: &str, f: &mut dyn FnMut()| {
        f();
        let runs = 20;
        let start = Instant::now();
        for _ in 0..runs {
            f();
        }
        println!(
            "| {name} | {:.2} ms |",
            start.elapsed().as_secs_f64() * 1000.0 / runs as f64
        );
    };
    println!("\n| step (250² omni image, 128 × 512 panorama) | time per image |\n|---|---|");
    let remap = Remap::new(
        &omni,
        &View::panorama(512, 128, (-45f64).to_radians(), 15f64.to_radians()).unwrap(),
    )
    .unwrap();
    let panorama = remap.apply(&omni_image, Interpolation::Bilinear).unwrap().to_grey();
    let grey_omni = omni_image.to_grey();
    time("panorama remap, bilinear (table made once)", &mut || {
        remap.apply(&omni_image, Interpolation::Bilinear).unwrap();
    });
    time("panorama remap, bicubic", &mut || {
        remap.apply(&omni_image, Interpolation::Bicubic).unwrap();
    });
    time("Fourier signature, k = 16", &mut || {
        FourierSignature::new(&panorama, FourierParams::default()).unwrap();
    });
    time("Radon, 360 angles × 249 radii, of the omni image", &mut || {
        Radon::new(&grey_omni, RadonParams::default()).unwrap();
    });
    time("panoramic HOG, 16 cells × 8 bins", &mut || {
        panoramic_hog(&panorama, PanoramicHogParams::default()).unwrap();
    });
    time("block HOG, 8 px cells, 2 × 2 blocks", &mut || {
        block_hog(&panorama, BlockHogParams::default()).unwrap();
    });
    time("gist, 4 × 8 filters, 16 horizontal blocks", &mut || {
        gist(&panorama, GistParams::panoramic()).unwrap();
    });
}
