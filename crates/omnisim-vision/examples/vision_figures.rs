//! The timing figures of docs/vision.md: time per image of each descriptor on a 250² omni
//! image of env1 and its 512 × 128 panorama (the resampling error is `resampling_error`).
//!
//! cargo run --release -p omnisim-vision --example `vision_figures`

use std::path::PathBuf;
use std::time::Instant;

use glam::dvec3;
use omnisim::camera::Catadioptric;
use omnisim::{BackendChoice, Camera, Planes, Pose, Renderer, Scene};
use omnisim_vision::fourier::{FourierParams, FourierSignature};
use omnisim_vision::gist::{GistParams, gist};
use omnisim_vision::hog::{
    BlockHogParams, PanoramicHogParams, VerticalHogParams, block_hog, panoramic_hog, vertical_hog,
};
use omnisim_vision::radon::{Radon, RadonParams};
use omnisim_vision::sift::{SiftParams, sift};
use omnisim_vision::surf::{SurfParams, surf};
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
    let omni = Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()));
    let omni_image = render(&Camera::Catadioptric(omni.clone()));
    let time = |name: &str, f: &mut dyn FnMut()| {
        f();
        let runs = 20;
        let start = Instant::now();
        for _ in 0..runs {
            f();
        }
        println!(
            "| {name} | {:.2} ms |",
            start.elapsed().as_secs_f64() * 1000.0 / f64::from(runs)
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
    time("vertical-cell HOG, 32-column cells every column × 8 bins", &mut || {
        vertical_hog(&panorama, VerticalHogParams::default()).unwrap();
    });
    time("gist, 4 × 8 filters, 16 horizontal blocks", &mut || {
        gist(&panorama, GistParams::panoramic()).unwrap();
    });
    time("gist, 4 × 8 filters, 4 × 4 grid, of the omni image", &mut || {
        gist(&grey_omni, GistParams::default()).unwrap();
    });
    let count = |f: &omnisim_vision::keypoints::Features| f.keypoints.len();
    println!(
        "(keypoints: SIFT {} omni / {} panorama, SURF {} / {})",
        count(&sift(&grey_omni, &SiftParams::default()).unwrap()),
        count(&sift(&panorama, &SiftParams::default()).unwrap()),
        count(&surf(&grey_omni, &SurfParams::default()).unwrap()),
        count(&surf(&panorama, &SurfParams::default()).unwrap())
    );
    time("SIFT (doubled image), of the omni image", &mut || {
        sift(&grey_omni, &SiftParams::default()).unwrap();
    });
    time("SIFT (doubled image), of the panorama", &mut || {
        sift(&panorama, &SiftParams::default()).unwrap();
    });
    time("SURF, threshold 100, of the omni image", &mut || {
        surf(&grey_omni, &SurfParams::default()).unwrap();
    });
    time("SURF, threshold 100, of the panorama", &mut || {
        surf(&panorama, &SurfParams::default()).unwrap();
    });
    time("U-SURF, of the panorama", &mut || {
        surf(
            &panorama,
            &SurfParams {
                upright: true,
                ..SurfParams::default()
            },
        )
        .unwrap();
    });
}
